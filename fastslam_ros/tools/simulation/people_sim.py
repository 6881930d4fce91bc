# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""People simulator: rooms and corridors on a grid, a robot with a 2-D laser, people walking.

A 20 m x 20 m floor (five rooms off a corridor open at both ends, furniture) as a 0.05 m
evidence grid. The robot drives a route through the corridor and into the rooms at 0.5 m/s;
its wheel odometry integrates noisy, slightly biased velocities at 50 Hz. A 360-beam laser at
10 Hz (range noise 0.02 m, no return beyond ``max_range``) is ray cast against the walls and
against the people, cylinders of radius 0.2 m that occlude each other. Five people walk a graph
of corridor, door and room points at their own speeds, stop for a while, and leave by the
corridor's ends; whoever left is replaced, after a pause, by a new person (a new id) entering
there once the way is clear. People are solid: they keep PERSONAL_DISTANCE apart and off the
walls, step aside to pass each other and yield rather than block (``Crowd``).

The bag holds schema v1's ``/odom`` and ``/ground_truth/pose`` plus ``/map``
(``nav_msgs/OccupancyGrid``, one message), ``/scan`` (``sensor_msgs/LaserScan``, frame
``laser`` at the base origin), ``/ground_truth/people`` (``sensor_msgs/PointCloud2`` in
``map``: x y z float32, id int32, every person in the world, at every scan) and, unless
``--no-initial-pose``, one ``/initialpose`` (the true start pose, as RViz would send it).
"""
from __future__ import annotations

import math
import sys
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fastslam_ros.core.geometry import wrap_angle
from fastslam_ros.people.grid import OccupancyMap
from fastslam_ros.tools.bags.bag_schema import (INITIAL_POSE_TOPIC, TYPESTORE, LandmarkScans,
                                           PoseSeries, SchemaBag, stamp_to_ns, write_schema_bag,
                                           yaw_to_quaternion)
from fastslam_ros.tools import cli
from fastslam_ros.output import check_output, write_params_yaml

MAP_TOPIC = "/map"
SCAN_TOPIC = "/scan"
PEOPLE_TRUTH_TOPIC = "/ground_truth/people"
PEOPLE_CLOUD_DTYPE = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<i4")])
SIZE = 20.0
RESOLUTION = 0.05
WALL = 0.15
WALLS = (
    # outer walls, open where the corridor (y 8 .. 12) meets the left and right edges
    (0.0, SIZE, 0.0, WALL), (0.0, SIZE, SIZE - WALL, SIZE),
    (0.0, WALL, 0.0, 8.6), (0.0, WALL, 11.4, SIZE),
    (SIZE - WALL, SIZE, 0.0, 8.6), (SIZE - WALL, SIZE, 11.4, SIZE),
    # corridor walls with doors (bottom: x 3 .. 4.2, 9.4 .. 10.6, 16 .. 17.2; top: 4 .. 5.2,
    # 14.4 .. 15.6)
    (0.0, 3.0, 7.9, 8.1), (4.2, 9.4, 7.9, 8.1), (10.6, 16.0, 7.9, 8.1), (17.2, SIZE, 7.9, 8.1),
    (0.0, 4.0, 11.9, 12.1), (5.2, 14.4, 11.9, 12.1), (15.6, SIZE, 11.9, 12.1),
    # rooms: three below the corridor, two above
    (6.9, 7.1, 0.0, 8.0), (12.9, 13.1, 0.0, 8.0), (9.9, 10.1, 12.0, SIZE),
    # furniture
    (1.5, 3.0, 2.0, 3.0), (10.5, 12.0, 2.5, 4.0), (18.6, 19.85, 5.5, 6.3), (2.0, 3.5, 16.0, 17.0),
    (16.0, 18.0, 17.0, 17.3), (12.1, 12.5, 11.3, 11.7), (7.6, 8.0, 14.0, 14.4),
)
"""Walls and furniture as (x_min, x_max, y_min, y_max) rectangles (m)."""
ROUTE = ((2.0, 10.0), (9.0, 10.0), (10.0, 8.8), (10.0, 6.0), (8.5, 5.5), (10.0, 8.8),
         (15.0, 10.0), (15.0, 13.0), (14.0, 15.5), (15.0, 12.8), (16.6, 10.0), (18.0, 10.0),
         (16.6, 9.0), (16.6, 5.0), (16.6, 9.0), (8.0, 10.3), (4.6, 11.0), (4.6, 14.5),
         (6.0, 16.0), (4.6, 12.5), (2.0, 10.0))
"""The robot's route (m), driven in a loop; it starts at the first point facing the second."""
NODES = {
    "west_exit": (0.3, 10.0), "c1": (3.6, 10.0), "c2": (4.6, 10.0), "c3": (10.0, 10.0),
    "c4": (15.0, 10.0), "c5": (16.6, 10.0), "east_exit": (19.7, 10.0),
    "door_a": (3.6, 8.0), "room_a": (3.6, 5.0), "room_a2": (5.0, 2.0),
    "door_b": (10.0, 8.0), "room_b": (10.0, 6.0), "room_b2": (8.0, 2.0),
    "door_c": (16.6, 8.0), "room_c": (16.6, 5.0), "room_c2": (18.0, 2.0),
    "door_d": (4.6, 12.0), "room_d": (4.6, 15.0), "room_d2": (7.0, 18.0),
    "door_e": (15.0, 12.0), "room_e": (15.0, 15.0), "room_e2": (12.0, 18.0),
}
EDGES = (("west_exit", "c1"), ("c1", "c2"), ("c2", "c3"), ("c3", "c4"), ("c4", "c5"),
         ("c5", "east_exit"), ("c1", "door_a"), ("door_a", "room_a"), ("room_a", "room_a2"),
         ("c3", "door_b"), ("door_b", "room_b"), ("room_b", "room_b2"), ("c5", "door_c"),
         ("door_c", "room_c"), ("room_c", "room_c2"), ("c2", "door_d"), ("door_d", "room_d"),
         ("room_d", "room_d2"), ("c4", "door_e"), ("door_e", "room_e"), ("room_e", "room_e2"))
