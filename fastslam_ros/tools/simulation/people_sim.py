# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""People simulator: rooms and corridors on a grid, a robot with a 2-D laser, people walking.

A 20 m x 20 m floor (five rooms off a corridor open at both ends, furniture) as a 0.05 m
evidence grid. The robot drives a route through the corridor and into the rooms at 0.5 m/s,
standing while a person is in its path (who then steps aside);
its wheel odometry integrates noisy, slightly biased velocities at 50 Hz. A 360-beam laser at
10 Hz (range noise 0.02 m, no return beyond ``max_range``) is ray cast against the walls and
against the people, cylinders of radius 0.2 m that occlude each other. Five people walk a graph
of corridor, door and room points at their own speeds, stop for a while, and leave by the
corridor's ends; whoever left is replaced, after a pause, by a new person (a new id) entering
there once the way is clear. People are solid: they keep PERSONAL_DISTANCE apart and off the
walls, step aside to pass each other and yield rather than block. The floor and the people are
``tools/simulation/crowd.py``; this module drives the robot, casts the scans and writes the bag.

The bag holds schema v1's ``/odom`` and ``/ground_truth/pose`` plus ``/map``
(``nav_msgs/OccupancyGrid``, one message), ``/scan`` (``sensor_msgs/LaserScan``, frame
``laser`` at the base origin), ``/ground_truth/people`` (``sensor_msgs/PointCloud2`` in
``map``: x y z float32, id int32, every person in the world, at every scan) and, unless
``--no-initial-pose``, one ``/initialpose`` (the true start pose, as RViz would send it).
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fastslam_ros.core.geometry import wrap_angle
from fastslam_ros.people.grid import OccupancyMap
from fastslam_ros.tools.simulation.crowd import PERSON_RADIUS, Crowd, build_map
from fastslam_ros.tools.simulation.people_legs import circle_ranges
from fastslam_ros.tools.bags.bag_schema import (INITIAL_POSE_TOPIC, MAP_TOPIC,
                                           PEOPLE_TRUTH_TOPIC, SCAN_TOPIC, TYPESTORE,
                                           LandmarkScans, PoseSeries, SchemaBag, stamp_to_ns,
                                           write_schema_bag, yaw_to_quaternion)
from fastslam_ros.tools import cli
from fastslam_ros.output import check_output, write_params_yaml

PEOPLE_CLOUD_DTYPE = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<i4")])
ROUTE = ((2.0, 10.0), (9.0, 10.0), (10.0, 8.8), (10.0, 6.0), (8.5, 5.5), (10.0, 8.8),
         (15.0, 10.0), (15.0, 13.0), (14.0, 15.5), (15.0, 12.8), (16.6, 10.0), (18.0, 10.0),
         (16.6, 9.0), (16.6, 5.0), (16.6, 9.0), (8.0, 10.3), (4.6, 11.0), (4.6, 14.5),
         (6.0, 16.0), (4.6, 12.5), (2.0, 10.0))
"""The robot's route (m), driven in a loop; it starts at the first point facing the second."""
ROBOT_PATIENCE = 1.0
"""The robot stands for a person in its path (``Crowd.in_the_way``); after this long (s) the
people there step aside (``Crowd.make_way``)."""


