# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Loop closure confirmed across readings (``loop_closure_matches``).

Before a loop closes, the particles have usually collapsed to one or two ancestors that all
carry the odometry's drift, so when landmarks mapped long ago come back into view they lie
outside the association gate and every rule maps them a second time. This step runs after the
reading's filter update (on either backend, on the working set both leave identical) and looks
at the young landmarks the reading has just confirmed (existence reaching
``map_min_existence``; a clutter detection seldom gets there):

1. Such a landmark is matched *wide* to the particle's old confirmed landmarks (not observed
   for ``OLD_AFTER_RANGES`` sensor ranges of travel): the gate is their covariances plus an
   isotropic drift of ``DRIFT_PER_METER`` times the distance travelled since the old landmark
   was last observed.
2. Each wide match is an (old, young) pair. A particle keeps one hypothesis across readings:
   a wide match from an old landmark it does not hold yet joins it when the rigid motion
   (rotation and translation, weighted 2-D Procrustes with the rotation shrunk by its prior
   ``ROTATION_SIGMA`` and at most ``MAX_ROTATION``) fitted to the held pairs and the new one
   leaves every pair within ``AGREEMENT_GATE`` of its landmarks' own covariances; any other
   wide match replaces it. A hypothesis expires after ``LIFETIME_RANGES`` sensor ranges of
   travel.
