# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Landmark-world simulator in the style of the classic FastSLAM simulator (Bailey et al.).

A car-like vehicle (bicycle model) follows waypoints at constant speed. Controls run at 40 Hz;
the published odometry integrates the *noisy* controls, so it drifts like wheel odometry.
Range-bearing observations of point landmarks come at 5 Hz and are published as
``/landmarks`` clouds (x, y in the sensor frame, the true landmark id as a label, -1 for
clutter). True poses and the landmark map are written as ground truth (bag schema v1).

Scenarios: ``loop`` (one closed loop through a landmark field, 3.5 minutes), ``large``
(thousands of landmarks, a long route with crossings), ``clutter`` (the loop with false
detections and missed detections), ``room`` (a differential-drive robot at walking speed in a
6 m x 6 m room with 17 tubes seen constantly for 20 minutes by an accurate laser 0.219 m ahead
of its centre that misses 40 % of them; the scenario sets its own defaults, ``ROOM_DEFAULTS``),
``faults`` (the room with odometry faults: commanded turns not executed, wheel slip),
``clusters`` (the loop with 210 landmarks in tight clusters of 2-3, as MRCLAM's stand).
The vehicles, the sensor and the landmark placement are those of ``simulation/world.py``,
which the in-memory test worlds share.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fastslam_ros.tools import cli
from fastslam_ros.tools.simulation import laser_sim
from fastslam_ros.tools.bags.bag_schema import (LandmarkScans, LandmarkSet, PoseSeries, SchemaBag,
                                           write_schema_bag)
from fastslam_ros.output import check_output, write_params_yaml
from fastslam_ros.tools.datasets.converters import polar_to_points
from fastslam_ros.tools.simulation.world import (Car, DifferentialDrive, OdometryFaults,
                                                 RangeBearingSensor, distance_to_route,
                                                 scatter_landmarks)

SCENARIOS = ("loop", "large", "clutter", "room", "faults", "clusters")
LOOP_WAYPOINTS = ((0.0, 0.0), (84.0, 0.0), (140.0, 28.0), (161.0, 84.0), (133.0, 133.0),
                  (63.0, 147.0), (0.0, 119.0), (-28.0, 63.0), (-21.0, 17.0))
"""The loop scenario's route (m); the vehicle starts at the first point heading to the second."""
LARGE_WAYPOINTS = ((0.0, 0.0), (0.0, 300.0), (100.0, 300.0), (100.0, 0.0), (200.0, 0.0),
                   (200.0, 300.0), (300.0, 300.0), (300.0, 0.0), (400.0, 0.0), (400.0, 150.0),
                   (0.0, 150.0))
"""The large scenario's route (m): a 400 m x 300 m meander, then a leg across every column."""
ROOM_WAYPOINTS = ((1.0, 1.0), (5.0, 1.2), (4.8, 5.0), (3.0, 2.8), (1.2, 5.0))
"""The room scenario's route (m), inside the room's walls at 0 and ``ROOM_SIZE``."""
ROOM_SIZE = 6.0
"""Side of the room scenario's square room (m)."""
ROOM_CLEARANCE = 0.5
"""Smallest distance (m) of a room scenario's tube from the route and from the walls."""
ROOM_DEFAULTS = {
    "speed": 1.0, "control_rate": 40.0, "observation_rate": 10.0, "max_range": 5.6,
    "min_range": 0.4, "field_of_view": 4.2, "sigma_range": 0.03, "sigma_bearing": 0.026,
    "sigma_speed": 0.05, "sigma_turn_rate": 0.1, "waypoint_radius": 0.2, "laps": 1000,
    "num_landmarks": 17, "min_separation": 0.8, "detection_probability": 0.6,
    "clutter_rate": 0.0, "duration": 1200.0, "sensor_x": 0.219, "sensor_frame": "laser",
    "landmark_radius": 0.1}
"""The room scenario's settings where the command line leaves a field at its default: a lab
robot's laser ranging tubes (about 5 detections per reading at 10 Hz for 20 minutes)."""
FAULTS_DEFAULTS = {"turn_faults": 2.0, "slip_faults": 2.0, "duration": 600.0}
"""The faults scenario: the room for 10 minutes, with odometry faults (two episodes of each
kind a minute)."""
ROOM_SCENARIOS = ("room", "faults")
"""Scenarios of the lab robot in the room (a differential drive)."""
CLUSTER_SIZES = (2, 3)
"""Landmarks per cluster of the clusters scenario (each cluster draws one)."""
CLUSTER_SPREAD = (0.18, 0.25)
"""Range (m) of a cluster member's distance from the cluster's first landmark: MRCLAM's
barcode tubes stand in clusters 0.18-0.25 m apart, which a sensor with decimetres of range
noise cannot tell apart from a few metres."""
CLUSTER_MIN_ANGLE = math.radians(60.0)
"""Smallest angle (rad) between two members seen from the first, so that the members of a
cluster of three are at least ``CLUSTER_SPREAD[0]`` apart."""
HEADING_NOISE_INFLATION = 10.0
"""Variance factor on the heading noise of the recommended parameters (see recommended_params)."""
TRANSLATION_NOISE_INFLATION = 2.0
"""Variance factor on the translation noise of the recommended parameters."""
LOOP_CLOSURE_MATCHES = 2
"""``loop_closure_matches`` of the recommended parameters: old landmarks that must agree on a
particle's correction before a loop closes (see recommended_params)."""
FAULT_RECOVERY_MATCHES = 3
"""``fault_recovery_matches`` of the recommended parameters when turns are not made
(``turn_faults``): the faults scenario, seeds 1-5, 3.54 / 3.63 -> 0.296 / 0.371 m with its
recommended file (docs/benchmarks.md)."""
DENSE_IN_RANGE = 30.0
"""Landmarks within sensor range, on average along the route (``landmarks_in_range``), above
which a world is recommended neither loop closure nor the smoother. The large world (52: 2,000
landmarks over 400 m x 300 m) closed false loops, as the drift-widened gate of a loop closure
holds several old landmarks there and two chance agreements close; and the smoother's solves
space out to 15-30 s on its long log, where its estimate is worse than the filter's (seeds
1-2: 0.486 / 0.496 m against 0.347 / 0.266; docs/benchmarks.md, the large world). The loop
(8) and the clusters world (20) close true loops with both."""
SMOOTHING_PERIOD = 2.0
"""``smoothing_period`` of the recommended parameters, except in the room scenarios (the
filter alone is at the reference there; with odometry faults the smoother follows the
odometry's turns): default world 0.410 / 0.612 -> 0.219 / 0.223 m, clutter world 0.398 /
0.620 -> 0.360 / 0.437 (docs/benchmarks.md)."""


def setting(default: float | int | str, help_text: str):
    """A dataclass field with its ``--help`` text."""
    return field(default=default, metadata={"help": help_text})


@dataclass(frozen=True)
class SimConfig:
    """Every setting of a simulation (SI units, radians)."""

    scenario: str = "loop"
    seed: int = setting(0, "Seed of the control, measurement and clutter noise.")
    world_seed: int = setting(0,
        "Seed of the landmark layout (kept apart so that noise seeds share one world).")
    speed: float = setting(3.0, "Commanded forward speed (m/s).")
    wheelbase: float = setting(4.0, "Distance between the axles (m).")
    max_steer: float = setting(math.radians(30.0), "Steering angle limit (rad).")
    max_steer_rate: float = setting(math.radians(20.0), "Steering rate limit (rad/s).")
    waypoint_radius: float = setting(1.0, "A waypoint is reached within this distance (m).")
    control_rate: float = setting(40.0,
        "Control and odometry rate (Hz); ground truth is published at the same rate.")
    observation_rate: float = setting(5.0, "Sensor reading rate (Hz).")
    max_range: float = setting(30.0, "Landmarks farther than this are not observed (m).")
    min_range: float = setting(0.0, "Landmarks nearer than this are not observed (m).")
    landmark_radius: float = setting(0.0,
        "Radius of the landmarks (m): a detection is the point of the surface facing the "
        "sensor, nearer than the centre by the radius (a bias no sensor model states).")
    sensor_x: float = setting(0.0, "Sensor position ahead of the vehicle's origin (m).")
    field_of_view: float = setting(2.0 * math.pi,
        "Full opening angle of the sensor, centred on the heading (rad); 2 pi sees all around.")
    sigma_range: float = setting(0.1, "Range noise standard deviation (m).")
    sigma_bearing: float = setting(math.radians(1.0), "Bearing noise standard deviation (rad).")
    sigma_speed: float = setting(0.3,
        "Speed control noise standard deviation per control step (m/s).")
    sigma_steer: float = setting(math.radians(3.0),
        "Steering control noise standard deviation per control step (rad).")
    max_turn_rate: float = setting(1.0, "Turn rate limit of the differential drive (rad/s).")
    sigma_turn_rate: float = setting(0.0,
        "Turn-rate control noise standard deviation per control step of the differential "
        "drive (rad/s).")
    laps: int = setting(1,
        "Times the route is driven; the vehicle then continues to the route's second point, so the "
        "loop is closed over ground already mapped.")
    num_landmarks: int = setting(0, "Landmarks in the world; 0 picks the scenario's default.")
    min_separation: float = setting(4.0, "Smallest distance between two landmarks (m).")
    detection_probability: float = setting(-1.0,
        "Probability that a landmark in range is detected; -1 picks the scenario's default.")
    clutter_rate: float = setting(-1.0,
        "Mean number of false detections per reading (Poisson, uniform in range); -1 picks the "
        "scenario's default.")
    duration: float = setting(0.0, "Stop after this many seconds (0: drive the whole route).")
    turn_faults: float = setting(0.0,
        "Episodes per minute in which the differential drive does not execute its commanded "
        "turn while its odometry reports it (room and faults scenarios).")
    slip_faults: float = setting(0.0,
        "Episodes per minute in which the differential drive's wheels slip: it covers 0.3 of "
        "the distance its odometry reports (room and faults scenarios).")
    fault_duration: float = setting(1.0, "Length of a turn or slip episode (s).")
    sensor_frame: str = setting("base_link",
        "frame_id of the landmark clouds (the sensor sits sensor_x ahead of the vehicle's "
        "origin).")
    start_time: float = setting(1_700_000_000.0,
        "Stamp of the first message (s since the Unix epoch): a date, as a recording has, so "
        "viewers and tools that expect one show the bag as they would a real one.")

    def resolved(self) -> "SimConfig":
        """A copy with the scenario's defaults filled in and every value checked."""
        if self.scenario not in SCENARIOS:
            raise ValueError(f"scenario: must be one of {SCENARIOS} (got {self.scenario!r})")
        defaults = {"loop": (85, 1.0, 0.0), "large": (2000, 1.0, 0.0),
                    "clutter": (85, 0.9, 2.0), "room": (17, 0.6, 0.0),
                    "faults": (17, 0.6, 0.0), "clusters": (210, 1.0, 0.0)}[self.scenario]
        config = self
        if self.scenario in ROOM_SCENARIOS:
            unset = {item.name: item.default for item in dataclasses.fields(SimConfig)}
            scenario_defaults = {**ROOM_DEFAULTS,
                                 **(FAULTS_DEFAULTS if self.scenario == "faults" else {})}
            config = dataclasses.replace(self, **{
                name: value for name, value in scenario_defaults.items()
                if getattr(self, name) == unset[name]})
        config = dataclasses.replace(
            config,
            num_landmarks=self.num_landmarks or defaults[0],
            detection_probability=(defaults[1] if self.detection_probability < 0
                                   else self.detection_probability),
            clutter_rate=defaults[2] if self.clutter_rate < 0 else self.clutter_rate)
        for name in ("speed", "wheelbase", "max_steer", "max_steer_rate", "waypoint_radius",
                     "control_rate", "observation_rate", "max_range", "sigma_range",
                     "sigma_bearing", "min_separation", "max_turn_rate"):
            if not getattr(config, name) > 0.0:
                raise ValueError(f"{name}: must be > 0 (got {getattr(config, name)})")
        for name in ("sigma_speed", "sigma_steer", "sigma_turn_rate", "duration", "start_time",
                     "turn_faults", "slip_faults", "fault_duration",
                     "min_range", "landmark_radius"):
            if getattr(config, name) < 0.0:
                raise ValueError(f"{name}: must be >= 0 (got {getattr(config, name)})")
        if not 0.0 < config.field_of_view <= 2.0 * math.pi:
            raise ValueError("field_of_view: must be in (0, 2 pi]")
        if config.min_range >= config.max_range:
            raise ValueError("min_range: must be < max_range")
        if not 0.0 < config.detection_probability <= 1.0:
            raise ValueError("detection_probability: must be in (0, 1]")
        if config.laps < 1:
            raise ValueError("laps: must be >= 1")
        steps_per_reading = config.control_rate / config.observation_rate
        if abs(steps_per_reading - round(steps_per_reading)) > 1e-9:
            raise ValueError("observation_rate: must divide control_rate")
        return config


@dataclass
class World:
    """The route and the landmarks of a scenario (a landmark's id is its row)."""

    waypoints: np.ndarray
    landmarks: LandmarkSet


def build_world(config: SimConfig) -> World:
    """The scenario's route and a landmark field around it (seeded by ``world_seed``)."""
    rng = np.random.default_rng(config.world_seed)
    if config.scenario in ROOM_SCENARIOS:
        return build_room(config, rng)
    waypoints = np.array(LARGE_WAYPOINTS if config.scenario == "large" else LOOP_WAYPOINTS)
    # Every landmark is within sensor range of some point of the route, off the road itself.
    near, far = 2.0, min(25.0, 0.9 * config.max_range)

    def beside_route(points: np.ndarray) -> np.ndarray:
        distance = distance_to_route(points, waypoints)
        return (distance >= near) & (distance <= far)
    clustered = config.scenario == "clusters"
    sizes = (cluster_sizes(rng, config.num_landmarks) if clustered
             else np.ones(config.num_landmarks, np.int64))
    positions = scatter_landmarks(rng, len(sizes), waypoints.min(axis=0) - far,
                                  waypoints.max(axis=0) + far, config.min_separation,
                                  beside_route)
    if clustered:
        positions = cluster_members(rng, positions, sizes)
    return World(waypoints, LandmarkSet(positions, np.arange(len(positions), dtype=np.int32)))


def cluster_sizes(rng: np.random.Generator, count: int) -> np.ndarray:
    """Sizes (2 or 3 each, ``CLUSTER_SIZES``) of clusters that hold ``count`` (> 1) landmarks
    in all: the last ones are cut to fit, never to a single landmark."""
    sizes = rng.choice(CLUSTER_SIZES, size=count)
    sizes = sizes[:int(np.searchsorted(np.cumsum(sizes), count)) + 1]
    sizes[-1] -= int(sizes.sum()) - count
    if sizes[-1] == 1:  # 3 + 1 -> 2 + 2, 2 + 1 -> 3
        sizes = np.append(sizes[:-2], [2, 2] if sizes[-2] == 3 else [3])
    return sizes


def cluster_members(rng: np.random.Generator, firsts: np.ndarray,
                    sizes: np.ndarray) -> np.ndarray:
    """(sum(sizes), 2) landmarks: each first landmark (C, 2) and its cluster's other members,
    ``CLUSTER_SPREAD`` from it, ``CLUSTER_MIN_ANGLE`` or more apart as seen from it."""
    members = []
    for first, size in zip(firsts, sizes):
        members.append(first)
        angle = rng.uniform(-math.pi, math.pi)
        for _ in range(int(size) - 1):
            radius = rng.uniform(*CLUSTER_SPREAD)
            members.append(first + radius * np.array([math.cos(angle), math.sin(angle)]))
            angle += rng.uniform(CLUSTER_MIN_ANGLE, math.pi)
    return np.array(members)


def build_room(config: SimConfig, rng: np.random.Generator) -> World:
    """The room scenario: its route and tubes anywhere in the room ``ROOM_CLEARANCE`` from the
    route and the walls."""
    waypoints = np.array(ROOM_WAYPOINTS)

    def off_route(points: np.ndarray) -> np.ndarray:
        return distance_to_route(points, waypoints) >= ROOM_CLEARANCE
    positions = scatter_landmarks(rng, config.num_landmarks, ROOM_CLEARANCE,
                                  ROOM_SIZE - ROOM_CLEARANCE, config.min_separation, off_route)
    return World(waypoints, LandmarkSet(positions, np.arange(len(positions), dtype=np.int32)))


def simulate(config: SimConfig, world: World | None = None) -> SchemaBag:
    """Drive the scenario's route and return the schema bag (odometry, scans, ground truth);
    ``world``: ``build_world(config)``'s, when the caller has it."""
    config = config.resolved()
    world = build_world(config) if world is None else world
    # Separate streams: the odometry noise does not change with the sensor settings or the world.
    control_rng = np.random.default_rng([config.seed, 0])
    sensor_rng = np.random.default_rng([config.seed, 1])
    faults = (OdometryFaults(config.turn_faults, config.slip_faults, config.fault_duration)
              if config.turn_faults > 0.0 or config.slip_faults > 0.0 else None)
    vehicle = (DifferentialDrive(config.speed, config.max_turn_rate, config.waypoint_radius,
                                 config.sigma_speed, config.sigma_turn_rate, faults=faults)
               if config.scenario in ROOM_SCENARIOS else
               Car(config.speed, config.wheelbase, config.max_steer, config.max_steer_rate,
                   config.waypoint_radius, config.sigma_speed, config.sigma_steer))
    true_poses, odometry_poses = vehicle.drive(world.waypoints, config.laps,
                                               config.control_rate, control_rng, config.duration)
    sensor = RangeBearingSensor(config.max_range, config.sigma_range, config.sigma_bearing,
                                config.detection_probability, config.clutter_rate,
                                field_of_view=config.field_of_view, min_range=config.min_range,
                                landmark_radius=config.landmark_radius)
    # The sensor's poses: sensor_x ahead of the vehicle's origin, facing forward.
    sensor_poses = true_poses + config.sensor_x * np.column_stack(
        [np.cos(true_poses[:, 2]), np.sin(true_poses[:, 2]), np.zeros(len(true_poses))])
    steps_per_reading = int(round(config.control_rate / config.observation_rate))
    reading_steps = np.arange(steps_per_reading, len(true_poses), steps_per_reading)
    readings = [sensor.observe(sensor_poses[step], world.landmarks.positions, sensor_rng)
                for step in reading_steps]
    stamps = config.start_time + np.arange(len(true_poses)) / config.control_rate
    return SchemaBag(
        odometry=PoseSeries(stamps, odometry_poses, "odom", "base_link"),
        scans=LandmarkScans(stamps[reading_steps],
                            [polar_to_points(r.ranges, r.bearings).astype(np.float32)
                             for r in readings],
                            [r.labels.astype(np.int32) for r in readings],
                            config.sensor_frame),
        ground_truth=PoseSeries(stamps, true_poses, "map", "base_link"),
        landmarks_truth=world.landmarks)


# ---------------------------------------------------------------- filter settings


def landmarks_in_range(world: World, max_range: float, spacing: float = 5.0) -> float:
    """Mean number of landmarks within ``max_range`` (m) of the route's points, taken every
    ``spacing`` m along the closed route: how many a full-turn sensor holds at a time."""
    route = np.vstack([world.waypoints, world.waypoints[:1]])
    points = []
    for start, end in zip(route[:-1], route[1:]):
        length = float(np.linalg.norm(end - start))
        points.append(start + (end - start) * (np.arange(0.0, length, spacing) / length)[:, None])
    offsets = np.concatenate(points)[:, None, :] - world.landmarks.positions[None]
    return float(np.mean(np.count_nonzero(np.hypot(offsets[..., 0], offsets[..., 1])
                                          <= max_range, axis=1)))


def recommended_params(config: SimConfig, world: World | None = None
                       ) -> dict[str, float | int | str]:
    """Node parameters matched to the simulated sensor and control noise (``world``:
    ``build_world(config)``'s, when the caller has it).

    The motion-noise alphas start from the control noise accumulated over one observation
    interval (per-step speed and steering noise integrated through the bicycle model, or the
    turn-rate noise of the differential drive), divided by the squared distance travelled in
    it. The heading term is inflated 10x and the
    translation term 2x: with the exact values the particles are too concentrated to close the
    loop on some seeds (landmarks seen at the start are mapped again), which the inflation
    mostly cures. The landmarks that still come back outside the gate close the loop once two
    of them agree on one rigid correction (``loop_closure_matches``; not in the dense worlds,
    ``DENSE_IN_RANGE``, which get neither it nor the smoother). The pose output is the
    particles' weighted mean, which does not jump between hypotheses as the best particle
    does. Markers, path and particles are published at 0.2, 0.2 and 1 Hz of bag time. A
    sensor that misses landmarks without clutter states its detection probability (the
    existence log-odds follow from it); with clutter, fixed log-odds remove unconfirmed
    landmarks sooner. Odometry that reports turns not made gets the fault recovery
    (``fault_recovery_matches``).
    """
    config = config.resolved()
    world = build_world(config) if world is None else world
    dense = landmarks_in_range(world, config.max_range) > DENSE_IN_RANGE
    dt = 1.0 / config.control_rate
    steps = config.control_rate / config.observation_rate
    travel = config.speed * steps * dt
    translation_variance = steps * (config.sigma_speed * dt) ** 2
    heading_variance = steps * (config.speed * dt * config.sigma_steer / config.wheelbase) ** 2
    if config.scenario in ROOM_SCENARIOS:
        heading_variance = steps * (config.sigma_turn_rate * dt) ** 2
    params: dict[str, float | int | str] = {
        "sigma_range": config.sigma_range,
        "sigma_bearing": config.sigma_bearing,
        "max_range": config.max_range,
        "alpha1": 0.01,
        "alpha2": HEADING_NOISE_INFLATION * heading_variance / travel**2,
        "alpha3": TRANSLATION_NOISE_INFLATION * translation_variance / travel**2,
        "alpha4": 0.001,
        "pose_estimate": "mean",
        "loop_closure_matches": 0 if dense else LOOP_CLOSURE_MATCHES,
        # Replays run many times faster than real time: throttle the heavy outputs harder
        # than the live defaults (the final map and path are always published).
        "markers_rate": 0.2,
        "path_rate": 0.2,
        "particles_rate": 1.0,
    }
    if config.field_of_view < 2.0 * math.pi:
        params["field_of_view"] = config.field_of_view
    if config.min_range > 0.0:
        params["min_range"] = config.min_range
    if config.sensor_x != 0.0:
        params["sensor_x"] = config.sensor_x
    if config.scenario in ROOM_SCENARIOS:  # a few landmarks seen constantly (docs/benchmarks.md)
        params["persistent_landmarks"] = True
    elif not dense:
        params["smoothing_period"] = SMOOTHING_PERIOD
    if config.turn_faults > 0.0:
        params["fault_recovery_matches"] = FAULT_RECOVERY_MATCHES
    if config.clutter_rate > 0.0:
        params.update(logodds_observed=1.0, logodds_missed=-0.4, logodds_remove=-0.9)
    elif config.detection_probability < 1.0:
        # Without clutter the existence evidence follows from P_D alone (a detection is
        # certain, a miss in view log(1 - P_D)).
        params.update(detection_probability=config.detection_probability, logodds_remove=-0.9)
    return {name: float(value) if isinstance(value, (float, np.floating)) else value
            for name, value in params.items()}


# ---------------------------------------------------------------- command line


def build_parser() -> argparse.ArgumentParser:
    """The ``fastslam-sim`` argument parser (every SimConfig field is a flag)."""
    defaults = SimConfig()
    parser = cli.parser("fastslam-sim", __doc__, first_paragraph=True)
    parser.add_argument("--scenario", choices=SCENARIOS, default=defaults.scenario,
                        help="world and route (room: flags left at their default take the "
                             "room's: 1 m/s, 10 Hz, 0.4-5.6 m, 4.2 rad, 0.03 m, 0.026 rad, "
                             "sensor 0.219 m ahead, 17 tubes of 0.1 m radius, P_D 0.6, 1200 s; "
                             "faults: the room with 2 turn and 2 slip faults a minute, 600 s)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output bag folder (default: sim_<scenario>)")
    parser.add_argument("--params-out", type=Path, default=None,
                        help="recommended node parameters for this bag (default: <out>.yaml)")
    parser.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap",
                        help="bag storage format")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output")
    parser.add_argument("--laser", action="store_true",
                        help="also write /scan: a 270-degree laser ray cast against the "
                             "landmarks as poles (some reflective), walls and parked cars "
                             "(tools/simulation/laser_sim.py)")
    parser.add_argument("--laser-people", type=int, default=0, metavar="N",
                        help="with --laser: N people (bodies of 0.2 m radius, as wide as a "
                             "trunk) pacing at 1.2 m/s 2-6 m beside the route, clutter the "
                             "extractor cannot tell from a pole in one scan")
    parser.add_argument("--sweep", action="store_true",
                        help="with --laser: beams taken one after the other as the mirror "
                             "turns (a full turn per reading), each from where the vehicle is "
                             "then; LaserScan's time_increment says how far apart")
    parser.add_argument("--mixed-pixels", type=cli.probability, default=0.0, metavar="P",
                        help="with --laser: probability that a beam at a depth edge returns "
                             "a range between the two surfaces, in free space (a real "
                             "laser's mixed pixels)")
    for item in dataclasses.fields(SimConfig):
        if item.name == "scenario":
            continue
        flag = "--" + item.name.replace("_", "-")
        help_text = item.metadata["help"]
        if item.name in ("max_steer", "max_steer_rate", "sigma_bearing", "sigma_steer"):
            # %(default) in the text: the formatter then adds no second default.
            help_text += f" (default: %(default).6g = {math.degrees(item.default):g} deg)"
        parser.add_argument(flag, dest=item.name, type=type(item.default), default=item.default,
                            help=help_text)
    return parser