@dataclass(frozen=True)
class PeopleSimConfig:
    """Every setting of a people simulation (SI units, radians)."""

    seed: int = 1
    duration: float = 120.0
    people: int = 5
    start_time: float = 1_700_000_000.0
    """Stamp of the first message (s since the Unix epoch): a date, as a recording has (as
    ``SimConfig.start_time``)."""
    beams: int = 360
    field_of_view: float = 2.0 * math.pi
    """The laser's span (rad), centred ahead; 2 pi: a full turn."""
    scan_rate: float = 10.0
    odometry_rate: float = 50.0
    max_range: float = 12.0
    range_noise: float = 0.02
    speed: float = 0.5
    max_turn_rate: float = 0.8
    speed_noise: float = 0.05
    """Standard deviation of the odometry's speed per step (m/s)."""
    turn_noise: float = 0.05
    """Standard deviation of the odometry's turn rate per step (rad/s)."""
    speed_bias: float = 0.02
    """Relative error of the odometry's speed scale."""
    turn_bias: float = 0.01
    """Turn rate error of the odometry (rad/s per rad/s)."""
    yaw_rate_bias: float = 0.0
    """Constant error of the odometry's turn rate (rad/s): it reports a turn while the robot
    goes straight or stands, as uneven wheels or a gyro's offset do."""
    initial_pose: bool = True
    """Write ``/initialpose`` (the true start pose); without it the tracker localizes globally."""
    legs: bool = False
    """The real-laser world (``people_legs``): people as two swinging legs, tables and chairs
    on thin legs in the map, people walking close to walls and furniture."""
    mixed_pixels: float = 0.0
    """Probability that a beam at a depth edge returns a mixed pixel (``mix_edges``)."""
    sweep: bool = False
    """A laser whose beams are taken one after the other as its mirror turns (a full turn per
    scan period, ``time_increment`` apart), each from where the robot is then, as a real
    laser's are; False: every beam at the scan's stamp."""

    @property
    def time_increment(self) -> float:
        """Seconds between two beams (``LaserScan.time_increment``; 0 without ``sweep``)."""
        return (sweep_time_increment(self.field_of_view / self.beams, self.scan_rate)
                if self.sweep else 0.0)

    def validate(self) -> "PeopleSimConfig":
        for name in ("duration", "scan_rate", "odometry_rate", "max_range", "speed",
                     "max_turn_rate"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name}: must be > 0 (got {getattr(self, name)})")
        for name in ("range_noise", "speed_noise", "turn_noise"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"{name}: must be >= 0 (got {getattr(self, name)})")
        if not math.isfinite(self.yaw_rate_bias):
            raise ValueError(f"yaw_rate_bias: must be finite (got {self.yaw_rate_bias})")
        if not 0.0 <= self.mixed_pixels <= 1.0:
            raise ValueError(f"mixed_pixels: must be in [0, 1] (got {self.mixed_pixels})")
        if self.people < 0 or self.beams < 8:
            raise ValueError("people: must be >= 0 and beams >= 8")
        if not 0.0 < self.field_of_view <= 2.0 * math.pi:
            raise ValueError(f"field_of_view: must be in (0, 2 pi] (got {self.field_of_view})")
        ratio = self.odometry_rate / self.scan_rate
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError("scan_rate: must divide odometry_rate")
        return self


# ---------------------------------------------------------------- robot and laser

MIXED_PIXEL_JUMP = 0.3
"""A depth edge: neighbouring beams whose true ranges differ by more than this (m)."""


def mix_edges(ranges: np.ndarray, probability: float, rng: np.random.Generator) -> np.ndarray:
    """Ranges (B,) with mixed pixels: at each depth edge (neighbours more than MIXED_PIXEL_JUMP
    apart, both returning), with ``probability``, the nearer beam's spot straddles both
    surfaces and returns a range drawn uniformly between them, in free space (as a real
    laser's does at an object's silhouette)."""
    ranges = ranges.copy()
    near, far = ranges[:-1], ranges[1:]
    with np.errstate(invalid="ignore"):  # inf - inf where neither beam returns
        edge = np.flatnonzero(np.isfinite(near) & np.isfinite(far)
                              & (np.abs(far - near) > MIXED_PIXEL_JUMP))
    edge = edge[rng.random(len(edge)) < probability]
    beam = np.where(ranges[edge] < ranges[edge + 1], edge, edge + 1)
    low = np.minimum(ranges[edge], ranges[edge + 1])
    high = np.maximum(ranges[edge], ranges[edge + 1])
    ranges[beam] = low + rng.random(len(edge)) * (high - low)
    return ranges


def cast_scan(grid: OccupancyMap, sensor: np.ndarray, angles: np.ndarray, people: np.ndarray,
              max_range: float) -> np.ndarray:
    """True ranges (B,) from ``sensor`` (x, y, theta), or one sensor pose per beam (B, 3),
    against the walls and people (K, 2) (cylinders of PERSON_RADIUS); inf where nothing is
    hit within ``max_range``."""
    world = sensor[..., 2] + angles
    ranges = grid.cast(np.broadcast_to(sensor[..., :2], (len(angles), 2)), world, max_range)
    ranges = np.minimum(ranges, circle_ranges(sensor, world, people, PERSON_RADIUS))
    return np.where(ranges <= max_range, ranges, np.inf)


