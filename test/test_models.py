# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Motion and observation models, the landmark EKF and the 2.0 proposal against independent math."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fastslam_ros.core.geometry import (circular_mean, compose, mean_pose_and_covariance,
                                        relative_pose, rigid_fit, wrap_angle)
from fastslam_ros.core.landmark_ekf import initialize_landmarks, pack, unpack, update_landmarks
from fastslam_ros.core.motion import (OdometryControl, apply_control, control_variances,
                                      sample_motion)
from fastslam_ros.core.observation import SensorOffset, inverse_observe
from fastslam_ros.core.proposal import observation_proposal, sample_pose
from model_helpers import jacobians, motion_covariance, observe

OFFSETS = [SensorOffset(), SensorOffset(0.4, -0.2, 0.3), SensorOffset(3.78, 0.5, -np.pi / 2)]


def test_wrap_angle_range_and_identity():
    angles = np.linspace(-20, 20, 10001)
    wrapped = wrap_angle(angles)
    assert np.all(wrapped > -np.pi) and np.all(wrapped <= np.pi)
    np.testing.assert_allclose(np.sin(wrapped), np.sin(angles), atol=1e-12)
    np.testing.assert_allclose(np.cos(wrapped), np.cos(angles), atol=1e-12)
    assert wrap_angle(np.pi) == pytest.approx(np.pi)
    assert wrap_angle(-np.pi) == pytest.approx(np.pi)
    # Round-off at large multiples of pi must not leave the interval.
    edges = wrap_angle(np.nextafter(np.arange(-60, 61) * np.pi, np.inf))
    assert np.all(edges > -np.pi) and np.all(edges <= np.pi)


def test_rigid_fit_recovers_a_known_motion_weighted_batched_and_with_a_prior():
    """Points moved by a known rotation and shift give that motion back (per batch entry);
    a zero-weight outlier changes nothing; a rotation prior shrinks the angle towards 0 as
    its closed form says (atan2(cross, dot + precision))."""
    rng = np.random.default_rng(2)
    source = rng.uniform(-5.0, 5.0, (3, 6, 2))
    rotation = np.array([0.3, -1.2, 2.9])
    shift = rng.uniform(-3.0, 3.0, (3, 2))
    c, s = np.cos(rotation)[:, None], np.sin(rotation)[:, None]
    target = np.stack([c * source[..., 0] - s * source[..., 1],
                       s * source[..., 0] + c * source[..., 1]], axis=-1) + shift[:, None]
    fitted_rotation, fitted_shift = rigid_fit(source, target)
    np.testing.assert_allclose(fitted_rotation, rotation, atol=1e-12)
    np.testing.assert_allclose(fitted_shift, shift, atol=1e-12)
    outlier = target.copy()
    outlier[:, 0] += 40.0
    weight = np.ones((3, 6))
    weight[:, 0] = 0.0
    np.testing.assert_allclose(rigid_fit(source, outlier, weight)[0], rotation, atol=1e-12)
    a = source[0] - source[0].mean(axis=0)
    b = target[0] - target[0].mean(axis=0)
    dot = (a * b).sum()
    cross = (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]).sum()
    shrunk = rigid_fit(source[0], target[0], rotation_precision=dot)[0]
    assert abs(shrunk - math.atan2(cross, 2.0 * dot)) < 1e-12 and abs(shrunk) < abs(rotation[0])


def test_compose_and_relative_pose_are_inverse():
    rng = np.random.default_rng(0)
    a = rng.uniform(-5, 5, (50, 3))
    b = rng.uniform(-5, 5, (50, 3))
    np.testing.assert_allclose(compose(a, relative_pose(a, b)), wrap_pose(b), atol=1e-12)


def test_single_poses_take_the_float_path_with_the_same_result():
    rng = np.random.default_rng(1)
    a = rng.uniform(-5, 5, (50, 3))
    b = rng.uniform(-5, 5, (50, 3))
    b[0, 2] = a[0, 2] + np.pi   # the wrap boundary: (-pi, pi] on both paths
    batch_relative, batch_compose = relative_pose(a, b), compose(a, b)
    for k in range(50):
        np.testing.assert_allclose(relative_pose(a[k], b[k]), batch_relative[k], atol=1e-12)
        np.testing.assert_allclose(compose(a[k], b[k]), batch_compose[k], atol=1e-12)


