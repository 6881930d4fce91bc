# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""FastSLAM 1.0 and 2.0 over stacked particle arrays (Montemerlo and Thrun).

One ``update`` processes one sensor reading (any number of observations) for all M particles at
once, with no Python loop over particles, landmarks or observations. Per step:

1. Motion. Odometry given to ``predict`` is accumulated and applied at the next update. FastSLAM
   1.0 samples the odometry motion model; FastSLAM 2.0 keeps its Gaussian form N(s_hat, P).
2. Association, per particle and observation, against the particle's landmarks within the
   sensor's reach (taken from the *working set*, the cells around the robot gathered from the
   shared store and kept across readings until the robot reaches other cells): likelihood
   N(z; z_hat, Q), Q = G_m Sigma G_m^T + R (1.0) or N(z; z_hat, L), L = G_s P G_s^T + Q (2.0),
   p0 for a new landmark.
3. FastSLAM 2.0 only: the associated observations refine the pose proposal, all at once
   (``proposal.observation_proposal``); then the pose is sampled from it.
4. Map: EKF update (Joseph form) of each observed landmark, inverse-model initialisation of new
   ones, log-odds of existence raised for observed landmarks and lowered for landmarks inside
   the perceptual range that were not observed; landmarks below the bound are removed.
5. Weights multiply the chosen likelihoods (log space); resampling when N_eff is low.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import association as assoc
from .config import LOGODDS_MAX, FastSLAMConfig, numba_available
from .existence import explains, missed_logodds, observed_logodds
from .geometry import (compose, compose_floats, mean_pose_and_covariance, pose_floats,
                       relative_pose_floats, wrap_angle)
from .landmark_ekf import initialize_landmarks, pack, unpack, update_landmarks
from .landmark_store import COV, LOGODDS, MEAN, LandmarkStore, WorkingSet
from .loop_closure import LoopClosure
from .map_refinement import ReadingLog
from .working_cache import WorkingSetCache
from .motion import OdometryControl, control_variances, propagate_gaussian, sample_motion
from .observation import MIN_OBSERVATION_RANGE, SensorOffset, observation_terms
from .path_history import PathHistory
from .proposal import observation_proposal, sample_pose
from .relocalization import explained, find_pose, world_points
from .resampling import RESAMPLERS, effective_sample_size, normalize_log_weights

REACH_MARGIN = 2.0
"""Metres beyond the sensor's reach (the larger of ``max_range`` and the farthest observation)
within which landmarks join the working set and are scored against the observations: a
landmark whose mean lies farther out is no plausible match for any observation."""
MAX_PRIOR_HEADING_SIGMA = 0.3
"""FastSLAM 2.0: odometry between observations is carried as one Gaussian per particle, so the
proposal sees all of its uncertainty; once its heading standard deviation exceeds this (rad)
the particles are sampled from it, before the proposal's linearisation fails."""
RELOCALIZATION_RADIUS = 10.0
"""Metres beyond the sensor's reach around the best particle within which the map's landmarks
are matched to a reading when the filter is lost (``FastSLAM._relocalize``)."""
RELOCALIZATION_RETRY = 1.0
"""Seconds after a pose search that found nothing before the next one (a search over a
reading costs tens of milliseconds)."""
MAX_RELOCALIZATION_LANDMARKS = 150
"""Landmarks (the nearest to the best particle) a pose search matches a reading against: the
search's pair matching grows with their square."""
MIN_RELOCALIZATION_INLIERS = 3
"""Observations a pose found from one reading must put near landmarks (two pin any pair)."""
NO_MOTION = (0.0, 0.0, 0.0)
"""The accumulated odometry (dx, dy, dtheta) before any ``predict``."""
_NO_DRAWS = np.zeros(0)
_NO_NORMALS = np.zeros((0, 3))


@dataclass
class LandmarkMap:
    """One particle's map: means (N,2), covariances (N,2,2), existence probabilities (N,),
    external ids (N,) (-1 unknown) and stable landmark keys (N,)."""

    means: np.ndarray
    covariances: np.ndarray
    existence: np.ndarray
    ids: np.ndarray
    keys: np.ndarray

    def __len__(self) -> int:
        return len(self.means)

    def confirmed(self, min_existence: float) -> "LandmarkMap":
        """The landmarks at least ``min_existence`` likely to exist: the map without the
        tentative ones (a new landmark starts at sigmoid(logodds_observed)), as a user sees it
        (``map_min_existence``)."""
        if min_existence <= 0.0 and not np.isnan(self.existence).any():
            return self
        keep = self.existence >= min_existence
        return LandmarkMap(self.means[keep], self.covariances[keep], self.existence[keep],
                           self.ids[keep], self.keys[keep])


@dataclass
class UpdateReport:
    """What one ``update`` did, seen from the best particle (``best_index``)."""

    num_observations: int
    associated_ids: np.ndarray
    """(K,) label of the landmark each observation was associated to; -1: new or unlabelled."""
    is_new: np.ndarray
    """(K,) the observation created a landmark."""
    resampled: bool
    n_eff: float
    weights_underflow: bool


