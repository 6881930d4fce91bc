# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A 2-D laser in the simulator's landmark worlds: poles to find, walls, parked cars and people
to ignore.

Every landmark of a ``fastslam-sim`` world becomes a pole or trunk (radius uniform in
``RADII``) or, a share ``REFLECTIVE_SHARE`` of them, a thin post wrapped in reflective tape;
walls stand back from the route and cars are parked beside it, neither touching a pole;
people, if asked for (circles of ``WALKER_RADIUS``, a body at the laser's height), pace to and
fro beside the route. The laser (``Laser``: 1,081 beams over 270 degrees, as a Hokuyo
UTM-30LX) is ray cast analytically against circles and
line segments at the true pose; ranges get Gaussian noise, beams that hit nothing within
``max_range`` are +inf (REP 117). Intensities follow a diffuse surface, falling with range and
the incidence angle, with reflectors ``REFLECTOR_GAIN`` times brighter. The layout depends on
the world seed only, so every noise seed of a world shares it. Plain numpy, no ROS.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from fastslam_ros.tools.simulation.world import distance_to_route

RADII = (0.08, 0.25)
"""Range of the pole and trunk radii (m)."""
REFLECTIVE_SHARE = 0.3
"""Share of the poles that are reflector posts (reflective tape, radius POST_RADIUS)."""
POST_RADIUS = 0.05
DIFFUSE_INTENSITY = 2000.0
"""Intensity of a diffuse return at normal incidence and 0 m (falls as 1 / (1 + r / 10 m))."""
REFLECTOR_GAIN = 20.0
INTENSITY_NOISE = 0.1
"""Relative (log-normal) noise of the intensities."""
CAR_SIZE = (4.5, 1.8)
POLE_CLEARANCE = 1.0
"""Smallest gap (m) between a pole and a wall or a car."""
WALKER_RADIUS = 0.2
"""Radius (m) of a walking person's body as the laser sees it: as wide as a trunk."""
WALKER_SPEED = 1.2
"""Walking speed (m/s) of the people pacing beside the route."""
SCAN_TYPE = "sensor_msgs/msg/LaserScan"


@dataclass
class PoleWorld:
    """Poles (N,): ``centres`` (N, 2), ``radii`` and ``reflective``; ``walls`` (W, 4) line
    segments x0 y0 x1 y1 (walls and the sides of parked cars), in the map frame."""

    centres: np.ndarray
    radii: np.ndarray
    reflective: np.ndarray
    walls: np.ndarray
    walks: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 4)))
    """(P, 4) segments x0 y0 x1 y1 along which people pace at ``WALKER_SPEED``."""

    def walkers(self, time: float) -> np.ndarray:
        """(P, 2) positions of the people ``time`` s into the run: each walks its segment to
        and fro, person i starting a share 0.618 i (mod 1) of the way along it."""
        start, side = self.walks[:, :2], self.walks[:, 2:] - self.walks[:, :2]
        length = np.maximum(np.hypot(side[:, 0], side[:, 1]), 1e-9)
        travelled = (WALKER_SPEED * time
                     + length * ((0.618 * np.arange(len(length))) % 1.0)) % (2.0 * length)
        along = np.where(travelled < length, travelled, 2.0 * length - travelled) / length
        return start + along[:, None] * side

    def circles(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Centres (N + P, 2) and radii of every circle the laser sees at ``time``: the poles,
        then the people."""
        return (np.concatenate([self.centres, self.walkers(time)]),
                np.concatenate([self.radii, np.full(len(self.walks), WALKER_RADIUS)]))


def segment_distance(points: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Distance (m) of each point (K, 2) to the nearest of the segments ``walls`` (W, 4)."""
    if not len(walls) or not len(points):
        return np.full(len(points), np.inf)
    start, end = walls[:, :2], walls[:, 2:]
    direction = end - start
    length_sq = np.maximum(np.sum(direction ** 2, axis=1), 1e-12)
    offset = points[:, None, :] - start[None]
    along = np.clip(np.sum(offset * direction[None], axis=2) / length_sq, 0.0, 1.0)
    closest = start[None] + along[..., None] * direction[None]
    return np.min(np.linalg.norm(points[:, None, :] - closest, axis=2), axis=1)


def _rectangle(centre: np.ndarray, heading: float, size: tuple[float, float]) -> np.ndarray:
    """The four sides (4, 4) of a rectangle."""
    c, s = math.cos(heading), math.sin(heading)
    half = 0.5 * np.array(size)
    corners = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * half
    corners = centre + corners @ np.array([[c, s], [-s, c]])
    return np.hstack([corners, np.roll(corners, -1, axis=0)])


def build_pole_world(landmarks: np.ndarray, route: np.ndarray, rng: np.random.Generator,
                     walls: int = 12, cars: int = 20, people: int = 0) -> PoleWorld:
    """Poles at ``landmarks`` (N, 2); ``walls`` walls of 8-25 m 6-20 m off the closed
    ``route``, ``cars`` cars parked 3-5 m off it and ``people`` people pacing 4-12 m 2-6 m off
    it, each kept only clear of every pole."""
    radii = rng.uniform(*RADII, len(landmarks))
    reflective = rng.random(len(landmarks)) < REFLECTIVE_SHARE
    radii[reflective] = POST_RADIUS
    sides = []
    legs = np.roll(route, -1, axis=0) - route

    def place(offset_range, length_range, road_clearance, shape) -> np.ndarray | None:
        leg = int(rng.integers(len(route)))
        heading = math.atan2(legs[leg, 1], legs[leg, 0])
        normal = np.array([-math.sin(heading), math.cos(heading)]) * rng.choice([-1.0, 1.0])
        centre = route[leg] + rng.random() * legs[leg] + rng.uniform(*offset_range) * normal
        candidate = shape(centre, heading + rng.normal(0.0, 0.2), rng.uniform(*length_range))
        samples = np.concatenate([candidate[:, :2] + t * (candidate[:, 2:] - candidate[:, :2])
                                  for t in np.linspace(0.0, 1.0, 9)])
        clear = (segment_distance(landmarks, candidate).min(initial=np.inf)
                 >= POLE_CLEARANCE + RADII[1])
        if clear and distance_to_route(samples, route).min() >= road_clearance:
            return candidate
        return None

    def wall(centre, heading, length):
        step = 0.5 * length * np.array([math.cos(heading), math.sin(heading)])
        return np.concatenate([centre - step, centre + step])[None, :]

    def car(centre, heading, _):
        return _rectangle(centre, heading, CAR_SIZE)

    for count, offsets, lengths, clearance, shape in ((walls, (6.0, 20.0), (8.0, 25.0), 4.0,
                                                       wall),
                                                      (cars, (3.0, 5.0), (0.0, 0.0), 1.5, car)):
        placed = 0
        for _ in range(50 * count):
            if placed == count:
                break
            candidate = place(offsets, lengths, clearance, shape)
            if candidate is not None:
                sides.append(candidate)
                placed += 1
    walks = [walk for walk in (place((2.0, 6.0), (4.0, 12.0), 1.0, wall)
                               for _ in range(50 * people)) if walk is not None][:people]
    return PoleWorld(np.asarray(landmarks, dtype=float).reshape(-1, 2), radii, reflective,
                     np.concatenate(sides) if sides else np.zeros((0, 4)),
                     np.concatenate(walks) if walks else np.zeros((0, 4)))


@dataclass(frozen=True)
class Laser:
    """A planar laser at the vehicle's origin looking forward (SI units, radians)."""

    beams: int = 1081
    field_of_view: float = math.radians(270.0)
    max_range: float = 30.0
    sigma_range: float = 0.01

    @property
    def angles(self) -> np.ndarray:
        """Bearing of every beam in the sensor frame, symmetric about the heading."""
        return np.linspace(-0.5 * self.field_of_view, 0.5 * self.field_of_view, self.beams)

    def cast(self, world: PoleWorld, pose: np.ndarray, time: float = 0.0
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """True ranges (B,) (inf: nothing within max_range), the cosine of the incidence angle
        and the pole hit (-1: a wall, a car, a person or nothing) from ``pose`` (x, y, theta),
        or one pose per beam (B, 3) for a laser that sweeps, ``time`` s into the run (where
        the people are)."""
        heading = pose[..., 2] + self.angles
        direction = np.stack([np.cos(heading), np.sin(heading)], axis=1)
        origin = pose[..., None, :2]                                    # (1, 2) or (B, 1, 2)
        ranges = np.full(self.beams, np.inf)
        incidence = np.ones(self.beams)
        pole = np.full(self.beams, -1)
        centres, radii = world.circles(time)
        offset = centres - origin                                       # (N, 2) or (B, N, 2)
        reach = np.hypot(offset[..., 0], offset[..., 1]).reshape(-1, len(centres)).min(axis=0)
        near = np.flatnonzero(reach < self.max_range + radii)
        if len(near):
            toward = offset[..., near, :]
            along = (direction @ toward.T if toward.ndim == 2                 # (B, K)
                     else np.einsum("bd,bkd->bk", direction, toward))
            across_sq = np.sum(toward ** 2, axis=-1).reshape(-1, len(near)) - along ** 2
            radius_sq = radii[near][None] ** 2
            hit = along - np.sqrt(np.clip(radius_sq - across_sq, 0.0, None))
            hit = np.where((across_sq < radius_sq) & (hit > 0.0), hit, np.inf)
            first = np.argmin(hit, axis=1)
            ranges = hit[np.arange(self.beams), first]
            struck = np.isfinite(ranges)
            pole = np.where(struck & (near[first] < len(world.centres)), near[first], -1)
            cos = np.sqrt(np.clip(1.0 - across_sq[np.arange(self.beams), first]
                                  / radius_sq[0, first], 0.0, 1.0))
            incidence = np.where(struck, cos, 1.0)
        if len(world.walls):
            start = (world.walls[:, :2] - origin).reshape(-1, len(world.walls), 2)
            side = world.walls[:, 2:] - world.walls[:, :2]
            denominator = direction[:, :1] * side[None, :, 1] - direction[:, 1:] * side[None, :, 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (start[:, :, 0] * side[None, :, 1] - start[:, :, 1] * side[None, :, 0]) \
                    / denominator
                s = (start[:, :, 0] * direction[:, 1:] - start[:, :, 1] * direction[:, :1]) \
                    / denominator
            t = np.where((t > 0.0) & (s >= 0.0) & (s <= 1.0), t, np.inf)
            first = np.argmin(t, axis=1)
            wall_range = t[np.arange(self.beams), first]
            closer = wall_range < ranges
            normal = side[first] / np.linalg.norm(side[first], axis=1, keepdims=True)
            cos = np.abs(direction[:, 0] * normal[:, 1] - direction[:, 1] * normal[:, 0])
            ranges = np.where(closer, wall_range, ranges)
            incidence = np.where(closer, cos, incidence)
            pole = np.where(closer, -1, pole)
        ranges = np.where(ranges < self.max_range, ranges, np.inf)
        return ranges, incidence, pole

    def scan(self, world: PoleWorld, pose: np.ndarray, rng: np.random.Generator,
             time: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Noisy ranges (B,) and intensities (B,) from the true ``pose``, ``time`` s into the
        run."""
        ranges, incidence, pole = self.cast(world, pose, time)
        hit = np.isfinite(ranges)
        noisy = ranges + rng.normal(0.0, self.sigma_range, self.beams)
        noisy = np.where(hit & (noisy < self.max_range), np.maximum(noisy, 0.0), np.inf)
        gain = np.where((pole >= 0) & world.reflective[np.maximum(pole, 0)], REFLECTOR_GAIN, 1.0)
        intensity = DIFFUSE_INTENSITY * gain * np.maximum(incidence, 0.05) \
            / (1.0 + np.where(hit, ranges, 0.0) / 10.0)
        intensity *= np.exp(rng.normal(0.0, INTENSITY_NOISE, self.beams))
        return noisy, np.where(hit, intensity, 0.0)


def pole_world(world_seed: int, landmarks: np.ndarray, route: np.ndarray,
               people: int = 0) -> PoleWorld:
    """The pole world of a ``fastslam-sim`` world (its own stream of ``world_seed``; the
    people, drawn last, leave the rest of the layout as it is without them)."""
    return build_pole_world(landmarks, route, np.random.default_rng([world_seed, 7]),
                            people=people)


def scan_truth_poses(bag) -> np.ndarray:
    """True poses (S, 3) at the stamps of the bag's landmark readings (the laser's too)."""
    index = np.searchsorted(bag.ground_truth.stamps, bag.scans.stamps)
    return np.asarray(bag.ground_truth.poses)[index]


def noisy_scans(laser: Laser, world: PoleWorld, poses, times, seed: int,
                mixed_pixels: float = 0.0):
    """(ranges, intensities) of ``laser`` at each pose of ``poses`` (each (3,), or (B, 3)
    for a sweep) ``times`` s into the run, with range noise from ``seed`` and, with
    ``mixed_pixels`` P, a real laser's mixed pixels at the depth edges (``people_sim.mix_edges``,
    its own random stream: P = 0 leaves the scans as they were). The scans of
    ``fastslam-sim --laser`` and of ``extractor_eval``."""
    from fastslam_ros.tools.simulation.people_sim import mix_edges
    rng = np.random.default_rng([seed, 2])
    edges_rng = np.random.default_rng([seed, 3])
    for pose, time in zip(poses, times):
        ranges, intensities = laser.scan(world, pose, rng, float(time))
        if mixed_pixels > 0.0:
            ranges = mix_edges(ranges, mixed_pixels, edges_rng)
        yield ranges, intensities


def scan_records(config, world, bag, laser: Laser = Laser(), people: int = 0,
                 sweep: bool = False, mixed_pixels: float = 0.0
                 ) -> list[tuple[str, str, int, bytes]]:
    """``/scan`` records (topic, type, stamp ns, CDR) for ``write_schema_bag``: the laser at
    every landmark reading of a simulated ``bag`` of ``config`` and its ``world`` (route and
    landmarks, ``people`` people pacing beside the route), in the landmarks' frame, with range
    noise from ``config.seed``. With ``sweep`` the beams are taken one after the other (a
    full turn per reading period, ``time_increment`` apart from the stamp on), each from the
    true pose of its moment, as a real laser's mirror takes them; ``mixed_pixels`` as
    ``noisy_scans``."""
    from fastslam_ros.node_support.timing import interpolate_poses
    from fastslam_ros.tools.bags.bag_schema import TYPESTORE, stamp_to_ns
    from fastslam_ros.tools.simulation.people_sim import (SCAN_TOPIC, laser_scan_message,
                                                          sweep_time_increment)
    poles = pole_world(config.world_seed, world.landmarks.positions, world.waypoints, people)
    angles = laser.angles
    time_increment = (sweep_time_increment(angles[1] - angles[0], config.observation_rate)
                      if sweep else 0.0)
    beam_times = np.arange(laser.beams) * time_increment
    truth = bag.ground_truth
    stamps = bag.scans.stamps
    poses = (interpolate_poses(truth.stamps, truth.poses, stamp + beam_times) if sweep else pose
             for stamp, pose in zip(stamps, scan_truth_poses(bag)))
    scans = noisy_scans(laser, poles, poses, stamps - stamps[0], config.seed, mixed_pixels)
    records = []
    for stamp, (ranges, intensities) in zip(stamps, scans):
        msg = laser_scan_message(float(stamp), ranges, angles, laser.max_range,
                                 config.sensor_frame, config.observation_rate, intensities,
                                 time_increment)
        records.append((SCAN_TOPIC, SCAN_TYPE, stamp_to_ns(float(stamp)),
                        bytes(TYPESTORE.serialize_cdr(msg, SCAN_TYPE))))
    return records