"""The people's walking graph."""
EXITS = ("west_exit", "east_exit")
ROOMS = tuple(name for name in NODES if name.startswith("room"))
PERSON_RADIUS = 0.2
PERSONAL_DISTANCE = 0.6
"""People keep at least this far apart, centre to centre (m): 0.2 m between two bodies of
PERSON_RADIUS, within the 0.5-0.8 m that pedestrians passing each other in a corridor keep; two
people still pass side by side through a 1.2 m door."""
WALL_CLEARANCE = PERSON_RADIUS + 2.0 * RESOLUTION
"""A person's centre stays this far (m) from every occupied cell centre, which keeps the body
off the walls: the distance of a point's cell centre to the nearest occupied cell centre errs
from the point's distance to the wall's face by up to about two cells."""
ROBOT_DISTANCE = 0.7
"""People do not step closer than this to the robot (m); they wait for it to pass."""
LOOKAHEAD = 1.0
"""People steer by where they and the others will be in this many seconds (s)."""
COMFORT_DISTANCE = 1.2
"""Below this distance (m) between the look-ahead points the social cost rises."""
SOCIAL_WEIGHT = 4.0
"""Weight of the social cost against the progress towards the target."""
KEEP_RIGHT = 0.02
"""Preference for stepping aside to the right (breaks the tie of two people face to face)."""
ARRIVAL_SLACK = 1.0
"""A person kept from its next point (m) by others counts as there within this distance."""
WALK_HEADINGS = np.radians(np.arange(-90.0, 91.0, 15.0))
"""Headings (relative to the target) a walking person may step in."""
YIELD_HEADINGS = np.radians(np.arange(-180.0, 180.0, 15.0))
"""Headings a yielding person may step in (any)."""
TURN_TIME = 0.3
"""A walking person's velocity follows the step it chose with this time constant (s): people
round corners (a radius of about speed x TURN_TIME) and speed up and slow down over a few
tenths of a second instead of turning or stopping in one step."""
OFFSET_FRACTIONS = (1.0, 0.75, 0.5, 0.25, 0.0)
"""A person's lateral offset is shrunk by these fractions until its target point is walkable:
through a door, or where a room's point is near a wall, people aim where they can go."""


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
    initial_pose: bool = True
    """Write ``/initialpose`` (the true start pose); without it the tracker localizes globally."""
    legs: bool = False
    """The real-laser world (``people_legs``): people as two swinging legs, tables and chairs
    on thin legs in the map, people walking close to walls and furniture."""

    def validate(self) -> "PeopleSimConfig":
        for name in ("duration", "scan_rate", "odometry_rate", "max_range", "speed",
                     "max_turn_rate"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name}: must be > 0 (got {getattr(self, name)})")
        for name in ("range_noise", "speed_noise", "turn_noise"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"{name}: must be >= 0 (got {getattr(self, name)})")
        if self.people < 0 or self.beams < 8:
            raise ValueError("people: must be >= 0 and beams >= 8")
        ratio = self.odometry_rate / self.scan_rate
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError("scan_rate: must divide odometry_rate")
        return self