class FastSLAM:
    """The particle filter; public arrays ``poses`` (M, 3) and ``log_weights`` (M,)."""

    def __init__(self, config: FastSLAMConfig, rng: np.random.Generator | None = None,
                 initial_pose=(0.0, 0.0, 0.0)) -> None:
        self.config = config.validate()
        if rng is None:
            rng = np.random.default_rng(None if config.seed < 0 else config.seed)
        self.rng = rng
        self.offset = SensorOffset(config.sensor_x, config.sensor_y, config.sensor_yaw)
        self._lever_length = math.hypot(config.sensor_x, config.sensor_y)
        self.noise_diag = np.array([config.sigma_range ** 2, config.sigma_bearing ** 2])
        self.alphas = (config.alpha1, config.alpha2, config.alpha3, config.alpha4)
        self.linear_noise = (config.rotation_variance_per_radian,
                             config.rotation_variance_per_meter,
                             config.translation_variance_per_meter,
                             config.translation_variance_per_radian)
        self._log_p0 = float(np.log(config.new_landmark_likelihood))
        self._evidence = self.config.existence_evidence()
        """(tau+, tau-) of the existence log-odds (``FastSLAMConfig.existence_evidence``)."""
        self._confirmation = self.config.confirmation()
        """(l_c, tau- of a confirmed landmark) (``FastSLAMConfig.confirmation``)."""
        self._log_outlier = assoc.log_outlier_density(config)
        self._localization = config.mode == "localization"
        self._seed: tuple[np.ndarray, ...] | None = None
        self.num_recoveries = 0
        """Updates after which ``check_state`` found a non-finite state and repaired it."""
        self.num_relocalizations = 0
        """Readings after which ``localization`` mode redrew particles at a pose found from
        the reading (``relocalization_fraction``)."""
        self.kernels = self._load_kernels()
        """The compiled backend (``core.kernels``) when it runs, else None (numpy)."""
        self.backend = "numpy" if self.kernels is None else "numba"
        self._settings = None if self.kernels is None else self.kernels.reading_settings(
            self.config, self.offset, self._log_p0, self._log_outlier, LOGODDS_MAX)
        self._resample_compiled = self.kernels is not None and config.resampling == "systematic"
        """Systematic resampling, the poses' and the working set's in compiled calls."""
        self._resample = RESAMPLERS[config.resampling]
        self._log_uniform = -np.log(config.num_particles)
        """The log weight of every particle after resampling."""
        self.reset(initial_pose)

    def _load_kernels(self):
        """``core.kernels``, compiled (or loaded from cache) now, when ``backend`` asks for it
        and the configuration is one it covers; None: the numpy path."""
        config = self.config
        if config.backend == "numpy" or (config.backend == "auto" and not numba_available()):
            return None
        from . import kernels  # noqa: PLC0415 (optional dependency)
        kernels.warm_up()
        return kernels

    # ------------------------------------------------------------------ lifecycle
    def reset(self, initial_pose=(0.0, 0.0, 0.0)) -> None:
        """Forget everything: all particles at ``initial_pose``, empty maps, uniform weights."""
        count = self.config.num_particles
        self.poses = np.tile(np.asarray(initial_pose, dtype=float), (count, 1))
        self.log_weights = np.full(count, self._log_uniform)
        self._seed_landmarks()
        self.history = PathHistory(count, kernels=self.kernels)
        self.readings = ReadingLog()
        """The readings processed since the start, for ``map_refinement.refine``."""
        self._pending = NO_MOTION
        self._has_pending = False
        self._prior = None
        self._best = 0
        self._lost_since: float | None = None
        self._placed = False
        """A pose was given (``initialize_pose``) and the map not found since: a pose found
        from a reading is taken at once."""
        self._searched = -math.inf
        """Stamp of the latest pose search of the current loss."""
        self._closest = math.inf
        """Smallest distance (m) between the best particle and the pose found this loss."""
        self.num_updates = 0
        self.num_underflows = 0

    @property
    def num_particles(self) -> int:
        return self.config.num_particles

    def seed_map(self, means, covariances, ids=None, existence=None) -> None:
        """Make every particle's map these landmarks (a map loaded from a file): means (N, 2),
        covariances (N, 2, 2), ids (N,) (labels; -1 unknown), existence probabilities (N,)
        (default: certain). ``reset`` returns to this map; in ``localization`` mode it is fixed.
        The particles share one copy until one of them changes it."""
        means = np.asarray(means, dtype=float).reshape(-1, 2)
        count = len(means)
        labels = (np.full(count, -1, np.int64) if ids is None
                  else np.asarray(ids, dtype=np.int64).reshape(count))
        logodds = np.full(count, LOGODDS_MAX)
        if existence is not None:
            probability = np.clip(np.asarray(existence, dtype=float).reshape(count), 1e-9,
                                  1.0 - 1e-9)
            logodds = np.minimum(np.log(probability / (1.0 - probability)), LOGODDS_MAX)
        packed = pack(np.asarray(covariances, dtype=float).reshape(count, 2, 2))
        self._seed = (means, packed, labels, logodds)
        self._seed_landmarks()
        self.readings.clear()

    def _seed_landmarks(self) -> None:
        """A fresh landmark store (and its working-set cache) holding the seeded map (if any)
        in every particle."""
        count = self.num_particles
        self.landmarks = LandmarkStore(count, self.config.cell_size, kernels=self.kernels)
        self.working = WorkingSetCache(self.landmarks, self.config.association == "known")
        """The landmarks near the robot that readings work on (kept across readings)."""
        config = self.config
        self.loop = (LoopClosure(count, config.loop_closure_matches, config.map_min_existence,
                                 config.max_range)
                     if config.loop_closure_matches > 0 and not self._localization
                     and config.association != "known" else None)
        """Loop closure confirmed across readings (``loop_closure_matches``), or None."""
        if self._seed is None or len(self._seed[0]) == 0:
            return
        means, packed, labels, logodds = self._seed
        ws = self.landmarks.gather(np.full((count, 0), -1, np.int64), len(means))
        ws.mean[0], ws.cov[0], ws.logodds[0], ws.label[0] = means, packed, logodds, labels
        ws.key[0] = self.landmarks.new_keys(len(means))
        ws.valid[0] = ws.is_new[0] = True
        self.landmarks.scatter(ws, track_labels=self.config.association == "known")
        self.landmarks.resample(np.zeros(count, np.int64))
        if self.loop is not None:
            self.loop.register(self.landmarks.next_key)

    def initialize_pose(self, mean, covariance) -> None:
        """Redraw every particle's pose from N(mean (3,), covariance (3, 3)), e.g. a pose the
        user gives; maps and path are kept, the weights become uniform."""
        count = self.num_particles
        mean = np.broadcast_to(np.asarray(mean, dtype=float), (count, 3))
        covariance = np.broadcast_to(np.asarray(covariance, dtype=float), (count, 3, 3))
        poses = sample_pose(mean, covariance, self.rng.standard_normal((count, 3)))
        poses[:, 2] = wrap_angle(poses[:, 2])
        self.poses = poses
        self.log_weights = np.full(count, -np.log(count))
        self._prior = None
        self._pending = NO_MOTION
        self._has_pending = False
        self._lost_since = None
        self._placed = True
        self.readings.clear()

    # ------------------------------------------------------------------ motion
    def predict(self, odom_from, odom_to) -> None:
        """Accumulate the odometry increment between two odometry poses (odom frame).

        The motion is applied at the next ``update``, or at once when it grows beyond
        ``max_pending_translation`` / ``max_pending_rotation`` (so one (rot1, trans, rot2) step
        never spans a long curve): FastSLAM 1.0 then samples it; FastSLAM 2.0 adds it to each
        particle's Gaussian prior N(s_hat, P), which its proposal uses at the next observation.
        """
        step = relative_pose_floats(pose_floats(odom_from), pose_floats(odom_to))
        self._pending = compose_floats(self._pending, step)
        self.readings.move(step)
        if self.loop is not None:
            self.loop.travelled += math.hypot(step[0], step[1])
        self._has_pending = True
        x, y, theta = self._pending
        if (math.hypot(x, y) > self.config.max_pending_translation
                or abs(theta) > self.config.max_pending_rotation):
            self._advance_motion()

    def _advance_motion(self) -> None:
        """Apply the accumulated odometry: sampled (1.0) or into the Gaussian prior (2.0)."""
        if not self._has_pending:
            return
        if self.kernels is not None and self.config.algorithm == "fastslam2":
            # The same steps as below, the covariance left to the next reading's blocks of
            # particles (or to the first other use of the prior, ``_prior``).
            prior = self._prior
            moved, widest, turn, motion = self.kernels.advance_mean(
                prior, self.poses, self._pending, self._settings)
            self._prior = (moved, None)
            self._deferred = (turn, None if prior is None else prior[1], motion)
            self._pending = NO_MOTION
            self._has_pending = False
            if widest > MAX_PRIOR_HEADING_SIGMA ** 2:
                self.poses = self._sample_prior()
            return
        control = OdometryControl.from_delta(self._pending)
        variances = control_variances(control, self.alphas, self.config.min_translation_sigma,
                                      self.config.min_rotation_sigma, self.linear_noise)
        self._pending = NO_MOTION
        self._has_pending = False
        if self.config.algorithm == "fastslam1":
            normals = self.rng.standard_normal((self.num_particles, 3))
            sample = sample_motion if self.kernels is None else self.kernels.sample_motion
            self.poses = sample(self.poses, control, variances, normals)
            return
        mean, cov = self._prior if self._prior is not None else (
            self.poses, np.zeros((self.num_particles, 3, 3)))
        self._prior = propagate_gaussian(mean, cov, control, variances)
        if self._prior[1][:, 2, 2].max() > MAX_PRIOR_HEADING_SIGMA ** 2:
            # Too wide to linearise at the next observation: let the particles carry it.
            self.poses = self._sample_prior()

    @property
    def _prior(self) -> tuple[np.ndarray, np.ndarray] | None:
        """FastSLAM 2.0's Gaussian prior (mean (M, 3), cov (M, 3, 3)) or None; a covariance
        left to the next reading (``_deferred``: the turn, the covariance it moves from and
        the motion of ``kernels.advance_mean``) is propagated here first."""
        if self._deferred is not None:
            turn, cov, motion = self._deferred
            self._deferred = None
            self._prior_value = (self._prior_value[0],
                                 self.kernels.propagate_cov(turn, cov, motion))
        return self._prior_value

    @_prior.setter
    def _prior(self, value: tuple[np.ndarray, np.ndarray] | None) -> None:
        self._prior_value = value
        self._deferred = None

    def _sample_prior(self) -> np.ndarray:
        """Draw every particle's pose from its Gaussian prior, which is then consumed."""
        mean, cov = self._prior
        self._prior = None
        sample = sample_pose if self.kernels is None else self.kernels.sample_pose
        sampled = sample(mean, cov, self.rng.standard_normal((self.num_particles, 3)))
        sampled[:, 2] = wrap_angle(sampled[:, 2])
        return sampled

    # ------------------------------------------------------------------ update
    def update(self, ranges, bearings, ids=None, stamp: float = 0.0) -> UpdateReport:
        """Process one sensor reading: range/bearing (K,) in the sensor frame, optional ids.

        Observations with a non-finite range or one below ``MIN_OBSERVATION_RANGE`` or a
        non-finite bearing are skipped (the ROS node reports them). ``ids`` are required
        (>= 0) in ``known`` mode; in the other modes they are labels only (see
        ``UpdateReport.associated_ids``).
        """
        ranges = np.asarray(ranges, dtype=float).reshape(-1)
        bearings = np.asarray(bearings, dtype=float).reshape(-1)
        labels = (np.full(len(ranges), -1, np.int64) if ids is None
                  else np.asarray(ids, dtype=np.int64).reshape(-1))
        if not len(ranges) == len(bearings) == len(labels):
            raise ValueError("ranges, bearings and ids must have the same length")
        known = self.config.association == "known"
        if not self._localization:  # a fixed map is saved as it is
            self.readings.record(stamp, ranges, bearings, labels)
        if self.kernels is not None:
            report = self._update_compiled(*self.kernels.usable_observations(
                ranges, bearings, labels, known, MIN_OBSERVATION_RANGE), stamp)
        else:
            report = self._update_numpy(ranges, bearings, labels, stamp)
        if self._localization and self.config.relocalization_fraction > 0.0:
            self._relocalize(ranges, bearings, stamp)
        return report

    def _update_numpy(self, ranges: np.ndarray, bearings: np.ndarray, labels: np.ndarray,
                      stamp: float) -> UpdateReport:
        """``update`` on the numpy path (the reference)."""
        known = self.config.association == "known"
        usable = np.isfinite(ranges) & np.isfinite(bearings) & (ranges >= MIN_OBSERVATION_RANGE)
        if known:
            usable &= labels >= 0
        if not usable.all():
            ranges, bearings, labels = ranges[usable], bearings[usable], labels[usable]
        bearings = wrap_angle(bearings)

        fastslam2 = self.config.algorithm == "fastslam2"
        self._advance_motion()
        proposal_mean, proposal_cov = self._prior if self._prior is not None else (self.poses,
                                                                                    None)

        ws = self.working.for_reading(proposal_mean, self._reach(ranges), len(ranges),
                                      labels if known else None)
        if self.loop is not None:
            self.loop.before_reading(ws, None)
        choices, log_factors, robust, inverse_q = self._associate(
            ws, proposal_mean, proposal_cov, ranges, bearings, labels)
        observed = np.zeros(ws.valid.shape, dtype=bool)
        if self._localization:
            # A fixed map takes no new landmark: an unexplained observation weighs p0 only.
            choices[choices == assoc.NEW] = assoc.IGNORE
        if fastslam2 and proposal_cov is not None:
            proposal = self._proposal(ws, proposal_mean, proposal_cov, choices, ranges, bearings)
            log_factors = self._sample_proposal(proposal, choices, log_factors, inverse_q)
        log_factors = log_factors + robust
        self.log_weights = self.log_weights + log_factors.sum(axis=0)
        if self._localization:
            creating = np.zeros(choices.shape, dtype=bool)
        else:
            creating = self._apply_to_map(ws, observed, choices, ranges, bearings, labels)
            self._missed_evidence(ws, observed, creating | (choices == assoc.IGNORE), ranges,
                                  bearings)
        self.history.record(stamp, self.poses)
        self.num_updates += 1
        # This reading's new-landmark columns now hold landmarks (in some particles).
        self.working.created(int(creating.any(axis=1).sum()))
        report = self._finish_update(ws, choices, creating)
        self.check_state()
        return report

    def _update_compiled(self, ranges: np.ndarray, bearings: np.ndarray, labels: np.ndarray,
                         farthest: float, stamp: float) -> UpdateReport:
        """``update`` on the compiled backend: the reading's math in one call
        (``kernels.update_reading``), on the numpy path's random draws in its order;
        ``farthest``: the largest of ``ranges`` (0 when empty)."""
        config, count = self.config, self.num_particles
        known = config.association == "known"
        self._advance_motion()
        # A deferred prior (``motion``) has no covariance yet: the reading's blocks propagate it.
        mean, cov = self._prior_value if self._prior_value is not None else (self.poses, None)
        motion = self._deferred
        reach = self._reach_of(farthest)
        # Split over threads, the reading's chunks make a pending resampling's working-set copy
        # as they go; on one thread the copy in one call is the cheaper.
        ws = self.working.for_reading(mean, reach, len(ranges), labels if known else None,
                                      lazy=self.kernels.splits(count))
        if self.loop is not None:
            self.loop.before_reading(ws, self.working.pending)
        draws = (self.rng.random(len(ranges) * count) if config.association == "monte_carlo"
                 else _NO_DRAWS)
        propose = (cov is not None or motion is not None) and config.algorithm == "fastslam2"
        normals = self.rng.standard_normal((count, 3)) if propose else _NO_NORMALS
        (associated_ids, is_new, poses, self.log_weights, n_eff, underflow, best, columns, keys,
         finite, ws) = self.kernels.update_reading(
            ws, mean, cov, self.poses, ranges, bearings, labels, draws, normals,
            self.log_weights, self._settings, reach, self.landmarks.next_key, propose,
            self.history.next_generation(), self.working.pending, motion)
        self.working.took(ws)
        if propose:
            self._prior = None
        self.poses = poses
        self.landmarks.next_key += keys
        self.history.record(stamp, written=True)
        self.num_updates += 1
        self.num_underflows += int(underflow)
        report = UpdateReport(len(ranges), associated_ids, is_new, False, float(n_eff),
                              bool(underflow))
        self._best = int(best)
        # This reading's new-landmark columns now hold landmarks (in some particles).
        self.working.created(int(columns))
        self._close_loops()
        self._resample_if_degenerate(report)
        if not finite:
            self.check_state()
        return report

    def _relocalize(self, ranges: np.ndarray, bearings: np.ndarray, stamp: float) -> None:
        """Localization on a fixed map (sensor resetting). The best particle is lost while at
        most half of each reading's observations lie within ``relocalization_gate`` of a
        landmark seen from it. While lost, once per ``RELOCALIZATION_RETRY`` s, the pose that
        explains more of them is searched (``relocalization.find_pose``, over the landmarks
        within the sensor's reach plus ``RELOCALIZATION_RADIUS``, the nearest
        ``MAX_RELOCALIZATION_LANDMARKS``); a pose that explains more than half and at least
        ``MIN_RELOCALIZATION_INLIERS`` is taken once the loss has lasted
        ``relocalization_delay`` s, or earlier once it lies ``relocalization_gate`` farther
        from the best particle than the closest such pose of this loss (the filter is drifting
        away from the map, not finding it by itself), or at once while the map has not been
        found since an ``initialize_pose`` (a pose a user guessed, not a filter that may find
        the map by itself). Taking it redraws the
        ``relocalization_fraction`` lightest particles (among equal weights, as after
        resampling, the first ones) around it (weights uniform, as after resampling)."""
        usable = (np.isfinite(ranges) & np.isfinite(bearings)
                  & (ranges >= MIN_OBSERVATION_RANGE))
        count = int(usable.sum())
        if count < MIN_RELOCALIZATION_INLIERS or self._seed is None:
            return
        ranges, bearings = ranges[usable], bearings[usable]
        angle = bearings + self.offset.yaw
        points = np.column_stack([self.offset.x + ranges * np.cos(angle),
                                  self.offset.y + ranges * np.sin(angle)])
        pose = self.poses[self._best]
        means = self._seed[0]
        reach = self._reach(ranges) + RELOCALIZATION_RADIUS
        squared = ((means - pose[:2]) ** 2).sum(axis=1)
        near = means[squared <= reach * reach]
        if len(near) > MAX_RELOCALIZATION_LANDMARKS:
            near = means[np.argsort(squared, kind="stable")[:MAX_RELOCALIZATION_LANDMARKS]]
        gate = self.config.relocalization_gate
        hits = int(explained(world_points(pose, points), near, gate).sum())
        if 2 * hits > count:
            self._lost_since = None
            self._placed = False
            return
        if self._lost_since is None:
            self._lost_since, self._searched, self._closest = stamp, -math.inf, math.inf
        if stamp - self._searched < RELOCALIZATION_RETRY:
            # A search costs tens of milliseconds: one per RELOCALIZATION_RETRY s.
            return
        self._searched = stamp
        found, inliers = find_pose(points, near, gate)
        if 2 * inliers <= count or inliers < max(MIN_RELOCALIZATION_INLIERS, hits + 1):
            # Nothing found (e.g. where the map has no landmarks).
            self._closest = math.inf
            return
        apart = float(np.hypot(*(found[:2] - pose[:2])))
        self._closest = min(self._closest, apart)
        if (not self._placed and stamp - self._lost_since < self.config.relocalization_delay
                and apart < self._closest + gate):
            # Within the delay the filter may find the map by itself; once the pose the
            # readings give has drifted a gate farther from it than it was, it will not.
            return
        redrawn = np.argsort(self.log_weights, kind="stable")[
            :max(1, round(self.config.relocalization_fraction * self.num_particles))]
        spread = np.array([0.5 * gate, 0.5 * gate, gate / max(float(ranges.max()), gate)])
        poses = found + spread * self.rng.standard_normal((len(redrawn), 3))
        poses[:, 2] = wrap_angle(poses[:, 2])
        self.poses[redrawn] = poses
        self.log_weights = np.full(self.num_particles, -np.log(self.num_particles))
        self._best = int(redrawn[0])
        self._lost_since = None
        self._placed = False
        self.num_relocalizations += 1

    def _noise(self, ranges):
        """(range variance, bearing variance) of observations with these ranges: the range
        variance grows with the range when ``sigma_range_per_meter`` > 0."""
        if self.config.sigma_range_per_meter == 0.0:
            return self.noise_diag
        return (self.noise_diag[0] + (self.config.sigma_range_per_meter * ranges) ** 2,
                self.noise_diag[1])

    def flush(self) -> None:
        """Write the working set back into ``landmarks`` (the shared store) and drop it.

        ``update`` does this by itself when the robot reaches other cells; call it before
        reading ``landmarks`` directly. ``particle_map`` and ``best_map`` do not need it.
        """
        self.working.flush()

    def _known_candidates(self, ws: WorkingSet, labels: np.ndarray) -> np.ndarray:
        """(K, M, 1) working-set column of the landmark carrying each observation's id (-1:
        the particle has none)."""
        existing = ws.first_new_slot
        match = ws.valid[None, :, :existing] & (ws.label[None, :, :existing]
                                                 == labels[:, None, None])
        if existing == 0:
            return np.full(match.shape[:2] + (1,), -1, np.int64)
        return np.where(match.any(axis=2), match.argmax(axis=2), -1)[:, :, None]

    def _associate(self, ws: WorkingSet, mean: np.ndarray, cov, ranges: np.ndarray,
                   bearings: np.ndarray, labels: np.ndarray):
        """Choose every particle's landmark for every observation of the reading at once.

        Scored at the pose before this reading's observations are used: the sampled pose
        (1.0), or the predicted mean with its covariance P (2.0, likelihood with L). Every
        observation is scored against the particle's landmarks in the working-set columns
        within the sensor's reach (``_columns_in_reach``; so the cost does not grow with the
        map): the terms of a (particle, landmark) pair are computed once and broadcast over the
        observations. With known ids the only candidate is the landmark carrying the id.
        Returns choices (K, M), working-set columns or ``association.NEW`` / ``IGNORE`` (also
        for outliers, with ``outlier_probability`` > 0), the log weight factors (K, M), the
        robust-likelihood correction of the inliers (``association.reject_outliers``) and
        log(1 / q) (K, M) of each associated observation, q the probability with which its
        landmark was drawn (0 but with ``monte_carlo``, where it is the log marginal minus the
        landmark's own log likelihood).
        """
        config = self.config
        count = len(ranges)
        mode = config.association
        if mode == "known":
            candidates = self._known_candidates(ws, labels)                 # (K, M, 1)
            if cov is not None and config.outlier_probability == 0.0:
                # FastSLAM 2.0 weighs the associated observations by the proposal's joint
                # likelihood, and no outlier test needs theirs: nothing to score.
                choice = candidates[..., 0]                                  # -1 is NEW
                zeros = np.zeros(choice.shape)
                return choice, np.where(choice >= 0, 0.0, self._log_p0), zeros, zeros
            landmark = ws.records_at(candidates[..., 0])[:, :, None]         # (K, M, 1, 6)
            valid = candidates >= 0
        else:
            kept, near = self._columns_in_reach(ws, mean, ranges)
            landmark = ws.state[:, kept][None]                               # (1, M, E, 6)
            valid = near[:, kept][None]
        # Empty entries are scored against a point 1 m ahead (finite terms), then dropped.
        landmark_x = np.where(valid, landmark[..., 0], mean[:, 0, None] + 1.0)
        landmark_y = np.where(valid, landmark[..., 1], mean[:, 1, None])
        t = observation_terms(mean[:, 0, None], mean[:, 1, None], mean[:, 2, None],
                              landmark_x, landmark_y, self.offset)
        log_lik, mahalanobis = assoc.score(
            t, landmark[..., COV], ranges[:, None, None], bearings[:, None, None],
            self._noise(ranges[:, None, None]), None if cov is None else cov[:, None])
        # Rows of the association rules: observation-major, (K * M, C).
        shape = (count * self.num_particles, log_lik.shape[2])
        log_lik = np.where(valid, log_lik, -np.inf).reshape(shape)
        inverse_q = np.zeros(shape[0])
        if mode == "known":
            pick, log_factor = assoc.associate_maximum_likelihood(log_lik, -np.inf)
            rows = (pick >= 0).nonzero()[0]
            choice = pick.copy()
            choice[rows] = candidates.reshape(shape)[rows, pick[rows]]
            log_factor = np.where(choice >= 0, log_factor, self._log_p0)
        elif mode == "ml":
            choice, log_factor = assoc.associate_exclusive_maximum_likelihood(
                log_lik, self.num_particles, self._log_p0)
        elif mode == "monte_carlo":
            choice, log_factor = assoc.associate_monte_carlo(log_lik, self._log_p0, self.rng)
            rows = (choice >= 0).nonzero()[0]
            inverse_q[rows] = log_factor[rows] - log_lik[rows, choice[rows]]
        else:
            mahalanobis = np.where(valid, mahalanobis, np.inf).reshape(shape)
            choice, log_factor = assoc.associate_two_gates(
                log_lik, mahalanobis, self._log_p0, config.association_gate,
                config.new_landmark_gate)
        if mode != "known" and len(kept):
            choice = np.where(choice >= 0, kept[np.maximum(choice, 0)], choice)
        grid = (count, self.num_particles)
        return assoc.reject_outliers(choice.reshape(grid), log_factor.reshape(grid),
                                     config.outlier_probability,
                                     self._log_outlier) + (inverse_q.reshape(grid),)

    def _columns_in_reach(self, ws: WorkingSet, poses: np.ndarray, ranges: np.ndarray):
        """Working-set columns (of the landmarks that existed before this reading) holding a
        landmark within the sensor's reach plus ``REACH_MARGIN`` of its particle's pose (the
        working set holds whole cells of a box around all particles, about twice the area),
        and which particle's entries are in reach (M, existing): only those are candidates."""
        existing = ws.first_new_slot
        reach = self._reach(ranges)
        dx = ws.mean[:, :existing, 0] - poses[:, 0, None]
        dy = ws.mean[:, :existing, 1] - poses[:, 1, None]
        near = dx * dx
        near += dy * dy
        near = ws.valid[:, :existing] & (near <= reach * reach)
        return near.any(axis=0).nonzero()[0], near

    def _reach(self, ranges: np.ndarray) -> float:
        """Distance from the robot within which a landmark may match an observation."""
        return self._reach_of(float(ranges.max(initial=0.0)))

    def _reach_of(self, farthest: float) -> float:
        """``_reach`` of a reading whose largest range is ``farthest`` (0 when empty)."""
        return max(self.config.max_range, farthest) + REACH_MARGIN + self._lever_length

    def _proposal(self, ws: WorkingSet, mean: np.ndarray, cov: np.ndarray, choices: np.ndarray,
                  ranges: np.ndarray, bearings: np.ndarray):
        """FastSLAM 2.0: (mu_s, Sigma_s, joint log likelihood (M,)) of the proposal given the
        observations associated to existing landmarks (``choices`` (K, M))."""
        used = choices >= 0
        if not used.any():
            return mean, cov, np.zeros(self.num_particles)
        return observation_proposal(mean, cov, ws.records_at(choices), ranges[:, None],
                                    bearings[:, None], used, self.offset,
                                    self._noise(ranges[:, None]))

    def _sample_proposal(self, proposal, choices: np.ndarray, log_factors: np.ndarray,
                         inverse_q: np.ndarray) -> np.ndarray:
        """Draw every pose from the proposal; return the log weight factors (K, M).

        The associated observations' factors are replaced by their joint likelihood
        N(z; z_hat, L) (put on the first row) times 1 / q, q the probability of their sampled
        association (``monte_carlo``; 1 otherwise): the importance weight of the association
        draw, which makes a single observation weigh the marginal over associations, as in
        FastSLAM 1.0. New / ignored observations keep p0 (the marginal, when sampled) / 1.
        """
        mean, cov, joint = proposal
        self._prior = (mean, cov)
        self.poses = self._sample_prior()
        if len(log_factors) == 0:
            return log_factors
        log_factors = np.where(choices >= 0, inverse_q, log_factors)
        log_factors[0] += joint
        return log_factors

    def _apply_to_map(self, ws: WorkingSet, observed: np.ndarray, choices: np.ndarray,
                      ranges: np.ndarray, bearings: np.ndarray, labels: np.ndarray) -> np.ndarray:
        """New landmarks, then EKF updates of the associated ones, for all observations.

        ``choices`` (K, M) is updated in place: a new landmark's particles get the column it was
        put in, one free column per observation that creates a landmark in some particle. With
        known ids, a repeated id in one reading updates the landmark that its first observation
        created. All (observation, particle) pairs are updated in one batch; a landmark that
        several observations hit is updated by them in turn. Returns which (observation,
        particle) pairs created a landmark (K, M).
        """
        config = self.config
        first_new = ws.first_new_slot
        count = len(ranges)
        creating = choices == assoc.NEW
        repeated = None
        if config.association == "known" and count > 1:
            first_with_label: dict[int, int] = {}
            creator = np.array([first_with_label.setdefault(label, k)
                                for k, label in enumerate(labels.tolist())])
            if len(first_with_label) < count:
                repeated = (creator != np.arange(count))[:, None] & creating
                creating &= ~repeated
        column = np.full(count, -1, np.int64)
        creators = creating.any(axis=1).nonzero()[0]
        column[creators] = first_new + np.arange(len(creators))
        if repeated is not None:
            choices[repeated] = np.broadcast_to(column[creator][:, None], choices.shape)[repeated]
        obs, particle = creating.nonzero()
        if len(obs):
            slot = column[obs]
            ws.mean[particle, slot], ws.cov[particle, slot] = initialize_landmarks(
                self.poses[particle], ranges[obs], bearings[obs], self.offset,
                self._noise(ranges[obs]))
            ws.logodds[particle, slot] = self._evidence[0]
            ws.label[particle, slot] = labels[obs]
            ws.key[particle, slot] = self.landmarks.new_keys(len(obs))
            ws.valid[particle, slot] = True
            ws.is_new[particle, slot] = True
            observed[particle, slot] = True
            choices[obs, particle] = slot
        obs, particle = ((choices >= 0) & ~creating).nonzero()
        if len(obs) == 0:
            return creating
        slot = choices[obs, particle]
        pair = particle * ws.valid.shape[1] + slot
        batches = [slice(None)]
        if np.bincount(pair).max() > 1:
            # A landmark hit by several observations: they update it in turn, in batches of
            # distinct landmarks (the first observation of each, then the second, ...).
            order = np.lexsort((obs, pair))
            obs, particle, slot, pair = obs[order], particle[order], slot[order], pair[order]
            first = np.ones(len(pair), bool)
            first[1:] = pair[1:] != pair[:-1]
            repeat = np.arange(len(pair)) - np.maximum.accumulate(
                np.where(first, np.arange(len(pair)), 0))
            batches = [repeat == rank for rank in range(int(repeat.max()) + 1)]
        for batch in batches:
            p, s, j = particle[batch], slot[batch], obs[batch]
            state = ws.state[p, s]
            state[:, MEAN], state[:, COV] = update_landmarks(
                self.poses[p], state[:, MEAN], state[:, COV], ranges[j], bearings[j],
                self.offset, self._noise(ranges[j]))
            state[:, LOGODDS] = observed_logodds(state[:, LOGODDS], self._evidence[0],
                                                 self._confirmation[0], LOGODDS_MAX)
            ws.state[p, s] = state
        ws.dirty[particle, slot] = True
        observed[particle, slot] = True
        return creating

    def _missed_evidence(self, ws: WorkingSet, observed: np.ndarray, rejected: np.ndarray,
                         ranges: np.ndarray, bearings: np.ndarray) -> None:
        """Lower the log-odds of landmarks in the perceptual range that were not observed and
        that no observation the association rejected (``rejected`` (K, M)) explains
        (``existence.explains``); a confirmed landmark loses less (``existence``)."""
        config = self.config
        missed = self._evidence[1]
        if missed == 0.0:
            return
        # This reading's new landmarks (from column ``first_new_slot`` on) were all observed.
        existing = slice(0, ws.first_new_slot)
        mean = ws.mean[:, existing]
        t = observation_terms(self.poses[:, 0:1], self.poses[:, 1:2], self.poses[:, 2:3],
                              mean[..., 0], mean[..., 1], self.offset)
        inside = ws.valid[:, existing] & ~observed[:, existing]
        inside &= (t.range >= config.min_range) & (t.range <= config.max_range)
        if config.field_of_view < 2.0 * np.pi:
            # |bearing| <= fov / 2  <=>  cos(bearing) >= cos(fov / 2), without an arctan.
            along = t.dx * np.cos(t.heading) + t.dy * np.sin(t.heading)
            inside &= along >= t.range * np.cos(0.5 * config.field_of_view)
        obs, particle = rejected.nonzero()
        if len(obs):
            # (rejected pair, landmark): the observation explains the landmark's absence.
            variance_r, variance_b = self._noise(ranges[obs])
            variance_r = np.broadcast_to(variance_r, obs.shape)
            near = explains(
                ranges[obs, None] - t.range[particle],
                wrap_angle(bearings[obs, None] - (np.arctan2(t.dy[particle], t.dx[particle])
                                                  - t.heading[particle])),
                variance_r[:, None], variance_b)
            hit = np.zeros(inside.shape, bool)
            np.logical_or.at(hit, particle, near)
            inside &= ~hit
        logodds = ws.logodds[:, existing]
        logodds[inside] = missed_logodds(logodds[inside], missed, *self._confirmation)
        ws.dirty[:, existing] |= inside
        ws.valid[:, existing][inside & (logodds < config.logodds_remove)] = False

    def _finish_update(self, ws: WorkingSet, choices: np.ndarray,
                       creating: np.ndarray) -> UpdateReport:
        """Normalise weights, report from the best particle, resample if N_eff is low."""
        self.log_weights, underflow = normalize_log_weights(self.log_weights)
        self.num_underflows += int(underflow)
        weights = np.exp(self.log_weights)
        best = self._select_best()
        best_choice, is_new = choices[:, best], creating[:, best]
        labels = np.where(best_choice >= 0, ws.label[best, np.maximum(best_choice, 0)], -1)
        report = UpdateReport(len(best_choice), np.where(is_new, -1, labels), is_new, False,
                              effective_sample_size(weights), underflow)
        self._best = best
        self._close_loops()
        self._resample_if_degenerate(report)
        return report

    def _close_loops(self) -> None:
        """``loop_closure_matches``: the reading's new landmarks against old ones
        (``loop_closure.LoopClosure``), after the map step and before resampling, the same
        numpy step on both backends."""
        if self.loop is not None:
            self.poses = self.loop.after_reading(self.working, self.poses,
                                                 self.landmarks.next_key)

    def _resample_if_degenerate(self, report: UpdateReport) -> None:
        """Resample (poses, maps, working set, history) when N_eff is below the threshold;
        the reported particle follows its copy. Weights are normalised."""
        if report.n_eff >= self.config.resample_threshold * self.num_particles:
            return
        weights = np.exp(self.log_weights)
        heaviest = self.config.best_particle == "heaviest"
        if self._resample_compiled:
            indices, self.poses, copy = self.kernels.resample_poses(weights, self.rng,
                                                                    self.poses, self._best)
        else:
            indices = self._resample(weights, self.rng)
            self.poses = self.poses[indices]
            copies = (indices == self._best).nonzero()[0] if heaviest else ()
            copy = int(copies[0]) if len(copies) else -1
        self.landmarks.resample(indices)
        self.working.resample(indices)
        self.history.resample(indices)
        if self.loop is not None:
            self.loop.resample(indices)
        self.log_weights = np.full(self.num_particles, self._log_uniform)
        if not heaviest:
            self._best = self._select_best()
        else:
            # Multinomial resampling may draw no copy of the heaviest particle: take the
            # heaviest particle drawn instead.
            self._best = copy if copy >= 0 else int(weights[indices].argmax())
        report.resampled = True

    def _select_best(self) -> int:
        """The particle to report (``best_particle``): nearest the weighted mean position
        (``central``) or the highest weight (``heaviest``). Weights are normalised."""
        if self.config.best_particle == "central":
            positions = self.poses[:, :2]
            offsets = positions - np.exp(self.log_weights) @ positions
            return int(np.einsum("ij,ij->i", offsets, offsets).argmin())
        return int(self.log_weights.argmax())

    def check_state(self) -> bool:
        """Repair a non-finite state left by an update; True (and ``num_recoveries`` + 1) if
        it had to.

        Inputs are gated before they get here, so this is the last line of defence: a particle
        whose pose, prior or a landmark touched by the update is not finite is replaced by a
        copy of a finite one (weights uniform, as after resampling), so one bad reading cannot
        poison every later one. With no finite particle left the filter resets at the best
        particle's last finite pose (the map is lost).
        """
        ws, count = self.working.current, self.num_particles
        bad = ~np.isfinite(self.poses).all(axis=1)
        if self._prior is not None:
            bad |= ~(np.isfinite(self._prior[0]).all(axis=1)
                     & np.isfinite(self._prior[1]).reshape(count, -1).all(axis=1))
        if ws is not None:
            touched = ws.dirty & ws.valid
            bad |= (touched & ~np.isfinite(ws.state).all(axis=2)).any(axis=1)
        if not bad.any() and not np.isnan(self.log_weights).any():
            return False
        self.num_recoveries += 1
        good = (~bad).nonzero()[0]
        if len(good) == 0:
            stamps, poses = self.best_path()
            finite = np.isfinite(poses).all(axis=1).nonzero()[0]
            recoveries = self.num_recoveries
            self.reset(poses[finite[-1]] if len(finite) else (0.0, 0.0, 0.0))
            self.num_recoveries = recoveries
            return True
        indices = np.arange(count)
        indices[bad] = good[np.arange(int(bad.sum())) % len(good)]
        self.poses = self.poses[indices]
        if self._prior is not None:
            self._prior = (self._prior[0][indices], self._prior[1][indices])
        self.landmarks.resample(indices)
        self.working.resample(indices)
        self.history.resample(indices)
        if self.loop is not None:
            self.loop.resample(indices)
        self.log_weights = np.full(count, -np.log(count))
        if bad[self._best]:
            self._best = int(good[0])
        return True

    # ------------------------------------------------------------------ estimates
    def best_index(self) -> int:
        """The reported particle (``best_particle``): the highest weight (after resampling: a
        copy of it), or the one nearest the weighted mean position (after resampling: of the
        drawn set)."""
        return self._best

    def particle_poses(self) -> np.ndarray:
        """(M, 3) poses with the odometry received since the last update applied (its mean)."""
        poses = self._prior[0] if self._prior is not None else self.poses
        return compose(poses, self._pending) if self._has_pending else poses.copy()

    def best_pose(self) -> np.ndarray:
        """(3,) pose of the best particle, pending odometry applied."""
        return self.particle_poses()[self._best]

    def weights(self) -> np.ndarray:
        return np.exp(self.log_weights)

    def mean_pose_and_covariance(self) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean pose (circular mean of theta) and the particle spread around it."""
        return mean_pose_and_covariance(self.particle_poses(), self.weights())

    def best_map(self, min_existence: float = 0.0) -> LandmarkMap:
        """The best particle's landmarks with covariances and existence probabilities.

        ``min_existence`` keeps only landmarks at least that likely to exist
        (``LandmarkMap.confirmed``); the map a user sees takes ``config.map_min_existence``.
        """
        mean, cov, logodds, label, key = self.particle_map(self._best)
        existence = 1.0 / (1.0 + np.exp(-logodds))
        return LandmarkMap(mean, unpack(cov), existence, label, key).confirmed(min_existence)

    def particle_map(self, particle: int):
        """(mean (N,2), cov packed (N,3), logodds (N,), label (N,), key (N,)) of one particle's
        landmarks: the store's, with the working set's in place of the cells it holds."""
        ws, row = self.working.entries_of(particle)
        if ws is None:
            return self.landmarks.particle_map(particle)
        stored = self.landmarks.particle_map(particle, skip_columns=ws.columns[row])
        live = ws.valid[row]
        working = (ws.mean[row, live], ws.cov[row, live], ws.logodds[row, live],
                   ws.label[row, live], ws.key[row, live])
        return tuple(np.concatenate([a, b]) for a, b in zip(stored, working))

    def best_path(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (T,), poses (T, 3)) of the best particle, one pose per update."""
        return self.history.path(self._best)
