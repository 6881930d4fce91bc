# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A laser scan, and people detected in it: beams ending in free space away from obstacles.

The scan is cut into segments (runs of neighbouring beams whose ranges differ by less than
``segment_jump``) once, in the sensor frame. Which beams of a segment end away from the map's
obstacles depends on the robot pose, so it is decided per robot particle (``far`` (M, B)); a
segment holding at least ``min_detection_beams`` such beams, no wider than
``max_person_width``, is one person for that particle, placed at the middle bearing of those
beams and at their nearest range plus ``person_radius`` (the beams hit the person's front).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fastslam_ros.core.geometry import wrap_angle
from fastslam_ros.core.sweep import at_first_beam
from fastslam_ros.people.grid import OccupancyMap

SHORT_FLOOR_CELLS = 1.5
"""A beam ending in a cell next to a mapped obstacle (its centre within this many cells of an
occupied one: the eight neighbours) is never dynamic by the expected-range rule: at a grazing
angle along a wall, or past a corner it clipped (its range noise puts its end in the free cell
diagonal to the corner), the map's expected range is not meaningful."""


@dataclass(frozen=True)
class Scan:
    """One planar laser reading in the sensor frame: ``ranges`` (B,) m (inf: no return, the
    beam saw free space; NaN: no evidence at all) at ``angles`` (B,) rad, evenly spaced from
    ``angle_min`` by ``angle_increment``; beam i taken ``i * time_increment`` s after the
    first (``LaserScan.time_increment``; 0: all at once)."""

    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_max: float = np.inf
    time_increment: float = 0.0

    @property
    def angles(self) -> np.ndarray:
        return wrap_angle(self.angle_min + self.angle_increment * np.arange(len(self.ranges)))

    def returns(self, min_range: float, max_range: float) -> np.ndarray:
        """Mask of the beams that hit something: finite, in [min_range, min(max_range,
        range_max))."""
        limit = min(max_range, self.range_max)
        with np.errstate(invalid="ignore"):
            return np.isfinite(self.ranges) & (self.ranges >= min_range) & (self.ranges < limit)

    def _steps(self, bearings: np.ndarray) -> tuple[np.ndarray, float, bool]:
        """(beams from the first beam to each bearing, counted the scan's way round in
        [0, a full turn), beams in a full turn, whether the scan covers a full turn)."""
        turn = 2.0 * np.pi / abs(self.angle_increment)
        steps = np.mod((np.asarray(bearings, float) - self.angle_min) / self.angle_increment,
                       turn)
        return steps, turn, len(self.ranges) >= turn - 1e-6

    def beam_index(self, bearings: np.ndarray) -> np.ndarray:
        """Index of the beam nearest each bearing (rad), wrapping round a full turn; a bearing
        outside a partial scan's span takes the nearer of its end beams (``covers`` tells)."""
        count = len(self.ranges)
        steps, turn, full_turn = self._steps(bearings)
        if full_turn:
            return np.mod(np.rint(steps), count).astype(np.intp)
        beyond = steps > count - 1
        nearer_last = steps - (count - 1) < turn - steps
        return np.where(beyond, np.where(nearer_last, count - 1, 0),
                        np.rint(steps)).astype(np.intp)

    def range_toward(self, bearings: np.ndarray, min_range: float) -> np.ndarray:
        """The range measured along each bearing (rad) by its nearest beam: inf for no return
        or one below ``min_range`` (free space), NaN for no evidence (every comparison false)."""
        ranges = np.where(np.isnan(self.ranges) | (self.ranges >= min_range), self.ranges,
                          np.inf)
        return ranges[self.beam_index(bearings)]

    def covers(self, bearings: np.ndarray) -> np.ndarray:
        """Whether each bearing (rad) lies within the scan's span (up to half a beam beyond its
        end beams): a partial scan (a 270-degree laser) sees nothing behind it."""
        steps, turn, full_turn = self._steps(bearings)
        if full_turn:
            return np.ones(steps.shape, bool)
        return (steps <= len(self.ranges) - 0.5) | (steps >= turn - 0.5)


def deskewed(scan: Scan, yaw_rate: float, velocity: tuple[float, float] = (0.0, 0.0)) -> Scan:
    """The scan as the laser would have seen it all at once from where it was at the first
    beam, for a laser turning at ``yaw_rate`` (rad/s) and moving at ``velocity`` (m/s, in its
    own frame) while it swept the beams ``time_increment`` apart. The turn alone keeps the
    bearings evenly spaced, ``angle_increment + yaw_rate * time_increment`` apart; the travel
    moves each return by up to speed x sweep time, so every return is placed at its point
    seen from the first beam's pose, in the nearest beam of that spacing (the nearer return
    where two meet; a beam left with none carries no evidence)."""
    increment = scan.angle_increment + yaw_rate * scan.time_increment
    moved = Scan(scan.ranges, scan.angle_min, increment, scan.range_max, scan.time_increment)
    if velocity == (0.0, 0.0) or scan.time_increment == 0.0:
        return moved
    count = len(scan.ranges)
    hit = np.flatnonzero(np.isfinite(scan.ranges))
    taken = scan.angle_min + scan.angle_increment * hit            # as the laser took them
    x, y = at_first_beam(scan.ranges[hit] * np.cos(taken), scan.ranges[hit] * np.sin(taken),
                         scan.time_increment * hit, yaw_rate, velocity)
    bearing = scan.angle_min + increment * hit                     # their beams, deskewed
    seen = np.arctan2(y, x)
    seen += 2.0 * np.pi * np.rint((bearing - seen) / (2.0 * np.pi))   # unwrapped near its beam
    beam = np.rint((seen - scan.angle_min) / increment).astype(np.intp)
    inside = (beam >= 0) & (beam < count)
    placed = np.full(count, np.inf)
    np.minimum.at(placed, beam[inside], np.hypot(x, y)[inside])
    ranges = scan.ranges.astype(float)
    ranges[hit] = np.nan
    ranges = np.where(np.isfinite(placed), placed, ranges)
    return Scan(ranges, scan.angle_min, increment, scan.range_max, scan.time_increment)


@dataclass
class Segments:
    """Beams (indices into the scan, in scan order but starting at a break) grouped into
    segments: ``beams`` (K,), ``starts`` (S,) offsets of each segment in ``beams``,
    ``ranges`` (K,) and unwrapped ``angles`` (K,) of those beams."""

    beams: np.ndarray
    starts: np.ndarray
    ranges: np.ndarray
    angles: np.ndarray


def mixed_pixels(ranges: np.ndarray, jump: float) -> np.ndarray:
    """(B,) returns that lie alone between a nearer and a farther neighbour, each more than
    ``jump`` away in range: a real laser's mixed pixels (its spot straddling an object's
    silhouette and the background behind it returns a range between them, in free space)."""
    before, after = np.roll(ranges, 1), np.roll(ranges, -1)
    with np.errstate(invalid="ignore"):
        step_before, step_after = ranges - before, after - ranges
        mixed = (((step_before > jump) & (step_after > jump))
                 | ((step_before < -jump) & (step_after < -jump)))
    mixed[[0, -1]] = False     # at a partial scan's ends (a full turn's: rarely one)
    return mixed & np.isfinite(ranges)


def without_mixed_pixels(far: np.ndarray, segments: Segments, ranges: np.ndarray,
                         mixed: np.ndarray, reach: float, lone_range: float) -> np.ndarray:
    """The dynamic beams ``far`` (M, K) but a real laser's mixed pixels: a lone return between
    a nearer and a farther neighbour (``mixed`` (B,), ``mixed_pixels`` of the scan's
    ``ranges`` (B,), inf where no return) stays dynamic for a particle only if that particle
    takes its nearer neighbour for dynamic (at a chair leg's or a door jamb's silhouette it
    is a mixed pixel) and it is within ``reach`` (m) behind it (the other leg of the same
    person), or beyond ``lone_range`` (m), where a leg returns a single beam (partly hidden
    by a nearer person); a mixed pixel at a person's silhouette lies anywhere between the
    person and the background, mostly farther."""
    lone = np.flatnonzero(mixed[segments.beams])
    if len(lone) == 0:
        return far
    count = len(ranges)
    beam = segments.beams[lone]
    before, after = (beam - 1) % count, (beam + 1) % count
    nearer = np.where(ranges[before] < ranges[after], before, after)
    position = np.full(count, -1)
    position[segments.beams] = np.arange(len(segments.beams))
    index = position[nearer]
    plausible = (index >= 0) & ((ranges[beam] - ranges[nearer] <= reach)
                                | (ranges[beam] > lone_range))
    far = far.copy()
    far[:, lone] &= plausible & far[:, np.maximum(index, 0)]
    return far


MIXED_PIXEL_SHARE = 0.05
"""``mixed_pixel_filter: auto`` filters while more than this share of the static
depth edges seen are bridged by a lone return in free space (``static_edges``): a laser that
returns mixed pixels (a tenth or more of the edges at P = 0.2 in the simulator), where people's
legs alone bridge fewer than one in a hundred."""
MIXED_PIXEL_EDGES = 50
"""Static depth edges ``auto`` counts before it judges the laser (a few scans in a room)."""


def static_edges(ranges: np.ndarray, dynamic: np.ndarray, mixed: np.ndarray,
                 jump: float) -> tuple[int, int]:
    """(depth edges between two static returns, of them bridged by a lone dynamic return) in
    one scan: ``ranges`` (B,) (inf where no return), ``dynamic`` (B,) the beams one robot pose
    takes for dynamic, ``mixed`` (B,) its lone returns (``mixed_pixels`` with ``jump``). An
    edge is two static returns more than twice ``jump`` apart in range, next to each other or
    with one lone return between them that lies in free space between the two: the share
    bridged is the laser's mixed-pixel rate."""
    static = np.isfinite(ranges) & ~dynamic
    before, after = np.roll(static, 1), np.roll(static, -1)
    bridged = mixed & dynamic & before & after
    with np.errstate(invalid="ignore"):
        gap = np.abs(np.diff(ranges)) > 2.0 * jump
    direct = int((static[:-1] & static[1:] & gap).sum())
    count = int(bridged.sum())
    return direct + count, count


class MixedPixelMonitor:
    """Whether the laser returns mixed pixels, from every static depth edge seen so far
    (``static_edges``: a property of the laser, so counted over the whole run), and whether
    to filter them (``mode``: the ``mixed_pixel_filter`` parameter)."""

    def __init__(self, mode: str = "auto") -> None:
        self.mode = mode
        self.edges = 0
        self.bridged = 0

    def observe(self, ranges: np.ndarray, mixed: np.ndarray, segments: Segments,
                far: np.ndarray, jump: float) -> None:
        """Count one scan's edges (``ranges`` (B,), inf where no return; ``mixed`` (B,) its
        ``mixed_pixels`` with ``jump``) as one robot pose sees them (``far`` (K,): its dynamic
        beams, in the order of ``segments.beams``)."""
        dynamic = np.zeros(len(ranges), dtype=bool)
        dynamic[segments.beams] = far
        edges, bridged = static_edges(ranges, dynamic, mixed, jump)
        self.edges += edges
        self.bridged += bridged

    @property
    def share(self) -> float:
        """Share of the static depth edges bridged by a lone return (0 before any edge)."""
        return self.bridged / self.edges if self.edges else 0.0

    @property
    def filtering(self) -> bool:
        """Whether to filter: ``always``, never with ``never``; with ``auto`` until
        MIXED_PIXEL_EDGES edges were seen (the first scans' ghosts would be tracked for
        seconds), then while the share exceeds MIXED_PIXEL_SHARE."""
        if self.mode != "auto":
            return self.mode == "always"
        return self.edges < MIXED_PIXEL_EDGES or self.share > MIXED_PIXEL_SHARE


def segment_scan(scan: Scan, returns: np.ndarray, jump: float) -> Segments:
    """Cut the returning beams into runs of neighbours closer than ``jump`` in range.

    The scan is rotated to start at a break (a missing return or a jump), so that an object
    seen across the start of a full-turn scan is one segment.
    """
    ranges = np.where(returns, scan.ranges, np.inf)
    count = len(ranges)
    with np.errstate(invalid="ignore"):
        joined = returns & np.roll(returns, 1) & (np.abs(ranges - np.roll(ranges, 1)) <= jump)
    full_turn = abs(scan.angle_increment) * count >= 2.0 * np.pi - 1e-6
    if not full_turn and count:
        joined[0] = False
    breaks = np.flatnonzero(~joined)
    shift = int(breaks[0]) if len(breaks) else 0
    order = np.roll(np.arange(count), -shift)
    keep = returns[order]
    beams = order[keep]
    starts = np.flatnonzero(~joined[order][keep])
    if len(beams) and (len(starts) == 0 or starts[0] != 0):
        starts = np.concatenate([[0], starts])
    angles = np.unwrap(scan.angle_min + scan.angle_increment * beams.astype(float)) \
        if len(beams) else np.zeros(0)
    return Segments(beams, starts.astype(np.intp), scan.ranges[beams].astype(float), angles)


def dynamic_beams(grid: OccupancyMap, sensors: np.ndarray, ends: np.ndarray,
                  distances: np.ndarray, angles: np.ndarray, min_obstacle_distance: float,
                  short_margin: float) -> np.ndarray:
    """(M, K) beams that are evidence of something dynamic, per robot particle (sensor poses
    (M, 3), beam ends (M, K, 2), their likelihood-field ``distances`` (M, K), beam ``angles``
    (K,)): ending in a free cell, and either at least ``min_obstacle_distance`` from every
    mapped obstacle or clearly short of the range the map predicts (no occupied cell within
    ``short_margin`` beyond the end along the beam: ray casting on the grid, for the few
    beams near an obstacle only), so a person beside a wall or a table is seen."""
    free = grid.is_free(ends)
    dynamic = free & (distances >= min_obstacle_distance)
    if short_margin <= 0.0:
        return dynamic
    m, k = np.nonzero(free & ~dynamic
                      & (distances >= SHORT_FLOOR_CELLS * grid.resolution - 1e-9))
    if len(m) == 0:
        return dynamic
    step = 0.5 * grid.resolution
    along = np.arange(1, int(np.ceil(short_margin / step)) + 1) * step
    along[-1] = short_margin
    heading = sensors[m, 2] + angles[k]
    direction = np.stack([np.cos(heading), np.sin(heading)], axis=1)
    points = ends[m, k][:, None, :] + along[None, :, None] * direction[:, None, :]
    dynamic[m, k] = ~grid.is_occupied(points).any(axis=1)
    return dynamic


def beams_needed(min_beams: int, width: float, ranges: np.ndarray, angle_increment: float
                 ) -> np.ndarray:
    """Beams a detection at ``ranges`` must hold: ``min_beams``, or fewer (at least one)
    beyond ``detectable_range(width, min_beams, ...)``, where an object ``width`` (m) wide
    returns fewer than that: a leg far away is one beam, and requiring two would miss it."""
    fits = np.floor(detectable_range(width, 1, angle_increment) / np.maximum(ranges, 1e-9))
    return np.clip(fits, 1, min_beams).astype(np.int64)


def detectable_range(width: float, min_beams: int, angle_increment: float) -> float:
    """Farthest range (m) at which a person ``width`` (m) wide across the beams returns
    ``min_beams`` beams of a scan ``angle_increment`` (rad) apart: beyond it a person in view
    is missed by the beam spacing alone, so not detecting one there is no evidence."""
    return width / (min_beams * max(abs(angle_increment), 1e-9))


@dataclass
class Detections:
    """Per robot particle and candidate segment: ``valid`` (M, S), and the detection's range
    ``ranges`` (M, S) and ``bearings`` (M, S) in the sensor frame."""

    valid: np.ndarray
    ranges: np.ndarray
    bearings: np.ndarray
    paired: np.ndarray | None = None
    """(M, S) the detection is two legs seen apart (strong evidence of a person); None: no
    such distinction (``detect_people``)."""
    sparse: np.ndarray | None = None
    """(M, S) the person is farther than the range within which one leg always returns a
    beam, so the beam spacing misses it in some scans and a second detection may come scans
    later; None: not judged (one leg returns ``min_beams`` at any range)."""


def detect_people(segments: Segments, far: np.ndarray, min_beams: int, max_width: float,
                  person_radius: float) -> Detections:
    """People per particle from the beams ending away from obstacles (``far`` (M, K), in the
    order of ``segments.beams``)."""
    particles = far.shape[0]
    if len(segments.starts) == 0:
        empty = np.zeros((particles, 0))
        return Detections(empty.astype(bool), empty, empty)
    count = np.add.reduceat(far.astype(np.int32), segments.starts, axis=1)
    candidate = (count >= min_beams).any(axis=0)
    if not candidate.any():
        empty = np.zeros((particles, 0))
        return Detections(empty.astype(bool), empty, empty)
    nearest = np.minimum.reduceat(np.where(far, segments.ranges, np.inf), segments.starts, axis=1)
    first = np.minimum.reduceat(np.where(far, segments.angles, np.inf), segments.starts, axis=1)
    last = np.maximum.reduceat(np.where(far, segments.angles, -np.inf), segments.starts, axis=1)
    count, nearest = count[:, candidate], nearest[:, candidate]
    first, last = first[:, candidate], last[:, candidate]
    with np.errstate(invalid="ignore"):
        width = 2.0 * nearest * np.sin(0.5 * np.clip(last - first, 0.0, np.pi))
        valid = (count >= min_beams) & (width <= max_width)
        bearings = np.where(valid, wrap_angle(np.where(valid, 0.5 * (first + last), 0.0)), 0.0)
    ranges = np.where(valid, nearest + person_radius, 0.0)
    return Detections(valid, ranges, bearings)


ARC_DEPTH = math.pi / 4.0
"""The mean of a circle's front arc, hit at an even spacing across the line of sight, lies
this many radii in front of its centre (the mean of sqrt(R^2 - u^2) over u in [-R, R])."""
ARC_FIT_BEAMS = 3
"""A cluster wider than a leg with at least this many beams is fitted with a circle."""
ARC_FIT_TOLERANCE = 0.05
"""A fitted circle passes within this distance (m) of every beam end of its cluster."""


@dataclass(frozen=True)
class LegModel:
    """How people look at knee height: legs of ``leg_radius`` (m) whose clusters are at most
    ``max_leg_width`` wide (m; wider, up to ``max_person_width``, is two legs seen as one),
    paired into a person within ``max_leg_spacing`` (m, centre to centre); a person returns
    at least ``min_beams`` beams."""

    leg_radius: float
    max_leg_width: float
    max_leg_spacing: float
    max_person_width: float
    min_beams: int


def leg_clusters(segments: Segments, dynamic: np.ndarray) -> np.ndarray:
    """Offsets (C,) into ``segments.beams`` where clusters start: at each segment's start and
    wherever the reference mask ``dynamic`` (K,) changes (a leg beside a wall is cut off it)."""
    count = len(segments.beams)
    if count == 0:
        return np.zeros(0, dtype=np.intp)
    start = np.zeros(count, dtype=bool)
    start[segments.starts] = True
    start[1:] |= dynamic[1:] != dynamic[:-1]
    start[0] = True
    return np.flatnonzero(start)


def detect_legs(segments: Segments, far: np.ndarray, reference: int, model: LegModel,
                ranges: np.ndarray, angle_increment: float | None) -> Detections:
    """People per robot particle from leg clusters (Arras et al.'s leg model, simplified).

    Clusters are cut in the sensor frame (segments, cut again where the ``reference``
    particle's dynamic mask changes); a cluster is dynamic for particle m when at least half
    of its beams end away from the map (``far`` (M, K)). A cluster's centre is the mean of its
    beam ends pushed back by ARC_DEPTH ``leg_radius`` along its bearing (the beams hit the
    leg's front); a wider one's is the centre of a circle fitted to them (``fit_arc``), if
    one fits.
    Clusters up to ``max_leg_width`` wide are legs; the closest legs within
    ``max_leg_spacing`` of each other are paired (once, in the sensor frame, among the
    reference particle's dynamic clusters). A person is the midpoint of its two legs, or the
    one leg a particle sees (the other occluded); a cluster wider than a leg and up to
    ``max_person_width`` is a person whose legs are seen as one. It returns ``min_beams``
    beams, or, farther than one leg returns that many at ``angle_increment`` (rad), the beams
    one leg returns there (``beams_needed``), unless a leg of it is partly hidden (a beam
    beside it, in the scan's ``ranges`` (B,), ends more than a leg's width nearer: the rest
    of the person may be behind); ``angle_increment`` None: ``min_beams`` at any range (a
    laser with mixed pixels, whose lone returns far away are mostly not legs).
    """
    particles = far.shape[0]
    empty = np.zeros((particles, 0))
    if len(segments.beams) == 0:
        return Detections(empty.astype(bool), empty, empty)
    starts = leg_clusters(segments, far[reference])
    counts = np.diff(np.append(starts, len(segments.beams)))
    candidate = far[reference][starts]
    if not candidate.any():
        return Detections(empty.astype(bool), empty, empty)
    x = segments.ranges * np.cos(segments.angles)
    y = segments.ranges * np.sin(segments.angles)
    points = np.stack([np.add.reduceat(x, starts), np.add.reduceat(y, starts)], axis=1)
    points /= counts[:, None]
    ends = np.stack([x, y], axis=1)
    last = np.append(starts[1:], len(segments.beams)) - 1
    width = np.linalg.norm(ends[last] - ends[starts], axis=1)
    norm = np.maximum(np.linalg.norm(points, axis=1), 1e-9)
    centres = points * ((norm + ARC_DEPTH * model.leg_radius) / norm)[:, None]
    keep = np.flatnonzero(candidate & (width <= model.max_person_width))
    for k in keep[(width[keep] > model.max_leg_width) & (counts[keep] >= ARC_FIT_BEAMS)]:
        fitted = fit_arc(ends[starts[k]:last[k] + 1], 0.5 * model.max_person_width)
        if fitted is not None:
            centres[k] = fitted
    if len(keep) == 0:
        return Detections(empty.astype(bool), empty, empty)
    far_count = np.add.reduceat(far.astype(np.int32), starts, axis=1)[:, keep]   # (M, C)
    seen = 2 * far_count >= counts[keep]
    beams = np.where(seen, counts[keep], 0)
    centres, width = centres[keep], width[keep]
    people = _pair_legs(centres, width, model)                    # (P, 2): -1 for no second
    first, second = people[:, 0], people[:, 1]
    has_second = second >= 0
    second = np.where(has_second, second, first)
    seen_a = seen[:, first]
    seen_b = seen[:, second] & has_second
    both = seen_a & seen_b
    weight_a = np.where(both, 0.5, seen_a.astype(float))
    position = (weight_a[..., None] * centres[first][None]
                + (1.0 - weight_a)[..., None] * centres[second][None])   # (M, P, 2)
    distance = np.hypot(position[..., 0], position[..., 1])
    needed = np.full(distance.shape, model.min_beams)
    if angle_increment is not None:
        hidden = _partly_hidden(segments, starts, last, ranges, 2.0 * model.leg_radius)[keep]
        whole = ~(hidden[first] | (hidden[second] & has_second))
        needed = np.where(whole, beams_needed(model.min_beams, 2.0 * model.leg_radius,
                                              distance, angle_increment), needed)
    valid = (seen_a | seen_b) & (beams[:, first] + np.where(has_second, beams[:, second], 0)
                                 >= needed)
    ranges = np.where(valid, distance, 0.0)
    bearings = np.where(valid, np.arctan2(position[..., 1], position[..., 0]), 0.0)
    sparse = None if angle_increment is None else valid & (
        distance > detectable_range(2.0 * model.leg_radius, 1, angle_increment))
    return Detections(valid, ranges, wrap_angle(bearings), valid & both, sparse)


def _partly_hidden(segments: Segments, starts: np.ndarray, last: np.ndarray,
                   ranges: np.ndarray, depth: float) -> np.ndarray:
    """(C,) whether the beam before a cluster's first or after its last (scan order, wrapping
    round) ends more than ``depth`` nearer than the cluster's nearest beam."""
    count = len(ranges)
    nearest = np.minimum.reduceat(segments.ranges, starts)
    before = ranges[(segments.beams[starts] - 1) % count]
    after = ranges[(segments.beams[last] + 1) % count]
    return np.minimum(before, after) < nearest - depth


def fit_arc(ends: np.ndarray, max_radius: float) -> np.ndarray | None:
    """Centre (2,) of the circle through beam ends (K, 2) (Kasa's algebraic fit), when it is
    a convex arc facing the sensor (centre behind the ends' mean), of radius at most
    ``max_radius``, within ARC_FIT_TOLERANCE of every end; None otherwise (a wide cluster that
    is not one round body: two legs seen as one, a flat object)."""
    design = np.column_stack([ends, np.ones(len(ends))])
    target = -(ends ** 2).sum(axis=1)
    (d, e, f), *_ = np.linalg.lstsq(design, target, rcond=None)
    centre = np.array([-0.5 * d, -0.5 * e])
    radius_sq = centre @ centre - f
    if not radius_sq > 0.0:
        return None
    radius = float(np.sqrt(radius_sq))
    mean = ends.mean(axis=0)
    residual = np.abs(np.linalg.norm(ends - centre, axis=1) - radius).max()
    if radius > max_radius or residual > ARC_FIT_TOLERANCE or centre @ mean <= mean @ mean:
        return None
    return centre


def _pair_legs(centres: np.ndarray, width: np.ndarray, model: LegModel) -> np.ndarray:
    """(P, 2) cluster indices of the people: the closest pair of legs (clusters up to
    ``max_leg_width``) within ``max_leg_spacing`` first, then the next; a leg left alone and
    a wider cluster are a person by themselves (second index -1)."""
    count = len(centres)
    is_leg = width <= model.max_leg_width
    gaps = np.linalg.norm(centres[:, None] - centres[None], axis=2)
    gaps[~is_leg] = np.inf
    gaps[:, ~is_leg] = np.inf
    gaps[np.arange(count), np.arange(count)] = np.inf
    people, used = [], np.zeros(count, dtype=bool)
    for flat in np.argsort(gaps, axis=None):
        a, b = divmod(int(flat), count)
        if gaps[a, b] > model.max_leg_spacing:
            break
        if a < b and not used[a] and not used[b]:
            people.append((a, b))
            used[a] = used[b] = True
    people.extend((k, -1) for k in np.flatnonzero(~used))
    return np.array(people, dtype=np.intp).reshape(-1, 2)