def wrap_pose(p):
    return np.column_stack([p[:, :2], wrap_angle(p[:, 2])])


@pytest.mark.parametrize("offset", OFFSETS)
def test_jacobians_match_finite_differences(offset):
    rng = np.random.default_rng(1)
    for _ in range(20):
        pose = rng.uniform([-3, -3, -np.pi], [3, 3, np.pi])
        landmark = pose[:2] + rng.uniform(2, 8) * np.array([np.cos(a := rng.uniform(-3, 3)),
                                                            np.sin(a)])
        g_s, g_m = jacobians(pose, landmark, offset)
        eps = 1e-6
        for i in range(3):
            d = np.zeros(3)
            d[i] = eps
            diff = observe(pose + d, landmark, offset) - observe(pose - d, landmark, offset)
            diff[1] = wrap_angle(diff[1])
            np.testing.assert_allclose(g_s[:, i], diff / (2 * eps), atol=1e-6)
        for i in range(2):
            d = np.zeros(2)
            d[i] = eps
            diff = observe(pose, landmark + d, offset) - observe(pose, landmark - d, offset)
            diff[1] = wrap_angle(diff[1])
            np.testing.assert_allclose(g_m[:, i], diff / (2 * eps), atol=1e-6)


@pytest.mark.parametrize("offset", OFFSETS)
def test_inverse_observation_round_trips(offset):
    rng = np.random.default_rng(2)
    poses = rng.uniform([-3, -3, -np.pi], [3, 3, np.pi], (100, 3))
    ranges = rng.uniform(0.5, 30, 100)
    bearings = rng.uniform(-np.pi, np.pi, 100)
    landmarks = inverse_observe(poses, ranges, bearings, offset)
    z = observe(poses, landmarks, offset)
    np.testing.assert_allclose(z[:, 0], ranges, atol=1e-9)
    np.testing.assert_allclose(wrap_angle(z[:, 1] - bearings), 0.0, atol=1e-9)


def test_odometry_decomposition_reproduces_the_motion_and_handles_reversing():
    rng = np.random.default_rng(3)
    for _ in range(100):
        start = rng.uniform([-3, -3, -np.pi], [3, 3, np.pi])
        delta = rng.uniform([-1, -1, -1], [1, 1, 1])
        u = OdometryControl.from_delta(delta)
        moved = apply_control(start[None], u.rot1, u.trans, u.rot2)[0]
        np.testing.assert_allclose(wrap_pose(moved[None]), wrap_pose(compose(start, delta)[None]),
                                   atol=1e-12)
        assert abs(u.rot1) <= np.pi / 2 + 1e-12
    backwards = OdometryControl.from_delta([-1.0, 0.0, 0.0])
    assert backwards.trans == pytest.approx(-1.0) and backwards.rot1 == pytest.approx(0.0)


def test_gaussian_motion_covariance_matches_sampled_spread():
    rng = np.random.default_rng(4)
    pose = np.array([[1.0, 2.0, 0.3]])
    u = OdometryControl(0.1, 0.8, -0.05)
    var = control_variances(u, (0.05, 0.01, 0.05, 0.01), 1e-3, 1e-3)
    samples = sample_motion(np.repeat(pose, 200000, 0), u, var, rng.standard_normal((200000, 3)))
    mean = apply_control(pose, u.rot1, u.trans, u.rot2)[0]
    deviation = samples - mean
    deviation[:, 2] = wrap_angle(deviation[:, 2])
    empirical = deviation.T @ deviation / len(samples)
    np.testing.assert_allclose(empirical, motion_covariance(pose, u, var)[0], rtol=0.05,
                               atol=2e-5)


def test_landmark_initialization_covariance_is_the_linearized_inverse():
    pose = np.array([[0.5, -1.0, 0.4]])
    offset = SensorOffset(0.3, 0.1, 0.2)
    noise = np.array([0.04, 0.001])
    mean, cov = initialize_landmarks(pose, np.array([5.0]), np.array([0.3]), offset, noise)
    _, g_m = jacobians(pose[0], mean[0], offset)
    g_inv = np.linalg.inv(g_m)
    np.testing.assert_allclose(unpack(cov)[0], g_inv @ np.diag(noise) @ g_inv.T, rtol=1e-10)