@cli.interruptible("fastslam-sim")
def main(argv: list[str] | None = None) -> int:
    """``fastslam-sim``: simulate a scenario and write a schema-v1 bag plus its parameter file."""
    arguments = sys.argv[1:] if argv is None else list(argv)
    if "people" in (arguments[i + 1] for i, a in enumerate(arguments[:-1]) if a == "--scenario") \
            or "--scenario=people" in arguments:
        from fastslam_ros.tools.simulation import people_sim
        return people_sim.main(arguments)
    args = build_parser().parse_args(argv)
    values = {item.name: getattr(args, item.name) for item in dataclasses.fields(SimConfig)}
    try:
        config = SimConfig(**values).resolved()
        if args.sweep and not args.laser:
            raise ValueError("--sweep: only with --laser")
        if args.laser_people < 0:
            raise ValueError(f"--laser-people: must be >= 0 (got {args.laser_people})")
        if args.mixed_pixels and not args.laser:
            raise ValueError("--mixed-pixels: only with --laser")
    except ValueError as error:
        return cli.fail("fastslam-sim", error, cli.EXIT_USAGE)
    out = args.out or Path(f"sim_{config.scenario}")
    params_out = args.params_out or out.with_name(out.name + ".yaml")
    try:
        cli.output_folder(out, "--out")
        cli.output_file(params_out, "--params-out")
        check_output(out, args.overwrite, "bag")  # both outputs checked before either is written
        check_output(params_out, args.overwrite, "file", inputs=[out])
        world = build_world(config)
        bag = simulate(config, world)
        extra = (laser_sim.scan_records(config, world, bag, people=args.laser_people,
                                        sweep=args.sweep, mixed_pixels=args.mixed_pixels)
                 if args.laser else ())
        write_schema_bag(out, bag, storage=args.storage, overwrite=args.overwrite, extra=extra)
        write_params_yaml(params_out, recommended_params(config, world),
                          f"Recommended fastslam parameters for {out.name} "
                          f"(fastslam-sim --scenario {config.scenario} --seed {config.seed}).",
                          overwrite=args.overwrite)
    except (cli.UsageError, ValueError, OSError) as error:
        return cli.fail("fastslam-sim", error)
    duration = bag.odometry.stamps[-1] - bag.odometry.stamps[0]
    detections = sum(len(ids) for ids in bag.scans.ids)
    print(f"wrote {out}: {config.scenario}, {duration:.1f} s, {len(bag.odometry.stamps)} odometry, "
          f"{len(bag.scans.stamps)} scans ({detections} detections), "
          f"{len(bag.landmarks_truth.ids)} landmarks; parameters in {params_out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