def build_map() -> OccupancyMap:
    """The floor as an evidence grid (walls occupied, the rest free)."""
    cells = int(round(SIZE / RESOLUTION))
    centres = (np.arange(cells) + 0.5) * RESOLUTION
    x, y = np.meshgrid(centres, centres)
    occupied = np.zeros((cells, cells), dtype=bool)
    for x0, x1, y0, y1 in WALLS:
        occupied |= (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
    return OccupancyMap(occupied, ~occupied, RESOLUTION)


# ---------------------------------------------------------------- people


@dataclass
class Person:
    """A walking person: position, the points still to walk, speed, pause left (s), and how
    long it has been kept from walking on (s), how long it waits before yielding (s), and how
    long it still yields (s)."""

    ident: int
    position: np.ndarray
    node: str
    path: deque = field(default_factory=deque)
    speed: float = 1.0
    offset: float = 0.0
    pause: float = 0.0
    leaving: bool = False
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(2))
    waited: float = 0.0
    patience: float = 2.0
    yielding: float = 0.0


def _graph() -> dict[str, list[str]]:
    neighbours: dict[str, list[str]] = {name: [] for name in NODES}
    for a, b in EDGES:
        neighbours[a].append(b)
        neighbours[b].append(a)
    return neighbours


def _route(graph: dict[str, list[str]], start: str, goal: str) -> list[str]:
    """Nodes from ``start`` (excluded) to ``goal`` by breadth-first search."""
    previous = {start: None}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        for following in graph[node]:
            if following not in previous:
                previous[following] = node
                queue.append(following)
    path = []
    node = goal
    while node != start:
        path.append(node)
        node = previous[node]
    return path[::-1]