def test_landmark_ekf_update_matches_textbook_joseph_form():
    rng = np.random.default_rng(5)
    offset = SensorOffset(0.2, 0.1, -0.1)
    noise = np.array([0.01, 0.0004])
    poses = rng.uniform([-1, -1, -np.pi], [1, 1, np.pi], (30, 3))
    landmarks = poses[:, :2] + rng.uniform(3, 6, (30, 2))
    a = rng.normal(size=(30, 2, 2))
    covs = a @ a.transpose(0, 2, 1) * 0.1 + 0.01 * np.eye(2)
    z = observe(poses, landmarks, offset) + rng.normal(0, [0.1, 0.02], (30, 2))
    new_mean, new_cov = update_landmarks(poses, landmarks, pack(covs), z[:, 0], z[:, 1], offset,
                                         noise)
    for i in range(30):
        _, g = jacobians(poses[i], landmarks[i], offset)
        q = g @ covs[i] @ g.T + np.diag(noise)
        k = covs[i] @ g.T @ np.linalg.inv(q)
        nu = z[i] - observe(poses[i], landmarks[i], offset)
        nu[1] = wrap_angle(nu[1])
        np.testing.assert_allclose(new_mean[i], landmarks[i] + k @ nu, atol=1e-12)
        expected = (np.eye(2) - k @ g) @ covs[i]
        np.testing.assert_allclose(unpack(new_cov)[i], expected, atol=1e-12)


def test_landmark_ekf_is_consistent_nees_over_seeds():
    """A landmark seen repeatedly from known poses: NEES averages to 2 (chi-square, 2 dof)."""
    offset = SensorOffset(0.1, 0.0, 0.0)
    noise = np.array([0.1 ** 2, 0.02 ** 2])
    runs = 400
    rng = np.random.default_rng(6)
    truth = np.array([6.0, 3.0])
    poses = np.column_stack([np.linspace(0, 4, 10), np.zeros(10), np.linspace(0, 0.5, 10)])
    nees = []
    for _ in range(runs):
        z0 = observe(poses[0], truth, offset) + rng.normal(0, np.sqrt(noise))
        mean, cov = initialize_landmarks(poses[:1], z0[:1], z0[1:], offset, noise)
        for pose in poses[1:]:
            z = observe(pose, truth, offset) + rng.normal(0, np.sqrt(noise))
            mean, cov = update_landmarks(pose[None], mean, cov, z[:1], z[1:], offset, noise)
        error = mean[0] - truth
        nees.append(error @ np.linalg.inv(unpack(cov)[0]) @ error)
    # Mean of 400 chi2(2) draws: 2 +- 3 sigma (sigma = 2 / sqrt(400) = 0.1).
    assert 1.7 < np.mean(nees) < 2.3


def joint_kalman_proposal(mean, cov, landmarks, z, offset, noise):
    """One particle's proposal from all its observations stacked into one measurement vector,
    with np.linalg (EKF form: Jacobians at the predicted mean)."""
    rows, predicted, blocks = [], [], []
    for lm in landmarks:
        g_s, g_m = jacobians(mean, lm[:2], offset)
        sigma_m = unpack(lm[2:])
        rows.append(g_s)
        predicted.append(observe(mean, lm[:2], offset))
        blocks.append(g_m @ sigma_m @ g_m.T + noise)
    g = np.vstack(rows)
    q = np.zeros((len(g), len(g)))
    for k, block in enumerate(blocks):
        q[2 * k:2 * k + 2, 2 * k:2 * k + 2] = block
    nu = (z - np.array(predicted)).ravel()
    nu[1::2] = wrap_angle(nu[1::2])
    big_l = g @ cov @ g.T + q
    gain = cov @ g.T @ np.linalg.inv(big_l)
    point = mean + gain @ nu
    new_cov = cov - gain @ big_l @ gain.T
    log_w = (-0.5 * nu @ np.linalg.solve(big_l, nu) - 0.5 * np.log(np.linalg.det(big_l))
             - 0.5 * len(nu) * np.log(2 * np.pi))
    return point, new_cov, log_w


