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
from .backend import choose_backend
from .config import LOGODDS_MAX, FastSLAMConfig
from .fault_recovery import FaultRecovery, correct_map
from .geometry import (compose, compose_floats, mean_pose_and_covariance, pose_floats,
                       relative_pose_floats, wrap_angle)
from .landmark_clock import LandmarkClock
from .landmark_ekf import pack, unpack
from .landmark_store import LandmarkStore
from .loop_closure import LoopClosure
from .reading_log import ReadingLog
from .smoother import OnlineSmoother
from .working_cache import WorkingSetCache
from .motion import OdometryControl, control_variances, turn_fault_shift
from .observation import SensorOffset
from .path_history import PathHistory
from .proposal import sample_pose
from .reading import NumpyReading, UpdateReport
from .relocalization import Relocalizing

REACH_MARGIN = 2.0
"""Metres beyond the sensor's reach (the larger of ``max_range`` and the farthest observation)
within which landmarks join the working set and are scored against the observations: a
landmark whose mean lies farther out is no plausible match for any observation."""
MAX_PRIOR_HEADING_SIGMA = 0.3
"""FastSLAM 2.0: odometry between observations is carried as one Gaussian per particle, so the
proposal sees all of its uncertainty; once its heading standard deviation exceeds this (rad)
the particles are sampled from it, before the proposal's linearisation fails."""
NO_MOTION = (0.0, 0.0, 0.0)
"""The accumulated odometry (dx, dy, dtheta) before any ``predict``."""


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


