# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The saved map refined by a batch least squares over the best particle's whole path.

A FastSLAM particle's map is conditional on that particle's path: each landmark was estimated
from the poses the particle sampled, and nothing moves it once the robot has left. When a loop
closes (``loop_closure_matches``) the particle's pose and the landmarks near the robot jump, the
far side of the loop keeps its drift, and the map is torn or bent. ``refine`` fixes that the way a
graph-based SLAM back end does, once, before the map is written:

1. ``ReadingLog`` (``core/reading_log.py``) keeps every reading the filter processed: the
   odometry pose at the reading (the increments ``FastSLAM.predict`` received, composed) and
   its range-bearing observations in the sensor frame. Its memory is bounded
   (``MAX_READINGS``, ``MAX_OBSERVATIONS``): when either is full the older half of the
   readings is thinned to every other one, as the path history is, so the recent readings
   stay whole.
2. Each logged observation is associated, as seen from the best particle's pose at that
   reading (``FastSLAM.best_path``), to the nearest confirmed landmark of its map within the
   squared Mahalanobis gate ``ASSOCIATION_GATE`` (the landmark's covariance plus the
   observation's, in the world frame); the particle's map was built from exactly that path, so
   this mostly reproduces its associations. Unmatched observations are dropped. With
   ``association: known`` the observation's id picks the landmark instead.
3. The full SLAM least squares over the poses (3 per reading) and the observed landmarks (2
   each): odometry factors between consecutive readings with the motion model's noise
   (``motion.control_variances`` of the increment, mapped to (dx, dy, dtheta); the lateral
   and along-track variances floored at ``min_translation_sigma``^2), range-bearing factors with
   ``sigma_range`` (and ``sigma_range_per_meter``) and ``sigma_bearing``, and a prior that
   pins the first pose (the gauge). It is solved by Levenberg-Marquardt on the sparse normal
   equations (``scipy.sparse.linalg.splu``, ``SYMMETRIC``), the observation factors under a
   Cauchy loss (iteratively reweighted; the odometry is never down-weighted: the jump a loop
   closure left in the path is what the solve spreads over the loop), with the robust weight
   scale ``CAUCHY_SCALE``.
   Beyond ``MAX_SOLVE_POSES`` readings the poses of keyframes (every k-th reading) are solved
   for, the readings between tied to theirs by odometry (each observation then seen from its
   sensor's pose in the keyframe's frame): the factorization's fill grows faster than the
   number of poses when the path revisits the same landmarks.
4. The associations are redone from the refined poses and landmarks (observations a closure
   had moved out of the gate find their landmark again) and the problem solved again, up to
   ``ASSOCIATION_ROUNDS`` times, until they no longer change.

The refined covariances are each landmark's conditional on the refined path (the inverse of
its own 2x2 block of the information matrix, robust weights included), as the filter's are
conditional on the particle's path; the online smoother reports their marginals (``Marginals``:
their blocks of the inverse of the whole information matrix), which hold the path's
uncertainty too, so that the map it reports claims no more than the solve supports. A landmark
with no associated observation in the log (a loaded one never seen again, or one whose readings
were thinned away) keeps the filter's mean and covariance.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from .geometry import compose, relative_pose, wrap_angle
from .motion import OdometryControl, control_variances
from .observation import SensorOffset, inverse_observe, observation_terms
from .reading_log import ReadingLog

