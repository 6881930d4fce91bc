# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The math of one reading on each backend, behind one interface ``FastSLAM.update`` calls:
association of every observation in every particle (step 2 of ``fastslam.py``), the FastSLAM
2.0 proposal and its draw (3), the landmark EKF updates, new landmarks and existence evidence
(4), the weights (5), on numpy: ``NumpyReading``, the reference, which
``backend_compiled.read`` twins in one call of ``compiled.update_reading`` on the same random
draws."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import association as assoc
from .config import LOGODDS_MAX
from .existence import explains, missed_logodds, observed_logodds
from .geometry import wrap_angle
from .landmark_ekf import initialize_landmarks, update_landmarks
from .landmark_store import COV, LOGODDS, MEAN, WorkingSet
from .observation import MIN_OBSERVATION_RANGE, observation_terms
from .proposal import observation_proposal
from .resampling import effective_sample_size, normalize_log_weights

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


@dataclass
class ReadingOutcome:
    """What a backend's reading leaves to the steps ``FastSLAM.update`` shares."""

    report: UpdateReport
    """Seen from the reported particle, before any resampling."""
    best: int
    """The reported particle."""
    columns: int
    """The reading's new-landmark columns that now hold landmarks (in some particles)."""
    checked: bool
    """The reading found every particle's state finite (else ``check_state`` looks)."""


class NumpyReading:
    """The numpy reading of ``FastSLAM`` (the reference): ``_read_numpy`` and its steps."""

    def _usable_numpy(self, ranges: np.ndarray, bearings: np.ndarray, labels: np.ndarray):
        """The observations ``update`` uses: a finite range of at least
        ``MIN_OBSERVATION_RANGE``, a finite bearing (wrapped) and, with known ids, an id >= 0;
        with the largest range kept (0 when none is)."""
        usable = np.isfinite(ranges) & np.isfinite(bearings) & (ranges >= MIN_OBSERVATION_RANGE)
        if self.config.association == "known":
            usable &= labels >= 0
        if not usable.all():
            ranges, bearings, labels = ranges[usable], bearings[usable], labels[usable]
        return ranges, wrap_angle(bearings), labels, float(ranges.max(initial=0.0))

    def _read_numpy(self, ws: WorkingSet, proposal_mean: np.ndarray,
                    proposal_cov: np.ndarray | None, ranges: np.ndarray, bearings: np.ndarray,
                    labels: np.ndarray, reach: float, stamp: float) -> ReadingOutcome:
        """Steps 2 to 5 of a reading on the working set ``ws``, the observations scored at
        ``proposal_mean`` (with its covariance, FastSLAM 2.0's prior, or None) against the
        landmarks within ``reach`` of it; the weights normalised and the path history given
        the new poses."""
        fastslam2 = self.config.algorithm == "fastslam2"
        choices, log_factors, robust, inverse_q = self._associate(
            ws, proposal_mean, proposal_cov, ranges, bearings, labels, reach)
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
        self.log_weights, underflow = normalize_log_weights(self.log_weights)
        self.num_underflows += int(underflow)
        best = self._select_best()
        best_choice, is_new = choices[:, best], creating[:, best]
        labels = np.where(best_choice >= 0, ws.label[best, np.maximum(best_choice, 0)], -1)
        report = UpdateReport(len(best_choice), np.where(is_new, -1, labels), is_new, False,
                              effective_sample_size(np.exp(self.log_weights)), underflow)
        return ReadingOutcome(report, best, int(creating.any(axis=1).sum()), False)

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
                   bearings: np.ndarray, labels: np.ndarray, reach: float):
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
            kept, near = self._columns_in_reach(ws, mean, reach)
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

    def _columns_in_reach(self, ws: WorkingSet, poses: np.ndarray, reach: float):
        """Working-set columns (of the landmarks that existed before this reading) holding a
        landmark within ``reach`` (``FastSLAM._reach_of``) of its particle's pose (the
        working set holds whole cells of a box around all particles, about twice the area),
        and which particle's entries are in reach (M, existing): only those are candidates."""
        existing = ws.first_new_slot
        dx = ws.mean[:, :existing, 0] - poses[:, 0, None]
        dy = ws.mean[:, :existing, 1] - poses[:, 1, None]
        near = dx * dx
        near += dy * dy
        near = ws.valid[:, :existing] & (near <= reach * reach)
        return near.any(axis=0).nonzero()[0], near

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
        self._set_prior((mean, cov))
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
        if len(obs) and config.persistent_landmarks:
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