def sweep_time_increment(angle_increment: float, scan_rate: float) -> float:
    """Seconds between two beams ``angle_increment`` (rad) apart of a laser whose mirror
    turns once per scan (``scan_rate`` Hz)."""
    return abs(angle_increment) / (2.0 * math.pi * scan_rate)


def sweep_poses(pose: np.ndarray, speed: float, turn: float, beams: int,
                time_increment: float) -> np.ndarray:
    """(B, 3) poses of a robot at ``pose`` driving at ``speed`` (m/s) and ``turn`` (rad/s),
    ``time_increment`` s apart from the first beam on (a unicycle: exact arcs)."""
    t = np.arange(beams) * time_increment
    heading = pose[2] + turn * t
    if abs(turn) > 1e-9:
        x = pose[0] + speed / turn * (np.sin(heading) - math.sin(pose[2]))
        y = pose[1] - speed / turn * (np.cos(heading) - math.cos(pose[2]))
    else:
        x, y = pose[0] + speed * t * math.cos(pose[2]), pose[1] + speed * t * math.sin(pose[2])
    return np.stack([x, y, heading], axis=1)


@dataclass
class PeopleRun:
    """A simulated run as arrays, before it becomes a bag."""

    grid: OccupancyMap
    odometry: PoseSeries
    truth: PoseSeries
    scan_stamps: np.ndarray
    scans: list[np.ndarray]
    angles: np.ndarray
    people_stamps: np.ndarray
    people: list[tuple[np.ndarray, np.ndarray]]
    """Per scan: ids (K,) and positions (K, 2) of the people in the world."""


def simulate_people(config: PeopleSimConfig) -> PeopleRun:
    """Drive the route for ``duration`` s among the people; return the run."""
    config = config.validate()
    grid = build_map()
    rng_world = np.random.default_rng([config.seed, 0])
    rng_odometry = np.random.default_rng([config.seed, 1])
    rng_laser = np.random.default_rng([config.seed, 2])
    rng_edges = np.random.default_rng([config.seed, 3])
    world = None
    if config.legs:
        from fastslam_ros.tools.simulation.people_legs import LATERAL, LegWorld
        world = LegWorld(grid)
        grid = world.map
        crowd = Crowd(config.people, rng_world, grid, world.walkable, LATERAL)
    else:
        crowd = Crowd(config.people, rng_world, grid)
    dt = 1.0 / config.odometry_rate
    per_scan = int(round(config.odometry_rate / config.scan_rate))
    route = np.array(ROUTE)
    pose = np.array([route[0, 0], route[0, 1],
                     math.atan2(route[1, 1] - route[0, 1], route[1, 0] - route[0, 0])])
    odometry = np.zeros(3)
    target = 1
    standing = 0.0
    angles = -0.5 * config.field_of_view + (np.arange(config.beams) + 0.5) * (
        config.field_of_view / config.beams)
    stamps, true_poses, odometry_poses = [], [], []
    scan_stamps, scans, people = [], [], []
    steps = int(round(config.duration * config.odometry_rate))
    for step in range(steps + 1):
        t = step * dt  # time since the start; the stamps are start_time + t
        stamps.append(config.start_time + t)
        true_poses.append(pose.copy())
        odometry_poses.append(odometry.copy())
        # unicycle towards the next route point
        goal = route[target]
        if np.hypot(*(goal - pose[:2])) < 0.3:
            target = (target + 1) % len(route)
            goal = route[target]
        error = wrap_angle(math.atan2(goal[1] - pose[1], goal[0] - pose[0]) - pose[2])
        turn = float(np.clip(2.0 * error, -config.max_turn_rate, config.max_turn_rate))
        speed = config.speed * max(0.0, math.cos(error)) ** 2
        if crowd.in_the_way(pose):
            speed, standing = 0.0, standing + dt
            if standing >= ROBOT_PATIENCE:
                crowd.make_way(pose)
                standing = 0.0
        else:
            standing = 0.0
        if step % per_scan == 0:
            positions = (np.array([p.position for p in crowd.people])
                         if crowd.people else np.zeros((0, 2)))
            sensor = (sweep_poses(pose, speed, turn, config.beams, config.time_increment)
                      if config.sweep else pose)
            if world is None:
                ranges = cast_scan(grid, sensor, angles, positions, config.max_range)
            else:
                ranges, _ = world.cast(sensor, angles, [p.ident for p in crowd.people],
                                       positions,
                                       np.array([p.velocity for p in crowd.people]).reshape(-1, 2),
                                       1.0 / config.scan_rate, config.max_range)
            if config.mixed_pixels > 0.0:
                ranges = mix_edges(ranges, config.mixed_pixels, rng_edges)
            noisy = ranges + rng_laser.normal(0.0, config.range_noise, len(ranges))
            scans.append(np.where(np.isfinite(ranges), np.maximum(noisy, 0.0), np.inf))
            scan_stamps.append(config.start_time + t)
            people.append((np.array([p.ident for p in crowd.people], dtype=np.int32), positions))
        if step == steps:
            break
        heading = pose[2] + 0.5 * turn * dt
        pose = np.array([pose[0] + speed * dt * math.cos(heading),
                         pose[1] + speed * dt * math.sin(heading), wrap_angle(pose[2] + turn * dt)])
        measured_speed = speed * (1.0 + config.speed_bias) + rng_odometry.normal(
            0.0, config.speed_noise)
        measured_turn = turn * (1.0 + config.turn_bias) + config.yaw_rate_bias \
            + rng_odometry.normal(0.0, config.turn_noise)
        heading = odometry[2] + 0.5 * measured_turn * dt
        odometry = np.array([odometry[0] + measured_speed * dt * math.cos(heading),
                             odometry[1] + measured_speed * dt * math.sin(heading),
                             wrap_angle(odometry[2] + measured_turn * dt)])
        crowd.step(t + dt, dt, pose)
    stamps = np.array(stamps)
    return PeopleRun(grid, PoseSeries(stamps, np.array(odometry_poses), "odom", "base_link"),
                     PoseSeries(stamps, np.array(true_poses), "map", "base_link"),
                     np.array(scan_stamps), scans, angles, np.array(scan_stamps), people)


