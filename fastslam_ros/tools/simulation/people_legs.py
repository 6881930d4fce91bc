# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The people simulator's real-laser world (``fastslam-sim --scenario people --legs``).

A laser at knee height does not see a person as a disc: it sees two legs, each an arc of a few
centimetres, swinging while the person walks, and it sees tables and chairs as their thin
legs. Here each person is two circles of LEG_RADIUS, HIP_WIDTH apart across the walking
direction, swinging +-SWING along it in antiphase (the legs 0.2-0.36 m apart, centre to
centre; together when standing); each table and chair is four circles of FURNITURE_LEG_RADIUS
at its corners. The laser is ray cast against the walls' grid and these circles exactly; the
map given to the tracker holds the furniture legs as the grid cells they touch (as a map built
from scans would). People walk closer to walls and furniture than in the plain world (centre
WALL_CLEARANCE from the nearest occupied cell, anywhere across a corridor), never through a
table's or chair's footprint, and pause beside the tables of the rooms.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from fastslam_ros.people.grid import OccupancyMap

LEG_RADIUS = 0.06
"""Radius of a person's leg at knee height (m)."""
HIP_WIDTH = 0.2
"""Distance between the legs' centres across the walking direction (m)."""
SWING = 0.15
"""Amplitude (m) of a leg's swing along the walking direction at full speed (1 m/s or more):
the legs are up to sqrt(HIP_WIDTH^2 + (2 SWING)^2) = 0.36 m apart."""
STRIDE = 1.3
"""Distance (m) walked per gait cycle (two steps)."""
FURNITURE_LEG_RADIUS = 0.03
"""Radius of a table's or chair's leg (m)."""
WALL_CLEARANCE = 0.3
"""A person's centre stays this far from every occupied cell centre (m): its legs come within
0.05-0.15 m of a wall's face."""
LATERAL = 1.6
"""People walk up to this far (m) to either side of their graph's edges: anywhere across the
4 m corridor, along its walls too."""
TABLES = ((4.0, 5.2, 4.6, 5.4), (10.4, 11.6, 5.4, 6.2), (15.2, 16.2, 4.4, 5.2),
          (3.2, 4.2, 14.6, 15.4), (15.4, 16.4, 15.2, 16.0), (8.4, 9.6, 1.6, 2.4))
"""Tables (x_min, x_max, y_min, y_max) (m), beside the room points where people pause."""
CHAIRS = ((5.6, 5.0), (12.0, 5.8), (15.6, 4.0), (3.7, 14.2), (16.0, 14.6), (8.0, 11.6),
          (13.5, 8.4), (6.5, 8.4), (9.0, 1.2))
"""Chairs (centre) (m), 0.4 m square."""
CHAIR_SIZE = 0.4
LEG_INSET = 0.05
"""A furniture leg's centre sits this far inside its footprint's corner (m)."""


def furniture_footprints() -> list[tuple[float, float, float, float]]:
    """Every table's and chair's footprint (x_min, x_max, y_min, y_max) (m)."""
    half = 0.5 * CHAIR_SIZE
    return list(TABLES) + [(x - half, x + half, y - half, y + half) for x, y in CHAIRS]


def furniture_legs() -> np.ndarray:
    """(K, 2) centres of every table's and chair's legs (m)."""
    legs = []
    for x0, x1, y0, y1 in furniture_footprints():
        for x in (x0 + LEG_INSET, x1 - LEG_INSET):
            for y in (y0 + LEG_INSET, y1 - LEG_INSET):
                legs.append((x, y))
    return np.array(legs)


def circle_ranges(sensor: np.ndarray, world_angles: np.ndarray, centres: np.ndarray,
                  radius: float) -> np.ndarray:
    """Range (B,) from ``sensor`` (x, y, ...), or one sensor per beam (B, >= 2), along each
    world angle to the nearest of the circles ``centres`` (K, 2) of ``radius``; inf where
    none is hit (a sensor inside a circle sees nothing of it)."""
    if len(centres) == 0:
        return np.full(len(world_angles), np.inf)
    direction = np.stack([np.cos(world_angles), np.sin(world_angles)], axis=1)
    origin = np.atleast_2d(np.asarray(sensor, dtype=float))[:, None, :2]      # (B or 1, 1, 2)
    centre = np.asarray(centres, dtype=float)[None, :, :] - origin            # (B or 1, K, 2)
    along = np.einsum("bi,bki->bk", direction, np.broadcast_to(
        centre, (len(direction),) + centre.shape[1:]))                        # (B, K)
    across_sq = np.sum(centre ** 2, axis=2) - along ** 2
    hit = along - np.sqrt(np.clip(radius ** 2 - across_sq, 0.0, None))
    return np.where((across_sq < radius ** 2) & (hit > 0.0), hit, np.inf).min(axis=1)


