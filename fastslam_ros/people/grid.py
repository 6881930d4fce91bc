# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The known map as an evidence grid, its likelihood field, and ray casting (ROS-free).

Cells are free, occupied or unknown (nav2's convention: occupancy >= ``occupied_threshold`` is
occupied, <= ``free_threshold`` free, -1 unknown). The likelihood field holds, for every cell,
the distance (m) to the nearest occupied cell (a Euclidean distance transform), clipped at
``max_distance``: a beam ending at distance d from every obstacle is explained by the map with
likelihood N(d; 0, sigma_hit^2). Row r, column c of the grid is the cell whose lower-left corner
is at origin + (c, r) * resolution (map_server's layout, row 0 at the bottom).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import distance_transform_edt

FREE_THRESHOLD = 25
"""Occupancy (0-100) at or below which a cell is free (nav2 map_server's free_thresh 0.25)."""
OCCUPIED_THRESHOLD = 65
"""Occupancy at or above which a cell is occupied (nav2 map_server's occupied_thresh 0.65)."""


@dataclass
class OccupancyMap:
    """A planar evidence grid: ``occupied``/``free`` (H, W) masks, cell size (m), origin (m).

    The origin is the map-frame position of the lower-left corner of cell (0, 0); rotated map
    origins are not supported (nav2 maps have yaw 0).
    """

    occupied: np.ndarray
    free: np.ndarray
    resolution: float
    origin: tuple[float, float] = (0.0, 0.0)
    max_distance: float = 2.0
    """Distances in the likelihood field are clipped here (m)."""
    distance: np.ndarray = field(init=False, repr=False)
    """(H, W) distance (m) from each cell centre to the nearest occupied cell, clipped."""

    def __post_init__(self) -> None:
        self.occupied = np.asarray(self.occupied, dtype=bool)
        self.free = np.asarray(self.free, dtype=bool) & ~self.occupied
        if self.occupied.ndim != 2 or self.occupied.shape != self.free.shape:
            raise ValueError("occupied and free must be (H, W) masks of one shape")
        if not self.resolution > 0.0:
            raise ValueError(f"resolution must be > 0 (got {self.resolution})")
        if self.occupied.any():
            cells = distance_transform_edt(~self.occupied)
        else:
            cells = np.full(self.occupied.shape, np.inf)
        self.distance = np.minimum(cells * self.resolution, self.max_distance)

    @classmethod
    def from_occupancy(cls, values: np.ndarray, resolution: float,
                       origin: tuple[float, float] = (0.0, 0.0), max_distance: float = 2.0,
                       free_threshold: int = FREE_THRESHOLD,
                       occupied_threshold: int = OCCUPIED_THRESHOLD) -> "OccupancyMap":
        """From (H, W) occupancy values 0-100 (-1 unknown), as nav_msgs/OccupancyGrid holds."""
        values = np.asarray(values)
        return cls(values >= occupied_threshold, (values >= 0) & (values <= free_threshold),
                   resolution, origin, max_distance)

    @property
    def shape(self) -> tuple[int, int]:
        return self.occupied.shape

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of the grid (m)."""
        height, width = self.shape
        x0, y0 = self.origin
        return x0, x0 + width * self.resolution, y0, y0 + height * self.resolution

    def cells(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rows, cols, inside) of the cells holding points (..., 2); outside points get 0, 0."""
        scaled_x = (points[..., 0] - self.origin[0]) * (1.0 / self.resolution)
        scaled_y = (points[..., 1] - self.origin[1]) * (1.0 / self.resolution)
        height, width = self.shape
        inside = (scaled_x >= 0) & (scaled_x < width) & (scaled_y >= 0) & (scaled_y < height)
        cols = np.where(inside, scaled_x, 0).astype(np.intp)
        rows = np.where(inside, scaled_y, 0).astype(np.intp)
        return rows, cols, inside

    def distance_at(self, points: np.ndarray) -> np.ndarray:
        """Likelihood-field distance (m) at points (..., 2); ``max_distance`` off the grid."""
        rows, cols, inside = self.cells(points)
        return np.where(inside, self.distance[rows, cols], self.max_distance)

    def is_free(self, points: np.ndarray) -> np.ndarray:
        """Whether points (..., 2) lie in free cells (off the grid: not free)."""
        rows, cols, inside = self.cells(points)
        return inside & self.free[rows, cols]

    def is_occupied(self, points: np.ndarray) -> np.ndarray:
        """Whether points (..., 2) lie in occupied cells (off the grid: not occupied)."""
        rows, cols, inside = self.cells(points)
        return inside & self.occupied[rows, cols]

    def free_cell_centres(self) -> np.ndarray:
        """(K, 2) map-frame centres of the free cells (where a robot or a person may be)."""
        rows, cols = np.nonzero(self.free)
        return np.stack([self.origin[0] + (cols + 0.5) * self.resolution,
                         self.origin[1] + (rows + 0.5) * self.resolution], axis=1)

    def cast(self, origins: np.ndarray, angles: np.ndarray, max_range: float) -> np.ndarray:
        """Range (m) from each origin (K, 2) along each angle (K,) to the first occupied cell;
        ``inf`` when none is met within ``max_range`` (the grid's edge ends the ray).

        Rays march in steps of half a cell, which places a hit within half a cell of the
        wall's face: for simulation and for the occlusion of the evaluation, not for weights.
        """
        origins = np.asarray(origins, dtype=float).reshape(-1, 2)
        angles = np.asarray(angles, dtype=float).reshape(-1)
        step = 0.5 * self.resolution
        distances = np.arange(1, int(np.ceil(max_range / step)) + 1) * step
        hits = np.full(len(angles), np.inf)
        chunk = max(1, 200_000 // len(distances))
        for start in range(0, len(angles), chunk):
            part = slice(start, start + chunk)
            direction = np.stack([np.cos(angles[part]), np.sin(angles[part])], axis=1)
            points = origins[part, None, :] + distances[None, :, None] * direction[:, None, :]
            blocked = self.is_occupied(points)
            first = np.argmax(blocked, axis=1)
            met = blocked[np.arange(len(first)), first]
            hits[part] = np.where(met, distances[first], np.inf)
        return hits
