# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""People tracking on a known map: Montemerlo, Thrun and Whittaker's conditional particle
filter (ICRA 2002), vectorized over robot particles, people and people particles.

Each robot pose particle m carries its own people: for person slot n, M_p position particles
``people[m, n]`` (M, N_max, M_p, 2), alive flags, existence log-odds and a stable key. The
people are estimated conditioned on the robot's pose, as FastSLAM's landmarks are:

1. predict: the robot particles by the sampled odometry model (core.motion); every person by
   its motion model (``person_motion.py``): Brownian motion, sigma = person_diffusion sqrt(dt),
   drifting with the person's walking velocity smoothed from its detections, or constant
   velocity (each particle carries a velocity, with random acceleration);
2. weigh the robot particles by the likelihood field of the map (localization);
3. detect people per robot particle (beams ending in free space away from obstacles);
4. associate, per robot particle, detections to people under the Gaussian summary of each
   person's particles N(z; mean, cov + R), likeliest (detection, person) pair first; a
   detection left with no person above p0 starts a new person (its key is shared by every
   robot particle that starts one for that detection, and it takes the key most of the
   particles' weight associated that detection to, so a person one particle lost and found
   again keeps its id and ids stay stable when another particle becomes the best, or else the
   id of a hidden or removed person of that particle who could have walked there since last
   seen and no other detection of this reading was associated to: re-identification); no new
   person within DUPLICATE_GATE of a person of that robot particle; the robot particle's
   weight is multiplied by max(likelihood, p0);
