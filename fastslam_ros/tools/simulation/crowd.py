# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The people simulator's world: the floor and the crowd that walks it (``people_sim``).

The floor is 20 m x 20 m, five rooms off a corridor open at both ends, with furniture, as a
0.05 m evidence grid (``build_map``). People walk a graph of corridor, door and room points at
their own speeds, stop for a while, and leave by the corridor's ends; whoever left is replaced,
after a pause, by a new person (a new id) entering there once the way is clear. People are
solid: they keep PERSONAL_DISTANCE apart and off the walls, step aside to pass each other and
yield rather than block (``Crowd``).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from fastslam_ros.people.grid import OccupancyMap

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
STOP_AHEAD = 1.0
"""The robot stands while a person's centre is within this distance (m) ahead of its centre and
within STOP_HALF_WIDTH of its heading line, as a real robot's safety field makes it."""
STOP_HALF_WIDTH = 0.5
"""Half the width (m) of the robot's path in which a person makes it stand (STOP_AHEAD)."""
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
    long it has been kept from walking on (s), how long it waits before yielding (s), how
    long it still yields (s), and the robot's pose it yields to (stepping out of its way)."""

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
    yield_to: np.ndarray | None = None


def _aside(robot: np.ndarray, position: np.ndarray) -> np.ndarray:
    """The direction across the robot's heading (pose ``robot``) on ``position``'s side."""
    normal = np.array([-math.sin(robot[2]), math.cos(robot[2])])
    return normal if float((position - robot[:2]) @ normal) >= 0.0 else -normal


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
            away = (start - person.position if person.yield_to is None
                    else _aside(person.yield_to, person.position))
            reference = math.atan2(away[1], away[0])
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
        person.yield_to = None
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
        (a person already that close, the robot having turned towards it, may step anywhere
        not nearer to it)."""
        limit = min(ROBOT_DISTANCE, float(np.linalg.norm(position - robot[:2])))
        return np.linalg.norm(candidates - robot[:2], axis=1) < limit

    def in_the_way(self, robot: np.ndarray) -> list[Person]:
        """The people standing in the robot's path (STOP_AHEAD, STOP_HALF_WIDTH)."""
        heading = np.array([math.cos(robot[2]), math.sin(robot[2])])
        ahead = []
        for person in self.people:
            offset = person.position - robot[:2]
            along = float(offset @ heading)
            across = float(offset[0] * heading[1] - offset[1] * heading[0])
            if 0.0 < along < STOP_AHEAD and abs(across) < STOP_HALF_WIDTH:
                ahead.append(person)
        return ahead

    def make_way(self, robot: np.ndarray) -> None:
        """The people in the robot's path step aside for 1-2 s (a standing one too), as people
        do for a robot that waits for them."""
        for person in self.in_the_way(robot):
            person.pause = 0.0
            person.yielding = float(self.rng.uniform(1.0, 2.0))
            person.yield_to = robot.copy()

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
