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
2. Each wide match proposes a translation of the particle (old landmark minus young one). A
   particle keeps one such offset hypothesis across readings: a match consistent with it
   (within ``AGREEMENT_GATE`` of the landmarks' own covariances, no drift) from an old landmark
   it does not hold yet joins it (information-weighted mean); any other wide match replaces
   it. A hypothesis expires after ``LIFETIME_RANGES`` sensor ranges of travel.
3. Once ``matches`` distinct old landmarks agree, the particle's pose and its recent landmarks
   in the working set (created since its supporting old landmarks were last observed) are
   shifted by the offset, and the duplicates that supported it are removed: the loop is
   closed, and the next readings associate the old landmarks as usual. Recent landmarks
   outside the working set (far from the robot) keep their place.

A single wrong wide match never moves a particle. "Last observed" is kept per landmark key
(shared by a landmark's copies in every particle): a landmark is observed when the reading
changed its covariance in some particle. Landmarks of a loaded map count as observed at start.
"""
from __future__ import annotations

import math

import numpy as np

from .landmark_store import COV, LOGODDS, WorkingSet

DRIFT_PER_METER = 0.01
"""Standard deviation (m per m travelled) of the odometry drift the wide match allows for (the
default world drifts about 0.5 %; 1 % and 2 % give the same runs there and in the clutter
world)."""
WIDE_GATE = 9.21
"""Squared Mahalanobis distance of a wide match (chi-square, 2 dof, 99 %)."""
AGREEMENT_GATE = 9.21
"""Squared Mahalanobis distance within which two wide matches' offsets agree (99 %)."""
OLD_AFTER_RANGES = 2.0
"""A landmark not observed for this many ``max_range`` of travel is old (the robot has left
it and come back)."""
LIFETIME_RANGES = 1.0
"""An offset hypothesis expires after this many ``max_range`` of travel; a landmark is young
(may propose one) for as long after its creation."""


def _mahalanobis(d: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """d^T S^-1 d for 2-D vectors d (..., 2) and packed covariances S (..., 3)."""
    sxx, sxy, syy = cov[..., 0], cov[..., 1], cov[..., 2]
    det = sxx * syy - sxy * sxy
    dx, dy = d[..., 0], d[..., 1]
    return (syy * dx * dx - 2.0 * sxy * dx * dy + sxx * dy * dy) / det


def _inverse(cov: np.ndarray) -> np.ndarray:
    """Inverse of packed 2x2 covariances (..., 3), packed."""
    sxx, sxy, syy = cov[..., 0], cov[..., 1], cov[..., 2]
    det = sxx * syy - sxy * sxy
    return np.stack([syy / det, -sxy / det, sxx / det], axis=-1)


def _times(packed: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Packed symmetric 2x2 matrices (..., 3) times vectors (..., 2)."""
    return np.stack([packed[..., 0] * d[..., 0] + packed[..., 1] * d[..., 1],
                     packed[..., 1] * d[..., 0] + packed[..., 2] * d[..., 1]], axis=-1)


class LoopClosure:
    """Per-particle offset hypotheses and per-key observation times (module docstring)."""

    def __init__(self, num_particles: int, matches: int, min_existence: float,
                 max_range: float) -> None:
        self.matches = matches
        self.min_logodds = (-math.inf if min_existence <= 0.0 else
                            math.log(min_existence / (1.0 - min_existence))
                            if min_existence < 1.0 else math.inf)
        self.old_after = OLD_AFTER_RANGES * max_range
        self.lifetime = LIFETIME_RANGES * max_range
        self.travelled = 0.0
        """Odometry distance (m) received so far (``FastSLAM.predict``)."""
        self.num_closures = 0
        """Particle shifts made so far (a closure shifts every particle that confirmed it)."""
        self._seen = np.zeros(0)
        """Per landmark key: ``travelled`` when some particle last observed it."""
        self._created = np.zeros(0)
        """Per landmark key: ``travelled`` when it was created."""
        self._num_keys = 0
        count = num_particles
        self.support = np.zeros(count, np.int64)
        """Distinct old landmarks agreeing on each particle's offset (0: no hypothesis)."""
        self.offset = np.zeros((count, 2))
        self.offset_cov = np.ones((count, 3))
        self._started = np.zeros(count)
        self._since = np.zeros(count)
        """Latest time (``travelled``) a supporting old landmark was observed."""
        self._old_keys = np.full((count, matches), -1, np.int64)
        self._new_keys = np.full((count, matches), -1, np.int64)
        self._before: np.ndarray | None = None
        self._first_new = 0

    def register(self, next_key: int) -> None:
        """Keys below ``next_key`` not registered yet were created (and observed) now."""
        known = self._num_keys
        if next_key <= known:
            return
        if next_key > len(self._seen):
            # Doubling: a reading creates up to one key per particle and new landmark.
            grow = max(next_key, 2 * len(self._seen)) - len(self._seen)
            self._seen = np.concatenate([self._seen, np.zeros(grow)])
            self._created = np.concatenate([self._created, np.zeros(grow)])
        self._seen[known:next_key] = self._created[known:next_key] = self.travelled
        self._num_keys = next_key

    def before_reading(self, ws: WorkingSet, pending: np.ndarray | None) -> None:
        """Remember the covariances and log-odds of the working set's landmarks (``pending``:
        the resampling the reading applies to it first), to tell which the reading observes
        and which it confirms."""
        kept = ws.state[:, :ws.first_new_slot, COV.start:LOGODDS + 1]
        self._before = kept[pending] if pending is not None else kept.copy()
        self._first_new = ws.first_new_slot

    def after_reading(self, ws: WorkingSet, poses: np.ndarray, next_key: int) -> np.ndarray:
        """Update observation times, match this reading's new landmarks, close confirmed
        loops; returns the poses (shifted where a loop closed)."""
        first, before = self._first_new, self._before
        self._before = None
        changed = ws.valid[:, :first] & (ws.cov[:, :first] != before[..., :3]).any(axis=2)
        self._seen[ws.key[:, :first][changed]] = self.travelled
        self.register(next_key)
        self.support[self.travelled - self._started > self.lifetime] = 0
        # Landmarks this reading confirmed: their log-odds reached the bound now.
        confirmed = ws.valid & (ws.logodds >= self.min_logodds)
        confirmed[:, :first] &= before[..., 3] < self.min_logodds
        confirmed &= (self.travelled - self._created[np.maximum(ws.key, 0)]) <= self.lifetime
        if confirmed.any():
            key = np.maximum(ws.key[:, :first], 0)
            stale = self.travelled - self._seen[key]
            old = (ws.valid[:, :first] & (ws.logodds[:, :first] >= self.min_logodds)
                   & (stale >= self.old_after))
            if old.any():
                for column in np.flatnonzero(confirmed.any(axis=0)).tolist():
                    self._match(ws, column, confirmed[:, column], old, key, stale)
        closing = self.support >= self.matches
        if closing.any():
            poses = self._close(ws, poses, closing.nonzero()[0])
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
        agree_d2 = _mahalanobis(offsets - self.offset[:, None],
                                match_cov + self.offset_cov[:, None])
        held = (key[:, :, None] == self._old_keys[:, None, :]).any(axis=2)
        agree = wide & (self.support > 0)[:, None] & (agree_d2 <= AGREEMENT_GATE) & ~held
        joins = agree.any(axis=1)
        rows = joins.nonzero()[0]
        if len(rows):
            pick = np.where(agree[rows], agree_d2[rows], np.inf).argmin(axis=1)
            info_old = _inverse(self.offset_cov[rows])
            info_new = _inverse(match_cov[rows, pick])
            cov = _inverse(info_old + info_new)
            self.offset[rows] = _times(cov, _times(info_old, self.offset[rows])
                                       + _times(info_new, offsets[rows, pick]))
            self.offset_cov[rows] = cov
            slot = np.minimum(self.support[rows], self.matches - 1)
            self._old_keys[rows, slot] = key[rows, pick]
            self._new_keys[rows, slot] = ws.key[rows, column]
            self._since[rows] = np.maximum(self._since[rows], self._seen[key[rows, pick]])
            self.support[rows] += 1
        rows = (wide.any(axis=1) & ~joins).nonzero()[0]
        if len(rows):
            pick = np.where(wide[rows], wide_d2[rows], np.inf).argmin(axis=1)
            self.offset[rows] = offsets[rows, pick]
            self.offset_cov[rows] = match_cov[rows, pick]
            self._old_keys[rows] = -1
            self._new_keys[rows] = -1
            self._old_keys[rows, 0] = key[rows, pick]
            self._new_keys[rows, 0] = ws.key[rows, column]
            self._since[rows] = self._seen[key[rows, pick]]
            self._started[rows] = self.travelled
            self.support[rows] = 1

    def _close(self, ws: WorkingSet, poses: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Shift the poses and recent landmarks of particles ``rows`` by their offsets and
        remove the duplicates that confirmed them."""
        shift = self.offset[rows]
        valid = ws.valid[rows]
        key = ws.key[rows]
        recent = valid & (self._created[np.maximum(key, 0)] > self._since[rows, None])
        mean = ws.mean[rows]
        mean += np.where(recent[..., None], shift[:, None], 0.0)
        ws.mean[rows] = mean
        duplicate = valid & (key[:, :, None] == self._new_keys[rows, None, :]).any(axis=2)
        ws.valid[rows] = valid & ~duplicate
        ws.dirty[rows] |= recent | duplicate
        poses = poses.copy()
        poses[rows, :2] += shift
        self.support[rows] = 0
        self.num_closures += len(rows)
        return poses

    def resample(self, indices: np.ndarray) -> None:
        """Particle m takes the hypothesis of particle ``indices[m]``."""
        for name in ("support", "offset", "offset_cov", "_started", "_since", "_old_keys",
                     "_new_keys"):
            setattr(self, name, getattr(self, name)[indices])