ASSOCIATION_GATE = 13.82
"""Squared Mahalanobis distance (chi-square, 2 dof, 99.9 %) within which a logged observation
is associated to a landmark: the landmark means moved a little after the reading that saw them
(their later updates), which the filter's own gate did not have to allow for."""
CANDIDATES = 3
"""Nearest landmarks (Euclidean, in the world) an observation is scored against."""
CAUCHY_SCALE = 3.0
"""Whitened residual norm at which a range-bearing factor's Cauchy weight is one half: a
consistent observation (within about 3 standard deviations) counts nearly fully, one 10
standard deviations off (a wrong association) about a tenth."""
FIRST_POSE_SIGMA = 1e-3
"""Standard deviation (m, rad) of the prior that pins the first logged pose at the particle's
(the least squares' gauge: the map frame is where the filter put it)."""
MAX_SOLVE_POSES = 8192
"""Poses the least squares solves for at most: a longer log is solved on keyframes (every
k-th reading, k the smallest that fits), the readings between them tied to their keyframe by
odometry, as the sparse factorization's cost grows faster than the number of poses."""
ASSOCIATION_ROUNDS = 3
"""Solves with the associations redone from the refined estimate in between, at most."""
MAX_ITERATIONS = 50
"""Levenberg-Marquardt iterations per solve, at most."""
SYMMETRIC = {"permc_spec": "MMD_AT_PLUS_A", "diag_pivot_thresh": 0.0,
             "options": {"SymmetricMode": True}}
"""SuperLU's settings for a symmetric positive definite matrix: minimum degree ordering on
A + A^T, the diagonal as pivots (3.4x faster than its default on the bench's maps)."""
MARGINAL_COLUMNS = 256
"""Columns of the inverse solved at once for the landmarks' marginals (unknowns x 256 floats)."""
TOLERANCE = 1e-7
"""A solve stops once an accepted step lowers the cost by less than this fraction."""


@dataclass
class RefinementReport:
    """What one ``refine`` did."""

    readings: int
    landmarks: int
    """Landmarks of the map."""
    refined: int
    """Landmarks that had associated observations (the rest kept the filter's estimate)."""
    observations: int
    """Usable logged observations."""
    associated: int
    """Of them, associated (the rest dropped) in the final round."""
    rounds: int
    iterations: int
    initial_cost: float
    final_cost: float
    seconds: float
    mean_shift: float
    """Mean distance (m) the refined landmarks moved from the filter's."""
    stamps: np.ndarray
    poses: np.ndarray
    """Stamps and refined poses (3) of the solved readings (all, or the keyframes)."""
    solution: "Solution"
    """Every logged reading's refined pose and the refined landmarks, to start the next
    solve from."""
    latest_covariance: np.ndarray | None = None
    """(3, 3) marginal covariance of the last solved pose (``refine(latest_covariance=True)``)."""
    marginals: "Marginals | None" = None
    """The solve's factorized information, for the landmarks' marginal covariances
    (``refine(latest_covariance=True)``)."""


@dataclass
class Solution:
    """A solve's estimate, in the log origin's frame: a later solve starts from it."""

    stamps: np.ndarray
    poses: np.ndarray
    """(T,) stamps and (T, 3) poses of every logged reading."""
    keys: np.ndarray
    means: np.ndarray
    """(N,) landmark keys and (N, 2) their means."""


@dataclass
class Problem:
    """The least squares' fixed data: noise models and the observation list."""

    odometry: np.ndarray
    """(T - 1, 3) measured increments between consecutive readings."""
    odometry_whitening: np.ndarray
    """(T - 1, 3, 3) inverse Cholesky factors of the increments' covariances."""
    anchor: np.ndarray
    """(3,) the first pose's prior mean."""
    reading: np.ndarray
    landmark: np.ndarray
    """(K,) the observations' reading and landmark (index into the refined landmarks)."""
    ranges: np.ndarray
    bearings: np.ndarray
    sigma_range: np.ndarray
    sigma_bearing: float
    offset: SensorOffset

    @property
    def num_poses(self) -> int:
        return len(self.odometry) + 1


def odometry_whitening(increments: np.ndarray, config) -> np.ndarray:
    """(T, 3, 3) W with W^T W the information of each odometry increment
    (``odometry_covariances``)."""
    return np.linalg.inv(np.linalg.cholesky(odometry_covariances(increments, config)))


