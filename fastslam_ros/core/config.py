# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Settings of the FastSLAM core, validated once at construction.

Every field is a plain number or string declared with ``params.parameter``: its default, its
range or choices and its description are written here once, and the node's parameter
descriptors, the start-up validation, config/fastslam.yaml and docs/parameters.md are derived
from them (``python3 -m fastslam_ros.tools.params_doc``). ``validate()`` raises
``params.ParameterValueError`` naming the parameter(s) the user typed.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .existence import (EXPLAINED_GATE, confirmation_logodds, confirmed_evidence,
                        detection_evidence)
from .params import ParameterValueError, check_fields, parameter

ALGORITHMS = ("fastslam1", "fastslam2")
ASSOCIATION_MODES = ("known", "ml", "monte_carlo", "two_gate")
RESAMPLING_SCHEMES = ("systematic", "stratified", "residual", "multinomial")
BEST_PARTICLE_RULES = ("heaviest", "central")
MODES = ("mapping", "localization")
BACKENDS = ("auto", "numpy", "numba")

TWO_PI = 2.0 * math.pi
LOGODDS_MAX = 10.0
"""Existence log-odds saturate here, so a landmark that disappears can still be removed."""
CHI2_99_2DOF = 9.21
"""Squared Mahalanobis distance of the 99 % ellipse in two dimensions."""
MIN_CELL_SIZE = 0.5
"""Smallest map cell side (m). Cells only index the map (a reading gathers the whole cells
within the sensor's reach), so a cell far below the spacing of landmarks and the sensor's
reach multiplies the cells touched per reading without making anything more exact; at
1e-300 m the integer cell index overflows and landmarks are lost and duplicated."""


