# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
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


def insert(store: LandmarkStore, particle: int, points: np.ndarray, labels=None) -> None:
    """Create landmarks for one particle through the working-set path the filter uses."""
    ws = store.gather(np.full((store.num_particles, 0), -1, np.int64), len(points))
    ws.mean[particle] = points
    ws.cov[particle] = (0.1, 0.0, 0.1)
    ws.valid[particle] = ws.is_new[particle] = True
    if labels is not None:
        ws.label[particle] = labels
    store.scatter(ws, track_labels=labels is not None)


def edit_box(store: LandmarkStore, low: np.ndarray, change: np.ndarray, move_share: float,
             remove_share: float) -> list[tuple[int, int, bool]]:
    """Gather the cells of the 10 m box at ``low``, move the live entries whose ``change``
    draw is below ``move_share`` by 0.01 m, remove those below ``remove_share`` (of the moved),
    and write back. Returns (particle, label, removed) of every entry touched."""
    count = store.num_particles
    columns = store.columns_in_box(low, low + 10.0)
    ws = store.gather(np.broadcast_to(columns, (count, len(columns))), 0)
    particle, slot = ws.valid.nonzero()
    draw = change[:len(particle)]
    pick = draw < move_share
    gone = pick & (draw < remove_share)
    ws.mean[particle[pick], slot[pick]] += 0.01
    ws.dirty[particle[pick], slot[pick]] = True
    ws.valid[particle[gone], slot[gone]] = False
    touched = [(int(m), int(ws.label[m, s]), bool(g))
               for m, s, g in zip(particle[pick], slot[pick], gone[pick])]
    store.scatter(ws, track_labels=True)
    return touched


def drifting_loop(seed: int, heading_bias: float = 3e-4, laps: float = 1.2,
                  max_range: float = 8.0):
    """A loop whose odometry turns ``heading_bias`` rad too far each step (a systematic drift
    no motion noise of the filter covers), driven ``laps`` times round a circle of radius 15 m
    through 60 landmarks: (truth poses (T, 3), odometry poses (T, 3), landmarks (N, 2), the
    sensor, its random generator)."""
    from fastslam_ros.core.geometry import relative_pose
    from fastslam_ros.core.motion import apply_control
    from fastslam_ros.tools.simulation.world import (RangeBearingSensor, circle_path,
                                                     scatter_landmarks)

    rng = np.random.default_rng(seed)
    truth = circle_path(15.0, int(300 * laps), laps)
    odometry = np.empty_like(truth)
    odometry[0] = truth[0]
    for k, delta in enumerate(relative_pose(truth[:-1], truth[1:])):
        control = OdometryControl.from_delta(delta)
        odometry[k + 1] = apply_control(odometry[k:k + 1], control.rot1 + heading_bias,
                                        control.trans, control.rot2)[0]
    landmarks = scatter_landmarks(rng, 60, (-22.0, -22.0), (22.0, 22.0), 2.5)
    sensor = RangeBearingSensor(max_range, 0.05, 0.01)
    return truth, odometry, landmarks, sensor, rng