class Crowd:
    """The people of a simulation, moved in steps; ``people`` are the ones in the world.

    People are solid: no one steps within PERSONAL_DISTANCE of another person, within
    WALL_CLEARANCE of a wall, or closer than ROBOT_DISTANCE to the robot. Each step a walking
    person picks, among the headings up to 90 degrees off its target, the one that best trades
    progress for a social cost (how close its look-ahead point comes to the others' predicted
    ones), so people step aside early to pass each other, keeping right. A person kept from
    progressing for longer than its patience (1.5-2.5 s) yields: for 1-2 s it steps in any
    direction away from the others (and back along its edge), which lets the other pass; it
    never waits for good. A walking person's velocity follows the chosen step with time
    constant TURN_TIME (rounded corners, no instant stops), and it aims at the walkable point
    nearest its lateral offset beside the next graph point (through a door, within the
    door). Newcomers enter only when their entry point is clear.
    """

    def __init__(self, count: int, rng: np.random.Generator,
                 grid: OccupancyMap | None = None, walkable: np.ndarray | None = None,
                 lateral: float = 0.3) -> None:
        self.rng = rng
        self.grid = grid if grid is not None else build_map()
        self.walkable = (walkable if walkable is not None
                         else self.grid.free & (self.grid.distance >= WALL_CLEARANCE))
        """Cells a person's centre may be in."""
        self.lateral = lateral
        """People walk up to this far (m) to either side of the graph's edges."""
        self.graph = _graph()
        self.people: list[Person] = []
        self.next_id = 0
        self.arrivals: list[tuple[float, str]] = []
        """(time, exit) of the newcomers to come."""
        for _ in range(count):
            self._spawn_in_room()

    def _clear(self, points: np.ndarray, person: Person | None = None) -> np.ndarray:
        """Whether each of points (K, 2) is in free space and PERSONAL_DISTANCE from everyone
        (but ``person``)."""
        points = np.atleast_2d(points)
        rows, cols, inside = self.grid.cells(points)
        clear = inside & self.walkable[rows, cols]
        others = [p.position for p in self.people if p is not person]
        if others:
            gaps = np.linalg.norm(points[:, None, :] - np.array(others)[None], axis=2)
            clear &= gaps.min(axis=1) >= PERSONAL_DISTANCE
        return clear

    def _spawn_in_room(self) -> None:
        """A person at a random room point, or near it where the room point is taken."""
        rng = self.rng
        node = str(rng.choice(ROOMS))
        position = np.array(NODES[node], dtype=float)
        for _ in range(1000):
            if self._clear(position)[0]:
                break
            position = np.array(NODES[node]) + rng.uniform(-0.8, 0.8, 2)
        else:
            raise ValueError("people: too many for the rooms")
        self._spawn(node, position)

    def _spawn(self, node: str, position: np.ndarray) -> None:
        rng = self.rng
        person = Person(self.next_id, position, node, speed=float(rng.uniform(0.5, 1.1)),
                        offset=float(rng.uniform(-self.lateral, self.lateral)),
                        pause=float(rng.uniform(0.0, 3.0)),
                        patience=float(rng.uniform(1.5, 2.5)))
        self.next_id += 1
        self.people.append(person)
        self._new_goal(person)

    def _new_goal(self, person: Person) -> None:
        rng = self.rng
        leave = rng.random() < 0.25
        choices = [name for name in (EXITS if leave else ROOMS) if name != person.node]
        goal = str(rng.choice(choices))
        person.leaving = goal in EXITS
        person.path = deque(_route(self.graph, person.node, goal))

    def _social_cost(self, person: Person, lookahead: np.ndarray) -> np.ndarray:
        """(K,) cost of look-ahead points (K, 2): how far into the others' comfort distance
        (at their predicted positions) they reach."""
        others = [p for p in self.people if p is not person]
        if not others:
            return np.zeros(len(lookahead))
        predicted = np.array([p.position + LOOKAHEAD * p.velocity for p in others])
        gaps = np.linalg.norm(lookahead[:, None, :] - predicted[None], axis=2)
        return np.sum(np.clip(1.0 - gaps / COMFORT_DISTANCE, 0.0, None) ** 2, axis=1)

    def _walk(self, person: Person, dt: float, robot: np.ndarray) -> None:
        """One step of a walking person towards its next point (or of a yielding one)."""
        target_node = person.path[0]
        start = np.array(NODES[person.node])
        end = np.array(NODES[target_node])
        direction = (end - start) / max(np.linalg.norm(end - start), 1e-9)
        normal = np.array([-direction[1], direction[0]])
        offset = 0.0 if target_node in EXITS else person.offset
        target = self._reachable_target(end, normal, offset)
        to_target = target - person.position
        distance = float(np.linalg.norm(to_target))
        step = person.speed * dt
        if distance <= step and self._clear(target, person)[0] and not self._robot_blocks(
                person.position, target[None], robot)[0]:
            person.velocity = (target - person.position) / dt
            person.position = target
            person.node = person.path.popleft()
            person.waited = 0.0
            return
        if person.yielding > 0.0:
            person.yielding -= dt
            relative = YIELD_HEADINGS
            back = start - person.position
            reference = math.atan2(back[1], back[0])
            preference = 0.5 * np.cos(relative)
        else:
            relative = WALK_HEADINGS
            reference = math.atan2(to_target[1], to_target[0])
            preference = np.cos(relative) - KEEP_RIGHT * np.sin(relative)
        headings = reference + relative
        unit = np.stack([np.cos(headings), np.sin(headings)], axis=1)
        length = min(step, distance) if person.yielding <= 0.0 else step
        candidates = person.position + length * unit
        feasible = self._clear(candidates, person) & ~self._robot_blocks(person.position,
                                                                         candidates, robot)
        score = preference - SOCIAL_WEIGHT * self._social_cost(
            person, person.position + LOOKAHEAD * person.speed * unit)
        progress = 0.0
        if feasible.any():
            best = int(np.argmax(np.where(feasible, score, -np.inf)))
            chosen = candidates[best]
            if person.yielding <= 0.0:  # walking: the velocity follows the chosen step
                velocity = person.velocity + min(1.0, dt / TURN_TIME) * (
                    (chosen - person.position) / dt - person.velocity)
                smooth = person.position + velocity * dt
                if self._clear(smooth, person)[0] and not self._robot_blocks(
                        person.position, smooth[None], robot)[0]:
                    chosen = smooth
            moved = chosen - person.position
            progress = float(moved @ to_target) / max(distance, 1e-9)
            person.velocity = moved / dt
            person.position = chosen
        else:
            person.velocity = np.zeros(2)
        if person.yielding > 0.0:
            return
        if progress >= 0.25 * step:
            person.waited = 0.0
            return
        person.waited += dt
        if distance < ARRIVAL_SLACK:
            person.node = person.path.popleft()  # kept from the point: close enough
            person.waited = 0.0
        elif person.waited >= person.patience:
            person.yielding = float(self.rng.uniform(1.0, 2.0))
            person.waited = 0.0

    def _reachable_target(self, end: np.ndarray, normal: np.ndarray, offset: float
                          ) -> np.ndarray:
        """The point ``end`` + f ``offset`` ``normal`` for the first fraction f of
        OFFSET_FRACTIONS that is walkable (``end`` itself otherwise)."""
        points = end + np.outer(np.array(OFFSET_FRACTIONS) * offset, normal)
        rows, cols, inside = self.grid.cells(points)
        walkable = inside & self.walkable[rows, cols]
        return points[int(np.argmax(walkable))] if walkable.any() else end

    @staticmethod
    def _robot_blocks(position: np.ndarray, candidates: np.ndarray,
                      robot: np.ndarray) -> np.ndarray:
        """Whether stepping to each candidate would come within ROBOT_DISTANCE of the robot
        (a person already that close may step anywhere: the robot drove up to it)."""
        if np.linalg.norm(position - robot[:2]) < ROBOT_DISTANCE:
            return np.zeros(len(candidates), dtype=bool)
        return np.linalg.norm(candidates - robot[:2], axis=1) < ROBOT_DISTANCE

    def step(self, t: float, dt: float, robot: np.ndarray) -> None:
        """Walk everyone for ``dt`` s, one after the other (each against the others' newest
        positions); newcomers whose time has come enter where their exit is clear."""
        rng = self.rng
        for person in list(self.people):
            if person.pause > 0.0:
                person.pause -= dt
                person.velocity = np.zeros(2)
                continue
            if not person.path:
                if person.leaving:
                    self.people.remove(person)
                    self.arrivals.append((t + float(rng.uniform(2.0, 8.0)),
                                          str(rng.choice(EXITS))))
                    continue
                person.pause = float(rng.uniform(0.0, 6.0)) if rng.random() < 0.6 else 0.0
                self._new_goal(person)
                continue
            self._walk(person, dt, robot)
        for arrival in [a for a in self.arrivals if a[0] <= t]:
            entry = np.array(NODES[arrival[1]], dtype=float)
            if self._clear(entry)[0] and np.linalg.norm(entry - robot[:2]) >= ROBOT_DISTANCE:
                self.arrivals.remove(arrival)
                self._spawn(arrival[1], entry)