@pytest.mark.parametrize("offset", OFFSETS[:2])
def test_proposal_equals_joint_kalman_update(offset):
    """The information-sum proposal (no inverse of P, one pass over all pairs) equals the
    Kalman update on all observations stacked, per particle; particles without pairs keep
    their prior."""
    rng = np.random.default_rng(7)
    n = 12
    mean = rng.normal(size=(n, 3))
    a = rng.normal(size=(n, 3, 3))
    cov = a @ a.transpose(0, 2, 1) * 0.02 + 1e-4 * np.eye(3)
    cov[3] = np.diag([1e-4, 0.0, 0.0])          # singular P: no information form possible
    counts = rng.integers(0, 4, size=n)
    counts[0] = 0
    particle = np.repeat(np.arange(n), counts)
    landmarks = np.column_stack([mean[particle, :2] + rng.uniform(2.0, 8.0, (len(particle), 2)),
                                 pack(np.repeat(np.eye(2)[None] * 0.05, len(particle), 0))])
    noise = np.diag([0.01, 0.001])
    truth = [observe(mean[p] + rng.normal(size=3) * 0.05, lm[:2], offset)
             for p, lm in zip(particle, landmarks)]
    z = np.array(truth) + rng.normal(size=(len(particle), 2)) * [0.1, 0.03]
    # The dense (observation, particle) layout of the pairs: particle m's k-th pair in row k.
    rank = np.arange(len(particle)) - np.searchsorted(particle, particle)
    used = np.zeros((counts.max(), n), bool)
    used[rank, particle] = True
    dense = np.zeros((counts.max(), n, 5))
    dense[rank, particle] = landmarks
    z_range, z_bearing = np.zeros(used.shape), np.zeros(used.shape)
    z_range[rank, particle], z_bearing[rank, particle] = z[:, 0], z[:, 1]
    got_mean, got_cov, got_w = observation_proposal(mean, cov, dense, z_range, z_bearing, used,
                                                    offset, np.diag(noise))
    for m in range(n):
        mine = particle == m
        if not mine.any():
            np.testing.assert_allclose(got_mean[m], mean[m], atol=1e-12)
            np.testing.assert_allclose(got_cov[m], cov[m], atol=1e-12)
            assert got_w[m] == 0.0
            continue
        want_mean, want_cov, want_w = joint_kalman_proposal(mean[m], cov[m], landmarks[mine],
                                                            z[mine], offset, noise)
        want_mean[2] = wrap_angle(want_mean[2])
        np.testing.assert_allclose(got_mean[m], want_mean, atol=1e-9)
        np.testing.assert_allclose(got_cov[m], want_cov, atol=1e-9)
        assert got_w[m] == pytest.approx(want_w, abs=1e-8)


def test_sample_pose_has_the_requested_covariance_even_when_singular():
    rng = np.random.default_rng(8)
    a = np.array([[0.2, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.0, 0.05]])
    cov = a @ a.T   # rank 2
    samples = sample_pose(np.zeros((100000, 3)), np.repeat(cov[None], 100000, 0),
                          rng.standard_normal((100000, 3)))
    assert np.all(np.isfinite(samples))
    np.testing.assert_allclose(samples.T @ samples / 100000, cov, atol=3e-4)


def test_random_walk_motion_noise_does_not_depend_on_the_split():
    # Heading variance var(rot1) + var(rot2) and translation variance of one step equal the
    # sums over the same motion cut into four steps (alphas and floors off).
    linear = (0.01, 0.005, 0.0005, 0.0012)
    whole = control_variances(OdometryControl(0.1, 1.0, 0.1), (0, 0, 0, 0), 0.0, 0.0, linear)
    part = control_variances(OdometryControl(0.025, 0.25, 0.025), (0, 0, 0, 0), 0.0, 0.0,
                             linear)
    np.testing.assert_allclose(whole[0] + whole[2], 4 * (part[0] + part[2]), rtol=1e-12)
    np.testing.assert_allclose(whole[1], 4 * part[1], rtol=1e-12)
    # Backward motion (negative translation) adds the same noise as forward motion.
    back = control_variances(OdometryControl(0.1, -1.0, 0.1), (0, 0, 0, 0), 0.0, 0.0, linear)
    np.testing.assert_allclose(back, whole, rtol=1e-12)


