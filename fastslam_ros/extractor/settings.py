# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Settings of the landmark extractor: one ``parameter(...)`` per field (default, range, meaning).

The node declares one ROS parameter per field, the YAML file and the docs table come from the
same metadata (``fastslam_ros.core.params.specs``), and ``validate()`` fails naming the field.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from fastslam_ros.core.params import ParameterValueError, check_fields, parameter

DETECTORS = ("circles", "reflectors", "both")


@dataclass(frozen=True)
class ExtractorSettings:
    """Every tunable of the landmark extractor (SI units, radians)."""

    detector: str = parameter(
        "circles", "Which landmarks: 'circles' (poles, trunks, legs: circles fitted to scan "
                   "segments), 'reflectors' (clusters of bright beams) or 'both' (a circle "
                   "within max_diameter of a reflector is dropped).", choices=DETECTORS)
    min_range: float = parameter(
        0.1, "Returns nearer than this (m) are ignored; like a return below the scan's "
             "range_min, NaN or -inf (REP 117) they may hide what is behind them.", low=0.0,
        high=1e4)
    max_range: float = parameter(
        30.0, "Returns at or beyond this (m), beyond the scan's range_max or +inf are no "
              "return (free space).", low=0.0, low_exclusive=True, high=1e4)
    segment_jump: float = parameter(
        0.3, "Neighbouring returns whose ranges differ by more than this (m) belong to "
             "different objects; a segment whose neighbour beam is nearer than its edge by more "
             "than this is occluded there and not a landmark.", low=0.0, low_exclusive=True,
        high=100.0)
    min_beams: int = parameter(3, "Circles: returns a segment needs to be fitted.", low=3,
                               high=10000)
    min_diameter: float = parameter(0.05, "Circles: smallest diameter kept (m).", low=0.0,
                                    high=100.0)
    max_diameter: float = parameter(
        0.6, "Circles: largest diameter kept (m); a segment longer than this end to end (a "
             "wall) is never fitted.", low=0.0, low_exclusive=True, high=100.0)
    max_residual: float = parameter(
        0.03, "Circles: largest RMS distance (m) of a segment's returns from its fitted "
              "circle.", low=0.0, low_exclusive=True, high=10.0)
    straight_residual: float = parameter(
        0.005, "Circles: a segment within this RMS distance (m) of its best straight line is "
               "straight (a piece of wall), not a landmark; about half the range noise.",
        low=0.0, high=10.0)
    reflector_intensity: float = parameter(
        0.0, "Reflectors: beams brighter than this are reflector returns; 0: found in each "
             "scan as median + reflector_mads * 1.4826 MAD of its returns' intensities.",
        low=0.0, high=1e12)
    reflector_mads: float = parameter(
        10.0, "Reflectors: with reflector_intensity 0, how many robust standard deviations "
              "above the median intensity a reflector return lies.", low=0.0,
        low_exclusive=True, high=1000.0)
    reflector_min_beams: int = parameter(1, "Reflectors: bright returns a cluster needs.",
                                         low=1, high=10000)
    reflector_max_width: float = parameter(
        0.3, "Reflectors: a wider cluster (m, end to end) is no reflector post (a reflective "
             "sign or wall).", low=0.0, low_exclusive=True, high=100.0)
    reflector_radius: float = parameter(
        0.05, "Reflectors: radius (m) of the posts; the centre is this far behind the "
              "cluster's mean return along the beam.", low=0.0, high=100.0)
    static_window: float = parameter(
        0.0, "Moving objects: a landmark is dropped when the scan about this long (s) or half "
             "as long before saw free space all round it (within static_tolerance, in the "
             "odometry frame): a walker moved there, a pole would have been seen; needs "
             "odometry on odom. 0: off, no odometry needed.", low=0.0, high=10.0)
    static_tolerance: float = parameter(
        0.3, "Moving objects: radius (m) of the disc around a landmark that an earlier scan "
             "must have seen empty (odometry drift and extraction error over static_window).",
        low=0.0, low_exclusive=True, high=10.0)
    static_heading_tolerance: float = parameter(
        0.01, "Moving objects: static_tolerance grows by this much per metre of range (rad: the "
             "odometry's heading error over static_window moves far landmarks most).",
        low=0.0, high=1.0)
    deskew_scans: bool = parameter(
        True, "Correct each landmark for the robot's motion while the laser swept the scan (its "
              "time_increment; the odometry's turn rate and velocity over the sweep, or since "
              "the previous scan when it does not cover the sweep, read on odom; a scan with "
              "time_increment 0 is taken at once). False for a driver whose time_increment is "
              "wrong.")
    sensor_x: float = parameter(0.0, "Sensor position on the robot, forward (m) (static_window "
                                     "puts landmarks in the odometry frame; deskew_scans moves "
                                     "them with the laser).",
                                low=-100.0, high=100.0)
    sensor_y: float = parameter(0.0, "Sensor position on the robot, left (m).",
                                low=-100.0, high=100.0)
    sensor_yaw: float = parameter(0.0, "Sensor heading relative to the robot (rad).",
                                  low=-math.pi, high=math.pi)

    def validate(self) -> "ExtractorSettings":
        """Self when every field is in range (``ParameterValueError`` naming the field)."""
        check_fields(self)
        if self.min_range >= self.max_range:
            raise ParameterValueError(("min_range", "max_range"),
                                      f"min_range must be < max_range (got {self.min_range!r} "
                                      f">= {self.max_range!r})")
        if self.min_diameter >= self.max_diameter:
            raise ParameterValueError(("min_diameter", "max_diameter"),
                                      "min_diameter must be < max_diameter (got "
                                      f"{self.min_diameter!r} >= {self.max_diameter!r})")
        return self