def odometry_covariances(increments: np.ndarray, config) -> np.ndarray:
    """(T, 3, 3) covariance of each odometry increment (dx, dy, dtheta): the motion model's
    (rot1, trans, rot2) variances (``motion.control_variances``) mapped through
    V = d(dx, dy, dtheta) / d(rot1, trans, rot2), plus min_translation_sigma^2 on x and y (a
    short step's lateral variance trans^2 var(rot1) vanishes)."""
    alphas = (config.alpha1, config.alpha2, config.alpha3, config.alpha4)
    linear = (config.rotation_variance_per_radian, config.rotation_variance_per_meter,
              config.translation_variance_per_meter, config.translation_variance_per_radian)
    controls = [OdometryControl.from_delta(step) for step in increments.tolist()]
    rot1 = np.array([u.rot1 for u in controls])
    trans = np.array([u.trans for u in controls])
    rot2 = np.array([u.rot2 for u in controls])
    variances = control_variances(OdometryControl(rot1, trans, rot2), alphas,
                                  config.min_translation_sigma, config.min_rotation_sigma,
                                  linear)
    c, s = np.cos(rot1), np.sin(rot1)
    zero, one = np.zeros_like(c), np.ones_like(c)
    v = np.stack([np.stack([-trans * s, c, zero], -1),
                  np.stack([trans * c, s, zero], -1),
                  np.stack([one, zero, one], -1)], -2)
    cov = np.einsum("nij,jn,nkj->nik", v, variances, v)
    cov[:, 0, 0] += config.min_translation_sigma ** 2
    cov[:, 1, 1] += config.min_translation_sigma ** 2
    return cov


def residuals(problem: Problem, poses: np.ndarray, landmarks: np.ndarray):
    """Whitened residuals: (prior (3,), odometry (T-1, 3), observations (K, 2))."""
    prior = (poses[0] - problem.anchor) / FIRST_POSE_SIGMA
    prior[2] = wrap_angle(poses[0, 2] - problem.anchor[2]) / FIRST_POSE_SIGMA
    predicted = relative_pose(poses[:-1], poses[1:])
    error = predicted - problem.odometry
    error[:, 2] = wrap_angle(error[:, 2])
    odometry = np.einsum("nij,nj->ni", problem.odometry_whitening, error)
    pose = poses[problem.reading]
    mark = landmarks[problem.landmark]
    t = observation_terms(pose[:, 0], pose[:, 1], pose[:, 2], mark[:, 0], mark[:, 1],
                          problem.offset)
    observed = np.stack([(problem.ranges - t.range) / problem.sigma_range,
                         t.bearing_innovation(problem.bearings) / problem.sigma_bearing], -1)
    return prior, odometry, observed


