"""Small SE(2) helpers shared by the models (angles in radians, wrapped to (-pi, pi])."""
from __future__ import annotations

import numpy as np


def wrap_angle(angle):
    """Wrap angles to (-pi, pi]; works on scalars and arrays.

    pi - mod(pi - a, 2 pi) lands in (-pi, pi] with a single modulo (it sits on hot paths).
    """
    wrapped = np.pi - np.mod(np.pi - np.asarray(angle, dtype=float), 2.0 * np.pi)
    return wrapped if np.ndim(wrapped) else float(wrapped)


def relative_pose(pose_from, pose_to) -> np.ndarray:
    """Pose of ``pose_to`` expressed in the frame of ``pose_from`` (both (..., 3))."""
    pose_from = np.asarray(pose_from, dtype=float)
    pose_to = np.asarray(pose_to, dtype=float)
    dx = pose_to[..., 0] - pose_from[..., 0]
    dy = pose_to[..., 1] - pose_from[..., 1]
    c, s = np.cos(pose_from[..., 2]), np.sin(pose_from[..., 2])
    return np.stack([c * dx + s * dy, -s * dx + c * dy,
                     wrap_angle(pose_to[..., 2] - pose_from[..., 2])], axis=-1)


def compose(pose, delta) -> np.ndarray:
    """Pose ``delta`` (given in the frame of ``pose``) composed onto ``pose`` (both (..., 3))."""
    pose = np.asarray(pose, dtype=float)
    delta = np.asarray(delta, dtype=float)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    return np.stack([pose[..., 0] + c * delta[..., 0] - s * delta[..., 1],
                     pose[..., 1] + s * delta[..., 0] + c * delta[..., 1],
                     wrap_angle(pose[..., 2] + delta[..., 2])], axis=-1)
