"""Model functions only the tests need: h(s, m), its Jacobians, the motion covariance and
written on the core's own building blocks."""
from __future__ import annotations

import numpy as np

from fastslam_ros.core.landmark_store import LandmarkStore
from fastslam_ros.core.motion import OdometryControl, propagate_gaussian
from fastslam_ros.core.observation import (ObservationTerms, SensorOffset, heading_column,
                                           observation_terms)


def observe(pose, landmark, offset: SensorOffset = SensorOffset()) -> np.ndarray:
    """h(s, m): (range, bearing) of landmarks (..., 2) seen from poses (..., 3)."""
    pose, landmark = np.asarray(pose, float), np.asarray(landmark, float)
    t = observation_terms(pose[..., 0], pose[..., 1], pose[..., 2],
                          landmark[..., 0], landmark[..., 1], offset)
    return np.stack([t.range, t.bearing], axis=-1)


def landmark_jacobian(t: ObservationTerms) -> np.ndarray:
    """G_m = dh/dm, shape (..., 2, 2)."""
    r = t.range
    return np.stack([np.stack([t.dx / r, t.dy / r], -1),
                     np.stack([-t.dy / t.q, t.dx / t.q], -1)], -2)


def pose_jacobian(t: ObservationTerms) -> np.ndarray:
    """G_s = dh/ds, shape (..., 2, 3); the sensor lever arm makes theta enter both rows."""
    r = t.range
    w0, w1 = (np.broadcast_to(w, np.shape(r)) for w in heading_column(t))
    entries = np.stack([-t.dx / r, -t.dy / r, w0, t.dy / t.q, -t.dx / t.q, w1], -1)
    return entries.reshape(entries.shape[:-1] + (2, 3))


def jacobians(pose, landmark, offset: SensorOffset = SensorOffset()):
    """(G_s, G_m) at (pose, landmark)."""
    pose, landmark = np.asarray(pose, float), np.asarray(landmark, float)
    t = observation_terms(pose[..., 0], pose[..., 1], pose[..., 2],
                          landmark[..., 0], landmark[..., 1], offset)
    return pose_jacobian(t), landmark_jacobian(t)


def motion_covariance(poses: np.ndarray, u: OdometryControl, variances: np.ndarray) -> np.ndarray:
    """P_t = V M V^T for every particle (M, 3, 3), V = dh/d(rot1, trans, rot2)."""
    return propagate_gaussian(poses, np.zeros((len(poses), 3, 3)), u, variances)[1]


def landmark_counts(store: LandmarkStore) -> np.ndarray:
    """Number of landmarks of every particle (M,)."""
    store.apply_resampling()
    rows = store.table[:, :store.num_cells]
    counts = np.where(rows >= 0, store.occupied.sum(axis=1)[np.maximum(rows, 0)], 0)
    return counts.sum(axis=1)