def jacobian(problem: Problem, poses: np.ndarray, landmarks: np.ndarray,
             observation_weights: np.ndarray):
    """Sparse Jacobian (``scipy.sparse.csr_matrix``) of the whitened residuals (rows: prior,
    odometry, observations, the observation rows scaled by the square roots of their robust
    weights) with respect to (poses (3T), landmarks (2N))."""
    import scipy.sparse as sp  # noqa: PLC0415 (the filter itself never needs scipy)
    count = problem.num_poses
    rows, cols, values = [], [], []
    # Prior: identity / sigma on the first pose.
    rows.append(np.arange(3))
    cols.append(np.arange(3))
    values.append(np.full(3, 1.0 / FIRST_POSE_SIGMA))
    # Odometry: d relative_pose / d (pose_i, pose_j), whitened.
    start, end = poses[:-1], poses[1:]
    c, s = np.cos(start[:, 2]), np.sin(start[:, 2])
    dx, dy = end[:, 0] - start[:, 0], end[:, 1] - start[:, 1]
    n = len(start)
    a = np.zeros((n, 3, 3))
    b = np.zeros((n, 3, 3))
    a[:, 0, 0], a[:, 0, 1], a[:, 0, 2] = -c, -s, -s * dx + c * dy
    a[:, 1, 0], a[:, 1, 1], a[:, 1, 2] = s, -c, -c * dx - s * dy
    a[:, 2, 2] = -1.0
    b[:, 0, 0], b[:, 0, 1] = c, s
    b[:, 1, 0], b[:, 1, 1] = -s, c
    b[:, 2, 2] = 1.0
    w = problem.odometry_whitening
    for block, pose_index in ((w @ a, np.arange(n)), (w @ b, np.arange(1, n + 1))):
        row = 3 + 3 * np.arange(n)[:, None, None] + np.arange(3)[None, :, None]
        col = 3 * pose_index[:, None, None] + np.arange(3)[None, None, :]
        rows.append(np.broadcast_to(row, block.shape).ravel())
        cols.append(np.broadcast_to(col, block.shape).ravel())
        values.append(block.ravel())
    # Observations: range and bearing by (x, y, theta) of the pose and (x, y) of the landmark.
    pose = poses[problem.reading]
    mark = landmarks[problem.landmark]
    t = observation_terms(pose[:, 0], pose[:, 1], pose[:, 2], mark[:, 0], mark[:, 1],
                          problem.offset)
    range_theta = (t.dx * t.lever_y - t.dy * t.lever_x) / t.range
    bearing_theta = -(t.dx * t.lever_x + t.dy * t.lever_y) / t.q - 1.0
    scale = np.sqrt(observation_weights)
    kr = -scale / problem.sigma_range
    kb = -scale / problem.sigma_bearing
    ux, uy = t.dx / t.range, t.dy / t.range
    vx, vy = -t.dy / t.q, t.dx / t.q
    obs = np.zeros((len(pose), 2, 5))
    obs[:, 0] = np.stack([-ux, -uy, range_theta, ux, uy], -1) * kr[:, None]
    obs[:, 1] = np.stack([-vx, -vy, bearing_theta, vx, vy], -1) * kb[:, None]
    row0 = 3 + 3 * n + 2 * np.arange(len(pose))
    row = row0[:, None, None] + np.arange(2)[None, :, None]
    col = np.concatenate([3 * problem.reading[:, None] + np.arange(3),
                          3 * count + 2 * problem.landmark[:, None] + np.arange(2)], axis=1)
    rows.append(np.broadcast_to(row, obs.shape).ravel())
    cols.append(np.broadcast_to(col[:, None, :], obs.shape).ravel())
    values.append(obs.ravel())
    shape = (3 + 3 * n + 2 * len(pose), 3 * count + 2 * len(landmarks))
    return sp.csr_matrix((np.concatenate(values), (np.concatenate(rows),
                                                    np.concatenate(cols))), shape=shape)