@dataclass
class Gait:
    """Per person id: the walking heading (rad, kept while standing) and the gait phase (rad)."""

    heading: dict[int, float] = field(default_factory=dict)
    phase: dict[int, float] = field(default_factory=dict)

    def legs(self, idents: list[int], positions: np.ndarray, velocities: np.ndarray,
             dt: float) -> np.ndarray:
        """(2K, 2) leg centres of people at ``positions`` (K, 2) walking at ``velocities``
        (K, 2), the gait advanced by ``dt`` s: legs HIP_WIDTH apart across the heading,
        swinging in antiphase along it by SWING x min(speed, 1 m/s) sin(phase)."""
        legs = np.zeros((2 * len(idents), 2))
        for k, ident in enumerate(idents):
            speed = float(np.linalg.norm(velocities[k]))
            if speed > 0.05:
                self.heading[ident] = math.atan2(velocities[k][1], velocities[k][0])
            heading = self.heading.setdefault(ident, 1.3 * ident)
            phase = self.phase.get(ident, 2.1 * ident) + 2.0 * math.pi * speed * dt / STRIDE
            self.phase[ident] = phase
            forward = np.array([math.cos(heading), math.sin(heading)])
            left = np.array([-forward[1], forward[0]])
            swing = SWING * min(speed, 1.0) * math.sin(phase)
            legs[2 * k] = positions[k] + 0.5 * HIP_WIDTH * left + swing * forward
            legs[2 * k + 1] = positions[k] - 0.5 * HIP_WIDTH * left - swing * forward
        return legs


class LegWorld:
    """The real-laser world: walls, furniture legs, walkable cells, and the laser's ray cast.

    ``walls`` is the plain world's grid (cast against), ``map`` adds the furniture legs'
    cells (the tracker's map), ``walkable`` the cells a person's centre may be in."""

    def __init__(self, walls: OccupancyMap) -> None:
        self.walls = walls
        self.furniture = furniture_legs()
        occupied = walls.occupied.copy()
        height, width = walls.shape
        res = walls.resolution
        cols, rows = np.meshgrid(np.arange(width), np.arange(height))
        centres_x = walls.origin[0] + (cols + 0.5) * res
        centres_y = walls.origin[1] + (rows + 0.5) * res
        reach = FURNITURE_LEG_RADIUS + 0.5 * res * math.sqrt(2.0)
        for x, y in self.furniture:   # the cells a leg touches
            near = (np.abs(centres_x - x) <= reach) & (np.abs(centres_y - y) <= reach)
            occupied |= near & (np.hypot(centres_x - x, centres_y - y) <= reach)
        self.map = OccupancyMap(occupied, ~occupied, res, walls.origin, walls.max_distance)
        blocked = np.zeros_like(occupied)
        margin = 0.25  # a body's half depth: no one stands inside a table or chair
        for x0, x1, y0, y1 in furniture_footprints():
            blocked |= ((centres_x >= x0 - margin) & (centres_x <= x1 + margin)
                        & (centres_y >= y0 - margin) & (centres_y <= y1 + margin))
        self.walkable = self.map.free & (self.map.distance >= WALL_CLEARANCE) & ~blocked
        self.gait = Gait()

    def cast(self, sensor: np.ndarray, angles: np.ndarray, idents: list[int],
             positions: np.ndarray, velocities: np.ndarray, dt: float, max_range: float
             ) -> tuple[np.ndarray, np.ndarray]:
        """True ranges (B,) from ``sensor`` (x, y, theta), or one pose per beam (B, 3), against
        walls, furniture legs and the people's legs (advanced by ``dt`` s of gait), inf beyond
        ``max_range``; and the legs (2K, 2)."""
        world = sensor[..., 2] + angles
        ranges = self.walls.cast(np.broadcast_to(sensor[..., :2], (len(angles), 2)), world,
                                 max_range)
        ranges = np.minimum(ranges, circle_ranges(sensor, world, self.furniture,
                                                  FURNITURE_LEG_RADIUS))
        legs = self.gait.legs(idents, positions, velocities, dt)
        ranges = np.minimum(ranges, circle_ranges(sensor, world, legs, LEG_RADIUS))
        return np.where(ranges <= max_range, ranges, np.inf), legs
