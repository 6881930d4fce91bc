# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A plain, per-particle FastSLAM written from the textbook formulas, for the tests only.

Loops over particles and landmarks, full matrices, ``np.linalg.inv``: nothing shared with the
vectorized core except the configuration object and the order in which random numbers are drawn
(one (M, 3) normal draw per motion step, one uniform per (observation, particle) for Monte Carlo
association, one uniform for systematic resampling). Each particle owns a deep copy of its map.

Semantics mirrored from the core (documented there): the association of every observation of a
reading is decided at the pose before the reading is used (FastSLAM 1.0: the sampled pose;
FastSLAM 2.0: the predicted mean, scored with L = G_s P G_s^T + Q); FastSLAM 2.0 then refines
the proposal with each associated observation in turn, every Jacobian taken at the predicted
mean, and samples the pose once. Existence: a landmark in view that was not observed is
missed unless an observation the association rejected (new, outlier or ignored) lies within 10
sensor standard deviations of its predicted observation; a confirmed landmark (log-odds at
least logit(map_min_existence)) goes back to the saturation when observed, and a miss costs it
tau- (10 - l_c) / 20.
"""
from __future__ import annotations

import copy
import math

import numpy as np


def wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


def measure(pose, landmark, offset):
    """Range, bearing and the Jacobians G_s (2x3), G_m (2x2) written out from the geometry."""
    x, y, theta = pose
    ox, oy, oyaw = offset
    sx = x + math.cos(theta) * ox - math.sin(theta) * oy
    sy = y + math.sin(theta) * ox + math.cos(theta) * oy
    dx, dy = landmark[0] - sx, landmark[1] - sy
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    z_hat = np.array([r, wrap(math.atan2(dy, dx) - theta - oyaw)])
    g_m = np.array([[dx / r, dy / r], [-dy / q, dx / q]])
    dsx_dtheta, dsy_dtheta = -(sy - y), sx - x
    g_s = np.array([[-dx / r, -dy / r, -(dx * dsx_dtheta + dy * dsy_dtheta) / r],
                    [dy / q, -dx / q, (dy * dsx_dtheta - dx * dsy_dtheta) / q - 1.0]])
    return z_hat, g_s, g_m


def log_gauss(innovation, cov) -> float:
    return float(-0.5 * innovation @ np.linalg.inv(cov) @ innovation
                 - math.log(2 * math.pi) - 0.5 * math.log(np.linalg.det(cov)))


LOGODDS_MAX = 10.0
"""Existence log-odds saturate here (the core's constant)."""


class ReferenceFastSLAM:
    def __init__(self, config, rng, initial_pose, max_prior_heading_sigma=0.3):
        self.c = config
        self.max_prior_heading_sigma = max_prior_heading_sigma
        self.rng = rng
        self.M = config.num_particles
        self.poses = [np.array(initial_pose, float) for _ in range(self.M)]
        self.log_w = [-math.log(self.M)] * self.M
        self.maps = [[] for _ in range(self.M)]   # dicts: mean, cov, logodds, label
        self.pending = None
        self.prior = None          # FastSLAM 2.0: per particle (mean, cov) of flushed odometry
        self.offset = (config.sensor_x, config.sensor_y, config.sensor_yaw)
        self.log_p0 = math.log(config.new_landmark_likelihood)
        self.eps = config.outlier_probability
        # Outlier term eps * u, u uniform over the perceptual range and field of view.
        self.log_outlier = (math.log(self.eps) - math.log(
            (config.max_range - config.min_range) * config.field_of_view)
            if self.eps > 0.0 else -math.inf)
        self.removed = 0
        self.outliers = 0
        self.explained = 0
        p = config.map_min_existence
        keep = config.persistent_landmarks or config.keep_confirmed_landmarks
        self.confirmed = (math.inf if p >= 1.0 or not keep
                          else config.logodds_remove if p <= 0.0
                          else max(math.log(p / (1.0 - p)), config.logodds_remove))
        self.confirmed_missed = (config.logodds_missed * (LOGODDS_MAX - self.confirmed) / 20.0
                                 if math.isfinite(self.confirmed) else 0.0)

    def noise(self, z_range):
        """R of one observation: the range variance grows with the range."""
        c = self.c
        return np.diag([c.sigma_range ** 2 + (c.sigma_range_per_meter * z_range) ** 2,
                        c.sigma_bearing ** 2])

    # -------------------------------------------------------------- motion
    def predict(self, odom_from, odom_to):
        x0, y0, t0 = odom_from
        x1, y1, t1 = odom_to
        c, s = math.cos(t0), math.sin(t0)
        step = np.array([c * (x1 - x0) + s * (y1 - y0), -s * (x1 - x0) + c * (y1 - y0),
                         wrap(t1 - t0)])
        if self.pending is None:
            self.pending = np.zeros(3)
        px, py, pt = self.pending
        self.pending = np.array([px + math.cos(pt) * step[0] - math.sin(pt) * step[1],
                                 py + math.sin(pt) * step[0] + math.cos(pt) * step[1],
                                 wrap(pt + step[2])])
        if (math.hypot(self.pending[0], self.pending[1]) > self.c.max_pending_translation
                or abs(self.pending[2]) > self.c.max_pending_rotation):
            self._advance()

    def _advance(self):
        """Sample the pending odometry (1.0) or push it through the Gaussian prior (2.0)."""
        if self.pending is None:
            return
        u, var = self._take()
        if self.c.algorithm == "fastslam1":
            normals = self.rng.standard_normal((self.M, 3))
            self.poses = [self._sample_motion(p, u, var, n) for p, n in zip(self.poses, normals)]
            return
        prior = self.prior or [(p, np.zeros((3, 3))) for p in self.poses]
        self.prior = []
        for mean, cov in prior:
            rot1, trans, _ = u
            f = np.eye(3)
            f[0, 2] = -trans * math.sin(mean[2] + rot1)
            f[1, 2] = trans * math.cos(mean[2] + rot1)
            self.prior.append((self._move(mean, *u),
                               f @ cov @ f.T + self._motion_cov(mean, u, var)))
        if max(cov[2, 2] for _, cov in self.prior) > self.max_prior_heading_sigma ** 2:
            self.poses = self._sample_prior()

    def _sample_prior(self):
        normals = self.rng.standard_normal((self.M, 3))
        poses = []
        for (mean, cov), n in zip(self.prior, normals):
            pose = mean + np.linalg.cholesky(cov + 1e-12 * np.eye(3)) @ n
            pose[2] = wrap(pose[2])
            poses.append(pose)
        self.prior = None
        return poses

    def _take(self):
        dx, dy, dtheta = self.pending
        self.pending = None
        trans = math.hypot(dx, dy)
        rot1 = math.atan2(dy, dx) if trans > 1e-9 else 0.0
        if abs(rot1) > math.pi / 2:
            rot1 = wrap(rot1 - math.pi)
            trans = -trans
        rot2 = wrap(dtheta - rot1)
        a1, a2, a3, a4 = self.c.alpha1, self.c.alpha2, self.c.alpha3, self.c.alpha4
        var = np.array([a1 * rot1 ** 2 + a2 * trans ** 2 + self.c.min_rotation_sigma ** 2,
                        a3 * trans ** 2 + a4 * (rot1 ** 2 + rot2 ** 2)
                        + self.c.min_translation_sigma ** 2,
                        a1 * rot2 ** 2 + a2 * trans ** 2 + self.c.min_rotation_sigma ** 2])
        c = self.c   # random-walk terms, linear in the step's size
        var = var + np.array([
            c.rotation_variance_per_radian * abs(rot1) + 0.5 * c.rotation_variance_per_meter
            * abs(trans),
            c.translation_variance_per_meter * abs(trans) + c.translation_variance_per_radian
            * (abs(rot1) + abs(rot2)),
            c.rotation_variance_per_radian * abs(rot2) + 0.5 * c.rotation_variance_per_meter
            * abs(trans)])
        return (rot1, trans, rot2), var

    @staticmethod
    def _move(pose, rot1, trans, rot2):
        x, y, theta = pose
        return np.array([x + trans * math.cos(theta + rot1), y + trans * math.sin(theta + rot1),
                         wrap(theta + rot1 + rot2)])

    def _sample_motion(self, pose, u, var, normals):
        noisy = np.array(u) - normals * np.sqrt(var)
        return self._move(pose, *noisy)

    def _motion_cov(self, pose, u, var):
        rot1, trans, _ = u
        h = pose[2] + rot1
        v = np.array([[-trans * math.sin(h), math.cos(h), 0.0],
                      [trans * math.cos(h), math.sin(h), 0.0],
                      [1.0, 0.0, 1.0]])
        return v @ np.diag(var) @ v.T

    # -------------------------------------------------------------- update
    def update(self, ranges, bearings, labels):
        c = self.c
        fast2 = c.algorithm == "fastslam2"
        z_all = [np.array([r, wrap(b)]) for r, b in zip(ranges, bearings)]
        K = len(z_all)
        self._advance()
        motion = self.prior
        # Association of every observation, every particle, at the pre-update pose.
        points = [motion[m][0] if motion else self.poses[m] for m in range(self.M)]
        covs = [motion[m][1] if motion else None for m in range(self.M)]
        choice, factor = self._associate(points, covs, z_all, labels)
        if motion:
            proposals = [self._proposal(motion[m], choice, z_all, m) for m in range(self.M)]
        at_association = [row[:] for row in factor]
        for m in range(self.M):
            if motion:
                mean, cov, factors = proposals[m]
                for j, value in factors.items():
                    # A sampled association (monte_carlo) also weighs 1 / q, q = its own
                    # likelihood over the marginal that ``factor`` holds.
                    factor[j][m] = value + (at_association[j][m] - self.chosen_ll[j][m]
                                            if c.association == "monte_carlo" else 0.0)
                motion[m] = (mean, cov)
            for j in range(K):   # robust likelihood (1 - eps) N + eps u, N at association
                if self.eps > 0.0 and (isinstance(choice[j][m], int)
                                       or choice[j][m] == "outlier"):
                    gauss = at_association[j][m]
                    robust = float(np.logaddexp(math.log(1.0 - self.eps) + gauss,
                                                self.log_outlier))
                    # An outlier weighs its robust likelihood; an inlier its Gaussian weight
                    # (joint with the others in 2.0) times robust / N.
                    factor[j][m] = robust if choice[j][m] == "outlier" else (
                        factor[j][m] + robust - gauss)
            self.log_w[m] += sum(factor[j][m] for j in range(K))
        if motion and fast2:
            self.prior = motion
            self.poses = self._sample_prior()

        for m in range(self.M):
            before = {id(lm) for lm in self.maps[m]}
            observed = set()
            created_by_label = {}
            rejected = []
            for j, z in enumerate(z_all):
                n = choice[j][m]
                if n == "new" and c.association == "known" and labels[j] in created_by_label:
                    n = created_by_label[labels[j]]     # repeated id: update what it created
                if isinstance(n, str):
                    rejected.append(z)
                if isinstance(n, (int, dict)):
                    lm = self.maps[m][n] if isinstance(n, int) else n
                    z_hat, _, g_m = measure(self.poses[m], lm["mean"], self.offset)
                    r = self.noise(z[0])
                    q = g_m @ lm["cov"] @ g_m.T + r
                    gain = lm["cov"] @ g_m.T @ np.linalg.inv(q)
                    nu = z - z_hat
                    nu[1] = wrap(nu[1])
                    lm["mean"] = lm["mean"] + gain @ nu
                    a = np.eye(2) - gain @ g_m
                    lm["cov"] = a @ lm["cov"] @ a.T + gain @ r @ gain.T
                    lm["logodds"] = (LOGODDS_MAX if lm["logodds"] >= self.confirmed
                                     else min(lm["logodds"] + c.logodds_observed, LOGODDS_MAX))
                    observed.add(id(lm))
                elif n == "new":
                    x, y, theta = self.poses[m]
                    ox, oy, oyaw = self.offset
                    sx = x + math.cos(theta) * ox - math.sin(theta) * oy
                    sy = y + math.sin(theta) * ox + math.cos(theta) * oy
                    angle = theta + oyaw + z[1]
                    mean = np.array([sx + z[0] * math.cos(angle), sy + z[0] * math.sin(angle)])
                    _, _, g_m = measure(self.poses[m], mean, self.offset)
                    g_inv = np.linalg.inv(g_m)
                    lm = dict(mean=mean, cov=g_inv @ self.noise(z[0]) @ g_inv.T,
                              logodds=c.logodds_observed, label=int(labels[j]))
                    self.maps[m].append(lm)
                    created_by_label[int(labels[j])] = lm
            survivors = []
            for lm in self.maps[m]:
                if id(lm) in before and id(lm) not in observed and c.logodds_missed != 0.0:
                    z_hat, _, _ = measure(self.poses[m], lm["mean"], self.offset)
                    if (c.min_range <= z_hat[0] <= c.max_range
                            and abs(z_hat[1]) <= 0.5 * c.field_of_view):
                        if c.persistent_landmarks and any(
                               (z[0] - z_hat[0]) ** 2 / self.noise(z[0])[0, 0]
                               + wrap(z[1] - z_hat[1]) ** 2 / c.sigma_bearing ** 2 <= 100.0
                               for z in rejected):
                            self.explained += 1
                            survivors.append(lm)
                            continue
                        lm["logodds"] += (self.confirmed_missed
                                          if lm["logodds"] >= self.confirmed
                                          else c.logodds_missed)
                        if lm["logodds"] < c.logodds_remove:
                            self.removed += 1
                            continue
                survivors.append(lm)
            self.maps[m] = survivors

        log_w = np.array(self.log_w)
        peak = log_w.max()
        log_w = log_w - (peak + math.log(np.exp(log_w - peak).sum()))
        self.log_w = list(log_w)
        w = np.exp(log_w)
        n_eff = 1.0 / np.sum(w ** 2)
        if n_eff < c.resample_threshold * self.M:
            positions = (self.rng.random() + np.arange(self.M)) / self.M
            cumulative = np.cumsum(w)
            cumulative[-1] = 1.0
            indices = np.searchsorted(cumulative, positions, side="right")
            self.poses = [self.poses[i].copy() for i in indices]
            self.maps = [copy.deepcopy(self.maps[i]) for i in indices]
            self.log_w = [-math.log(self.M)] * self.M

    def _associate(self, points, covs, z_all, labels):
        """choice[j][m], factor[j][m] of every observation j and particle m at ``points``."""
        c = self.c
        K = len(z_all)
        uniforms = (self.rng.random(K * self.M).reshape(K, self.M)
                    if c.association == "monte_carlo" and K else None)
        choice = [[None] * self.M for _ in range(K)]
        factor = [[0.0] * self.M for _ in range(K)]
        self.chosen_ll = [[None] * self.M for _ in range(K)]
        all_scores = [[None] * self.M for _ in range(K)]
        for m in range(self.M):
            pose, pose_cov = points[m], covs[m]
            for j, z in enumerate(z_all):
                scores = []
                for n, lm in enumerate(self.maps[m]):
                    z_hat, g_s, g_m = measure(pose, lm["mean"], self.offset)
                    s_cov = g_m @ lm["cov"] @ g_m.T + self.noise(z[0])
                    if pose_cov is not None:
                        s_cov = s_cov + g_s @ pose_cov @ g_s.T
                    nu = z - z_hat
                    nu[1] = wrap(nu[1])
                    maha = float(nu @ np.linalg.inv(s_cov) @ nu)
                    scores.append((n, log_gauss(nu, s_cov), maha))
                all_scores[j][m] = scores
                choice[j][m], factor[j][m] = self._choose(scores, m, j, labels[j], uniforms)
                if c.association == "monte_carlo" and isinstance(choice[j][m], int):
                    self.chosen_ll[j][m] = next(ll for n, ll, _ in scores if n == choice[j][m])
            if c.association == "ml":
                self._exclusive(all_scores, choice, factor, m, K)
            for j in range(K):   # (1 - eps) N < eps u: an outlier, not used
                if (self.eps > 0.0 and isinstance(choice[j][m], int)
                        and math.log(1.0 - self.eps) + factor[j][m] < self.log_outlier):
                    choice[j][m] = "outlier"
                    self.outliers += 1
        return choice, factor

    def _proposal(self, prior, choice, z_all, m):
        """Particle m's proposal (mean, cov) from its prior and associated observations, and
        the weight factor of each of them {j: log N(nu; 0, L)}."""
        point, cov = prior
        mean = point
        factors = {}
        # Sequential updates, every Jacobian taken at the predicted mean ``point``.
        for j, z in enumerate(z_all):
            n = choice[j][m]
            if not isinstance(n, int):
                continue
            lm = self.maps[m][n]
            z_point, g_s, g_m = measure(point, lm["mean"], self.offset)
            step = mean - point
            step[2] = wrap(step[2])
            q = g_m @ lm["cov"] @ g_m.T + self.noise(z[0])
            big_l = g_s @ cov @ g_s.T + q
            nu = z - (z_point + g_s @ step)
            nu[1] = wrap(nu[1])
            # Textbook information form (P invertible in these tests).
            sigma = np.linalg.inv(g_s.T @ np.linalg.inv(q) @ g_s + np.linalg.inv(cov))
            mean = mean + sigma @ g_s.T @ np.linalg.inv(q) @ nu
            cov = sigma
            factors[j] = log_gauss(nu, big_l)
        mean = mean.copy()
        mean[2] = wrap(mean[2])
        return mean, cov, factors

    def _exclusive(self, all_scores, choice, factor, m, K):
        """One landmark per reading: the most likely observation keeps it, the rest re-pick."""
        removed = [set() for _ in range(K)]
        while True:
            claims = {}
            for j in range(K):
                if isinstance(choice[j][m], int):
                    claims.setdefault(choice[j][m], []).append(j)
            losers = []
            for n, js in claims.items():
                winner = max(js, key=lambda j: (factor[j][m], -j))
                losers += [(j, n) for j in js if j != winner]
            if not losers:
                return
            for j, n in losers:
                removed[j].add(n)
                remaining = [s for s in all_scores[j][m] if s[0] not in removed[j]]
                choice[j][m], factor[j][m] = self._choose(remaining, m, j, None, None)

    def _choose(self, scores, m, j, label, uniforms):
        """(landmark index | 'new' | 'ignore', log factor)."""
        c = self.c
        if c.association == "known":
            for n, ll, _ in scores:
                if self.maps[m][n]["label"] == label:
                    return n, ll
            return "new", self.log_p0
        if c.association == "ml":
            if scores:
                n, ll, _ = max(scores, key=lambda s: s[1])
                if ll >= self.log_p0:
                    return n, ll
            return "new", self.log_p0
        if c.association == "monte_carlo":
            scores = sorted(scores, key=lambda s: -s[1])    # most likely first, as the core
            options = [ll for _, ll, _ in scores] + [self.log_p0]
            peak = max(options)
            cumulative = np.cumsum([math.exp(o - peak) for o in options])
            draw = uniforms[j, m] * cumulative[-1]
            k = min(int(np.sum(cumulative <= draw)), len(scores))
            log_marginal = peak + math.log(cumulative[-1])
            return (scores[k][0] if k < len(scores) else "new"), log_marginal
        if not scores:
            return "new", self.log_p0
        n, ll, maha = min(scores, key=lambda s: s[2])
        if maha < c.association_gate:
            return n, ll
        if maha > c.new_landmark_gate:
            return "new", self.log_p0
        return "ignore", 0.0