class FastSLAM(NumpyReading, Relocalizing):
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
        self._backend = choose_backend(self.config, self.offset, self._log_p0, self._log_outlier)
        """The one place the backend is chosen: the functions every step below calls."""
        self.backend = self._backend.name
        self._log_uniform = -np.log(config.num_particles)
        """The log weight of every particle after resampling."""
        self.reset(initial_pose)

    # ------------------------------------------------------------------ lifecycle
    def reset(self, initial_pose=(0.0, 0.0, 0.0)) -> None:
        """Forget everything: all particles at ``initial_pose``, empty maps, uniform weights."""
        count = self.config.num_particles
        self.poses = np.tile(np.asarray(initial_pose, dtype=float), (count, 1))
        self.log_weights = np.full(count, self._log_uniform)
        self._seed_landmarks()
        self.history = PathHistory(count, prune=self._backend.prune)
        self.readings = ReadingLog(origin=initial_pose)
        """The readings processed since the start, for ``map_refinement.refine``."""
        self.smoother = (OnlineSmoother(self.config.smoothing_period)
                         if self.config.smoothing_period > 0.0 and not self._localization
                         else None)
        """The estimate re-solved over the reported particle's path (``smoothing_period``)."""
        self._pending = NO_MOTION
        self._has_pending = False
        self._set_prior(None)
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
    def num_fault_recoveries(self) -> int:
        """Corrections made after odometry faults (``fault_recovery_matches``)."""
        return 0 if self.fault is None else self.fault.num_recoveries

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
        self._forget_readings(self.mean_pose_and_covariance()[0])

    def _seed_landmarks(self) -> None:
        """A fresh landmark store (and its working-set cache) holding the seeded map (if any)
        in every particle."""
        count = self.num_particles
        self.landmarks = LandmarkStore(count, self.config.cell_size,
                                       kernels=self._backend.store_kernels)
        self.working = WorkingSetCache(self.landmarks, self.config.association == "known")
        """The landmarks near the robot that readings work on (kept across readings)."""
        config = self.config
        mapping = not self._localization and config.association != "known"
        self.clock = (LandmarkClock() if mapping and (config.loop_closure_matches > 0
                                                      or config.fault_recovery_matches > 0)
                      else None)
        """Creation and observation times of the landmark keys, for the two below."""
        self.loop = (LoopClosure(count, config.loop_closure_matches, config.map_min_existence,
                                 config.max_range, self.clock)
                     if mapping and config.loop_closure_matches > 0 else None)
        """Loop closure confirmed across readings (``loop_closure_matches``), or None."""
        self.fault = (FaultRecovery(config.fault_recovery_matches, config.fault_recovery_gate,
                                    config.map_min_existence, config.max_range, self.clock)
                      if mapping and config.fault_recovery_matches > 0 else None)
        """Recovery from odometry faults (``fault_recovery_matches``), or None."""
        if self._seed is None or len(self._seed[0]) == 0:
            return
        means, packed, labels, logodds = self._seed
        ws = self.landmarks.gather(np.full((count, 0), -1, np.int64), len(means))
        ws.mean[0], ws.cov[0], ws.logodds[0], ws.label[0] = means, packed, logodds, labels
        ws.key[0] = self.landmarks.new_keys(len(means))
        ws.valid[0] = ws.is_new[0] = True
        self.landmarks.scatter(ws, track_labels=self.config.association == "known")
        self.landmarks.resample(np.zeros(count, np.int64))
        if self.clock is not None:
            self.clock.register(self.landmarks.next_key)

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
        self._set_prior(None)
        self._pending = NO_MOTION
        self._has_pending = False
        self._lost_since = None
        self._placed = True
        self._forget_readings(np.asarray(mean[0]))

    def _forget_readings(self, origin: np.ndarray) -> None:
        """Restart the reading log (and the smoother's solution) with the robot at ``origin``."""
        self.readings.clear(origin)
        if self.smoother is not None:
            self.smoother.clear()

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
        if self.clock is not None:
            self.clock.travelled += math.hypot(step[0], step[1])
        self._has_pending = True
        x, y, theta = self._pending
        if (math.hypot(x, y) > self.config.max_pending_translation
                or abs(theta) > self.config.max_pending_rotation):
            self._advance_motion()

    def _advance_motion(self) -> None:
        """Apply the accumulated odometry: sampled (1.0) or into the Gaussian prior (2.0), a
        share of the particles with a turn fault (``turn_fault_probability``)."""
        if not self._has_pending:
            return
        faults = self._draw_turn_faults()
        self._move()
        if faults is not None:
            faulty, before, control, errors = faults
            moved = self._prior[0] if self._prior is not None else self.poses
            moved[faulty] += turn_fault_shift(before, control, errors)
            moved[faulty, 2] = wrap_angle(moved[faulty, 2])

    def _draw_turn_faults(self) -> tuple[np.ndarray, np.ndarray, OdometryControl,
                                         np.ndarray] | None:
        """(particles, their poses before the motion, the motion, their rotation errors) of
        the particles that take this motion's turn as not executed as reported, each error
        N(0, rot^2) on rot1 and rot2; None when ``turn_fault_probability`` is 0."""
        fraction = self.config.turn_fault_probability
        if fraction == 0.0:
            return None
        control = OdometryControl.from_delta(self._pending)
        faulty = np.flatnonzero(self.rng.random(self.num_particles) < fraction)
        errors = self.rng.standard_normal((len(faulty), 2)) * np.abs([control.rot1, control.rot2])
        prior = self._settled_prior()
        return faulty, (self.poses if prior is None else prior[0])[faulty], control, errors

    def _move(self) -> None:
        """``_advance_motion`` without the turn faults: FastSLAM 1.0 samples the motion, 2.0
        moves its Gaussian prior (sampled when too wide to linearise)."""
        delta = self._pending
        self._pending = NO_MOTION
        self._has_pending = False
        if self.config.algorithm == "fastslam1":
            control = OdometryControl.from_delta(delta)
            variances = control_variances(control, self.alphas,
                                          self.config.min_translation_sigma,
                                          self.config.min_rotation_sigma, self.linear_noise)
            normals = self.rng.standard_normal((self.num_particles, 3))
            self.poses = self._backend.sample_motion(self.poses, control, variances, normals)
            return
        if self._backend.advance_prior(self, delta) > MAX_PRIOR_HEADING_SIGMA ** 2:
            # Too wide to linearise at the next observation: let the particles carry it.
            self.poses = self._sample_prior()

    def _settled_prior(self) -> tuple[np.ndarray, np.ndarray] | None:
        """FastSLAM 2.0's Gaussian prior (mean (M, 3), cov (M, 3, 3)) or None, with a covariance
        left to the next reading (``_deferred``: the turn, the covariance it moves from and the
        motion of ``compiled.advance_mean``) propagated now."""
        if self._deferred is not None:
            turn, cov, motion = self._deferred
            self._deferred = None
            self._prior = (self._prior[0], self._backend.propagate_cov(turn, cov, motion))
        return self._prior

    def _set_prior(self, value: tuple[np.ndarray, np.ndarray] | None) -> None:
        """Replace the prior (and drop any covariance left to the next reading)."""
        self._prior = value
        self._deferred = None

    def _sample_prior(self) -> np.ndarray:
        """Draw every particle's pose from its Gaussian prior, which is then consumed."""
        mean, cov = self._settled_prior()
        self._set_prior(None)
        sampled = self._backend.sample_pose(mean, cov,
                                            self.rng.standard_normal((self.num_particles, 3)))
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
        if not self._localization:  # a fixed map is saved as it is
            self.readings.record(stamp, ranges, bearings, labels)
        usable_ranges, usable_bearings, usable_labels, farthest = self._backend.usable(
            self, ranges, bearings, labels)
        self._advance_motion()                                                  # 1. motion
        # FastSLAM 2.0 scores the observations at its prior (whose covariance the compiled
        # reading may propagate in its blocks: ``_deferred``), FastSLAM 1.0 at the poses.
        mean, cov = self._prior if self._prior is not None else (self.poses, None)
        reach = self._reach_of(farthest)
        # Split over threads, the compiled reading's chunks make a pending resampling's
        # working-set copy as they go; on one thread the copy in one call is the cheaper.
        lazy = self._backend.splits(self.num_particles)
        known = self.config.association == "known"
        ws = self.working.for_reading(mean, reach, len(usable_ranges),
                                      usable_labels if known else None, lazy=lazy)
        if self.clock is not None:
            self.clock.before_reading(ws, self.working.pending)
        outcome = self._backend.read(self, ws, mean, cov, usable_ranges,        # 2. to 5.
                                     usable_bearings, usable_labels, reach, stamp)
        self.num_updates += 1
        self.working.created(outcome.columns)
        self._best = outcome.best
        self._close_loops()
        self._recover_from_fault(stamp)
        self._resample_if_degenerate(outcome.report)
        if not outcome.checked:
            self.check_state()
        if self._localization and self.config.relocalization_fraction > 0.0:
            self._relocalize(ranges, bearings, stamp)
        if self.smoother is not None and self.smoother.due(stamp):
            self.smoother.solve(self, stamp)
        return outcome.report

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

    def _reach(self, ranges: np.ndarray) -> float:
        """Distance from the robot within which a landmark may match an observation."""
        return self._reach_of(float(ranges.max(initial=0.0)))

    def _reach_of(self, farthest: float) -> float:
        """``_reach`` of a reading whose largest range is ``farthest`` (0 when empty)."""
        return max(self.config.max_range, farthest) + REACH_MARGIN + self._lever_length

    def _close_loops(self) -> None:
        """``loop_closure_matches``: the reading's new landmarks against old ones
        (``loop_closure.LoopClosure``), after the map step and before resampling, the same
        numpy step on both backends; the landmark clock takes the reading first."""
        if self.clock is not None:
            self.clock.after_reading(self.working.current, self.landmarks.next_key)
        if self.loop is not None:
            self.poses = self.loop.after_reading(self.working, self.poses)

    def _recover_from_fault(self, stamp: float) -> None:
        """``fault_recovery_matches``: correct the reported particle when its young landmarks
        are a rigidly moved copy of older ones (``fault_recovery``); every particle then takes
        its corrected pose and map (they all carry the fault), weights uniform."""
        if self.fault is None or not self.fault.due(stamp):
            return
        best = self._best
        correction = self.fault.search(self.poses[best], self.particle_map(best), stamp)
        if correction is None:
            return
        self.working.flush()
        ws = self.landmarks.gather_maps(np.array([best]))
        correct_map(ws, best, correction)
        self.landmarks.scatter_moved(ws, self.working.track_labels)
        pose = np.append(correction.pivot + correction.shift,
                         wrap_angle(self.poses[best, 2] + correction.rotation))
        indices = np.full(self.num_particles, best)
        self._reindex(indices, working=False)
        if self._prior is not None:
            mean, cov = self._settled_prior()
            self._set_prior((np.tile(pose, (self.num_particles, 1)),
                             None if cov is None else cov[indices]))
        self.poses = np.tile(pose, (self.num_particles, 1))
        self.log_weights = np.full(self.num_particles, self._log_uniform)

    def _resample_if_degenerate(self, report: UpdateReport) -> None:
        """Resample (poses, maps, working set, history) when N_eff is below the threshold;
        the reported particle follows its copy. Weights are normalised."""
        if report.n_eff >= self.config.resample_threshold * self.num_particles:
            return
        weights = np.exp(self.log_weights)
        heaviest = self.config.best_particle == "heaviest"
        indices, self.poses, copy = self._backend.resample(weights, self.rng, self.poses,
                                                           self._best)
        self._reindex(indices)
        self.log_weights = np.full(self.num_particles, self._log_uniform)
        if not heaviest:
            self._best = self._select_best()
        else:
            # Multinomial resampling may draw no copy of the heaviest particle: take the
            # heaviest particle drawn instead.
            self._best = copy if copy >= 0 else int(weights[indices].argmax())
        report.resampled = True

    def _reindex(self, indices: np.ndarray, working: bool = True) -> None:
        """Every per-particle store but the poses and weights takes particles ``indices``
        (resampling, repairs); ``working``: the working set too (not after a flush)."""
        self.landmarks.resample(indices)
        if working:
            self.working.resample(indices)
        self.history.resample(indices)
        for store in (self.loop, self.smoother):
            if store is not None:
                store.resample(indices)

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
        if self._settled_prior() is not None:
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
        if self._settled_prior() is not None:
            self._set_prior((self._prior[0][indices], self._prior[1][indices]))
        self._reindex(indices)
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

    def smoothed_pose(self) -> np.ndarray | None:
        """(3,) the smoother's pose now (``smoothing_period``), None when off or unsolved."""
        if self.smoother is None:
            return None
        return self.smoother.pose(self)

    def smoothed_covariance(self) -> np.ndarray | None:
        """(3, 3) covariance of ``smoothed_pose`` (the solve's marginal plus the odometry's
        noise since), None when off or unsolved."""
        if self.smoother is None:
            return None
        return self.smoother.covariance(self.readings.odometry_pose, self.config)

    def reported_path(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (T,), poses (T, 3)) that go with the reported pose: the smoother's solved
        path when it has one, else the best particle's."""
        smoothed = None if self.smoother is None else self.smoother.path(self)
        return self.best_path() if smoothed is None else smoothed

    def reported_map(self) -> LandmarkMap:
        """The confirmed map (``map_min_existence``) that goes with the reported pose: the
        smoother's latest solve when it has one, else the best particle's."""
        if self.smoother is not None and self.smoother.landmark_map is not None:
            return self.smoother.landmark_map
        return self.best_map(self.config.map_min_existence)

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