5. update each associated person: weigh its M_p particles by N(z; theta_i, R), resample them;
6. existence (core.existence): + tau+ when detected; + tau- when in view, near enough to
   return ``min_detection_beams`` beams (``detectable_range``), not occluded (the beams toward
   it passed beyond it: a person behind a wall or another person is no evidence) and not
   detected; removed below the bound, or when its particles' spread exceeds
   ``lost_spread`` (out of view for long, the person is lost: its Brownian cloud would cover
   half the map and catch anyone's detection); a new person is tentative, not published,
   until its log-odds reach ``logodds_confirm``, and removed as a duplicate within
   DUPLICATE_GATE of a confirmed one; negative information in the particles of a person not
   detected: those in seen free space are weighed down and resampled away, so a hidden
   person's cloud stays in the shadow of what hides it (the others are left alone);
7. vote the ids across the robot particles: a person near the weighted centroid of an id more
   weight holds than its own takes that id (the published ids survive a change of the best
   particle);
8. resample the robot particles when N_eff is low: one index array gathers the poses and the
   whole people arrays, so each robot particle's people follow it (the conditional structure).

Published (``published_people``, in ``identity.py``) are the best robot particle's confirmed
people whose particles' position standard deviation is at most ``publish_spread``: a person
unseen for a while is still tracked, but where it is has become too uncertain to report. A
person within PUBLISHED_GATE of one published at the previous reading keeps that one's
published id, whatever key the (new) best particle gives it, and of two people within
PUBLISHED_GATE of each other only one is reported (the one continuing, else the one published
longer).

Without an initial pose the robot particles start uniform over the free space and are
localized globally (``global_localization.py``).
"""
from __future__ import annotations

import math

import numpy as np

from fastslam_ros.core.existence import in_perceptual_range, removed, update_logodds
from fastslam_ros.core.geometry import mean_pose_and_covariance, relative_pose, wrap_angle
from fastslam_ros.core.motion import OdometryControl, control_variances, sample_motion
from fastslam_ros.core.resampling import (batched_systematic_resample, effective_sample_size,
                                          normalize_log_weights, systematic_resample)
from fastslam_ros.people.detection import (LegModel, MixedPixelMonitor, Scan, detect_legs,
                                           detect_people, detectable_range, dynamic_beams,
                                           mixed_pixels, segment_scan, without_mixed_pixels)
from fastslam_ros.people.global_localization import GlobalLocalization
from fastslam_ros.people.grid import OccupancyMap
from fastslam_ros.people.identity import PeopleIdentities
from fastslam_ros.people.particle_stats import (particle_covariances, particle_means,
                                                 planar_distance, squared_planar_distance)
from fastslam_ros.people.person_motion import PersonMotion
from fastslam_ros.people.report import PeopleEstimate, UpdateReport
from fastslam_ros.people.localization import (beam_endpoints, likelihood_field_log_weights,
                                              sample_free_poses,
                                              sample_gaussian_poses, sensor_poses)
from fastslam_ros.people.settings import TrackerSettings

MISSED_FRACTION = 0.5
"""A person with at least this fraction of its particles in seen free space is in view."""
MAX_DIFFUSION_STEP = 2.0
"""Seconds of Brownian motion at most between two readings (a gap in the data does not blow
the people up to the size of the map)."""
DUPLICATE_GATE = 0.5
"""A detection no person explains starts no new person within this distance (m) of a person
of its robot particle (tentative or confirmed, already detected in this scan or not): it is
part of that person (a person cut into several segments) or of a pair seen as one."""
SEEN_FREE_LIKELIHOOD = 0.1
"""Weight of a particle of a person not detected that lies in seen free space (the laser's
beam passed through it: no person there), against 1 for one the laser could not see. A
particle left there k readings weighs 0.1^k; soft, the weight keeps more particles of a
narrow shadow apart than a near-zero one (which gave as much MOTA, more identity switches)."""


class PeopleTracker(GlobalLocalization, PeopleIdentities):
    """The conditional particle filter on an ``OccupancyMap``; feed ``predict`` with odometry
    pose pairs and ``update`` with scans, in stamp order."""

    def __init__(self, settings: TrackerSettings, grid: OccupancyMap | None = None,
                 rng: np.random.Generator | None = None) -> None:
        self.settings = settings.validate()
        self.rng = rng if rng is not None else np.random.default_rng(
            None if settings.seed < 0 else settings.seed)
        self.offset = np.array([settings.sensor_x, settings.sensor_y, settings.sensor_yaw])
        self.motion = PersonMotion(settings.person_motion, settings.person_diffusion,
                                   settings.person_sway, settings.person_acceleration,
                                   settings.person_velocity_time, settings.max_person_speed,
                                   settings.person_walk_time)
        self._leg_model = LegModel(settings.leg_radius, settings.max_leg_width,
                                   settings.max_leg_spacing, settings.max_person_width,
                                   settings.min_detection_beams)
        self._seen_width = 4.0 * settings.leg_radius if settings.person_model == "legs" \
            else 2.0 * settings.person_radius  # two legs, or the outline, across the beams
        self.grid: OccupancyMap | None = None
        self.globally_localizing = True
        self.next_key = 0
        self._updates = 0
        self._published: tuple[int, PeopleEstimate] | None = None
        self._id_of_key: dict[int, int] = {}
        self._first_published: dict[int, float] = {}
        self._last_place: dict[int, tuple[float, np.ndarray]] = {}
        """Published id -> (stamp, position) of the last detection of the person it was last
        published for."""
        self._last_published = (np.zeros(0, np.int64), np.zeros((0, 2)))
        self.last_stamp: float | None = None
        self.mixed_pixels = MixedPixelMonitor(settings.mixed_pixel_filter)  # kept over resets
        self._allocate(np.zeros((0, 3)))
        if grid is not None:
            self.set_map(grid)

    # --- state --------------------------------------------------------------------------------

    def _allocate(self, poses: np.ndarray, people: bool = True) -> None:
        """Robot particles at ``poses`` with equal weights and no people (and no person slots
        at all without ``people``: global localization)."""
        s = self.settings
        count = len(poses)
        self._converging = 0
        self._first_global_reading = not people
        self.poses = np.asarray(poses, dtype=float)
        self.log_weights = np.full(count, -math.log(count) if count else 0.0)
        slots = s.max_people if people else 0
        self.people = np.zeros((count, slots, s.people_particles, 2))
        self.velocities = np.zeros_like(self.people)  # constant_velocity's; else zero
        self.alive = np.zeros((count, slots), dtype=bool)
        self.logodds = np.zeros((count, slots))
        self.keys = np.full((count, slots), -1, dtype=np.int64)
        self.confirmed = np.zeros((count, slots), dtype=bool)
        self.last_seen = np.zeros((count, slots))
        self.walk = np.zeros((count, slots, 2))  # person_walk_time's velocities (brownian)
        self.seen_mean = np.zeros((count, slots, 2))  # mean after the last detection
        # removed confirmed people, kept for re-identification: key (-1: empty), position at
        # removal, stamp of their last detection
        self.lost_keys = np.full((count, slots), -1, dtype=np.int64)
        self.lost_positions = np.zeros((count, slots, 2))
        self.lost_seen = np.zeros((count, slots))

    @property
    def num_particles(self) -> int:
        return len(self.poses)

    @property
    def ready(self) -> bool:
        """Whether a map is set (the filter can run)."""
        return self.grid is not None and self.num_particles > 0

    def set_map(self, grid: OccupancyMap) -> None:
        """Use a (new) map; the robot is localized again globally unless reset with a pose. A
        map with no free cell is refused (``ValueError``) and the old one kept."""
        if not grid.free.any():
            raise ValueError("the map has no free cell to localize in")
        self.grid = grid
        self.reset()

    def reset(self, pose: np.ndarray | None = None, covariance: np.ndarray | None = None) -> None:
        """Forget the people; robot particles from N(pose, covariance) (``num_particles``), or,
        without a pose, uniform over the free space (``global_particles``)."""
        if self.grid is None:
            raise ValueError("no map: set_map() first")
        s = self.settings
        if pose is None:
            self._allocate(sample_free_poses(self.grid, s.global_particles, self.rng), False)
            self.globally_localizing = True
        else:
            covariance = np.zeros((3, 3)) if covariance is None else np.asarray(covariance)
            self._allocate(sample_gaussian_poses(np.asarray(pose, dtype=float), covariance,
                                                 s.num_particles, self.rng))
            self.globally_localizing = False
        self.last_stamp = None
        self._span: Scan | None = None   # the latest scan: people outside its span go unreported
        self._published = None
        self._last_published = (np.zeros(0, np.int64), np.zeros((0, 2)))

    # --- prediction ---------------------------------------------------------------------------

    def predict(self, odom_from: np.ndarray, odom_to: np.ndarray) -> None:
        """Move the robot particles by the odometry step between two odometry poses."""
        if self.num_particles == 0:
            return
        s = self.settings
        control = OdometryControl.from_delta(relative_pose(odom_from, odom_to))
        variances = control_variances(control, (s.alpha1, s.alpha2, s.alpha3, s.alpha4),
                                      s.min_translation_sigma, s.min_rotation_sigma)
        self.poses = sample_motion(self.poses, control, variances,
                                   self.rng.standard_normal((self.num_particles, 3)))

    def _diffuse_people(self, stamp: float) -> None:
        """Move every live person particle by the person motion model over the time since the
        last reading."""
        dt = 0.0 if self.last_stamp is None else min(max(stamp - self.last_stamp, 0.0),
                                                     MAX_DIFFUSION_STEP)
        previous, self.last_stamp = self.last_stamp, stamp
        if dt <= 0.0 or not self.alive.any():
            return
        m, n = np.nonzero(self.alive)
        moved, velocities = self.motion.predict(self.people[m, n], self.velocities[m, n], dt,
                                                self.rng)
        shift, self.walk[m, n] = self.motion.walk_on(self.walk[m, n],
                                                     self.last_seen[m, n] < previous, dt)
        self.people[m, n] = moved + shift[:, None, :]
        if self.motion.carries_velocity:
            self.velocities[m, n] = velocities

    # --- update -------------------------------------------------------------------------------

    def update(self, stamp: float, scan: Scan) -> UpdateReport:
        """One laser reading at ``stamp`` (s): weigh, detect, associate, track, resample."""
        if not self.ready:
            raise ValueError("no map: set_map() first")
        s = self.settings
        self._diffuse_people(stamp)
        self._span = scan
        max_range = min(s.max_range, scan.range_max)
        returns = scan.returns(s.min_range, s.max_range)
        if self.globally_localizing:
            return self._localize_globally(scan, returns, max_range)
        segments = segment_scan(scan, returns, s.segment_jump)
        angles = segments.angles
        sensors = sensor_poses(self.poses, self.offset)
        ends = beam_endpoints(sensors, segments.ranges, angles)
        distances = self.grid.distance_at(ends)
        weighed = np.zeros(len(segments.beams), dtype=bool)
        weighed[np.flatnonzero(segments.beams % s.beam_stride == 0)] = True
        self.log_weights = self.log_weights + likelihood_field_log_weights(
            distances[:, weighed], s.sigma_hit, s.z_hit, max_range)
        far = dynamic_beams(self.grid, sensors, ends, distances, angles,
                            s.min_obstacle_distance, s.short_margin)
        ranges = np.where(returns, scan.ranges, np.inf)
        best = self.best_index     # weighed by this scan, before its people are associated
        mixed = mixed_pixels(ranges, s.segment_jump)       # once: counted, then filtered
        self.mixed_pixels.observe(ranges, mixed, segments, far[best], s.segment_jump)
        if self.mixed_pixels.filtering:
            single_beam = detectable_range(2.0 * s.leg_radius, 2, scan.angle_increment)
            far = without_mixed_pixels(far, segments, ranges, mixed, s.max_leg_spacing,
                                       single_beam)
        if s.person_model == "legs":
            lone_legs = None if self.mixed_pixels.filtering else scan.angle_increment
            detections = detect_legs(segments, far, best, self._leg_model, ranges, lone_legs)
        else:
            detections = detect_people(segments, far, s.min_detection_beams,
                                       s.max_person_width, s.person_radius)
        observed, created, unexplained = self._associate(sensors, detections)
        removed_count = self._missed_evidence(sensors, scan, observed, max_range)
        best_before = int(np.argmax(self.log_weights))
        report = UpdateReport(
            detections=int(detections.valid[best_before].sum()),
            associated=int(detections.valid[best_before].sum() - created[best_before]
                           - unexplained[best_before]),
            created=int(created[best_before]), unexplained=int(unexplained[best_before]),
            removed=int(removed_count[best_before]), effective_sample_size=0.0,
            resampled=False, converged=not self.globally_localizing)
        self._finish(report)
        self._updates += 1
        self.published_people()  # every reading: the ids' continuity is reading to reading
        return report

    def _person_summaries(self) -> tuple[np.ndarray, np.ndarray]:
        """Mean (M, N, 2) and covariance (M, N, 2, 2) of every live person's particles (a
        free slot: mean 0, identity covariance; its particles are not read)."""
        count, slots = self.alive.shape
        mean = np.zeros((count, slots, 2))
        cov = np.broadcast_to(np.eye(2), (count, slots, 2, 2)).copy()
        m, n, particles, live_mean = self._live_people()
        mean[m, n] = live_mean
        cov[m, n] = particle_covariances(particles - live_mean[:, None, :])
        return mean, cov

    def _live_people(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(robot particle (K,), slot (K,), particles (K, M_p, 2), mean (K, 2)) of the K live
        people: free slots are many and their particles are not read."""
        m, n = np.nonzero(self.alive)
        particles = self.people[m, n]
        return m, n, particles, particle_means(particles)

    def _associate(self, sensors: np.ndarray, detections) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
        """Associate detections per robot particle (``_likeliest_pairs``), then create people
        for the detections left over, in scan order (a person already associated in this
        reading is neither re-identified nor given a second detection), update the associated
        ones and weigh the robot particles; returns (observed (M, N), created (M,),
        unexplained (M,))."""
        s = self.settings
        count = self.num_particles
        observed = np.zeros_like(self.alive)
        created = np.zeros(count, dtype=np.int64)
        unexplained = np.zeros(count, dtype=np.int64)
        if detections.valid.shape[1] == 0:
            return observed, created, unexplained
        heading = sensors[:, 2:3] + detections.bearings
        points = np.stack([sensors[:, 0:1] + detections.ranges * np.cos(heading),
                           sensors[:, 1:2] + detections.ranges * np.sin(heading)], axis=-1)
        mean, cov = self._person_summaries()
        rows = np.arange(count)
        p0 = s.new_person_likelihood
        slot_of, likelihood_of = self._likeliest_pairs(points, detections.valid, mean, cov)
        weights = np.exp(self.log_weights - self.log_weights.max())
        self.log_weights = self.log_weights + np.sum(
            np.where(detections.valid, np.log(np.maximum(likelihood_of, p0)), 0.0), axis=1)
        associated_m, associated_j = np.nonzero(slot_of >= 0)
        associated_n = slot_of[associated_m, associated_j]
        observed[associated_m, associated_n] = True
        key_of_detection = {}
        for j in range(detections.valid.shape[1]):
            valid = detections.valid[:, j]
            if not valid.any():
                continue
            associate = slot_of[:, j] >= 0
            if not np.any(valid & ~associate):
                continue
            best = np.maximum(slot_of[:, j], 0)
            dx = points[:, j, None, 0] - mean[..., 0]
            dy = points[:, j, None, 1] - mean[..., 1]
            duplicate = np.any(self.alive & (np.hypot(dx, dy) < DUPLICATE_GATE), axis=1)
            new = valid & ~associate & ~duplicate
            free = ~self.alive
            m = np.flatnonzero(new)
            if len(m) == 0:
                continue
            slot = np.where(free[m].any(axis=1), np.argmax(free[m], axis=1), -1)  # -1: full
            fresh = key_of_detection.setdefault(j, self.next_key + len(key_of_detection))
            key = np.full(len(m), fresh)
            if associate.any():  # the key the other particles' weight gave this detection
                voted, inverse = np.unique(self.keys[rows, best][associate], return_inverse=True)
                consensus = voted[np.argmax(np.bincount(inverse, weights[associate]))]
                has_it = np.any(self.alive[m] & (self.keys[m] == consensus), axis=1)
                key = np.where(has_it, key, consensus)
            unknown = np.flatnonzero(key == fresh)
            found, found_slot = self._reidentify(m[unknown], points[m[unknown], j], mean,
                                                 observed)
            key[unknown] = np.where(found >= 0, found, fresh)
            slot[unknown] = np.where(found_slot >= 0, found_slot, slot[unknown])
            # A hidden person found again is associated, not created; with no free slot and
            # no one found again, the detection stays unexplained.
            moved = np.zeros(len(m), dtype=bool)
            moved[unknown] = found_slot >= 0
            placed = slot >= 0
            unexplained[m[~placed]] += 1
            created[m[placed & ~moved]] += 1
            m, slot, key = m[placed], slot[placed], key[placed]
            self.people[m, slot] = points[m, j, None, :] + self.rng.normal(
                0.0, s.detection_sigma, (len(m), s.people_particles, 2))
            self.velocities[m, slot] = self.motion.initial_velocities(
                (len(m), s.people_particles, 2), self.rng)
            self.alive[m, slot] = True
            mean[m, slot] = points[m, j]
            confirm_now = np.zeros(len(m), dtype=bool)   # two legs, far or clear: confirmed now
            if s.confirm_pairs and detections.paired is not None:
                confirm_now |= detections.paired[m, j]
            if s.confirm_far and detections.sparse is not None:
                confirm_now |= detections.sparse[m, j]
            if s.confirm_clear and not self.mixed_pixels.filtering:  # no lone mixed pixel
                confirm_now |= self.grid.distance_at(points[m, j]) > s.max_leg_spacing
            self.logodds[m, slot] = np.where(
                confirm_now, max(0.0, s.logodds_confirm - s.logodds_observed), 0.0)
            self.keys[m, slot] = key
            self.confirmed[m, slot] = False
            self.last_seen[m, slot] = self.last_stamp
            self.walk[m, slot], self.seen_mean[m, slot] = 0.0, points[m, j]
            observed[m, slot] = True
        self.next_key += len(key_of_detection)
        if len(associated_m):
            m, n = associated_m, associated_n
            z = points[m, associated_j]
            particles = self.people[m, n]                      # (K, M_p, 2)
            squared = squared_planar_distance(particles, z[:, None, :])
            log_w = -0.5 * squared / s.detection_sigma ** 2
            w = np.exp(log_w - log_w.max(axis=1, keepdims=True))
            w /= w.sum(axis=1, keepdims=True)
            index = batched_systematic_resample(w, self.rng)
            self.people[m, n] = np.take_along_axis(particles, index[..., None], axis=1)
            self._gather_velocities(m, n, index)
            seen_mean = particle_means(self.people[m, n])
            self.walk[m, n] = self.motion.walk_estimate(self.walk[m, n], self.seen_mean[m, n],
                                                        seen_mean, self.last_stamp
                                                        - self.last_seen[m, n])
            self.seen_mean[m, n], self.last_seen[m, n] = seen_mean, self.last_stamp
        return observed, created, unexplained

    def _likeliest_pairs(self, points: np.ndarray, valid: np.ndarray, mean: np.ndarray,
                         cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per robot particle, associate the detections at ``points`` (M, J, 2) (``valid``
        (M, J)) to its live people (summaries ``mean`` (M, N, 2), ``cov`` (M, N, 2, 2)) under
        N(z; mean, cov + R), likeliest (detection, person) pair first, down to p0: in scan
        order, a detection between two people could take the one that a later detection fits
        far better (two people side by side, or crossing). Returns the slot of each detection
        (M, J) (-1: none) and its likelihood (M, J) (0: none)."""
        s = self.settings
        count, detections = valid.shape
        innovation_cov = cov + s.detection_sigma ** 2 * np.eye(2)
        a, b, d = innovation_cov[..., 0, 0], innovation_cov[..., 0, 1], innovation_cov[..., 1, 1]
        det = a * d - b * b                                             # (M, N)
        dx = points[:, :, None, 0] - mean[:, None, :, 0]                # (M, J, N)
        dy = points[:, :, None, 1] - mean[:, None, :, 1]
        mahalanobis = (d[:, None] * dx * dx - 2.0 * b[:, None] * dx * dy
                       + a[:, None] * dy * dy) / det[:, None]
        likelihood = np.exp(-0.5 * mahalanobis) / (2.0 * math.pi * np.sqrt(det[:, None]))
        likelihood = np.where(valid[:, :, None] & self.alive[:, None, :], likelihood, 0.0)
        slot_of = np.full((count, detections), -1, dtype=np.intp)
        likelihood_of = np.zeros((count, detections))
        slots = likelihood.shape[2]
        rows = np.arange(count)
        for _ in range(min(detections, slots)):
            flat = likelihood.reshape(count, -1)
            pair = np.argmax(flat, axis=1)
            best = flat[rows, pair]
            m = np.flatnonzero(best >= s.new_person_likelihood)
            if len(m) == 0:
                break
            j, n = np.divmod(pair[m], slots)
            slot_of[m, j] = n
            likelihood_of[m, j] = best[m]
            likelihood[m, j, :] = 0.0
            likelihood[m, :, n] = 0.0
        return slot_of, likelihood_of

    def _missed_evidence(self, sensors: np.ndarray, scan: Scan, observed: np.ndarray,
                         max_range: float) -> np.ndarray:
        """Negative information: update the people not detected; returns the people removed
        per robot particle.

        A person particle lies in seen free space when it is in the perceptual range and the
        beam toward it passed more than ``person_radius`` beyond it. A person with at least
        MISSED_FRACTION of its particles there was in view and not detected: tau-. A person
        behind a wall or another person has its particles where the beams ended short of
        them: no evidence, its existence is unchanged. A person whose particles' position
        standard deviation exceeds ``lost_spread`` is lost and removed; one whose log-odds
        reached ``logodds_confirm`` is confirmed (published); a tentative one within
        DUPLICATE_GATE of a confirmed one is a duplicate of it and removed.
        """
        s = self.settings
        m, n = np.nonzero(self.alive & ~observed)
        if len(m):
            particles = self.people[m, n]                              # (K, M_p, 2)
            dx = particles[..., 0] - sensors[m, None, 0]
            dy = particles[..., 1] - sensors[m, None, 1]
            distance = np.hypot(dx, dy)
            bearing = wrap_angle(np.arctan2(dy, dx) - sensors[m, None, 2])
            measured = scan.range_toward(bearing, s.min_range)   # NaN: never seen free
            reach = min(max_range, detectable_range(self._seen_width, s.min_detection_beams,
                                                    scan.angle_increment))
            seen_free = (in_perceptual_range(distance, bearing, s.min_range, reach)
                         & scan.covers(bearing) & (measured > distance + s.person_radius))
            fraction = seen_free.mean(axis=1)
            missed = np.zeros_like(observed)
            missed[m, n] = fraction >= MISSED_FRACTION
            self._confine_to_unseen(m, n, seen_free, fraction)
        else:
            missed = np.zeros_like(observed)
        self.logodds = update_logodds(self.logodds, observed, missed, s.logodds_observed,
                                      s.logodds_missed)
        self.confirmed |= self.alive & (self.logodds >= s.logodds_confirm)
        m, n, particles, live_mean = self._live_people()
        mean = np.zeros(self.alive.shape + (2,))
        mean[m, n] = live_mean
        lost = np.zeros_like(self.alive)
        # Variance of x plus variance of y, from the mean just taken (``var`` would take it again).
        lost[m, n] = (particle_means(np.square(particles - live_mean[:, None])).sum(axis=1)
                      > 2.0 * s.lost_spread ** 2)
        apart = planar_distance(mean[:, :, None, :], mean[:, None, :, :])
        confirmed = self.alive & self.confirmed
        duplicate = ~self.confirmed & np.any(confirmed[:, None, :] & (apart < DUPLICATE_GATE),
                                             axis=2)
        gone = self.alive & (removed(self.logodds, s.logodds_remove) | lost | duplicate)
        self._remember(gone & self.confirmed, mean)
        self.alive &= ~gone
        self.keys[gone] = -1
        self.confirmed &= self.alive
        return gone.sum(axis=1)

    def _confine_to_unseen(self, m: np.ndarray, n: np.ndarray, seen_free: np.ndarray,
                           fraction: np.ndarray) -> None:
        """Negative information in the people's particles (Montemerlo, Thrun and Whittaker):
        a person not detected is not where the laser saw free space. Its particles there
        (``seen_free`` (K, M_p)) weigh SEEN_FREE_LIKELIHOOD, the others (behind a wall or
        another person, out of range) 1, and are resampled: the cloud of a hidden person
        stays in the shadow of its occluder and follows it. A person with every particle
        in seen free space is left alone (the existence rule judges it)."""
        rows = np.flatnonzero((fraction > 0.0) & (fraction < 1.0))
        if len(rows) == 0:
            return
        m, n = m[rows], n[rows]
        w = np.where(seen_free[rows], SEEN_FREE_LIKELIHOOD, 1.0)
        w /= w.sum(axis=1, keepdims=True)
        index = batched_systematic_resample(w, self.rng)
        self.people[m, n] = np.take_along_axis(self.people[m, n], index[..., None], axis=1)
        self._gather_velocities(m, n, index)

    def _gather_velocities(self, m: np.ndarray, n: np.ndarray, index: np.ndarray) -> None:
        """The velocities of people (``m``, ``n``) follow their particles' resampling
        ``index`` (K, M_p) (Brownian motion carries none)."""
        if self.motion.carries_velocity:
            self.velocities[m, n] = np.take_along_axis(self.velocities[m, n], index[..., None],
                                                       axis=1)

    def _finish(self, report: UpdateReport) -> None:
        """Normalise, resample when N_eff is low, end global localization when converged."""
        s = self.settings
        self.log_weights, _ = normalize_log_weights(self.log_weights)
        weights = np.exp(self.log_weights)
        self._vote_keys(weights)
        report.effective_sample_size = effective_sample_size(weights)
        if report.effective_sample_size < s.resample_threshold * self.num_particles:
            self._gather(systematic_resample(weights, self.rng))
            report.resampled = True

    def _gather(self, index: np.ndarray) -> None:
        """Keep the robot particles ``index`` with their people, at equal weights."""
        self.poses = self.poses[index]
        self.people = self.people[index]
        self.velocities = self.velocities[index]
        self.alive = self.alive[index]
        self.logodds = self.logodds[index]
        self.keys = self.keys[index]
        self.confirmed = self.confirmed[index]
        self.last_seen = self.last_seen[index]
        self.walk = self.walk[index]
        self.seen_mean = self.seen_mean[index]
        self.lost_keys = self.lost_keys[index]
        self.lost_positions = self.lost_positions[index]
        self.lost_seen = self.lost_seen[index]
        self.log_weights = np.full(len(index), -math.log(len(index)))

    # --- estimates ----------------------------------------------------------------------------

    @property
    def best_index(self) -> int:
        return int(np.argmax(self.log_weights))

    def best_pose(self) -> np.ndarray:
        return self.poses[self.best_index].copy()

    def mean_pose_and_covariance(self) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean pose (circular mean heading) and covariance of the robot particles."""
        return mean_pose_and_covariance(self.poses, np.exp(self.log_weights))
