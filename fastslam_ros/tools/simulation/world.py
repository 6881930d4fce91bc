# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Landmark worlds: the generative model behind the simulator's bags and the in-memory worlds.

One model for ``fastslam-sim`` (``simulation/sim.py``, written to bags) and for the core's tests
and ``fastslam-bench`` (``simulation/synthetic.py``, kept in memory): point landmarks scattered
at least a minimum distance apart, a true path, odometry that drifts from it, and a range-
bearing sensor (:class:`RangeBearingSensor`) that detects each landmark within its reach with a
probability, adds Gaussian range and bearing noise, and reports Poisson clutter. Vehicles drive
the worlds: a car (:class:`Car`, a bicycle model steering towards waypoints) and a differential-
drive robot (:class:`DifferentialDrive`) whose odometry integrates noisy controls, as wheel
odometry does, and a robot on a circle (:func:`circle_path`) whose odometry carries the filter's
own odometry-model noise (:func:`odometry_with_noise`), so that tests meet exactly the model the
filter assumes. Plain numpy, no ROS.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from fastslam_ros.core.geometry import relative_pose, wrap_angle
from fastslam_ros.core.motion import OdometryControl, apply_control

# ---------------------------------------------------------------- landmarks


def scatter_landmarks(rng: np.random.Generator, count: int, low, high, min_separation: float,
                      accept: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """``count`` points (count, 2) drawn uniformly in the box ``low``..``high`` (m), kept where
    ``accept`` (a mask of (K, 2) candidates) allows, at least ``min_separation`` apart.

    Candidates come in batches and are taken greedily in the order drawn.
    """
    accepted = np.zeros((0, 2))
    for _ in range(200):
        candidates = rng.uniform(low, high, size=(4 * count, 2))
        if accept is not None:
            candidates = candidates[accept(candidates)]
        for candidate in candidates:
            if len(accepted) == count:
                return accepted
            nearest = (np.min(np.linalg.norm(accepted - candidate, axis=1)) if len(accepted)
                       else np.inf)
            if nearest >= min_separation:
                accepted = np.vstack([accepted, candidate])
        if len(accepted) == count:
            return accepted
    raise ValueError(f"cannot place {count} landmarks {min_separation} m apart "
                     f"(placed {len(accepted)}); lower num_landmarks or min_separation")


def distance_to_route(points: np.ndarray, route: np.ndarray) -> np.ndarray:
    """Distance (m) of each point (K, 2) to the closed polyline ``route`` (W, 2)."""
    starts, ends = route, np.roll(route, -1, axis=0)
    segment = ends - starts
    length_sq = np.maximum(np.sum(segment**2, axis=1), 1e-12)
    offset = points[:, None, :] - starts[None, :, :]
    along = np.clip(np.sum(offset * segment[None], axis=2) / length_sq, 0.0, 1.0)
    closest = starts[None] + along[..., None] * segment[None]
    return np.min(np.linalg.norm(points[:, None, :] - closest, axis=2), axis=1)


# ---------------------------------------------------------------- sensor


@dataclass
class Reading:
    """One sensor reading: ranges (m), bearings (rad, sensor frame) and labels (K,) each; the
    label of a detection is the row of its landmark, -1 for clutter."""

    ranges: np.ndarray
    bearings: np.ndarray
    labels: np.ndarray


@dataclass(frozen=True)
class RangeBearingSensor:
    """A range-bearing sensor at the vehicle's origin, looking forward (SI units, radians).

    Each landmark within ``min_range``..``max_range`` and within ``field_of_view`` (the full
    opening, centred on the vehicle's heading; 2 pi sees all around) is detected with
    ``detection_probability``, its range and bearing off by N(0, sigma_range) and
    N(0, sigma_bearing); each reading adds
    Poisson(``clutter_rate``) false detections, spread evenly over the area the sensor reaches
    (``clutter_spread="area"``, as false returns from anywhere in view) or evenly over range and
    bearing (``"range"``, the outlier density the filter assumes, which puts more of them near
    the sensor). Nothing is reported beyond ``max_range`` or outside the field of view.
    """

    max_range: float
    sigma_range: float
    sigma_bearing: float
    detection_probability: float = 1.0
    clutter_rate: float = 0.0
    clutter_spread: Literal["area", "range"] = "area"
    field_of_view: float = 2.0 * math.pi
    min_range: float = 0.0
    """Landmarks nearer than this (m) are not detected (a laser's blind zone)."""
    landmark_radius: float = 0.0
    """Radius (m) of the landmarks (tubes): a detection reports the point of the surface
    facing the sensor, this much nearer than the centre the map should hold."""

    def __post_init__(self):
        if self.clutter_spread not in ("area", "range"):
            raise ValueError(f"clutter_spread: must be 'area' or 'range' "
                             f"(got {self.clutter_spread!r})")
        if not 0.0 < self.field_of_view <= 2.0 * math.pi:
            raise ValueError(f"field_of_view: must be in (0, 2 pi] (got {self.field_of_view})")

    def observe(self, pose: np.ndarray, landmarks: np.ndarray,
                rng: np.random.Generator) -> Reading:
        """A noisy reading of ``landmarks`` (N, 2) from the true ``pose`` (x, y, theta)."""
        offset = landmarks - pose[:2]
        ranges = np.hypot(offset[:, 0], offset[:, 1])
        half = 0.5 * self.field_of_view
        true_bearings = wrap_angle(np.arctan2(offset[:, 1], offset[:, 0]) - pose[2])
        in_view = (ranges <= self.max_range) & (ranges >= self.min_range)
        if half < math.pi:
            in_view &= np.abs(true_bearings) <= half
        visible = np.flatnonzero(in_view)
        detected = visible[rng.random(len(visible)) < self.detection_probability]
        bearings = true_bearings[detected]
        measured_range = (ranges[detected] - self.landmark_radius
                          + rng.normal(0.0, self.sigma_range, len(detected)))
        measured_bearing = bearings + rng.normal(0.0, self.sigma_bearing, len(detected))
        labels = detected
        clutter_count = rng.poisson(self.clutter_rate) if self.clutter_rate > 0 else 0
        if clutter_count:
            spread = rng.random(clutter_count)
            clutter_range = self.max_range * (np.sqrt(spread) if self.clutter_spread == "area"
                                              else spread)
            clutter_bearing = rng.uniform(-half, half, clutter_count)
            measured_range = np.concatenate([measured_range, clutter_range])
            measured_bearing = np.concatenate([measured_bearing, clutter_bearing])
            labels = np.concatenate([labels, np.full(clutter_count, -1)])
        measured_bearing = wrap_angle(measured_bearing)
        keep = ((measured_range > 0.0) & (measured_range <= self.max_range)
                & (measured_range >= self.min_range))
        if half < math.pi:
            # A detection whose noisy bearing falls outside the opening is not reported.
            keep &= np.abs(measured_bearing) <= half
        return Reading(measured_range[keep], measured_bearing[keep], labels[keep])


# ---------------------------------------------------------------- vehicles and odometry


def bicycle_step(pose: np.ndarray, speed: float, steer: float, wheelbase: float,
                 dt: float) -> np.ndarray:
    """Rear-axle bicycle model, one step of ``dt`` s (midpoint heading)."""
    turn = speed * dt * math.tan(steer) / wheelbase
    heading = pose[2] + 0.5 * turn
    return np.array([pose[0] + speed * dt * math.cos(heading),
                     pose[1] + speed * dt * math.sin(heading),
                     wrap_angle(pose[2] + turn)])


@dataclass(frozen=True)
class Car:
    """A car-like vehicle that drives waypoints at constant speed (SI units, radians).

    It steers towards the next waypoint within the steering angle and rate limits; its
    odometry integrates the commanded speed and steering angle with Gaussian noise on each
    control step, so it drifts like wheel odometry.
    """

    speed: float
    wheelbase: float
    max_steer: float
    max_steer_rate: float
    waypoint_radius: float
    """A waypoint is reached within this distance (m)."""
    sigma_speed: float
    """Speed noise standard deviation per control step (m/s)."""
    sigma_steer: float
    """Steering noise standard deviation per control step (rad)."""

    def drive(self, route: np.ndarray, laps: int, control_rate: float,
              rng: np.random.Generator, duration: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """True and odometry poses (T, 3), one per control step at ``control_rate`` Hz.

        The car starts at the route's first point heading to the second, drives the closed
        route ``laps`` times and on to its second point again, or stops after ``duration`` s
        (when > 0).
        """
        dt = 1.0 / control_rate
        targets = [i % len(route) for i in range(1, laps * len(route) + 2)]
        start = route[0]
        first_heading = math.atan2(route[1][1] - start[1], route[1][0] - start[0])
        true_pose = np.array([start[0], start[1], first_heading])
        odometry_pose = true_pose.copy()
        steer = 0.0
        true_poses, odometry_poses = [true_pose], [odometry_pose]
        if duration > 0:
            max_steps = int(round(duration * control_rate))
        else:  # a car that cannot reach a waypoint (too tight a turn) circles; stop it anyway
            route_length = np.sum(np.linalg.norm(np.diff(route, axis=0, append=route[:1]),
                                                 axis=1))
            max_steps = int(10 * route_length * (laps + 1) / self.speed * control_rate)
        while targets and len(true_poses) <= max_steps:
            target = route[targets[0]]
            if np.hypot(*(target - true_pose[:2])) < self.waypoint_radius:
                targets.pop(0)
                continue
            wanted = wrap_angle(math.atan2(target[1] - true_pose[1], target[0] - true_pose[0])
                                - true_pose[2])
            wanted = float(np.clip(wanted, -self.max_steer, self.max_steer))
            max_change = self.max_steer_rate * dt
            steer += float(np.clip(wanted - steer, -max_change, max_change))
            true_pose = bicycle_step(true_pose, self.speed, steer, self.wheelbase, dt)
            noisy_speed = self.speed + rng.normal(0.0, self.sigma_speed)
            noisy_steer = steer + rng.normal(0.0, self.sigma_steer)
            odometry_pose = bicycle_step(odometry_pose, noisy_speed, noisy_steer,
                                         self.wheelbase, dt)
            true_poses.append(true_pose)
            odometry_poses.append(odometry_pose)
        return np.array(true_poses), np.array(odometry_poses)


@dataclass(frozen=True)
class DifferentialDrive:
    """A differential-drive robot that drives waypoints (SI units, radians).

    It turns towards the next waypoint at a rate proportional to the heading error (at most
    ``max_turn_rate``) and slows with the cosine of that error (turning on the spot when the
    waypoint is behind it). Its odometry integrates the commanded speed and turn rate with
    Gaussian noise on each control step, as wheel encoders drift.
    """

    speed: float
    max_turn_rate: float
    waypoint_radius: float
    """A waypoint is reached within this distance (m)."""
    sigma_speed: float
    """Speed noise standard deviation per control step (m/s)."""
    sigma_turn_rate: float
    """Turn-rate noise standard deviation per control step (rad/s)."""
    turn_gain: float = 2.0
    """Turn rate per radian of heading error (1/s)."""
    faults: "OdometryFaults | None" = None
    """Episodes in which the robot does not do what its odometry reports; None: none."""

    def drive(self, route: np.ndarray, laps: int, control_rate: float,
              rng: np.random.Generator, duration: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """True and odometry poses (T, 3), as ``Car.drive``."""
        dt = 1.0 / control_rate
        targets = [i % len(route) for i in range(1, laps * len(route) + 2)]
        first_heading = math.atan2(route[1][1] - route[0][1], route[1][0] - route[0][0])
        true_pose = np.array([route[0][0], route[0][1], first_heading])
        odometry_pose = true_pose.copy()
        true_poses, odometry_poses = [true_pose], [odometry_pose]
        # Every drive starts with no episode under way (the vehicle itself is immutable).
        faults = None if self.faults is None else replace(self.faults, turn_left=0.0,
                                                          slip_left=0.0)
        route_length = np.sum(np.linalg.norm(np.diff(route, axis=0, append=route[:1]), axis=1))
        max_steps = int(round(duration * control_rate)) if duration > 0 else int(
            10 * route_length * (laps + 1) / self.speed * control_rate)
        while targets and len(true_poses) <= max_steps:
            target = route[targets[0]]
            if np.hypot(*(target - true_pose[:2])) < self.waypoint_radius:
                targets.pop(0)
                continue
            error = wrap_angle(math.atan2(target[1] - true_pose[1], target[0] - true_pose[0])
                               - true_pose[2])
            turn_rate = float(np.clip(self.turn_gain * error, -self.max_turn_rate,
                                      self.max_turn_rate))
            speed = self.speed * max(math.cos(error), 0.0)
            executed_speed, executed_turn = (speed, turn_rate) if faults is None else \
                faults.executed(speed, turn_rate, dt, rng)
            true_pose = unicycle_step(true_pose, executed_speed, executed_turn, dt)
            odometry_pose = unicycle_step(odometry_pose,
                                          speed + rng.normal(0.0, self.sigma_speed),
                                          turn_rate + rng.normal(0.0, self.sigma_turn_rate), dt)
            true_poses.append(true_pose)
            odometry_poses.append(odometry_pose)
        return np.array(true_poses), np.array(odometry_poses)


@dataclass
class OdometryFaults:
    """Episodes of a differential drive whose odometry integrates the commanded velocities:
    a commanded turn not executed (the robot goes on straight while its odometry turns) and
    wheel slip (the robot covers ``1 - SLIP_LOSS`` of the commanded distance), as MRCLAM's
    robots show. Episodes start at random (Poisson, per minute) and last ``duration`` s."""

    turn_rate: float
    """Turn-fault episodes per minute."""
    slip_rate: float
    """Slip episodes per minute."""
    duration: float
    """Length of an episode (s)."""
    turn_left: float = 0.0
    slip_left: float = 0.0

    SLIP_LOSS = 0.7
    """Share of the commanded distance a slipping robot does not cover."""

    def executed(self, speed: float, turn_rate: float, dt: float,
                 rng: np.random.Generator) -> tuple[float, float]:
        """(speed, turn rate) the robot executes this control step of ``dt`` s."""
        self.turn_left, self.slip_left = self.turn_left - dt, self.slip_left - dt
        if self.turn_left <= 0.0 and rng.random() < self.turn_rate * dt / 60.0:
            self.turn_left = self.duration
        if self.slip_left <= 0.0 and rng.random() < self.slip_rate * dt / 60.0:
            self.slip_left = self.duration
        return (speed * (1.0 - self.SLIP_LOSS) if self.slip_left > 0.0 else speed,
                0.0 if self.turn_left > 0.0 else turn_rate)


def unicycle_step(pose: np.ndarray, speed: float, turn_rate: float, dt: float) -> np.ndarray:
    """One step of ``dt`` s at ``speed`` (m/s) and ``turn_rate`` (rad/s), midpoint heading."""
    heading = pose[2] + 0.5 * turn_rate * dt
    return np.array([pose[0] + speed * dt * math.cos(heading),
                     pose[1] + speed * dt * math.sin(heading),
                     wrap_angle(pose[2] + turn_rate * dt)])


def circle_path(radius: float, num_steps: int, laps: float) -> np.ndarray:
    """Poses (num_steps + 1, 3) evenly spaced on a counter-clockwise circle about the origin,
    ``laps`` times round, starting at (radius, 0) heading along +y."""
    angles = 2.0 * np.pi * laps * np.arange(num_steps + 1) / num_steps
    return np.column_stack([radius * np.cos(angles), radius * np.sin(angles),
                            wrap_angle(angles + 0.5 * np.pi)])


def odometry_with_noise(truth: np.ndarray, noise: tuple[float, float, float],
                        rng: np.random.Generator) -> np.ndarray:
    """Odometry poses (T, 3) that start at ``truth[0]`` and drift from the path ``truth``.

    The odometry motion model: each step's (rot1, trans, rot2) is corrupted by
    N(0, noise[0]) rad, a relative N(0, noise[1]) scale error and N(0, noise[2]) rad.
    """
    errors = rng.normal(0.0, noise, size=(len(truth) - 1, 3))
    odometry = np.empty_like(truth)
    odometry[0] = truth[0]
    for k, delta in enumerate(relative_pose(truth[:-1], truth[1:])):
        control = OdometryControl.from_delta(delta)
        odometry[k + 1] = apply_control(odometry[k:k + 1], control.rot1 + errors[k, 0],
                                        control.trans * (1.0 + errors[k, 1]),
                                        control.rot2 + errors[k, 2])[0]
    return odometry
