# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Who is who among the tracked people: a hidden or recently removed person re-identified by
position (``max_person_speed``), keys voted across the robot particles, and the people
published with their ids, kept by position from one reading to the next."""
from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from fastslam_ros.core.existence import existence_probability
from fastslam_ros.people.localization import sensor_poses
from fastslam_ros.people.particle_stats import (particle_covariances, particle_means,
                                                 planar_distance)
from fastslam_ros.people.report import PeopleEstimate

PUBLISHED_GATE = 0.4
"""Two people to publish within this distance (m) of each other are one person (two tracks on
it: one is reported), and a person within it of one published at the previous reading is
that person (keeps its id). Below the 0.6 m two people's centres keep apart, as the tracks of
a close pair may come nearer each other than their people."""
REID_MARGIN = 0.5
"""Re-identification reach beyond walking: max_person_speed x time unseen + this (m)."""
REID_MEMORY = 60.0
"""A removed person's id is kept this long (s) after it was last detected, for re-identification."""
REID_MIN_UNSEEN = 1.0
"""A person unseen for at least this long (s) may be re-identified in a new detection."""
VOTE_GATE = 0.3
"""A person takes the id that most of the robot particles' weight gives a person within this
distance (m) of it (the weighted centroid of that id's people)."""


class PeopleIdentities:
    """The part of ``PeopleTracker`` that keeps the people's identities."""

    def _reidentify(self, m: np.ndarray, points: np.ndarray, mean: np.ndarray,
                    observed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Re-identification of the new people at ``points`` (K, 2) of robot particles ``m``
        (K,): the nearest confirmed person of the particle unseen for at least
        REID_MIN_UNSEEN (hidden, its cloud left behind where it was last seen) or removed at
        most REID_MEMORY ago (lost), that could have walked there since its last detection
        (``max_person_speed`` x time unseen + REID_MARGIN). Returns the keys (K,) (-1: none)
        and the slot of an unseen person to reuse (K,) (-1: a free one)."""
        s = self.settings
        if len(m) == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.intp)
        now = self.last_stamp
        unseen = now - self.last_seen[m]
        hidden = (self.alive[m] & self.confirmed[m] & ~observed[m] & (unseen >= REID_MIN_UNSEEN)
                  & (planar_distance(mean[m], points[:, None])
                     <= s.max_person_speed * unseen + REID_MARGIN))
        gone = now - self.lost_seen[m]
        alive_keys = np.where(self.alive[m], self.keys[m], -1)
        lost = ((self.lost_keys[m] >= 0) & (gone <= REID_MEMORY)
                & ~np.any(self.lost_keys[m][:, :, None] == alive_keys[:, None, :], axis=2)
                & (planar_distance(self.lost_positions[m], points[:, None])
                   <= s.max_person_speed * gone + REID_MARGIN))
        distance = np.concatenate([
            np.where(hidden, planar_distance(mean[m], points[:, None]), np.inf),
            np.where(lost, planar_distance(self.lost_positions[m], points[:, None]),
                     np.inf)], axis=1)
        choice = np.argmin(distance, axis=1)
        found = np.isfinite(distance[np.arange(len(m)), choice])
        slots = self.alive.shape[1]
        from_slot = found & (choice < slots)
        keys = np.where(from_slot, self.keys[m, np.minimum(choice, slots - 1)],
                        self.lost_keys[m, np.maximum(choice - slots, 0)])
        return np.where(found, keys, -1), np.where(from_slot, choice, -1)

    def _remember(self, gone: np.ndarray, mean: np.ndarray) -> None:
        """Keep the removed confirmed people ``gone`` (M, N) for re-identification: each
        replaces its own key's entry, else an empty or the oldest one (one slot per round,
        a round per slot holding a removal)."""
        rows = np.arange(self.num_particles)
        for n in np.flatnonzero(gone.any(axis=0)):
            m = rows[gone[:, n]]
            same = self.lost_keys[m] == self.keys[m, n, None]
            oldest = np.argmin(np.where(self.lost_keys[m] < 0, -np.inf, self.lost_seen[m]),
                               axis=1)
            entry = np.where(same.any(axis=1), np.argmax(same, axis=1), oldest)
            self.lost_keys[m, entry] = self.keys[m, n]
            self.lost_positions[m, entry] = mean[m, n]
            self.lost_seen[m, entry] = self.last_seen[m, n]

    def _vote_keys(self, weights: np.ndarray) -> None:
        """Ids voted across the robot particles: a person whose position is within VOTE_GATE
        of the weighted centroid of an id that more weight holds than its own takes that id
        (unless its particle holds it already), so that the robot particles agree on the ids
        and a change of the best particle does not change them."""
        m, n, _, means = self._live_people()
        if len(m) == 0:
            return
        unique, own = np.unique(self.keys[m, n], return_inverse=True)
        total = np.bincount(own, weights[m], len(unique))
        centroid = np.stack([np.bincount(own, weights[m] * means[:, i], len(unique))
                             for i in range(2)], axis=1) / np.maximum(total, 1e-300)[:, None]
        near = planar_distance(means[:, None], centroid[None]) < VOTE_GATE
        choice = np.argmax(np.where(near, total, -1.0), axis=1)
        rows = np.arange(len(m))
        take = near[rows, choice] & (total[choice] > total[own])
        take &= ~np.any(self.alive[m] & (self.keys[m] == unique[choice][:, None]), axis=1)
        _, first, count = np.unique(m * len(unique) + choice, return_index=True,
                                    return_counts=True)
        single = np.zeros(len(m), dtype=bool)
        single[first[count == 1]] = True
        take &= single
        self.keys[m[take], n[take]] = unique[choice[take]]

    def _published_ids(self, keys: np.ndarray, means: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
        """Published ids of the people ``keys`` at ``means`` (K, 2): paired by least total
        distance with the people published at the previous reading, a person within
        PUBLISHED_GATE of one keeps its id, whatever key its robot particle gives it (the best
        particle changed, or the person was lost and created again in place); an unpaired
        one takes its key's last published id (a fresh one if that is taken), else its key.
        The key then publishes that id until continuity hands it another. Returns the ids
        (K,) and whether each continues a person of the previous reading (K,)."""
        ids = np.array([self._id_of_key.get(k, k) for k in keys.tolist()], dtype=np.int64)
        previous_ids, previous_means = self._last_published
        kept = np.zeros(len(keys), dtype=bool)
        if len(keys) and len(previous_ids):
            apart = planar_distance(means[:, None], previous_means[None])
            rows, cols = linear_sum_assignment(np.where(apart < PUBLISHED_GATE, apart, 1e6))
            near = apart[rows, cols] < PUBLISHED_GATE
            kept[rows[near]] = True
            ids[rows[near]] = previous_ids[cols[near]]
        used = set(ids[kept].tolist())
        reach = self.settings.max_person_speed
        now = self.last_stamp if self.last_stamp is not None else 0.0
        for i in np.flatnonzero(~kept):
            # An id continuity gave another, or last published for a person last detected
            # where this one could not have walked from since (another robot particle's
            # person under the same key): a fresh one.
            stamp, place = self._last_place.get(int(ids[i]), (now, means[i]))
            walked = np.linalg.norm(means[i] - place) <= reach * (now - stamp) + REID_MARGIN
            if ids[i] in used or not walked:
                ids[i] = self.next_key
                self.next_key += 1
            used.add(int(ids[i]))
        self._id_of_key.update(zip(keys.tolist(), ids.tolist()))
        # Only a key some robot particle tracks or may re-identify (its lost people) can be
        # published again: the tables keep those, not every person of a whole shift.
        live = set(self.keys[self.alive].tolist()) | set(self.lost_keys[self.lost_keys >= 0]
                                                          .tolist())
        self._id_of_key = {k: i for k, i in self._id_of_key.items() if k in live}
        in_use = set(self._id_of_key.values())
        self._first_published = {i: s for i, s in self._first_published.items() if i in in_use}
        self._last_place = {i: p for i, p in self._last_place.items() if i in in_use}
        return ids, kept

    def published_people(self) -> PeopleEstimate:
        """The people to publish: the best robot particle's confirmed people but those whose
        particles' position standard deviation exceeds ``publish_spread`` or who lie outside a
        partial scan's span (behind a 270-degree laser: kept, not observed), and, without
        ``publish_hidden``, those hidden in the last scan (``_hidden``). Unseen for a while
        (hidden, or gone unnoticed), such a person's position is too uncertain to report: a
        stale track would be a false positive, and catch whoever walks by. The ids are the
        published ids (``_published_ids``), and of two people within PUBLISHED_GATE of each
        other (two tracks on one person) only one is reported: the one that continues a
        person published at the previous reading, else the one whose id was published first.
        Computed once per reading."""
        if self._published is not None and self._published[0] == self._updates:
            return self._published[1]
        people = self.people_of()
        keep = np.flatnonzero(np.trace(people.covariances, axis1=1, axis2=2)
                              <= 2.0 * self.settings.publish_spread ** 2)
        if self._span is not None and len(keep):
            # Outside a partial scan's span (behind a 270-degree laser) a person is kept, not
            # reported: nothing observes it there.
            sensor = sensor_poses(self.poses[self.best_index][None], self.offset)[0]
            offset = people.means[keep] - sensor[:2]
            keep = keep[self._span.covers(np.arctan2(offset[:, 1], offset[:, 0]) - sensor[2])]
            if not self.settings.publish_hidden:
                keep = keep[~self._hidden(people.keys[keep], people.means[keep], sensor)]
        ids, kept = self._published_ids(people.keys[keep], people.means[keep])
        now = self.last_stamp if self.last_stamp is not None else 0.0
        for i in ids.tolist():
            self._first_published.setdefault(i, now)
        first = np.array([self._first_published[i] for i in ids.tolist()])
        shown: list[int] = []
        for i in np.lexsort((first, ~kept)):
            if all(np.linalg.norm(people.means[keep[i]] - people.means[keep[j]])
                   >= PUBLISHED_GATE for j in shown):
                shown.append(int(i))
        shown.sort(key=lambda i: ids[i])
        rows = keep[shown]
        self._last_published = (ids[shown], people.means[rows])
        slots = self._best_slots(people.keys[rows])
        best = self.best_index
        self._last_place.update(zip(ids[shown].tolist(), zip(
            self.last_seen[best, slots].tolist(), self.seen_mean[best, slots])))
        estimate = PeopleEstimate(ids[shown], people.means[rows], people.covariances[rows],
                                  people.existence[rows])
        self._published = (self._updates, estimate)
        return estimate

    def _hidden(self, keys: np.ndarray, means: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """Which of the best robot particle's people ``keys`` at ``means`` (K, 2) the last
        scan, taken from ``sensor`` (x, y, yaw), did not detect and whose beam ended more than
        ``person_radius`` short of them (something nearer hides them)."""
        scan = self._span
        offset = means - sensor[:2]
        bearing = np.arctan2(offset[:, 1], offset[:, 0]) - sensor[2]
        measured = scan.range_toward(bearing, self.settings.min_range)  # NaN: not hidden
        detected = self.last_seen[self.best_index, self._best_slots(keys)] >= self.last_stamp
        return ~detected & (measured < np.hypot(offset[:, 0], offset[:, 1])
                            - self.settings.person_radius)

    def _best_slots(self, keys: np.ndarray) -> np.ndarray:
        """The best robot particle's slots of its live people ``keys`` (K,)."""
        if len(keys) == 0:     # also while localizing globally, with no slots at all
            return np.zeros(0, dtype=np.intp)
        best = self.best_index
        return np.argmax((self.keys[best][None] == keys[:, None]) & self.alive[best][None],
                         axis=1)

    def people_of(self, particle: int | None = None) -> PeopleEstimate:
        """The confirmed people of one robot particle (the best by default); tentative ones
        (log-odds not yet at ``logodds_confirm``) are left out."""
        m = self.best_index if particle is None else particle
        slots = np.flatnonzero(self.alive[m] & self.confirmed[m])
        particles = self.people[m, slots]
        means = particle_means(particles)
        covariances = particle_covariances(particles - means[:, None, :])
        order = np.argsort(self.keys[m, slots], kind="stable")
        return PeopleEstimate(self.keys[m, slots][order], means[order], covariances[order],
                              existence_probability(self.logodds[m, slots][order]))
