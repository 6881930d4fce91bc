# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""``fastslam-calibrate BAG [BAG ...]``: sensor and odometry noise fitted from bags with ground
truth, printed and optionally written as a parameter file.

Each bag follows bag schema v1 with ``/ground_truth/pose`` (with a heading) and
``/ground_truth/landmarks``; several bags (robots of one kind) are pooled. The procedure:

* Detections: each one is paired with a true landmark, by its id when the truth has that id,
  else with the nearest true landmark within ``--match-radius`` of the detection placed with
  the true pose; the others are clutter. Residual = measured minus predicted range and bearing,
  predicted from the ground-truth pose interpolated at the reading's stamp, the sensor pose on
  the robot (``sensor_x``, ``sensor_y``, ``sensor_yaw``) and the true landmark.
* sigma_range, sigma_range_per_meter: the robust (1.4826 MAD) variance of the range residuals
  in ten range bins, fitted as sigma_range^2 + (sigma_range_per_meter * range)^2 (non-negative
  least squares); sigma_bearing: the robust std of the bearing residuals; outlier_probability:
  the share of residuals beyond the chi-square 99 % bound of that noise, less the 1 % expected.
  The residuals' medians are printed as range_bias and bearing_bias: far from 0, they say the
  sensor pose is wrong (or the ranges are scaled).
* Reach: min_range and max_range are the 0.1 % and 99.9 % quantiles of the measured ranges,
  field_of_view twice the 99.9 % quantile of the bearings' magnitude (the full circle when that
  covers 98 % of it). Detection probability: the share of (reading, true landmark inside that
  reach) pairs the reading detected; clutter rate: clutter detections per reading.
* Odometry: ``--step`` s increments of ``/odom`` and of the ground truth. The random-walk
  variances (rotation and translation, per m travelled and per rad turned) are fitted to the
  squared heading and along-track errors, the alphas of the (rot1, trans, rot2) model to the
  increments' errors (both by non-negative least squares without the largest 2 %, scaled
  for the Gaussian variance that cut removes).
  ``--motion-model`` chooses which the parameter file uses; the other is set to 0.

Readings or increments spanning a ground-truth gap longer than ``--max-gap`` are left out.
"""
from __future__ import annotations

import argparse
import math
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fastslam_ros.core.config import TWO_PI, FastSLAMConfig
from fastslam_ros.core.geometry import compose, wrap_angle
from fastslam_ros.core.observation import ObservationTerms, SensorOffset, observation_terms
from fastslam_ros.core.params import ParameterValueError
from fastslam_ros.node_support.timing import interpolate_poses
from fastslam_ros.tools import cli
from fastslam_ros.tools.datasets.converters import robust_std
from fastslam_ros.tools.evaluation.calibration_check import VALIDATION_SEEDS, check_fit
from fastslam_ros.tools.evaluation.metrics import truth_covers

CHI2_99_2DOF = 9.21
"""Squared Mahalanobis distance of the 99 % bound of a 2-D Gaussian."""
REACH_QUANTILE = 0.999
"""Quantile of the measured ranges and bearing magnitudes taken as the sensor's reach."""
FULL_CIRCLE_SHARE = 0.98
"""A field of view covering this share of the circle is reported as the full circle."""
RANGE_BINS = 10
TRIMMED_SHARE = 0.02
"""Largest squared odometry errors left out of the motion fits."""
MOTION_MODELS = ("random-walk", "alphas")
RANDOM_WALK_NAMES = ("rotation_variance_per_radian", "rotation_variance_per_meter",
                     "translation_variance_per_meter", "translation_variance_per_radian")
ALPHA_NAMES = ("alpha1", "alpha2", "alpha3", "alpha4")


class CalibrationError(ValueError):
    """A bag that cannot be calibrated from (no ground truth, nothing paired)."""


@dataclass
class Residuals:
    """Paired detections of all readings: true range (m), range and bearing residuals, the
    measured range and bearing (each (N,)); the readings and their unpaired detections."""

    true_range: np.ndarray
    range_error: np.ndarray
    bearing_error: np.ndarray
    measured_range: np.ndarray
    measured_bearing: np.ndarray
    readings: int
    clutter: int