@dataclass(frozen=True)
class FastSLAMConfig:
    """All tunables of the filter (SI units, radians)."""

    num_particles: int = parameter(100, "M, the number of particles.", low=1, high=1_000_000)
    mode: str = parameter(
        "mapping", "mapping: build the map (starting from a loaded one, if any); localization: "
        "the loaded map is fixed (no landmark update, removal or addition) and the particles "
        "localize on it.", choices=MODES)
    algorithm: str = parameter(
        "fastslam2", "fastslam1: pose from the motion model; fastslam2: pose from the proposal "
        "that uses the current observations.", choices=ALGORITHMS)
    association: str = parameter(
        "ml", "known: the cloud's ids; ml: maximum likelihood with p0 (a landmark takes at most "
        "one observation per reading); monte_carlo: sampled in proportion to the likelihoods; "
        "two_gate: Mahalanobis gates.", choices=ASSOCIATION_MODES)
    new_landmark_likelihood: float = parameter(
        1e-4, "p0 (1/(m rad)): likelihood density below which an observation starts a new "
        "landmark; the weight of a particle that creates one is multiplied by p0.",
        low=0.0, low_exclusive=True, high=1e3)
    association_gate: float = parameter(
        9.21, "two_gate: squared Mahalanobis distance inside which an observation may be "
        "associated (chi-square, 2 dof; 9.21 = 99 %).", low=0.0, low_exclusive=True, high=1e4)
    new_landmark_gate: float = parameter(
        25.0, "two_gate: squared Mahalanobis distance beyond which (from every landmark) an "
        "observation starts a new landmark; between the gates it is ignored. "
        ">= association_gate.", low=0.0, low_exclusive=True, high=1e4)
    relocalization_fraction: float = parameter(
        0.5, "localization: fraction of the particles (the lightest) redrawn at the pose "
        "found from a reading once the filter has been lost for relocalization_delay (or "
        "earlier, once that pose has drifted relocalization_gate farther from the filter's), "
        "when that pose puts more than half of the reading's observations (and at least 3) "
        "near a landmark (0: never).",
        low=0.0, high=1.0)
    relocalization_gate: float = parameter(
        1.0, "localization: distance (m) from a landmark within which an observed point counts "
        "as explained, for the lost test and the pose search; the redrawn particles spread "
        "half of it.", low=0.0, low_exclusive=True, high=100.0)
    relocalization_delay: float = parameter(
        15.0, "localization: seconds the best particle must have been lost (at most half of "
        "each reading's observations near a landmark) before the pose found from the readings "
        "is taken while it stays within relocalization_gate of the closest found in this loss; "
        "shorter losses pass by themselves. After an initialpose it is taken at once, until "
        "the map is found.", low=0.0, high=1e6)
    alpha1: float = parameter(0.05, "Odometry noise: rotation from rotation (rad^2/rad^2).",
                              low=0.0, high=10.0)
    alpha2: float = parameter(0.001, "Odometry noise: rotation from translation (rad^2/m^2).",
                              low=0.0, high=10.0)
    alpha3: float = parameter(0.05, "Odometry noise: translation from translation (m^2/m^2).",
                              low=0.0, high=10.0)
    alpha4: float = parameter(0.01, "Odometry noise: translation from rotation (m^2/rad^2).",
                              low=0.0, high=10.0)
    rotation_variance_per_radian: float = parameter(
        0.0, "Random-walk heading noise from rotation (rad^2 per rad turned). Unlike the alphas "
        "it adds up to the same total however often observations divide the odometry.",
        low=0.0, high=10.0)
    rotation_variance_per_meter: float = parameter(
        0.0, "Random-walk heading noise from translation (rad^2 per m travelled).",
        low=0.0, high=10.0)
    translation_variance_per_meter: float = parameter(
        0.0, "Random-walk translation noise from translation (m^2 per m travelled).",
        low=0.0, high=10.0)
    translation_variance_per_radian: float = parameter(
        0.0, "Random-walk translation noise from rotation (m^2 per rad turned).",
        low=0.0, high=10.0)
    min_translation_sigma: float = parameter(
        0.001, "Noise floor of every motion step's translation (m), so the pose covariance "
        "never collapses.", low=0.0, low_exclusive=True, high=10.0)
    min_rotation_sigma: float = parameter(
        0.001, "Noise floor of every motion step's rotations (rad).",
        low=0.0, low_exclusive=True, high=math.pi)
    turn_fault_probability: float = parameter(
        0.0, "Share of the particles that, at each motion step, take the odometry's turn as "
        "not executed as reported: their two rotations get an extra N(0, rotation^2) error (a "
        "commanded turn the robot did not make, a skid-steer slipping in a turn), which the "
        "observations then confirm or not. For odometry that integrates commanded velocities "
        "(MRCLAM) or slips when turning; 0: off.", low=0.0, high=1.0, high_exclusive=True)
    max_pending_translation: float = parameter(
        1.0, "Odometry accumulated beyond this distance (m) is applied without waiting for an "
        "observation, so one (rot1, trans, rot2) step never spans a long curve.",
        low=0.0, low_exclusive=True, high=1e3)
    max_pending_rotation: float = parameter(
        0.5, "Same bound for accumulated rotation (rad).",
        low=0.0, low_exclusive=True, high=math.pi)
    sigma_range: float = parameter(0.1, "Range measurement standard deviation (m).",
                                   low=0.0, low_exclusive=True, high=100.0)
    sigma_bearing: float = parameter(0.0175, "Bearing measurement standard deviation (rad).",
                                     low=0.0, low_exclusive=True, high=math.pi)
    sigma_range_per_meter: float = parameter(
        0.0, "Range noise growing with the range (m per m): the range variance is "
        "sigma_range^2 + (sigma_range_per_meter * range)^2.", low=0.0, high=10.0)
    outlier_probability: float = parameter(
        0.0, "eps: probability that an associated observation is an outlier, uniform over the "
        "perceptual range; an observation more likely an outlier is not used (0: plain "
        "Gaussian).", low=0.0, high=1.0, high_exclusive=True)
    sensor_x: float = parameter(0.0, "Sensor position on the robot, forward (m).",
                                low=-100.0, high=100.0)
    sensor_y: float = parameter(0.0, "Sensor position on the robot, left (m).",
                                low=-100.0, high=100.0)
    sensor_yaw: float = parameter(0.0, "Sensor heading relative to the robot (rad).",
                                  low=-math.pi, high=math.pi)
    min_range: float = parameter(
        0.0, "Perceptual range, near bound (m): closer landmarks get no negative evidence. "
        "< max_range.", low=0.0, high=1e4)
    max_range: float = parameter(
        30.0, "Perceptual range, far bound (m); cloud points farther away are dropped.",
        low=0.0, low_exclusive=True, high=1e4)
    field_of_view: float = parameter(
        TWO_PI, "Full opening angle of the sensor (rad), centred on its x axis.",
        low=0.0, low_exclusive=True, high=TWO_PI)
    logodds_observed: float = parameter(
        1.0, "tau+: existence log-odds added when a landmark is observed (and given to a new "
        "one); they saturate at 10.", low=0.0, low_exclusive=True, high=LOGODDS_MAX)
    logodds_missed: float = parameter(
        -0.5, "tau-: log-odds added when a landmark inside the perceptual range is not "
        "observed (see persistent_landmarks).", low=-100.0, high=0.0)
    keep_confirmed_landmarks: bool = parameter(
        True, "A confirmed landmark (map_min_existence) loses tau- (10 - l_c) / 20 per miss and "
        "goes back to the saturation when observed, so only about 20 / |tau-| misses in a row "
        "make it tentative again: a map seen constantly is not removed and founded again from "
        "a drifted pose. false: every landmark loses tau- per miss.")
    persistent_landmarks: bool = parameter(
        False, "keep_confirmed_landmarks, and a landmark in view is not missed when an "
        "observation the association rejected lies within 10 sensor standard deviations of it. "
        "Keeps the map of a few landmarks seen constantly (MRCLAM, a room); costs a cluttered "
        "outdoor map (Victoria Park) its accuracy.")
    detection_probability: float = parameter(
        0.0, "P_D: probability that the sensor detects a landmark inside the perceptual range "
        "in one reading (fastslam-calibrate measures it). > 0: the existence log-odds follow "
        "from it and clutter_rate by Bayes' rule and replace logodds_observed and "
        "logodds_missed: a missed landmark in view gets tau- = log(1 - P_D), an observed one "
        "tau+ = log((P_D + p_F - P_D p_F) / p_F) (at most 10), p_F the chance that a clutter "
        "point falls into its association gate (the 99 % ellipse at mid-range); 0: the two "
        "are used as given.", low=0.0, high=1.0, high_exclusive=True)
    clutter_rate: float = parameter(
        0.0, "False detections per reading, uniform over the perceptual range (used with "
        "detection_probability).", low=0.0, high=1e4)
    logodds_remove: float = parameter(
        -1.5, "A landmark whose log-odds fall below this bound is removed. < logodds_observed.",
        low=-100.0, high=100.0)
    map_min_existence: float = parameter(
        0.9, "Existence probability from which a landmark is confirmed: below it a landmark is "
        "tentative, used by the filter but left out of ~/landmarks, ~/map_cloud and the file "
        "~/save_map writes (a new landmark starts at sigmoid(tau+): 0.73 for "
        "logodds_observed 1.0, 0.9 after about three detections). 0 shows every landmark.",
        low=0.0, high=1.0)
    loop_closure_matches: int = parameter(
        0, "k: a new landmark, once confirmed (map_min_existence), that lies within a "
        "drift-widened gate of an old confirmed landmark (not observed for two sensor ranges of "
        "travel) pairs with it; once k distinct old landmarks agree on one rigid motion (rotation "
        "and translation) over the readings, the particle's pose and the landmarks near the "
        "robot mapped since the old ones were last seen move by it, the duplicates are removed "
        "and the rest of the map keeps its place: a drifted loop closes instead of mapping its "
        "start twice (0: off; mapping with unknown association only).", low=0, high=10)
    fault_recovery_matches: int = parameter(
        0, "k: once per second the reported particle's young confirmed landmarks (created "
        "within two sensor ranges of travel) are matched to its older ones near the robot as "
        "one rigid body with any rotation; when at least k of them, and half, lie within "
        "fault_recovery_gate of older landmarks after a move farther than that gate, the "
        "particle moves by it, the copies are removed and every particle takes it: a turn "
        "the odometry reported and the robot did not make (odometry from commanded "
        "velocities, as MRCLAM's) no longer maps the room again in a rotated frame. For a "
        "small set of landmarks seen constantly (a room): with many similar landmarks "
        "(Victoria Park's trees) it matches the wrong ones (0: off; >= 3; mapping with "
        "unknown association only).", low=0, high=20)
    fault_recovery_gate: float = parameter(
        0.3, "Distance (m) within which a young landmark moved by the rigid match counts as a "
        "copy of an older one (fault_recovery_matches); below the spacing of distinct "
        "landmarks.", low=0.0, low_exclusive=True, high=10.0)
    smoothing_period: float = parameter(
        0.0, "Seconds of data between solves of the least squares over the reported "
        "particle's path and map (the map refinement, core/smoother.py), at least; a long log "
        "spaces them further (smoother.SOLVE_SPACING per logged observation), as a solve's "
        "cost grows with it; the estimate (~/pose, "
        "map -> odom) is then the latest solved pose moved by the particles' weighted mean "
        "motion since, in the frame the filter started in (0: the filter's own pose; SLAM "
        "mode only).", low=0.0, high=1e6)
    resampling: str = parameter("systematic", "Resampling scheme.", choices=RESAMPLING_SCHEMES)
    resample_threshold: float = parameter(
        0.5, "Resample when N_eff < resample_threshold * M (1.0: every update).",
        low=0.0, low_exclusive=True, high=1.0)
    best_particle: str = parameter(
        "central", "Which particle is reported (pose, map, path): heaviest, the highest "
        "weight; central, the one nearest the weighted mean position (least expected squared "
        "position error when particles with turned maps weigh about the same).",
        choices=BEST_PARTICLE_RULES)
    cell_size: float = parameter(
        10.0, "Side (m) of the spatial cells that index each particle's map; about the "
        "sensor's reach / 3. Below 0.5 m cells only multiply the work per reading.",
        low=MIN_CELL_SIZE, high=1e4)
    seed: int = parameter(-1, "Seed of the random generator; -1 draws one from the OS.",
                          low=-1, high=2**31 - 1)
    backend: str = parameter(
        "auto", "Per-reading math: numpy (the reference), numba (compiled, parallel over "
        "particles; the same results; needs the fast extra) or auto (numba when installed).",
        choices=BACKENDS)

    def validate(self) -> "FastSLAMConfig":
        """Raise ``ParameterValueError`` naming the bad field(s); return self when all are good.

        Each field's type and range come from its spec; the rules between fields follow, each
        naming every parameter it involves."""
        check_fields(self)

        def need(ok: bool, names: tuple[str, ...], rule: str) -> None:
            if not ok:
                got = ", ".join(f"{name} {getattr(self, name)!r}" for name in names)
                raise ParameterValueError(names, f"must be {rule} (got {got})")

        need(self.new_landmark_gate >= self.association_gate,
             ("association_gate", "new_landmark_gate"), "association_gate <= new_landmark_gate")
        need(self.min_range < self.max_range, ("min_range", "max_range"),
             "min_range < max_range")
        need(self.logodds_remove < self.logodds_observed, ("logodds_remove", "logodds_observed"),
             "logodds_remove < logodds_observed")
        need(self.logodds_remove < self.existence_evidence()[0],
             ("logodds_remove", "detection_probability", "clutter_rate"),
             "below the log-odds a detection gives (tau+)")
        need(self.fault_recovery_matches == 0 or self.fault_recovery_matches >= 3,
             ("fault_recovery_matches",), "0 (off) or at least 3")
        need(self.backend != "numba" or numba_available(), ("backend",),
             "numpy or auto when numba is not installed (pip install numba)")
        return self

    def existence_evidence(self) -> tuple[float, float]:
        """(tau+, tau-): the log-odds an observed and a missed landmark in view get, from
        ``detection_probability`` and ``clutter_rate`` when P_D > 0
        (``existence.detection_evidence``), else ``logodds_observed`` and ``logodds_missed``.

        The gate: the association's 99 % ellipse in (range, bearing) at the middle of the
        perceptual range, pi * 9.21 * sigma_r * sigma_b, over the range's area
        (max_range - min_range) * field_of_view."""
        if self.detection_probability <= 0.0:
            return self.logodds_observed, self.logodds_missed
        middle = 0.5 * (self.min_range + self.max_range)
        sigma_r = math.hypot(self.sigma_range, self.sigma_range_per_meter * middle)
        gate = math.pi * CHI2_99_2DOF * sigma_r * self.sigma_bearing
        view = (self.max_range - self.min_range) * self.field_of_view
        return detection_evidence(self.detection_probability, self.clutter_rate,
                                  min(gate / view, 1.0), LOGODDS_MAX)

    def confirmation(self) -> tuple[float, float]:
        """(l_c, tau- of a confirmed landmark): the log-odds from which a landmark is confirmed
        (``map_min_existence``) and what a miss costs it (``existence.confirmed_evidence``)."""
        if not (self.persistent_landmarks or self.keep_confirmed_landmarks):
            return math.inf, 0.0  # no landmark is treated as confirmed
        confirmed = confirmation_logodds(self.map_min_existence, self.logodds_remove)
        return confirmed, confirmed_evidence(self.existence_evidence()[1], confirmed,
                                             LOGODDS_MAX)

    def explained_gate(self) -> float:
        """Squared Mahalanobis distance within which a rejected observation explains a missed
        landmark (``existence.EXPLAINED_GATE``); -1 (never) without ``persistent_landmarks``."""
        return EXPLAINED_GATE if self.persistent_landmarks else -1.0

    def replace(self, **changes) -> "FastSLAMConfig":
        """A validated copy with some fields changed."""
        return dataclasses.replace(self, **changes).validate()


def numba_available() -> bool:
    """numba can be imported (the compiled backend's optional dependency)."""
    try:
        import numba  # noqa: F401, PLC0415
    except ImportError:
        return False
    return True