def cauchy(squared: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rho, weight) of the Cauchy loss on squared whitened residual norms."""
    c2 = CAUCHY_SCALE ** 2
    return c2 * np.log1p(squared / c2), 1.0 / (1.0 + squared / c2)


def cost(problem: Problem, poses: np.ndarray, landmarks: np.ndarray) -> float:
    """Half the robust sum of squares."""
    prior, odometry, observed = residuals(problem, poses, landmarks)
    rho, _ = cauchy((observed ** 2).sum(axis=1))
    return 0.5 * float((prior ** 2).sum() + (odometry ** 2).sum() + rho.sum())


def solve(problem: Problem, poses: np.ndarray, landmarks: np.ndarray):
    """Levenberg-Marquardt with iteratively reweighted observation factors; returns (poses,
    landmarks, observation weights, iterations, initial cost, final cost)."""
    import scipy.sparse as sp  # noqa: PLC0415 (the filter itself never needs scipy)
    from scipy.sparse.linalg import splu  # noqa: PLC0415
    count = problem.num_poses
    current = cost(problem, poses, landmarks)
    initial = current
    damping = 1e-4
    iterations = 0
    for iterations in range(1, MAX_ITERATIONS + 1):
        prior, odometry, observed = residuals(problem, poses, landmarks)
        _, weights = cauchy((observed ** 2).sum(axis=1))
        jac = jacobian(problem, poses, landmarks, weights)
        error = np.concatenate([prior, odometry.ravel(),
                                (observed * np.sqrt(weights)[:, None]).ravel()])
        jt = jac.T.tocsr()
        hessian = (jt @ jac).tocsc()
        gradient = jt @ error
        diagonal = hessian.diagonal()
        accepted = False
        while damping < 1e8:
            damped = (hessian + sp.diags(damping * np.maximum(diagonal, 1e-9))).tocsc()
            step = splu(damped, **SYMMETRIC).solve(-gradient)
            trial_poses = poses + step[:3 * count].reshape(-1, 3)
            trial_poses[:, 2] = wrap_angle(trial_poses[:, 2])
            trial_landmarks = landmarks + step[3 * count:].reshape(-1, 2)
            trial = cost(problem, trial_poses, trial_landmarks)
            if np.isfinite(trial) and trial <= current:
                accepted = True
                break
            damping *= 10.0
        if not accepted:
            break
        poses, landmarks = trial_poses, trial_landmarks
        damping = max(damping / 10.0, 1e-9)
        gain, current = current - trial, trial
        if gain <= TOLERANCE * max(current, 1e-12):
            break
    _, _, observed = residuals(problem, poses, landmarks)
    _, weights = cauchy((observed ** 2).sum(axis=1))
    return poses, landmarks, weights, iterations, initial, current


def associate(poses: np.ndarray, reading: np.ndarray, ranges: np.ndarray,
              bearings: np.ndarray, means: np.ndarray, covariances: np.ndarray,
              noise: tuple[np.ndarray, float], offset: SensorOffset) -> np.ndarray:
    """(K,) the landmark (index into ``means``) each observation lies nearest to in squared
    Mahalanobis distance, among its ``CANDIDATES`` nearest, as seen from its reading's pose;
    -1 beyond ``ASSOCIATION_GATE``. ``noise``: (range variance (K,), bearing variance)."""
    from scipy.spatial import cKDTree  # noqa: PLC0415 (the filter itself never needs scipy)
    if len(means) == 0 or len(ranges) == 0:
        return np.full(len(ranges), -1, np.int64)
    pose = poses[reading]
    points = inverse_observe(pose, ranges, bearings, offset)
    k = min(CANDIDATES, len(means))
    _, nearest = cKDTree(means).query(points, k=k)
    nearest = nearest.reshape(len(points), k)
    # The observation's covariance in the world: G diag(var_r, var_b) G^T, G = d point / d(r, b).
    angle = pose[:, 2] + offset.yaw + bearings
    c, s = np.cos(angle), np.sin(angle)
    var_r, var_b = noise[0] * np.ones(len(ranges)), noise[1] * ranges ** 2
    sxx = c * c * var_r + s * s * var_b
    sxy = c * s * (var_r - var_b)
    syy = s * s * var_r + c * c * var_b
    cov = covariances[nearest]
    axx, axy, ayy = sxx[:, None] + cov[..., 0, 0], sxy[:, None] + cov[..., 0, 1], \
        syy[:, None] + cov[..., 1, 1]
    d = points[:, None, :] - means[nearest]
    det = axx * ayy - axy * axy
    squared = (ayy * d[..., 0] ** 2 - 2.0 * axy * d[..., 0] * d[..., 1]
               + axx * d[..., 1] ** 2) / det
    best = squared.argmin(axis=1)
    chosen = nearest[np.arange(len(points)), best]
    return np.where(squared[np.arange(len(points)), best] <= ASSOCIATION_GATE, chosen, -1)


def initial_poses(log_stamps: np.ndarray, odometry: np.ndarray, path_stamps: np.ndarray,
                  path: np.ndarray) -> np.ndarray | None:
    """The particle's pose at each logged reading: its path's (the last T entries when their
    stamps are the log's, else the entry with the same stamp), a reading the path has thinned
    away placed by odometry from the nearest reading it has. None when no reading is in it."""
    count = len(log_stamps)
    if len(path) >= count and np.array_equal(path_stamps[len(path) - count:], log_stamps):
        return path[len(path) - count:].copy()
    order = np.argsort(path_stamps, kind="stable")
    at = np.searchsorted(path_stamps[order], log_stamps)
    at = np.minimum(at, len(path) - 1)
    match = order[at]
    found = path_stamps[match] == log_stamps
    if not found.any():
        return None
    known = np.flatnonzero(found)
    # Each reading from the nearest earlier one in the path (or the first one after it).
    source = known[np.maximum(np.searchsorted(known, np.arange(count), side="right") - 1, 0)]
    anchor = path[match[source]]
    return compose(anchor, relative_pose(odometry[source], odometry))


def refine(log: ReadingLog, path_stamps: np.ndarray, path: np.ndarray, landmark_map, config,
           known_ids: bool = False, start: Solution | None = None,
           max_solve_poses: int = MAX_SOLVE_POSES, max_rounds: int = ASSOCIATION_ROUNDS,
           latest_covariance: bool = False):
    """(refined map, ``RefinementReport``): ``landmark_map`` (a ``fastslam.LandmarkMap``, the
    best particle's confirmed landmarks) refined by the least squares over the log and the
    particle's path (``FastSLAM.best_path()``). ``config``: the filter's ``FastSLAMConfig``
    (noise models, sensor offset). ``known_ids``: the observations' ids name their landmarks
    (``association: known``). The first logged pose is pinned where the log's odometry puts
    it from ``log.origin`` (path and map first moved rigidly there): the frame is the one the
    filter started in, whichever particle is refined. ``start``: an earlier solve's
    ``Solution`` to start from where it has the reading or the landmark (the readings after
    it follow the particle's path from its last one). ``max_solve_poses``: keyframes beyond it;
    ``max_rounds``: solves with the associations redone in between; ``latest_covariance``:
    the last solved pose's marginal covariance too, and the ``Marginals`` that give the
    landmarks' (one more factorization). Raises
    ``ValueError`` when there is nothing to refine."""
    began = time.perf_counter()
    stamps, odometry, reading, ranges, bearings, labels = log.readings()
    count, size = len(stamps), len(landmark_map)
    if count < 2 or size == 0:
        raise ValueError(f"nothing to refine ({count} readings, {size} landmarks)")
    poses = initial_poses(stamps, odometry, np.asarray(path_stamps, float),
                          np.asarray(path, float))
    if poses is None:
        raise ValueError("the path holds none of the logged readings")
    first = compose(log.origin[None], odometry[:1])[0]
    poses, landmark_map = moved_rigidly(poses, landmark_map,
                                        compose(first[None], relative_pose(poses[:1],
                                                                           np.zeros((1, 3))))[0])
    warm = None if start is None else warm_started(stamps, poses, landmark_map, start)
    offset = SensorOffset(config.sensor_x, config.sensor_y, config.sensor_yaw)
    var_r = config.sigma_range ** 2 + (config.sigma_range_per_meter * ranges) ** 2
    noise = (var_r, config.sigma_bearing ** 2)
    means = np.asarray(landmark_map.means, float)
    covariances = np.asarray(landmark_map.covariances, float)
    # Keyframes: beyond MAX_SOLVE_POSES readings, every ``every``-th reading's pose is solved for
    # and the readings between are tied to it by their odometry.
    every = -(-count // max_solve_poses)
    key = np.arange(0, count, every)
    owner = np.arange(count) // every
    local = relative_pose(odometry[key[owner]], odometry)
    increments = relative_pose(odometry[key[:-1]], odometry[key[1:]])
    whitening = odometry_whitening(increments, config)
    if known_ids:
        ids = np.asarray(landmark_map.ids)
        order = np.argsort(ids, kind="stable")
        at = np.minimum(np.searchsorted(ids[order], labels), size - 1)
        fixed = np.where((ids[order][at] == labels) & (labels >= 0), order[at], -1)
    refined_means, refined_cov = means.copy(), covariances.copy()
    anchor = first
    key_poses = poses[key]
    iterations = rounds = 0
    initial_cost = final_cost = 0.0
    previous = None
    used = np.zeros(size, bool)
    chosen = np.full(len(ranges), -1, np.int64)
    for rounds in range(1, max_rounds + 1):
        chosen = fixed if known_ids else associate(poses, reading, ranges, bearings,
                                                   refined_means, refined_cov, noise, offset)
        if previous is not None and np.array_equal(chosen, previous):
            rounds -= 1
            break
        previous = chosen
        keep = chosen >= 0
        used = np.zeros(size, bool)
        used[chosen[keep]] = True
        if not used.any():
            raise ValueError("no logged observation matches a landmark")
        index = np.cumsum(used) - 1
        problem = Problem(increments, whitening, anchor, owner[reading[keep]],
                          index[chosen[keep]], ranges[keep], bearings[keep],
                          np.sqrt(var_r[keep]), config.sigma_bearing,
                          offset if every == 1 else sensor_in_keyframe(local[reading[keep]],
                                                                       offset))
        marks = refined_means[used]
        if warm is not None and rounds == 1:
            # The earlier solve's estimate, unless the particle's own is the better start (it
            # holds a loop closure the earlier solve had not seen).
            warm_poses, warm_means = warm[0][key], warm[1][used]
            if cost(problem, warm_poses, warm_means) < cost(problem, key_poses, marks):
                key_poses, marks = warm_poses, warm_means
        key_poses, marks, weights, steps, before, after = solve(problem, key_poses, marks)
        poses = key_poses if every == 1 else compose(key_poses[owner], local)
        iterations += steps
        initial_cost = before if rounds == 1 else initial_cost
        final_cost = after
        refined_means[used] = marks
        refined_cov[used] = conditional_covariances(problem, poses, marks, weights)
        if known_ids:
            break
    determinant = refined_cov[:, 0, 0] * refined_cov[:, 1, 1] - refined_cov[:, 0, 1] ** 2
    if not (np.isfinite(refined_means).all() and np.isfinite(refined_cov).all()
            and (refined_cov[:, 0, 0] > 0.0).all() and (determinant > 0.0).all()):
        raise ValueError("the least squares gave a non-finite or degenerate landmark")
    shift = np.hypot(*(refined_means - means).T)
    marginals = (factorize_information(problem, key_poses, marks, weights, used)
                 if latest_covariance else None)
    report = RefinementReport(count, size, int(used.sum()), len(ranges), int((chosen >= 0).sum()),
                              rounds, iterations, initial_cost, final_cost,
                              time.perf_counter() - began, float(shift.mean()), stamps[key],
                              key_poses, Solution(stamps, poses, np.asarray(landmark_map.keys),
                                                  refined_means),
                              None if marginals is None else marginals.pose(len(key_poses) - 1),
                              marginals)
    refined = dataclasses.replace(landmark_map, means=refined_means, covariances=refined_cov)
    return refined, report


@dataclass
class Marginals:
    """A solve's factorized J^T J (robust weights, first pose pinned): blocks of its inverse."""

    factor: Any                   # scipy.sparse.linalg.SuperLU of J^T J
    size: int
    num_poses: int
    solved: np.ndarray
    """(N,) which landmarks of the refined map the solve held (in order)."""

    def blocks(self, first: int, width: int, count: int) -> np.ndarray:
        """(count, width, width) diagonal blocks of the inverse from unknown ``first`` on."""
        unit = np.zeros((self.size, width * count))
        unit[first + np.arange(width * count), np.arange(width * count)] = 1.0
        columns = self.factor.solve(unit)[first:first + width * count]
        split = columns.reshape(count, width, count, width)
        block = split[np.arange(count), :, np.arange(count), :]
        return 0.5 * (block + block.transpose(0, 2, 1))

    def pose(self, index: int) -> np.ndarray:
        """(3, 3) marginal covariance of solved pose ``index``."""
        return self.blocks(3 * index, 3, 1)[0]

    def landmark_covariances(self, covariances: np.ndarray) -> np.ndarray:
        """The map's ``covariances`` (N, 2, 2), the solved landmarks' replaced by marginals."""
        count, chunk, base = int(self.solved.sum()), MARGINAL_COLUMNS // 2, 3 * self.num_poses
        result = np.array(covariances, float)
        if count:
            result[self.solved] = np.concatenate([
                self.blocks(base + 2 * start, 2, min(chunk, count - start))
                for start in range(0, count, chunk)])
        return result


def factorize_information(problem: Problem, poses: np.ndarray, landmarks: np.ndarray,
                          weights: np.ndarray, solved: np.ndarray) -> Marginals:
    """The ``Marginals`` of the solution (``solved``: the refined map's landmarks it holds)."""
    from scipy.sparse.linalg import splu  # noqa: PLC0415 (the filter itself never needs scipy)
    jac = jacobian(problem, poses, landmarks, weights)
    information = (jac.T.tocsr() @ jac).tocsc()
    return Marginals(splu(information, **SYMMETRIC), information.shape[0], len(poses),
                     solved.copy())


def warm_started(stamps: np.ndarray, poses: np.ndarray, landmark_map, start: Solution):
    """(poses (T, 3), landmark means (N, 2)): ``start``'s estimate where it has the reading or
    the landmark key, the readings after its last one following the path's motion from there,
    the rest as given."""
    at = np.minimum(np.searchsorted(start.stamps, stamps), len(start.stamps) - 1)
    known = start.stamps[at] == stamps
    if not known.any():
        return poses, np.asarray(landmark_map.means, float)
    last = int(np.flatnonzero(known)[-1])
    warm = poses.copy()
    warm[known] = start.poses[at[known]]
    warm[last + 1:] = compose(np.broadcast_to(warm[last], (len(poses) - last - 1, 3)),
                              relative_pose(poses[last][None], poses[last + 1:]))
    order = np.argsort(start.keys, kind="stable")
    keys = np.asarray(landmark_map.keys)
    found = np.minimum(np.searchsorted(start.keys[order], keys), max(len(order) - 1, 0))
    same = (start.keys[order][found] == keys) if len(order) else np.zeros(len(keys), bool)
    means = np.array(landmark_map.means, float)
    means[same] = start.means[order][found[same]]
    return warm, means


def moved_rigidly(poses: np.ndarray, landmark_map, transform: np.ndarray):
    """(poses, landmark map) moved by the rigid ``transform`` (x, y, theta) of the plane."""
    c, s = np.cos(transform[2]), np.sin(transform[2])
    rotation = np.array([[c, -s], [s, c]])
    covariances = rotation @ np.asarray(landmark_map.covariances, float) @ rotation.T
    moved = dataclasses.replace(
        landmark_map, means=np.asarray(landmark_map.means, float) @ rotation.T + transform[:2],
        covariances=covariances)
    return compose(np.broadcast_to(transform, poses.shape), poses), moved


def sensor_in_keyframe(local: np.ndarray, offset: SensorOffset) -> SensorOffset:
    """Per observation (arrays (K,)), the sensor's pose in the frame of its reading's keyframe:
    the reading's pose there (``local`` (K, 3), by odometry) composed with the lever arm."""
    c, s = np.cos(local[:, 2]), np.sin(local[:, 2])
    return SensorOffset(local[:, 0] + c * offset.x - s * offset.y,
                        local[:, 1] + s * offset.x + c * offset.y, local[:, 2] + offset.yaw)


def conditional_covariances(problem: Problem, poses: np.ndarray, landmarks: np.ndarray,
                            weights: np.ndarray) -> np.ndarray:
    """(N, 2, 2) each landmark's covariance given the poses: the inverse of the sum of its
    observations' weighted J_m^T J_m (whitened)."""
    pose = poses[problem.reading]
    mark = landmarks[problem.landmark]
    t = observation_terms(pose[:, 0], pose[:, 1], pose[:, 2], mark[:, 0], mark[:, 1],
                          problem.offset)
    jr = np.stack([t.dx / t.range, t.dy / t.range], -1) / problem.sigma_range[:, None]
    jb = np.stack([-t.dy / t.q, t.dx / t.q], -1) / problem.sigma_bearing
    info = weights[:, None, None] * (jr[:, :, None] * jr[:, None, :]
                                     + jb[:, :, None] * jb[:, None, :])
    total = np.stack([np.bincount(problem.landmark, info[:, i, j], len(landmarks))
                      for i in range(2) for j in range(2)], -1).reshape(-1, 2, 2)
    return np.linalg.inv(total)


def refine_best_map(slam):
    """``refine`` of a ``FastSLAM``'s best particle: its confirmed map (``map_min_existence``)
    over its path and the filter's reading log; (refined map, ``RefinementReport``)."""
    config = slam.config
    stamps, path = slam.best_path()
    return refine(slam.readings, stamps, path, slam.best_map(config.map_min_existence), config,
                  known_ids=config.association == "known")
