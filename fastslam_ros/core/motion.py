# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Odometry motion model (Probabilistic Robotics, table 5.6) in its sampled and Gaussian forms.

Odometry between two poses is decomposed into (rot1, trans, rot2). FastSLAM 1.0 samples the
nonlinear model; FastSLAM 2.0 uses the Gaussian form s_t = h(s_{t-1}, u) + w, w ~ N(0, P_t),
with P_t = V M V^T, M the control noise and V = dh/du.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .geometry import pose_floats, wrap_angle, wrap_scalar


@dataclass(frozen=True)
class OdometryControl:
    """One odometry step: first rotation, translation, second rotation (rad, m, rad)."""

    rot1: float
    trans: float
    rot2: float

    @classmethod
    def from_delta(cls, delta) -> "OdometryControl":
        """Decompose a relative pose (dx, dy, dtheta) in the start frame.

        Backward motion keeps a small rot1 with a negative translation instead of turning by pi,
        so reversing does not look like a half turn to the noise model.
        """
        dx, dy, dtheta = pose_floats(delta)
        trans = math.hypot(dx, dy)
        rot1 = math.atan2(dy, dx) if trans > 1e-9 else 0.0
        if abs(rot1) > math.pi / 2.0:
            rot1 = wrap_scalar(rot1 - math.pi)
            trans = -trans
        return cls(rot1, trans, wrap_scalar(dtheta - rot1))


def control_variances(u: OdometryControl, alphas, min_translation_sigma: float,
                      min_rotation_sigma: float, linear=(0.0, 0.0, 0.0, 0.0)) -> np.ndarray:
    """Variances of (rot1, trans, rot2): alpha-scaled terms plus a fixed floor.

    ``linear`` = (rotation per radian, rotation per meter, translation per meter, translation
    per radian) adds random-walk terms, linear in the step's size, so that the variance of a
    motion does not depend on how many steps it is divided into.
    """
    a1, a2, a3, a4 = alphas
    rot1_sq, trans_sq, rot2_sq = u.rot1 ** 2, u.trans ** 2, u.rot2 ** 2
    variances = np.array([
        a1 * rot1_sq + a2 * trans_sq + min_rotation_sigma ** 2,
        a3 * trans_sq + a4 * (rot1_sq + rot2_sq) + min_translation_sigma ** 2,
        a1 * rot2_sq + a2 * trans_sq + min_rotation_sigma ** 2,
    ])
    k_rr, k_rt, k_tt, k_tr = linear
    if k_rr or k_rt or k_tt or k_tr:
        rot1, trans, rot2 = abs(u.rot1), abs(u.trans), abs(u.rot2)
        variances += np.array([k_rr * rot1 + 0.5 * k_rt * trans,
                               k_tt * trans + k_tr * (rot1 + rot2),
                               k_rr * rot2 + 0.5 * k_rt * trans])
    return variances


def apply_control(poses: np.ndarray, rot1, trans, rot2) -> np.ndarray:
    """h(s, u): move poses (M, 3) by the controls (scalars or (M,) arrays)."""
    heading = poses[:, 2] + rot1
    return np.stack([poses[:, 0] + trans * np.cos(heading),
                     poses[:, 1] + trans * np.sin(heading),
                     wrap_angle(poses[:, 2] + rot1 + rot2)], axis=1)


def sample_motion(poses: np.ndarray, u: OdometryControl, variances: np.ndarray,
                  standard_normals: np.ndarray) -> np.ndarray:
    """Sample the odometry model for every particle; ``standard_normals`` is (M, 3)."""
    noisy = np.array([u.rot1, u.trans, u.rot2]) - standard_normals * np.sqrt(variances)
    return apply_control(poses, noisy[:, 0], noisy[:, 1], noisy[:, 2])


def propagate_gaussian(mean: np.ndarray, cov: np.ndarray, u: OdometryControl,
                       variances: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """EKF prediction of N(mean, cov) through h: (h(mean, u), F cov F^T + V M V^T).

    With heading h = theta + rot1, F = dh/ds is the identity but for its heading column
    f = (-trans sin h, trans cos h, 1), and V = dh/d(rot1, trans, rot2) has the columns
    (f_x, f_y, 1), (cos h, sin h, 0) and (0, 0, 1). Both products are written out per entry
    (numpy's stacked 3x3 matmul costs more than the whole expression).
    """
    heading = mean[:, 2] + u.rot1
    cos_h, sin_h = np.cos(heading), np.sin(heading)
    fx, fy = -u.trans * sin_h, u.trans * cos_h
    v_rot1, v_trans, v_rot2 = (float(v) for v in variances)
    p = cov.reshape(-1, 9)
    c0, c1, c2 = p[:, 2], p[:, 5], p[:, 8]            # cov times the heading axis
    w = c2 + v_rot1
    xx = p[:, 0] + 2.0 * fx * c0 + w * fx * fx + v_trans * cos_h * cos_h
    xy = p[:, 1] + fx * c1 + fy * c0 + w * fx * fy + v_trans * cos_h * sin_h
    yy = p[:, 4] + 2.0 * fy * c1 + w * fy * fy + v_trans * sin_h * sin_h
    xt, yt, tt = c0 + w * fx, c1 + w * fy, c2 + (v_rot1 + v_rot2)
    # np.array(list).T: one C call, where np.stack costs several Python-level ones.
    predicted = np.array([xx, xy, xt, xy, yy, yt, xt, yt, tt]).T.reshape(-1, 3, 3)
    moved = np.array([mean[:, 0] + u.trans * cos_h, mean[:, 1] + u.trans * sin_h,
                      wrap_angle(heading + u.rot2)]).T
    return moved, predicted


def turn_fault_shift(poses: np.ndarray, u: OdometryControl, errors: np.ndarray) -> np.ndarray:
    """h(s, u + e) - h(s, u) (heading wrapped) of poses (n, 3) whose rotations rot1 and rot2
    are off by ``errors`` (n, 2) rad: how far a turn fault moves each pose's motion."""
    shifted = apply_control(poses, u.rot1 + errors[:, 0], u.trans, u.rot2 + errors[:, 1])
    shift = shifted - apply_control(poses, u.rot1, u.trans, u.rot2)
    shift[:, 2] = wrap_angle(shift[:, 2])
    return shift