def test_robust_likelihood_floors_outliers_and_rejects_them():
    from fastslam_ros.core import association as assoc
    from fastslam_ros.core.config import FastSLAMConfig

    config = FastSLAMConfig(outlier_probability=0.05, min_range=0.5, max_range=8.0,
                            field_of_view=1.1)
    log_outlier = assoc.log_outlier_density(config)
    np.testing.assert_allclose(log_outlier, np.log(0.05 / (7.5 * 1.1)))
    choices = np.array([[3, 2, assoc.NEW]])
    log_lik = np.array([[2.0, -40.0, np.log(1e-4)]])
    kept, factors, correction = assoc.reject_outliers(choices, log_lik, 0.05, log_outlier)
    assert kept.tolist() == [[3, assoc.IGNORE, assoc.NEW]]
    # The outlier weighs (1 - eps) N + eps u, floored near eps u instead of e^-40.
    np.testing.assert_allclose(factors[0, 1], np.logaddexp(np.log(0.95) - 40.0, log_outlier))
    np.testing.assert_allclose(factors[0, 1], log_outlier, atol=1e-12)
    # The inlier keeps log N, and its correction makes it log((1 - eps) N + eps u).
    assert factors[0, 0] == 2.0
    np.testing.assert_allclose(factors[0, 0] + correction[0, 0],
                               np.log(0.95 * np.exp(2.0) + np.exp(log_outlier)))
    # New landmarks: p0, untouched.
    assert factors[0, 2] == log_lik[0, 2] and correction[0, 2] == 0.0
    # eps = 0: plain Gaussian, nothing changes.
    kept, factors, correction = assoc.reject_outliers(choices, log_lik, 0.0, -np.inf)
    assert kept.tolist() == choices.tolist() and np.array_equal(factors, log_lik)
    assert not correction.any()


def test_association_score_against_hand_counted_readings():
    from fastslam_ros.core.association import association_score

    labels = np.array([5, 7, -1, 9, 9, 3, 4])
    is_new = np.array([False, True, False, True, True, False, True])
    associated = np.array([5, -1, -1, -1, -1, 8, -1])
    # 5 right, 7 rightly new, -1 unscored, 9 twice wrongly new (mapped), 3 to 8 wrong, 4 new.
    assert association_score(labels, is_new, associated, np.array([5, -1, 9, 2])) == (6, 3)
    assert association_score(labels, is_new, associated, np.array([], np.int64)) == (6, 5)


def reference_score(labels, is_new, associated, mapped: set) -> tuple[int, int]:
    """Observation by observation, as the score is defined."""
    checked = correct = 0
    for label, new, went_to in zip(labels.tolist(), is_new.tolist(), associated.tolist()):
        if label < 0 or (not new and went_to < 0):
            continue
        checked += 1
        correct += (label not in mapped) if new else (went_to == label)
    return checked, correct


def test_association_score_from_the_best_particles_labels_equals_the_best_maps():
    """The node scores with the best particle's labels (``particle_map``), not a built map."""
    from fastslam_ros.core import FastSLAM, FastSLAMConfig
    from fastslam_ros.core.association import association_score
    from fastslam_ros.tools.simulation.synthetic import make_world

    world = make_world(seed=3, num_steps=60, num_landmarks=60, min_separation=0.8,
                       sigma_range=0.3, sigma_bearing=0.05, clutter_per_step=1.0,
                       odometry_noise=(0.03, 0.1, 0.03))
    slam = FastSLAM(FastSLAMConfig(num_particles=20, sigma_range=0.3, sigma_bearing=0.05,
                                   max_range=12.0, new_landmark_likelihood=1e-2, seed=1,
                                   backend="numpy"), initial_pose=world.steps[0].truth)
    previous, total, unmapped = world.steps[0].odometry, np.zeros(2, int), np.zeros(2, int)
    for k, step in enumerate(world.steps[1:]):
        slam.predict(previous, step.odometry)
        previous = step.odometry
        mapped = set(slam.best_map().ids.tolist())
        labels_before = slam.particle_map(slam.best_index())[3]
        report = slam.update(step.ranges, step.bearings, step.ids, stamp=float(k))
        score = association_score(step.ids, report.is_new, report.associated_ids, labels_before)
        assert score == reference_score(step.ids, report.is_new, report.associated_ids, mapped)
        total += score
        unmapped += reference_score(step.ids, report.is_new, report.associated_ids, set())
    # The run has wrong associations, and new landmarks started for labels already mapped.
    assert total[1] < total[0] and unmapped[1] > total[1]