# ---------------------------------------------------------------- robot and laser


def cast_scan(grid: OccupancyMap, sensor: np.ndarray, angles: np.ndarray, people: np.ndarray,
              max_range: float) -> np.ndarray:
    """True ranges (B,) from ``sensor`` (x, y, theta) against the walls and people (K, 2)
    (cylinders of PERSON_RADIUS); inf where nothing is hit within ``max_range``."""
    world = sensor[2] + angles
    ranges = grid.cast(np.broadcast_to(sensor[:2], (len(angles), 2)), world, max_range)
    if len(people):
        direction = np.stack([np.cos(world), np.sin(world)], axis=1)
        centre = people - sensor[:2]
        along = direction @ centre.T                                   # (B, K)
        across_sq = np.sum(centre ** 2, axis=1)[None, :] - along ** 2
        inside = (across_sq < PERSON_RADIUS ** 2) & (along > 0.0)
        hit = along - np.sqrt(np.clip(PERSON_RADIUS ** 2 - across_sq, 0.0, None))
        hit = np.where(inside & (hit > 0.0), hit, np.inf).min(axis=1)
        ranges = np.minimum(ranges, hit)
    return np.where(ranges <= max_range, ranges, np.inf)


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
    angles = -math.pi + (np.arange(config.beams) + 0.5) * (2.0 * math.pi / config.beams)
    stamps, true_poses, odometry_poses = [], [], []
    scan_stamps, scans, people = [], [], []
    steps = int(round(config.duration * config.odometry_rate))
    for step in range(steps + 1):
        t = step * dt  # time since the start; the stamps are start_time + t
        stamps.append(config.start_time + t)
        true_poses.append(pose.copy())
        odometry_poses.append(odometry.copy())
        if step % per_scan == 0:
            positions = (np.array([p.position for p in crowd.people])
                         if crowd.people else np.zeros((0, 2)))
            if world is None:
                ranges = cast_scan(grid, pose, angles, positions, config.max_range)
            else:
                ranges, _ = world.cast(pose, angles, [p.ident for p in crowd.people], positions,
                                       np.array([p.velocity for p in crowd.people]).reshape(-1, 2),
                                       1.0 / config.scan_rate, config.max_range)
            noisy = ranges + rng_laser.normal(0.0, config.range_noise, len(ranges))
            scans.append(np.where(np.isfinite(ranges), np.maximum(noisy, 0.0), np.inf))
            scan_stamps.append(config.start_time + t)
            people.append((np.array([p.ident for p in crowd.people], dtype=np.int32), positions))
        if step == steps:
            break
        # unicycle towards the next route point
        goal = route[target]
        if np.hypot(*(goal - pose[:2])) < 0.3:
            target = (target + 1) % len(route)
            goal = route[target]
        error = wrap_angle(math.atan2(goal[1] - pose[1], goal[0] - pose[0]) - pose[2])
        turn = float(np.clip(2.0 * error, -config.max_turn_rate, config.max_turn_rate))
        speed = config.speed * max(0.0, math.cos(error)) ** 2
        heading = pose[2] + 0.5 * turn * dt
        pose = np.array([pose[0] + speed * dt * math.cos(heading),
                         pose[1] + speed * dt * math.sin(heading), wrap_angle(pose[2] + turn * dt)])
        measured_speed = speed * (1.0 + config.speed_bias) + rng_odometry.normal(
            0.0, config.speed_noise)
        measured_turn = turn * (1.0 + config.turn_bias) + rng_odometry.normal(
            0.0, config.turn_noise)
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
                       intensities: np.ndarray | None = None):
    """A rosbags ``sensor_msgs/LaserScan`` (no return: inf, as REP 117 asks)."""
    increment = float(angles[1] - angles[0])
    return TYPESTORE.types["sensor_msgs/msg/LaserScan"](
        header=_header(stamp, frame_id), angle_min=float(angles[0]),
        angle_max=float(angles[-1]), angle_increment=increment, time_increment=0.0,
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
                                                config.max_range, rate=config.scan_rate)))
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
    parser.add_argument("--legs", action="store_true",
                        help="the real-laser world: people as two swinging legs, tables and "
                             "chairs on thin legs, people close to walls and furniture")
    args = parser.parse_args(argv)
    params_out = args.params_out or args.out.with_name(args.out.name + ".yaml")
    try:
        config = PeopleSimConfig(seed=args.seed, duration=args.duration, people=args.people,
                                 initial_pose=not args.no_initial_pose,
                                 legs=args.legs).validate()
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