3. Once ``matches`` distinct old landmarks agree, the particle's pose and the landmarks near
   the robot (in the reading's working set) created since its supporting old landmarks were
   last observed are moved by the fitted motion, and the duplicates that supported it are
   removed: the loop is closed, and the next readings associate the old landmarks as usual.
   The rest of the map keeps its place.

A single wrong wide match never moves a particle. "Last observed" is kept per landmark key
(shared by a landmark's copies in every particle): a landmark is observed when the reading
changed its covariance in some particle. Landmarks of a loaded map count as observed at start.
"""
from __future__ import annotations

import numpy as np

from .geometry import rigid_fit, wrap_angle
from .existence import existence_logodds
from .landmark_clock import LandmarkClock
from .landmark_store import WorkingSet
from .working_cache import WorkingSetCache

DRIFT_PER_METER = 0.01
"""Standard deviation (m per m travelled) of the odometry drift the wide match allows for (the
default world drifts about 0.5 %; 1 % and 2 % give the same runs there and in the clutter
world)."""
WIDE_GATE = 9.21
"""Squared Mahalanobis distance of a wide match (chi-square, 2 dof, 99 %)."""
AGREEMENT_GATE = 9.21
"""Squared Mahalanobis distance within which every held pair's residual under the rigid fit
must lie for a new pair to join the hypothesis (99 %)."""
ROTATION_SIGMA = 0.05
"""Prior standard deviation (rad) of the heading correction: the fit shrinks the rotation two
pairs a few metres apart determine poorly (small-angle maximum a posteriori). Without it the
maps of the localization bench's seed 1 lose the off start for 171 s; with it, a heading
drift much beyond ``ROTATION_SIGMA`` between close pairs does not close."""
MAX_ROTATION = 0.2
"""Largest heading correction (rad) a closure may make."""
OLD_AFTER_RANGES = 2.0
"""A landmark not observed for this many ``max_range`` of travel is old (the robot has left
it and come back)."""
LIFETIME_RANGES = 1.0
"""An offset hypothesis expires after this many ``max_range`` of travel; a landmark is young
(may propose one) for as long after its creation."""


def _mahalanobis(d: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """d^T S^-1 d for 2-D vectors d (..., 2) and packed covariances S (..., 3); empty
    entries (S = 0) give inf or nan, which the callers mask."""
    sxx, sxy, syy = cov[..., 0], cov[..., 1], cov[..., 2]
    det = sxx * syy - sxy * sxy
    dx, dy = d[..., 0], d[..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        return (syy * dx * dx - 2.0 * sxy * dx * dy + sxx * dy * dy) / det


def rotate_cov(cov: np.ndarray, cos: np.ndarray, sin: np.ndarray) -> np.ndarray:
    """R S R^T for packed covariances (..., 3) and rotations given by cos, sin (...)."""
    sxx, sxy, syy = cov[..., 0], cov[..., 1], cov[..., 2]
    cc, ss, cs = cos * cos, sin * sin, cos * sin
    return np.stack([cc * sxx - 2.0 * cs * sxy + ss * syy,
                     cs * (sxx - syy) + (cc - ss) * sxy,
                     ss * sxx + 2.0 * cs * sxy + cc * syy], axis=-1)


def _fit(old: np.ndarray, new: np.ndarray, cov: np.ndarray,
         used: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted least-squares rigid motion (rotation (...), translation (..., 2)) taking the
    points ``new`` (..., n, 2) onto ``old``, over the pairs ``used`` (..., n), each weighted by
    the inverse mean variance of its covariance ``cov`` (..., n, 3), the rotation shrunk by its
    prior ``ROTATION_SIGMA`` (closed-form 2-D Procrustes; one pair gives the pure
    translation)."""
    weight = np.where(used, 2.0 / (cov[..., 0] + cov[..., 2]), 0.0)
    return rigid_fit(new, old, weight, ROTATION_SIGMA ** -2)


def _fit_residuals(old: np.ndarray, new: np.ndarray, cov: np.ndarray,
                   used: np.ndarray) -> np.ndarray:
    """Largest squared Mahalanobis residual (...) of the used pairs under their rigid fit
    (``_fit``); the fitted rotation must also stay within ``MAX_ROTATION``."""
    rotation, translation = _fit(old, new, cov, used)
    cos, sin = np.cos(rotation)[..., None], np.sin(rotation)[..., None]
    fitted = np.stack([cos * new[..., 0] - sin * new[..., 1],
                       sin * new[..., 0] + cos * new[..., 1]], axis=-1) + translation[..., None, :]
    d2 = np.where(used, _mahalanobis(fitted - old, cov), 0.0).max(axis=-1)
    return np.where(np.abs(rotation) <= MAX_ROTATION, d2, np.inf)


class LoopClosure:
    """Per-particle offset hypotheses (module docstring)."""

    def __init__(self, num_particles: int, matches: int, min_existence: float,
                 max_range: float, clock: LandmarkClock) -> None:
        self.matches = matches
        self.min_logodds = existence_logodds(min_existence)
        self.old_after = OLD_AFTER_RANGES * max_range
        self.lifetime = LIFETIME_RANGES * max_range
        self.clock = clock
        """Creation and observation times of the landmark keys (shared, ``FastSLAM``)."""
        self.num_closures = 0
        """Particle shifts made so far (a closure shifts every particle that confirmed it)."""
        count = num_particles
        self.support = np.zeros(count, np.int64)
        """Distinct old landmarks agreeing on each particle's offset (0: no hypothesis)."""
        self._pair_old = np.zeros((count, matches, 2))
        """Per particle and supporting match: the old landmark's mean when it matched."""
        self._pair_new = np.zeros((count, matches, 2))
        """Per particle and supporting match: the young landmark's mean when it matched."""
        self._pair_cov = np.ones((count, matches, 3))
        """Per particle and supporting match: the two landmarks' summed covariances."""
        self._started = np.zeros(count)
        self._since = np.zeros(count)
        """Latest time (``travelled``) a supporting old landmark was observed."""
        self._old_keys = np.full((count, matches), -1, np.int64)
        self._new_keys = np.full((count, matches), -1, np.int64)

    def after_reading(self, cache: WorkingSetCache, poses: np.ndarray) -> np.ndarray:
        """Match the new landmarks of the reading's working set (``cache.current``; the clock
        has taken the reading), close confirmed loops; returns the poses (moved where a loop
        closed)."""
        ws = cache.current
        first, before = self.clock.first_new, self.clock.before
        travelled, created, seen = self.clock.travelled, self.clock.created, self.clock.seen
        self.support[travelled - self._started > self.lifetime] = 0
        # Landmarks this reading confirmed: their log-odds reached the bound now.
        confirmed = ws.valid & (ws.logodds >= self.min_logodds)
        confirmed[:, :first] &= before[..., 3] < self.min_logodds
        if confirmed.any():  # (before the first landmark no key can be looked up)
            confirmed &= (travelled - created[np.maximum(ws.key, 0)]) <= self.lifetime
        if confirmed.any():
            key = np.maximum(ws.key[:, :first], 0)
            stale = travelled - seen[key]
            old = (ws.valid[:, :first] & (ws.logodds[:, :first] >= self.min_logodds)
                   & (stale >= self.old_after))
            if old.any():
                for column in np.flatnonzero(confirmed.any(axis=0)).tolist():
                    self._match(ws, column, confirmed[:, column], old, key, stale)
        closing = self.support >= self.matches
        if closing.any():
            poses = self._close(cache, poses, closing.nonzero()[0])
        return poses

    def _match(self, ws: WorkingSet, column: int, created: np.ndarray, old: np.ndarray,
               key: np.ndarray, stale: np.ndarray) -> None:
        """Fold the wide matches of the landmarks just confirmed in ``column`` (the particles
        ``created``) into the hypotheses."""
        first = old.shape[1]
        offsets = ws.mean[:, :first] - ws.mean[:, column, None]                  # (M, E, 2)
        match_cov = ws.cov[:, :first] + ws.cov[:, column, None]                  # (M, E, 3)
        drift = (DRIFT_PER_METER * stale) ** 2
        wide_cov = match_cov + np.stack([drift, np.zeros_like(drift), drift], axis=-1)
        wide_d2 = _mahalanobis(offsets, wide_cov)
        wide = old & created[:, None] & (wide_d2 <= WIDE_GATE)
        if not wide.any():
            return
        # Agreement: the rigid fit of the held pairs plus this one leaves every residual
        # within the gate of its pair's covariance.
        count, held_count = len(self.support), self.matches
        used = np.arange(held_count)[None, :] < np.minimum(self.support, held_count)[:, None]
        shape = (count, first, held_count + 1)
        pair_old = np.concatenate([np.broadcast_to(self._pair_old[:, None], shape[:2] + (
            held_count, 2)), ws.mean[:, :first, None]], axis=2)
        pair_new = np.concatenate([np.broadcast_to(self._pair_new[:, None], shape[:2] + (
            held_count, 2)), np.broadcast_to(ws.mean[:, column, None, None], shape[:2] + (1, 2))],
            axis=2)
        pair_cov = np.concatenate([np.broadcast_to(self._pair_cov[:, None], shape[:2] + (
            held_count, 3)), match_cov[:, :, None]], axis=2)
        in_fit = np.concatenate([np.broadcast_to(used[:, None], shape[:2] + (held_count,)),
                                 np.ones(shape[:2] + (1,), bool)], axis=2)
        agree_d2 = _fit_residuals(pair_old, pair_new, pair_cov, in_fit)
        held = (key[:, :, None] == self._old_keys[:, None, :]).any(axis=2)
        agree = wide & (self.support > 0)[:, None] & (agree_d2 <= AGREEMENT_GATE) & ~held
        joins = agree.any(axis=1)
        rows = joins.nonzero()[0]
        if len(rows):
            pick = np.where(agree[rows], agree_d2[rows], np.inf).argmin(axis=1)
            slot = np.minimum(self.support[rows], self.matches - 1)
            self._store(ws, rows, slot, column, pick, key, match_cov)
            self._since[rows] = np.maximum(self._since[rows], self.clock.seen[key[rows, pick]])
            self.support[rows] += 1
        rows = (wide.any(axis=1) & ~joins).nonzero()[0]
        if len(rows):
            pick = np.where(wide[rows], wide_d2[rows], np.inf).argmin(axis=1)
            self._old_keys[rows] = -1
            self._new_keys[rows] = -1
            self._store(ws, rows, np.zeros(len(rows), np.int64), column, pick, key, match_cov)
            self._since[rows] = self.clock.seen[key[rows, pick]]
            self._started[rows] = self.clock.travelled
            self.support[rows] = 1

    def _store(self, ws: WorkingSet, rows: np.ndarray, slot: np.ndarray, column: int,
               pick: np.ndarray, key: np.ndarray, match_cov: np.ndarray) -> None:
        """Hold the match of old landmark ``pick`` to young ``column`` in ``slot`` of particles
        ``rows``."""
        self._old_keys[rows, slot] = key[rows, pick]
        self._new_keys[rows, slot] = ws.key[rows, column]
        self._pair_old[rows, slot] = ws.mean[rows, pick]
        self._pair_new[rows, slot] = ws.mean[rows, column]
        self._pair_cov[rows, slot] = match_cov[rows, pick]

    def _close(self, cache: WorkingSetCache, poses: np.ndarray,
               rows: np.ndarray) -> np.ndarray:
        """Correct particles ``rows`` by the rigid fit of their supporting pairs (young onto
        old): the pose, and the landmarks near the robot (in the reading's working set)
        created since the supporting old landmarks were last observed, which carry the
        same drift; remove the duplicates that confirmed the closure. The rest of the map
        keeps its place: the closure says nothing about where the drift grew along the way,
        and a guess bent over the map (in proportion to the distance travelled, or along the
        path) moved far landmarks that were right. The working set goes back to the store
        first; the closing particles' whole maps are gathered, corrected and written back
        (landmarks now in another cell move there)."""
        rotation, translation = _fit(self._pair_old[rows], self._pair_new[rows],
                                     self._pair_cov[rows],
                                     np.ones(self._pair_old[rows].shape[:2], bool))
        cos, sin = np.cos(rotation), np.sin(rotation)
        robot = poses[rows, :2]
        # The correction as a rotation about the robot's position and a shift of it.
        shift = np.stack([cos * robot[:, 0] - sin * robot[:, 1],
                          sin * robot[:, 0] + cos * robot[:, 1]], axis=-1) + translation - robot
        near = cache.current
        span = self.clock.num_keys + 1
        owner, entry = np.nonzero(near.valid[rows])
        near_codes = owner * span + near.key[rows][owner, entry]
        cache.flush()
        store = cache.store
        ws = store.gather_maps(rows)
        valid = ws.valid[rows]
        key = ws.key[rows]
        created = self.clock.created[np.maximum(key, 0)]
        codes = np.arange(len(rows))[:, None] * span + np.maximum(key, 0)
        moved = (valid & (created > self._since[rows, None])
                 & np.isin(codes, near_codes))
        angle = np.where(moved, rotation[:, None], 0.0)
        lcos, lsin = np.cos(angle), np.sin(angle)
        mean = ws.mean[rows] - robot[:, None]
        ws.mean[rows] = np.where(
            moved[..., None],
            np.stack([lcos * mean[..., 0] - lsin * mean[..., 1],
                      lsin * mean[..., 0] + lcos * mean[..., 1]], axis=-1)
            + (robot + shift)[:, None], ws.mean[rows])
        ws.cov[rows] = rotate_cov(ws.cov[rows], lcos, lsin)
        duplicate = valid & (key[:, :, None] == self._new_keys[rows, None, :]).any(axis=2)
        ws.valid[rows] = valid & ~duplicate
        ws.dirty[rows] |= moved | duplicate
        store.scatter_moved(ws, cache.track_labels)
        poses = poses.copy()
        poses[rows, :2] = robot + shift
        poses[rows, 2] = wrap_angle(poses[rows, 2] + rotation)
        self.support[rows] = 0
        self.num_closures += len(rows)
        return poses

    def resample(self, indices: np.ndarray) -> None:
        """Particle m takes the hypothesis of particle ``indices[m]``."""
        for name in ("support", "_pair_old", "_pair_new", "_pair_cov", "_started", "_since",
                     "_old_keys", "_new_keys"):
            setattr(self, name, getattr(self, name)[indices])