# ---------------------------------------------------------------- odometry fits


def relative_motion(poses: np.ndarray) -> np.ndarray:
    """(rot1, trans, rot2) rows (N-1, 3) between consecutive poses."""
    delta = np.diff(poses, axis=0)
    translation = np.hypot(delta[:, 0], delta[:, 1])
    rotation1 = wrap_angle(np.arctan2(delta[:, 1], delta[:, 0]) - poses[:-1, 2])
    rotation2 = wrap_angle(delta[:, 2] - rotation1)
    return np.column_stack((rotation1, translation, rotation2))


def _trimmed_nnls(design: np.ndarray, squared_errors: np.ndarray) -> np.ndarray:
    """Non-negative least squares of variances without the largest 2 % of the squared errors
    (truth dropouts, collisions), scaled back by the share of a Gaussian's variance that the
    cut leaves (0.856), so that Gaussian errors are fitted without bias."""
    from scipy.optimize import nnls
    from scipy.stats import chi2

    keep = squared_errors <= np.quantile(squared_errors, 1.0 - TRIMMED_SHARE)
    # E[X; X <= c] = k F_{k+2}(c) for X ~ chi-square(k), here k = 1.
    kept_share = chi2.cdf(chi2.ppf(1.0 - TRIMMED_SHARE, 1), 3)
    return nnls(design[keep], squared_errors[keep])[0] / kept_share


def fit_alphas(odometry: np.ndarray, truth: np.ndarray, min_translation: float = 0.03
               ) -> dict[str, float]:
    """alpha1..alpha4 of the odometry model from (rot1, trans, rot2) steps of odometry and truth.

    The model's variances are var(rot) = alpha1 rot^2 + alpha2 trans^2 and var(trans) = alpha3
    trans^2 + alpha4 (rot1^2 + rot2^2). The squared errors of the heading change (rot1 + rot2),
    of the direction of travel (rot1, only over steps longer than ``min_translation``, where it
    is defined) and of the translation are fitted by non-negative least squares, leaving out the
    largest 2 % (``_trimmed_nnls``).
    """
    rot1, trans, rot2 = truth.T
    turn_error = wrap_angle(odometry[:, 0] + odometry[:, 2] - rot1 - rot2)
    moving = trans > min_translation
    direction_error = wrap_angle(odometry[moving, 0] - rot1[moving])
    rotation_design = np.vstack((np.column_stack((rot1**2 + rot2**2, 2.0 * trans**2)),
                                 np.column_stack((rot1[moving]**2, trans[moving]**2))))
    alpha1, alpha2 = _trimmed_nnls(rotation_design,
                                   np.concatenate((turn_error**2, direction_error**2)))
    alpha3, alpha4 = _trimmed_nnls(np.column_stack((trans**2, rot1**2 + rot2**2)),
                                   (odometry[:, 1] - trans)**2)
    return {"alpha1": float(alpha1), "alpha2": float(alpha2), "alpha3": float(alpha3),
            "alpha4": float(alpha4)}