# ---------------------------------------------------------------- messages


def _header(stamp: float, frame_id: str):
    seconds, nanoseconds = divmod(stamp_to_ns(stamp), 1_000_000_000)
    types = TYPESTORE.types
    return types["std_msgs/msg/Header"](
        stamp=types["builtin_interfaces/msg/Time"](sec=seconds, nanosec=nanoseconds),
        frame_id=frame_id)


def _pose(types, x: float, y: float, yaw: float):
    qx, qy, qz, qw = yaw_to_quaternion(yaw)
    return types["geometry_msgs/msg/Pose"](
        position=types["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
        orientation=types["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw))


def occupancy_grid_message(grid: OccupancyMap, stamp: float, frame_id: str = "map"):
    """A rosbags ``nav_msgs/OccupancyGrid`` of the grid (100 occupied, 0 free, -1 unknown)."""
    types = TYPESTORE.types
    values = np.where(grid.occupied, 100, np.where(grid.free, 0, -1)).astype(np.int8)
    height, width = grid.shape
    info = types["nav_msgs/msg/MapMetaData"](
        map_load_time=_header(stamp, frame_id).stamp, resolution=float(grid.resolution),
        width=width, height=height, origin=_pose(types, grid.origin[0], grid.origin[1], 0.0))
    return types["nav_msgs/msg/OccupancyGrid"](header=_header(stamp, frame_id), info=info,
                                               data=values.ravel())


def laser_scan_message(stamp: float, ranges: np.ndarray, angles: np.ndarray, max_range: float,
                       frame_id: str = "laser", rate: float = 10.0,
                       intensities: np.ndarray | None = None, time_increment: float = 0.0):
    """A rosbags ``sensor_msgs/LaserScan`` (no return: inf, as REP 117 asks)."""
    increment = float(angles[1] - angles[0])
    return TYPESTORE.types["sensor_msgs/msg/LaserScan"](
        header=_header(stamp, frame_id), angle_min=float(angles[0]),
        angle_max=float(angles[-1]), angle_increment=increment,
        time_increment=time_increment,
        scan_time=1.0 / rate, range_min=0.05, range_max=float(max_range),
        ranges=np.asarray(ranges, dtype=np.float32),
        intensities=np.asarray(() if intensities is None else intensities, dtype=np.float32))


def people_cloud_message(stamp: float, ids: np.ndarray, positions: np.ndarray,
                         frame_id: str = "map"):
    """A rosbags ``sensor_msgs/PointCloud2`` (x y z float32, id int32) of people."""
    types = TYPESTORE.types
    records = np.zeros(len(ids), PEOPLE_CLOUD_DTYPE)
    if len(ids):
        records["x"], records["y"], records["id"] = positions[:, 0], positions[:, 1], ids
    fields = [types["sensor_msgs/msg/PointField"](name=name, offset=offset, datatype=datatype,
                                                   count=1)
              for name, offset, datatype in (("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("id", 12, 5))]
    return types["sensor_msgs/msg/PointCloud2"](
        header=_header(stamp, frame_id), height=1, width=len(ids), fields=fields,
        is_bigendian=False, point_step=PEOPLE_CLOUD_DTYPE.itemsize,
        row_step=PEOPLE_CLOUD_DTYPE.itemsize * len(ids), data=records.view(np.uint8),
        is_dense=True)


def initial_pose_message(stamp: float, pose: np.ndarray, sigma_xy: float = 0.1,
                         sigma_yaw: float = 0.05):
    """A rosbags ``geometry_msgs/PoseWithCovarianceStamped`` in ``map``, as RViz sends."""
    types = TYPESTORE.types
    covariance = np.zeros(36)
    covariance[0] = covariance[7] = sigma_xy ** 2
    covariance[35] = sigma_yaw ** 2
    return types["geometry_msgs/msg/PoseWithCovarianceStamped"](
        header=_header(stamp, "map"),
        pose=types["geometry_msgs/msg/PoseWithCovariance"](
            pose=_pose(types, pose[0], pose[1], pose[2]), covariance=covariance))


def _record(topic: str, msgtype: str, stamp: float, msg) -> tuple[str, str, int, bytes]:
    return topic, msgtype, stamp_to_ns(stamp), bytes(TYPESTORE.serialize_cdr(msg, msgtype))


def write_people_bag(path: str | Path, run: PeopleRun, config: PeopleSimConfig,
                     storage: str = "mcap", overwrite: bool = False) -> Path:
    """The run as a schema-v1 bag plus /map, /scan, /ground_truth/people, /initialpose."""
    start = float(run.odometry.stamps[0])
    extra = [_record(MAP_TOPIC, "nav_msgs/msg/OccupancyGrid", start,
                     occupancy_grid_message(run.grid, start))]
    if config.initial_pose:
        extra.append(_record(INITIAL_POSE_TOPIC, "geometry_msgs/msg/PoseWithCovarianceStamped",
                             start, initial_pose_message(start, run.truth.poses[0])))
    for stamp, ranges in zip(run.scan_stamps, run.scans):
        extra.append(_record(SCAN_TOPIC, "sensor_msgs/msg/LaserScan", float(stamp),
                             laser_scan_message(float(stamp), ranges, run.angles,
                                                config.max_range, rate=config.scan_rate,
                                                time_increment=config.time_increment)))
    for stamp, (ids, positions) in zip(run.people_stamps, run.people):
        extra.append(_record(PEOPLE_TRUTH_TOPIC, "sensor_msgs/msg/PointCloud2", float(stamp),
                             people_cloud_message(float(stamp), ids, positions)))
    empty = LandmarkScans(np.zeros(0), [], [], "laser")
    return write_schema_bag(path, SchemaBag(run.odometry, empty, run.truth), storage,
                            overwrite, extra)


def recommended_params(config: PeopleSimConfig) -> dict[str, float | int | str]:
    """Tracker parameters matched to the simulated laser, odometry and people (the plain
    world's people are round bodies: the 'blob' person model)."""
    return {"max_range": float(config.max_range), "seed": int(config.seed),
            "person_model": "legs" if config.legs else "blob"}


# ---------------------------------------------------------------- command line


def main(argv: list[str] | None = None) -> int:
    """``fastslam-sim --scenario people``: simulate and write the bag and its parameter file."""
    parser = cli.parser("fastslam-sim", __doc__, first_paragraph=True)
    parser.add_argument("--scenario", choices=("people",), default="people",
                        help="the simulated world (people: a known map with walking people)")
    parser.add_argument("--out", type=Path, default=Path("sim_people"), help="output bag folder")
    parser.add_argument("--params-out", type=Path, default=None,
                        help="tracker parameters for this bag (default: OUT.yaml)")
    parser.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap",
                        help="rosbag2 storage of the output bag")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output")
    defaults = PeopleSimConfig()
    parser.add_argument("--seed", type=int, default=defaults.seed,
                        help="seed of the world, the people's walks and the noise")
    parser.add_argument("--duration", type=float, default=defaults.duration,
                        help="simulated time (s)")
    parser.add_argument("--people", type=int, default=defaults.people, help="number of people")
    parser.add_argument("--no-initial-pose", action="store_true",
                        help="write no /initialpose: the tracker must localize globally")
    parser.add_argument("--beams", type=int, default=defaults.beams, help="beams per scan")
    parser.add_argument("--field-of-view", type=float, default=defaults.field_of_view,
                        help="the laser's span (rad), centred ahead (a 270-degree laser: 4.712)")
    parser.add_argument("--scan-rate", type=float, default=defaults.scan_rate,
                        help="scans per second (it must divide --odometry-rate)")
    parser.add_argument("--odometry-rate", type=float, default=defaults.odometry_rate,
                        help="odometry messages per second")
    parser.add_argument("--legs", action="store_true",
                        help="the real-laser world: people as two swinging legs, tables and "
                             "chairs on thin legs, people close to walls and furniture")
    parser.add_argument("--sweep", action="store_true",
                        help="beams taken one after the other as the mirror turns (a full turn "
                             "per scan), each from where the robot is then; LaserScan's "
                             "time_increment says how far apart")
    parser.add_argument("--mixed-pixels", type=float, default=defaults.mixed_pixels,
                        help="probability that a beam at a depth edge returns a range between "
                             "the two surfaces, in free space (a real laser's mixed pixels)")
    parser.add_argument("--yaw-rate-bias", type=float, default=defaults.yaw_rate_bias,
                        help="constant error of the odometry's turn rate (rad/s), as uneven "
                             "wheels or a gyro's offset give")
    args = parser.parse_args(argv)
    params_out = args.params_out or args.out.with_name(args.out.name + ".yaml")
    try:
        config = PeopleSimConfig(seed=args.seed, duration=args.duration, people=args.people,
                                 initial_pose=not args.no_initial_pose, legs=args.legs,
                                 beams=args.beams, field_of_view=args.field_of_view,
                                 scan_rate=args.scan_rate,
                                 odometry_rate=args.odometry_rate,
                                 mixed_pixels=args.mixed_pixels, sweep=args.sweep,
                                 yaw_rate_bias=args.yaw_rate_bias).validate()
        cli.output_folder(args.out, "--out")
        cli.output_file(params_out, "--params-out")
        check_output(args.out, args.overwrite, "bag")  # every output before writing any
        check_output(params_out, args.overwrite, "file", inputs=[args.out])
    except (cli.UsageError, ValueError, OSError) as error:  # an option value, an output
        return cli.fail("fastslam-sim", error, cli.EXIT_USAGE)
    try:
        run = simulate_people(config)
        write_people_bag(args.out, run, config, args.storage, args.overwrite)
        write_params_yaml(params_out, recommended_params(config),
                          f"people_tracker parameters for {args.out.name} (fastslam-sim "
                          f"--scenario people --seed {config.seed}).", overwrite=args.overwrite)
    except (ValueError, OSError) as error:
        return cli.fail("fastslam-sim", error)
    seen = len({int(i) for ids, _ in run.people for i in ids})
    print(f"wrote {args.out}: {config.duration:.0f} s, {len(run.scans)} scans, {seen} people; "
          f"parameters in {params_out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