def test_mean_pose_across_pi_against_a_rotated_frame():
    """Headings either side of pi average to pi (not 0), and the weighted mean pose and its
    covariance equal those computed with the headings rotated away from the cut (the circular
    and the arithmetic mean of a 0.1 rad spread differ by a few microradians)."""
    rng = np.random.default_rng(5)
    poses = np.column_stack([rng.normal(2.0, 0.3, 400), rng.normal(-1.0, 0.2, 400),
                             wrap_angle(np.pi + rng.normal(0.0, 0.1, 400))])
    weights = rng.random(400)
    weights /= weights.sum()
    assert abs(wrap_angle(circular_mean(poses[:, 2]) - np.pi)) < 0.02
    mean, cov = mean_pose_and_covariance(poses, weights)
    rotated = poses.copy()
    rotated[:, 2] = poses[:, 2] - np.pi + 2 * np.pi * (poses[:, 2] < 0)   # near 0, no cut
    expected_mean = weights @ rotated
    deviation = rotated - expected_mean
    np.testing.assert_allclose(wrap_angle(mean[2] - np.pi - expected_mean[2]), 0.0, atol=1e-4)
    np.testing.assert_allclose(mean[:2], expected_mean[:2], atol=1e-12)
    np.testing.assert_allclose(cov, (deviation * weights[:, None]).T @ deviation, atol=1e-6)


@pytest.mark.parametrize("offset", OFFSETS[:2])
def test_proposal_matches_the_sampled_nonlinear_posterior_of_one_reading(offset):
    """FastSLAM 2.0's Gaussian proposal for one reading against the exact posterior
    p(s | z) ~ p(s) p(z | s) with the landmark marginalised, by importance sampling from the
    prior with the nonlinear h: the same mean, a spread that has not collapsed, and a log
    weight equal to the log evidence log p(z) (what the filter multiplies into the weight)."""
    rng = np.random.default_rng(11)
    mean = np.array([[1.0, -0.5, 0.3]])
    cov = np.diag([0.15, 0.10, 0.05]) ** 2
    cov[0, 1] = cov[1, 0] = 0.4 * 0.15 * 0.10
    sigma_m = np.array([[0.04, 0.01], [0.01, 0.03]])
    landmarks = np.array([[[5.0, 2.0, *pack(sigma_m[None])[0]],
                           [0.0, 4.5, *pack(0.5 * sigma_m[None])[0]]]]).transpose(1, 0, 2)
    noise = np.array([0.05, 0.02]) ** 2
    true_pose = mean[0] + [0.1, -0.05, 0.04]
    z = observe(true_pose, landmarks[:, 0, :2], offset) + [0.02, -0.01]
    used = np.ones((2, 1), bool)
    got_mean, got_cov, got_log_w = observation_proposal(
        mean, cov[None], landmarks, z[:, :1], z[:, 1:], used, offset, noise)

    n = 400_000
    poses = mean[0] + rng.normal(size=(n, 3)) @ np.linalg.cholesky(cov).T
    log_lik = np.zeros(n)
    for k in range(2):
        points = landmarks[k, 0, :2] + rng.normal(size=(n, 2)) @ np.linalg.cholesky(
            unpack(landmarks[k, :, 2:])[0]).T
        nu = z[k] - observe(poses, points, offset)
        nu[:, 1] = wrap_angle(nu[:, 1])
        log_lik -= 0.5 * ((nu ** 2 / noise).sum(axis=1) + np.log(noise).sum()) + np.log(2 * np.pi)
    peak = log_lik.max()
    w = np.exp(log_lik - peak)
    log_evidence = peak + np.log(w.mean())
    w /= w.sum()
    want_mean = w @ poses
    centred = poses - want_mean
    want_cov = (w[:, None] * centred).T @ centred
    sigma = np.sqrt(np.diag(want_cov))
    assert np.all(np.abs(wrap_angle(got_mean[0] - want_mean)) <= 0.1 * sigma)
    np.testing.assert_allclose(np.sqrt(np.diag(got_cov[0])), sigma, rtol=0.1)
    assert got_log_w[0] == pytest.approx(log_evidence, abs=0.1)