def random_walk_rows(odom_stamps: np.ndarray, odom_poses: np.ndarray, gt_stamps: np.ndarray,
                     gt_poses: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Per increment of ``grid``: odometry path length (m), odometry absolute rotation (rad),
    heading error (rad) and along-track error (m) of the odometry against the ground truth."""
    length = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(odom_poses[:, :2], axis=0).T))))
    turned = np.concatenate(([0.0], np.cumsum(np.abs(wrap_angle(np.diff(odom_poses[:, 2]))))))
    odometry = interpolate_poses(odom_stamps, odom_poses, grid)
    truth = interpolate_poses(gt_stamps, gt_poses, grid)
    heading_error = wrap_angle(wrap_angle(np.diff(truth[:, 2]))
                               - wrap_angle(np.diff(odometry[:, 2])))

    def along(poses: np.ndarray) -> np.ndarray:
        delta = np.diff(poses[:, :2], axis=0)
        return np.cos(poses[:-1, 2]) * delta[:, 0] + np.sin(poses[:-1, 2]) * delta[:, 1]
    return np.column_stack((np.diff(np.interp(grid, odom_stamps, length)),
                            np.diff(np.interp(grid, odom_stamps, turned)),
                            heading_error, along(truth) - along(odometry)))


def fit_random_walk(rows: np.ndarray) -> dict[str, float]:
    """Random-walk (variance linear in the motion) noise from :func:`random_walk_rows`.

    The squared heading errors are fitted as rotation_variance_per_meter * length +
    rotation_variance_per_radian * turned, the squared along-track errors as
    translation_variance_per_meter * length + translation_variance_per_radian * turned
    (non-negative least squares, largest 2 % left out). Unlike the alphas, these do not depend
    on the increment the fit (or the filter) uses.
    """
    design = rows[:, :2]
    rotation_per_meter, rotation_per_radian = _trimmed_nnls(design, rows[:, 2] ** 2)
    translation_per_meter, translation_per_radian = _trimmed_nnls(design, rows[:, 3] ** 2)
    return {"rotation_variance_per_meter": float(rotation_per_meter),
            "rotation_variance_per_radian": float(rotation_per_radian),
            "translation_variance_per_meter": float(translation_per_meter),
            "translation_variance_per_radian": float(translation_per_radian)}


# ---------------------------------------------------------------- sensor fits


@dataclass
class Reading:
    """One sensor reading with the ground truth: the sensor's true pose (3,), the detections
    (K, 2) in the sensor frame, the row of ``landmarks`` each is paired with (K,) (-1:
    clutter) and the true landmark positions (L, 2) of its bag."""

    pose: np.ndarray
    points: np.ndarray
    rows: np.ndarray
    landmarks: np.ndarray


def pair_detections(bag, offset: SensorOffset, match_radius: float, max_gap: float
                    ) -> tuple[list[Reading], int]:
    """The readings of ``bag`` (``bag_schema.SchemaBag``) that the ground truth covers, their
    detections paired with true landmarks; and the number of readings left out."""
    truth, landmarks = bag.ground_truth, bag.landmarks_truth
    if truth is None or landmarks is None or len(landmarks.ids) == 0:
        raise CalibrationError("needs /ground_truth/pose and /ground_truth/landmarks")
    if truth.position_only:
        raise CalibrationError("the ground truth is position only (no heading): bearings "
                               "cannot be predicted")
    stamps = np.asarray(bag.scans.stamps, dtype=float)
    usable = truth_covers(truth.stamps, stamps, max_gap)
    robot = interpolate_poses(truth.stamps, truth.poses, stamps[usable])
    sensor = compose(robot, np.array([offset.x, offset.y, offset.yaw]))
    row_of_id = {int(i): row for row, i in enumerate(landmarks.ids)}
    readings = []
    for pose, index in zip(sensor, np.flatnonzero(usable)):
        points = np.asarray(bag.scans.points[index], dtype=float).reshape(-1, 2)
        ids = np.asarray(bag.scans.ids[index])
        rows = np.array([row_of_id.get(int(i), -1) for i in ids], dtype=int)
        unlabelled = np.flatnonzero(rows < 0)
        if len(unlabelled):
            local = np.column_stack((points[unlabelled], np.zeros(len(unlabelled))))
            world = compose(np.broadcast_to(pose, local.shape), local)[:, :2]
            distance = np.linalg.norm(world[:, None, :] - landmarks.positions[None], axis=2)
            nearest = np.argmin(distance, axis=1)
            close = distance[np.arange(len(nearest)), nearest] <= match_radius
            rows[unlabelled[close]] = nearest[close]
        readings.append(Reading(pose, points, rows, landmarks.positions))
    return readings, int(np.count_nonzero(~usable))


def predicted_observation(reading: Reading, landmarks: np.ndarray) -> ObservationTerms:
    """The filter's measurement model of ``landmarks`` (L, 2) seen from the reading's true
    sensor pose (the robot pose with the sensor offset applied)."""
    pose = reading.pose
    return observation_terms(pose[0], pose[1], pose[2], landmarks[:, 0], landmarks[:, 1],
                             SensorOffset())


def residuals(readings: list[Reading]) -> Residuals:
    """Range and bearing residuals of the paired detections."""
    parts, clutter = [], 0
    for reading in readings:
        paired = reading.rows >= 0
        clutter += int(np.count_nonzero(~paired))
        if not np.any(paired):
            continue
        predicted = predicted_observation(reading, reading.landmarks[reading.rows[paired]])
        measured = reading.points[paired]
        measured_range = np.hypot(measured[:, 0], measured[:, 1])
        measured_bearing = np.arctan2(measured[:, 1], measured[:, 0])
        parts.append((predicted.range, measured_range - predicted.range,
                      predicted.bearing_innovation(measured_bearing), measured_range,
                      measured_bearing))
    if not parts:
        raise CalibrationError("no detection could be paired with a true landmark (ids absent "
                               "from the truth and none within --match-radius)")
    columns = [np.concatenate(column) for column in zip(*parts)]
    return Residuals(*columns, readings=len(readings), clutter=clutter)


def fit_range_noise(true_range: np.ndarray, range_error: np.ndarray) -> tuple[float, float]:
    """(sigma_range, sigma_range_per_meter): variance sigma^2 + (k r)^2 fitted to the robust
    variances of the residuals in range bins of equal counts (weighted by the counts)."""
    from scipy.optimize import nnls

    edges = np.quantile(true_range, np.linspace(0.0, 1.0, RANGE_BINS + 1))
    bins = np.clip(np.searchsorted(edges, true_range, side="right") - 1, 0, RANGE_BINS - 1)
    design, target, weight = [], [], []
    for b in np.unique(bins):
        members = bins == b
        if np.count_nonzero(members) < 10:
            continue
        design.append((1.0, float(np.mean(true_range[members] ** 2))))
        target.append(robust_std(range_error[members]) ** 2)
        weight.append(math.sqrt(np.count_nonzero(members)))
    if len(design) < 2:
        return robust_std(range_error), 0.0
    weight = np.asarray(weight)
    constant, per_meter = nnls(np.asarray(design) * weight[:, None],
                               np.asarray(target) * weight)[0]
    return math.sqrt(constant), math.sqrt(per_meter)


def detection_share(readings: list[Reading], reach: dict[str, float]) -> tuple[float, int]:
    """Share of the (reading, true landmark inside ``reach`` of the true sensor pose) pairs
    that the reading detected, and the number of such pairs."""
    expected = detected = 0
    half_view = 0.5 * reach["field_of_view"]
    for reading in readings:
        predicted = predicted_observation(reading, reading.landmarks)
        distance, bearing = predicted.range, predicted.bearing
        inside = ((distance >= reach["min_range"]) & (distance <= reach["max_range"])
                  & (np.abs(bearing) <= half_view))
        expected += int(np.count_nonzero(inside))
        seen = np.zeros(len(distance), dtype=bool)
        seen[reading.rows[reading.rows >= 0]] = True
        detected += int(np.count_nonzero(inside & seen))
    return (detected / expected if expected else float("nan")), expected


def fit_sensor(readings: list[Reading]) -> tuple[dict[str, float], dict[str, float]]:
    """(parameters, other figures) of the sensor from paired readings."""
    found = residuals(readings)
    sigma_range, sigma_range_per_meter = fit_range_noise(found.true_range, found.range_error)
    sigma_bearing = robust_std(found.bearing_error)
    range_sigma = np.hypot(sigma_range, sigma_range_per_meter * found.true_range)
    distance_sq = ((found.range_error / np.maximum(range_sigma, 1e-12)) ** 2
                   + (found.bearing_error / max(sigma_bearing, 1e-12)) ** 2)
    beyond = float(np.mean(distance_sq > CHI2_99_2DOF))
    max_bearing = float(np.quantile(np.abs(found.measured_bearing), REACH_QUANTILE))
    field_of_view = min(2.0 * max_bearing, TWO_PI)
    if field_of_view >= FULL_CIRCLE_SHARE * TWO_PI:
        field_of_view = TWO_PI
    reach = {"min_range": float(np.quantile(found.measured_range, 1.0 - REACH_QUANTILE)),
             "max_range": float(np.quantile(found.measured_range, REACH_QUANTILE)),
             "field_of_view": field_of_view}
    probability, pairs = detection_share(readings, reach)
    params = {"sigma_range": sigma_range, "sigma_range_per_meter": sigma_range_per_meter,
              "sigma_bearing": sigma_bearing, "outlier_probability": max(0.0, beyond - 0.01),
              **reach}
    figures = {"range_bias": float(np.median(found.range_error)),
               "bearing_bias": float(np.median(found.bearing_error)),
               "detections_paired": len(found.true_range), "detections_clutter": found.clutter,
               "readings": found.readings, "detection_probability": probability,
               "reach_pairs": pairs, "clutter_rate": found.clutter / max(found.readings, 1),
               "residuals_beyond_chi2_99": beyond}
    return params, figures


# ---------------------------------------------------------------- the whole procedure


def odometry_rows(bag, step: float, max_gap: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(odometry steps, true steps, random-walk rows) of ``step`` s increments over the time
    both cover, without increments across a ground-truth gap."""
    odometry, truth = bag.odometry, bag.ground_truth
    start = max(odometry.stamps[0], truth.stamps[0])
    end = min(odometry.stamps[-1], truth.stamps[-1])
    grid = np.arange(start, end, step)
    grid = grid[grid <= end]  # at epoch stamps the last point can round past the end
    if len(grid) < 3:
        raise CalibrationError(f"odometry and ground truth overlap for less than 3 increments "
                               f"of {step} s")
    # An increment is kept when no ground-truth gap longer than max_gap lies inside it.
    gaps_before = np.concatenate(([0], np.cumsum(np.diff(truth.stamps) > max_gap)))
    first = np.maximum(np.searchsorted(truth.stamps, grid[:-1], side="right") - 1, 0)
    last = np.searchsorted(truth.stamps, grid[1:])
    keep = gaps_before[last] == gaps_before[first]
    odometry_steps = relative_motion(interpolate_poses(odometry.stamps, odometry.poses, grid))
    true_steps = relative_motion(interpolate_poses(truth.stamps, truth.poses, grid))
    walk = random_walk_rows(odometry.stamps, odometry.poses, truth.stamps, truth.poses, grid)
    return odometry_steps[keep], true_steps[keep], walk[keep]


def calibrate_bags(bags: list, offset: SensorOffset, step: float = 1.0,
                   match_radius: float = 1.0, max_gap: float = 1.0
                   ) -> tuple[dict[str, float], dict[str, float]]:
    """(fitted parameters, other figures) pooled over ``bags`` (``bag_schema.SchemaBag``)."""
    readings, left_out = [], 0
    odometry_parts, truth_parts, walk_parts = [], [], []
    for bag in bags:
        found, missing = pair_detections(bag, offset, match_radius, max_gap)
        readings += found
        left_out += missing
        odometry_steps, true_steps, walk = odometry_rows(bag, step, max_gap)
        odometry_parts.append(odometry_steps)
        truth_parts.append(true_steps)
        walk_parts.append(walk)
    params, figures = fit_sensor(readings)
    params.update(fit_random_walk(np.concatenate(walk_parts)))
    params.update(fit_alphas(np.concatenate(odometry_parts), np.concatenate(truth_parts)))
    figures.update(readings_without_truth=left_out,
                   odometry_increments=int(sum(len(part) for part in walk_parts)))
    return params, figures


def params_file_values(params: dict[str, float], motion_model: str, offset: SensorOffset,
                       base: dict[str, Any]) -> dict[str, Any]:
    """The parameter file's values: ``base`` with the fitted sensor noise and reach, the chosen
    motion model (the other one set to 0) and the sensor pose the fit assumed; ValueError
    (``ParameterValueError``) when they are no valid filter settings."""
    used, unused = ((RANDOM_WALK_NAMES, ALPHA_NAMES) if motion_model == "random-walk"
                    else (ALPHA_NAMES, RANDOM_WALK_NAMES))
    sensor = ("sigma_range", "sigma_range_per_meter", "sigma_bearing", "outlier_probability",
              "min_range", "max_range", "field_of_view")
    values = dict(base)
    values.update({name: float(params[name]) for name in sensor + used})
    values.update({name: 0.0 for name in unused})
    values.update(sensor_x=offset.x, sensor_y=offset.y, sensor_yaw=offset.yaw)
    # Tiny fitted sigmas must still be valid (> 0); round for a readable file.
    for name in ("sigma_range", "sigma_bearing"):
        values[name] = max(values[name], 1e-6)
    values = {name: float(f"{value:.4g}") if isinstance(value, float) else value
              for name, value in values.items()}
    core = {name: value for name, value in values.items()
            if name in FastSLAMConfig.__dataclass_fields__}
    FastSLAMConfig(**core).validate()
    return values


# ---------------------------------------------------------------- command line


def build_parser() -> argparse.ArgumentParser:
    """The ``fastslam-calibrate`` argument parser."""
    parser = cli.parser("fastslam-calibrate", __doc__, first_paragraph=True)
    parser.add_argument("bags", type=Path, nargs="+",
                        help="schema-v1 bag(s) with ground truth (pooled)")
    parser.add_argument("--out", type=Path, default=None,
                        help="write a ROS 2 parameter file (/** section) here")
    parser.add_argument("--params", type=Path, default=None,
                        help="parameter file to start from: its sensor pose is used by the fit "
                             "and its other values are copied into --out")
    parser.add_argument("--sensor-x", type=float, default=None,
                        help="sensor position on the robot, forward (m; default: --params, else 0)")
    parser.add_argument("--sensor-y", type=float, default=None,
                        help="sensor position on the robot, left (m; default: --params, else 0)")
    parser.add_argument("--sensor-yaw", type=float, default=None,
                        help="sensor heading on the robot (rad; default: --params, else 0)")
    parser.add_argument("--motion-model", choices=MOTION_MODELS, default="random-walk",
                        help="odometry noise written to --out (the other one is set to 0)")
    parser.add_argument("--step", type=float, default=1.0,
                        help="odometry increment of the motion fit (s)")
    parser.add_argument("--match-radius", type=float, default=1.0,
                        help="a detection without a known id is paired with the nearest true "
                             "landmark within this distance (m); farther: clutter")
    parser.add_argument("--max-gap", type=float, default=1.0,
                        help="longest ground-truth gap interpolated across (s)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing --out file (never a folder or an input)")
    parser.add_argument("--no-validate", action="store_true",
                        help="write --out without checking the fit (the check fits on the "
                             "first half of each bag, replays every bag whole with the "
                             "starting and the fitted parameters, seeds 1-5, and writes only "
                             "a fit no worse in mean and worst ATE)")
    return parser


@cli.interruptible("fastslam-calibrate")
def main(argv: list[str] | None = None) -> int:
    """``fastslam-calibrate``: print the fitted noise; write it with ``--out``."""
    from fastslam_ros.node_console import ParamsFileError
    from fastslam_ros.output import check_output, write_params_yaml
    from fastslam_ros.tools.bags.bag_schema import read_schema_bag

    prog = "fastslam-calibrate"
    parser = build_parser()
    args = parser.parse_args(argv)
    for name in ("step", "match_radius", "max_gap"):
        if not getattr(args, name) > 0.0:
            parser.error(f"--{name.replace('_', '-')} must be > 0")
    base: dict[str, Any] = {}
    try:
        for bag in args.bags:
            cli.input_bag(bag)
        if args.params is not None:
            cli.input_file(args.params, "parameter file")
            from fastslam_ros.tools.bags.replay import load_params_file
            base = load_params_file(args.params)
        if args.out is not None:
            cli.output_file(args.out, "--out")
            inputs = list(args.bags) + ([args.params] if args.params is not None else [])
            check_output(args.out, args.overwrite, "file", inputs=inputs)
    except cli.UsageError as error:
        return cli.fail(prog, error)
    except FileExistsError as error:
        return cli.fail(prog, error)
    except ParamsFileError as error:  # not a parameter file
        return cli.fail(prog, error, cli.EXIT_USAGE)
    except ValueError as error:  # not one parameter of it applies
        return cli.fail(prog, error, cli.EXIT_FAILURE)
    offset = SensorOffset(*(value if value is not None else float(base.get(name, 0.0))
                            for name, value in (("sensor_x", args.sensor_x),
                                                ("sensor_y", args.sensor_y),
                                                ("sensor_yaw", args.sensor_yaw))))
    try:
        bags = [read_schema_bag(bag) for bag in args.bags]
    except cli.BAG_ERRORS as error:
        return cli.fail(prog, f"cannot calibrate: {error}", cli.EXIT_FAILURE)
    try:
        params, figures = calibrate_bags(bags, offset, args.step, args.match_radius, args.max_gap)
    except CalibrationError as error:
        return cli.fail(prog, error, cli.EXIT_FAILURE)
    for name, value in params.items():
        print(f"{name}: {value:.6g}")
    for name, value in figures.items():
        print(f"# {name}: {value:.6g}")
    if args.out is None:
        return 0
    try:
        values = params_file_values(params, args.motion_model, offset, base)
    except ParameterValueError as error:
        return cli.fail(prog, f"the fit gives no valid parameters: {error}", cli.EXIT_FAILURE)
    if not args.no_validate:
        start = dict(base, sensor_x=offset.x, sensor_y=offset.y, sensor_yaw=offset.yaw)
        defaults = vars(FastSLAMConfig())
        try:
            verdict = check_fit(bags, args.bags, start, lambda parts: params_file_values(
                calibrate_bags(parts, offset, args.step, args.match_radius, args.max_gap)[0],
                args.motion_model, offset, base))
        except (CalibrationError, ParameterValueError, *cli.BAG_ERRORS) as error:
            return cli.fail(prog, f"cannot check the fit on replays: {error} (see "
                                  "--no-validate)", cli.EXIT_FAILURE)
        print(f"# ATE of whole replays (every bag, seeds {VALIDATION_SEEDS}), mean / worst: "
              f"{verdict.summary(verdict.start_ates)} m starting parameters, "
              f"{verdict.summary(verdict.fitted_ates)} m fitted on the first half")
        changed = {name: value for name, value in values.items()
                   if start.get(name, defaults.get(name)) != value}
        print("# changed: " + ", ".join(f"{name} {start.get(name, defaults.get(name))} -> "
                                        f"{value}" for name, value in changed.items()))
        if not verdict.keeps_fit:
            return cli.fail(prog, f"not written: the fit does worse on whole replays "
                                  f"({verdict.summary(verdict.fitted_ates)} m against "
                                  f"{verdict.summary(verdict.start_ates)} m with the starting "
                                  "parameters, mean / worst); keep those (or --no-validate)",
                            cli.EXIT_FAILURE)
    bag_names = " ".join(str(bag) for bag in args.bags)
    comment = "\n".join(textwrap.fill(line, 96) for line in [
        f"Calibrated by fastslam-calibrate {bag_names} (motion model {args.motion_model}, "
        f"increments of {args.step} s)" + (f", starting from {args.params}" if args.params else "")
        + ".",
        f"Detection probability {figures['detection_probability']:.3f} over "
        f"{figures['reach_pairs']} (reading, landmark in reach) pairs; clutter "
        f"{figures['clutter_rate']:.3f} detections per reading; "
        f"{figures['detections_paired']} residuals, "
        f"{100 * figures['residuals_beyond_chi2_99']:.1f} % beyond the chi-square 99 % bound."])
    try:
        write_params_yaml(args.out, values, comment, overwrite=args.overwrite)
    except OSError as error:
        return cli.fail(prog, f"cannot write {args.out}: {error}", cli.EXIT_USAGE)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
