# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Fault injection on the people tracker (issue classes 5-11): maps sent again or changed,
unusable and oversized maps and scans, REP 117 ranges, scan geometry and frames, initial
poses off the map, a lost tracker, bad map files at start, and exact output stamps.

Each dropped input is injected into a clean stream; the test asserts no exception (no
``dropped_internal_error``), the counter, the /diagnostics level, and an estimate equal to
the clean run's. Random LaserScan and OccupancyGrid messages (hypothesis) must be used or
dropped and counted, never break the node.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest
import rclpy
from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticStatus
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from nav_msgs.msg import OccupancyGrid
from rclpy.context import Context
from rclpy.time import Time
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Header

from fastslam_ros import people_io, ros_io
from fastslam_ros.people import OccupancyMap, PeopleTracker, TrackerSettings
from fastslam_ros.people.lifecycle import LOST_READINGS, change_map, same_map
from fastslam_ros.tools.simulation.people_sim import cast_scan
from test_people_core import ANGLES, room
from test_people_node import (PERSON, POSE, initial_pose_message, make_node,
                              map_message, odometry_message, scan_message)

START = 100.0
INJECT_AT = 10
"""Scan after which the bad message arrives (1 s into the run)."""
STEPS = 20
CAPS = {"max_map_cells": 50_000, "max_beams_per_scan": 400}
"""Caps above the room's 40,000 cells and 360 beams, so that the tests can exceed them."""
SPEED = 0.5
"""m/s along x of the moving robot (``moving_stream``)."""
DOMAIN_ID = 100 + os.getpid() % 100


@pytest.fixture(scope="module")
def context():
    ctx = Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.shutdown(context=ctx)


def true_pose(k: int, speed: float) -> np.ndarray:
    return POSE + np.array([speed * 0.1 * k, 0.0, 0.0])


def stream(steps: int = STEPS, speed: float = 0.0, start: float = START,
           scans=None) -> list[tuple[float, str, object]]:
    """(arrival, callback, message): the map, the initial pose, then 10 Hz odometry pairs and
    scans of a robot driving ``speed`` m/s along x from POSE and seeing PERSON. ``scans``
    (k -> ranges) replaces the k-th scan's ranges."""
    grid = room()
    events = [(start, "on_map", map_message(grid)),
              (start, "on_initial_pose", initial_pose_message(POSE))]
    for k in range(steps):
        stamp = start + 0.1 * k
        odometry = [(speed * (stamp + dt - start), 0.0, 0.0) for dt in (0.0, 0.05)]
        ranges = cast_scan(grid, true_pose(k + 0.2, speed), ANGLES, PERSON.reshape(1, 2), 12.0)
        if scans is not None and k in scans:
            ranges = scans[k](ranges)
        events += [(stamp, "on_odometry", odometry_message(stamp, odometry[0])),
                   (stamp, "on_odometry", odometry_message(stamp + 0.05, odometry[1])),
                   (stamp, "on_scan", scan_message(stamp + 0.02, ranges))]
    return events


def inserted(msg, callback: str, events=None) -> list:
    """The stream with ``msg`` arriving after the INJECT_AT-th scan."""
    events = stream() if events is None else events
    at = 2 + 3 * INJECT_AT
    return events[:at] + [(events[at - 1][0], callback, msg)] + events[at:]


class Run:
    """A fresh node fed ``events``: its counters, estimate, outputs and diagnostics."""

    def __init__(self, context, events, **params) -> None:
        node = make_node(context, **{**CAPS, **params})
        self.outputs: list[tuple[str, object]] = []
        node.output_listeners.append(lambda topic, msg: self.outputs.append((topic, msg)))
        try:
            clock = node.get_clock()
            for arrival, callback, msg in events:
                clock.set_ros_time_override(Time(nanoseconds=round(arrival * 1e9)))
                getattr(node, callback)(msg)
            node.flush()
            people = node.tracker.people_of() if node.tracker.ready else None
            self.stats = dict(node.stats)
            self.estimate = {"poses": node.tracker.poses.copy(),
                             "log_weights": node.tracker.log_weights.copy()}
            if people is not None:
                self.estimate.update(people=people.means.copy(), keys=people.keys.copy())
            self.node_state = {"globally_localizing": node.tracker.globally_localizing,
                               "map_received": node.tracker.grid is not None}
        finally:
            node.destroy_node()

    @property
    def statuses(self) -> list[DiagnosticStatus]:
        return [msg.status[0] for topic, msg in self.outputs if topic == "/diagnostics"]

    @property
    def worst_level(self) -> int:
        return max(int.from_bytes(s.level, "little") if isinstance(s.level, bytes)
                   else int(s.level) for s in self.statuses)

    def messages(self, suffix: str) -> list:
        return [msg for topic, msg in self.outputs if topic.endswith(suffix)]

    def mean_pose(self) -> np.ndarray:
        weights = np.exp(self.estimate["log_weights"])
        return np.average(self.estimate["poses"][:, :2], axis=0, weights=weights)


WARN = int.from_bytes(DiagnosticStatus.WARN, "little")
OK = int.from_bytes(DiagnosticStatus.OK, "little")


@pytest.fixture(scope="module")
def clean_run(context):
    run = Run(context, stream())
    assert not any(v for k, v in run.stats.items() if k.startswith("dropped_"))
    assert run.stats["used_scan"] == STEPS and run.stats["lost"] == 0
    assert run.worst_level == OK
    return run


# --- dropped input: counted, WARN, the estimate of the clean run ------------------------------

def scan_with(**fields) -> LaserScan:
    """The scan of the stream's INJECT_AT-th step, 0.01 s later, with ``fields`` changed."""
    stamp = START + 0.1 * (INJECT_AT - 1) + 0.03
    msg = scan_message(stamp, cast_scan(room(), POSE, ANGLES, PERSON.reshape(1, 2), 12.0))
    for name, value in fields.items():
        setattr(msg, name, value)
    return msg


def grid_message(values: np.ndarray, resolution: float = 0.05) -> OccupancyGrid:
    msg = OccupancyGrid(header=Header(frame_id="map"))
    msg.info.resolution = resolution
    msg.info.height, msg.info.width = values.shape
    msg.info.origin.orientation.w = 1.0
    msg.data = np.asarray(values, dtype=np.int8).ravel().tolist()
    return msg


def room_with_resolution(resolution: float) -> OccupancyGrid:
    msg = map_message(room())
    msg.info.resolution = resolution
    return msg


def initial_pose(pose=POSE, variance: float = 1e-4):
    msg = initial_pose_message(POSE)
    msg.pose.pose = ros_io.pose_msg(pose)
    covariance = np.zeros(36)
    covariance[0] = covariance[7] = covariance[35] = variance
    msg.pose.covariance = covariance.tolist()
    return msg


def nan_pose():
    msg = initial_pose()
    msg.pose.pose.position.x = math.nan
    return msg


INCREMENT = float(ANGLES[1] - ANGLES[0])
DROPPED = {  # name -> (message builder, callback, counter)
    # 10: scan geometry
    "scan angle_max 3 beams off": (lambda: scan_with(angle_max=float(ANGLES[-1] + 3 * INCREMENT)),
                                   "on_scan", "dropped_malformed_scan"),
    "scan angle_max 2 beams off": (lambda: scan_with(angle_max=float(ANGLES[-1] + 2 * INCREMENT)),
                                   "on_scan", "dropped_malformed_scan"),
    "scan angle_max 1 beam short": (lambda: scan_with(angle_max=float(ANGLES[-1] - INCREMENT)),
                                    "on_scan", "dropped_malformed_scan"),
    "scan range_max < range_min": (lambda: scan_with(range_min=5.0, range_max=1.0), "on_scan",
                                   "dropped_malformed_scan"),
    "scan range_min NaN": (lambda: scan_with(range_min=math.nan), "on_scan",
                           "dropped_malformed_scan"),
    "scan range_max NaN": (lambda: scan_with(range_max=math.nan), "on_scan",
                           "dropped_malformed_scan"),
    "scan time_increment NaN": (lambda: scan_with(time_increment=math.nan), "on_scan",
                                "dropped_malformed_scan"),
    # 9: caps
    "scan of 500 beams": (lambda: scan_with(
        ranges=[1.0] * 500, angle_min=-1.0, angle_increment=0.004,
        angle_max=-1.0 + 499 * 0.004), "on_scan", "dropped_oversized_scan"),
    "map of 300 x 300 cells": (lambda: grid_message(np.zeros((300, 300))), "on_map",
                               "dropped_oversized_map"),
    # 6: unusable maps
    "map with no free cell": (lambda: grid_message(np.full((200, 200), 100)), "on_map",
                              "dropped_malformed_map"),
    "map of unknown cells": (lambda: grid_message(np.full((200, 200), -1)), "on_map",
                             "dropped_malformed_map"),
    "map resolution 0": (lambda: room_with_resolution(0.0), "on_map", "dropped_malformed_map"),
    "map resolution -0.05": (lambda: room_with_resolution(-0.05), "on_map",
                             "dropped_malformed_map"),
    "map resolution NaN": (lambda: room_with_resolution(math.nan), "on_map",
                           "dropped_malformed_map"),
    # 8: initial poses
    "initialpose x = 1000 m": (lambda: initial_pose((1000.0, 5.0, 0.0)), "on_initial_pose",
                               "dropped_initialpose_off_map"),
    "initialpose x = 1e300": (lambda: initial_pose((1e300, 5.0, 0.0)), "on_initial_pose",
                              "dropped_initialpose_off_map"),
    "initialpose x = -0.01 m": (lambda: initial_pose((-0.01, 5.0, 0.0)), "on_initial_pose",
                                "dropped_initialpose_off_map"),
    "initialpose covariance 1e300": (lambda: initial_pose(variance=1e300), "on_initial_pose",
                                     "dropped_initialpose_covariance"),
    "initialpose x NaN": (nan_pose, "on_initial_pose", "dropped_nan"),
}
RECEIVED = {"on_scan": "received_scan", "on_map": "received_map",
            "on_initial_pose": "received_initialpose"}


@pytest.mark.parametrize("name", DROPPED)
def test_dropped_input_is_counted_and_changes_nothing(context, clean_run, name):
    build, callback, counter = DROPPED[name]
    run = Run(context, inserted(build(), callback))
    changed = {k: run.stats[k] - clean_run.stats[k] for k in run.stats
               if run.stats[k] != clean_run.stats[k]}
    assert changed == {counter: 1, RECEIVED[callback]: 1}
    assert run.worst_level == WARN
    assert any("1 input(s) dropped" in s.message for s in run.statuses)
    for key, value in clean_run.estimate.items():
        np.testing.assert_array_equal(run.estimate[key], value, err_msg=key)


def test_angle_max_of_the_last_beam_or_one_increment_beyond_is_accepted():
    """REP 117's angle_max is the last beam's angle; pointcloud_to_laserscan's is one
    increment further (n beams over [angle_min, angle_max)). Both read the same beams."""
    for angle_max in (ANGLES[-1], ANGLES[-1] + INCREMENT, ANGLES[-1] + 1e-4):
        scan = people_io.read_scan(scan_with(angle_max=float(angle_max)))
        assert scan.angle_min == float(ANGLES[0]) and len(scan.ranges) == len(ANGLES)
    reverse = scan_with(angle_min=float(ANGLES[-1]), angle_max=float(ANGLES[0]),
                        angle_increment=-INCREMENT)
    assert people_io.read_scan(reverse).angle_increment == -INCREMENT


def test_scans_in_another_frame_than_the_first_are_dropped(context):
    """scan_frame '' (the default): the first scan's frame is the expected one."""
    clean = Run(context, stream(), scan_frame="")
    other = scan_with()
    other.header.frame_id = "camera"
    run = Run(context, inserted(other, "on_scan"), scan_frame="")
    changed = {k: run.stats[k] - clean.stats[k] for k in run.stats
               if run.stats[k] != clean.stats[k]}
    assert changed == {"dropped_wrong_frame": 1, "received_scan": 1}
    assert run.worst_level == WARN
    for key, value in clean.estimate.items():
        np.testing.assert_array_equal(run.estimate[key], value, err_msg=key)


# --- 5: the map again, and a changed map -----------------------------------------------------

def changed_room() -> OccupancyGrid:
    """The room with a new box (a cupboard) far from the robot, its path and the person."""
    return map_message(room([(8.0, 9.0, 1.0, 2.0)]))


@pytest.fixture(scope="module")
def moving_run(context):
    run = Run(context, stream(speed=SPEED))
    assert run.stats["lost"] == 0 and run.stats["people_created"] == 1
    return run


def test_the_same_map_again_is_a_no_op(context, moving_run):
    run = Run(context, inserted(map_message(room()), "on_map", stream(speed=SPEED)))
    changed = {k: run.stats[k] - moving_run.stats[k] for k in run.stats
               if run.stats[k] != moving_run.stats[k]}
    assert changed == {"repeated_maps": 1, "received_map": 1}
    assert run.worst_level == OK
    for key, value in moving_run.estimate.items():
        np.testing.assert_array_equal(run.estimate[key], value, err_msg=key)


def test_a_changed_map_keeps_the_pose_and_makes_no_phantom_people(context, moving_run):
    """The robot has driven 0.5 m when the changed map arrives: it stays where it is (it
    used to jump back to the first initialpose and see phantom people), the person keeps
    its id, and the change is counted."""
    run = Run(context, inserted(changed_room(), "on_map", stream(speed=SPEED)))
    assert run.stats["map_changes"] == 1 and run.stats["used_map"] == 2
    assert run.stats["dropped_internal_error"] == 0
    assert run.stats["global_localizations"] == moving_run.stats["global_localizations"]
    assert not run.node_state["globally_localizing"]
    assert run.stats["people_created"] == moving_run.stats["people_created"] == 1
    truth = true_pose(STEPS - 1 + 0.2, SPEED)
    assert np.linalg.norm(run.mean_pose() - truth[:2]) < 0.1
    assert np.linalg.norm(moving_run.mean_pose() - truth[:2]) < 0.1
    np.testing.assert_array_equal(run.estimate["keys"], moving_run.estimate["keys"])
    assert np.linalg.norm(run.estimate["people"][0] - PERSON) < 0.2
    poses = [msg.pose.pose.position.x for msg in run.messages("/pose")]
    assert np.all(np.abs(np.diff(poses)) < 0.15)  # no jump at the change
    assert any("changed map" in s.message for s in run.statuses)


def test_change_map_keeps_free_particles_and_clears_people_in_new_walls():
    """Core: particles standing where the new map has a wall are resampled away (their
    weight goes to the others), people whose mean is in a new wall are removed."""
    settings = TrackerSettings(num_particles=200, people_particles=20, max_people=4, seed=2)
    tracker = PeopleTracker(settings, room(), rng=np.random.default_rng(2))
    covariance = np.diag([0.3 ** 2, 0.3 ** 2, 0.01])
    tracker.reset(POSE, covariance)
    tracker.alive[:, 0] = tracker.confirmed[:, 0] = True
    tracker.keys[:, 0] = 7
    tracker.people[:, 0] = PERSON
    tracker.alive[:, 1] = tracker.confirmed[:, 1] = True
    tracker.keys[:, 1] = 8
    tracker.people[:, 1] = (4.0, 8.0)
    # a wall over the particles with x > 2.0 (about half of them), a pillar over (4, 8)
    new = room([(2.0, 2.6, 4.0, 6.0), (3.8, 4.2, 7.8, 8.2)])
    before = tracker.poses.copy()
    change = change_map(tracker, new)
    assert change.kept_pose and change.people_removed == 1
    assert tracker.grid is new and not tracker.globally_localizing
    assert new.is_free(tracker.poses[:, :2]).all()
    kept = before[new.is_free(before[:, :2])]
    assert {tuple(p) for p in tracker.poses} <= {tuple(p) for p in kept}
    assert (tracker.keys[tracker.alive] == 7).all() and tracker.alive[:, 0].all()
    # every particle in a wall: the pose is no longer on the map, localize globally
    occupied = np.ones((200, 200), dtype=bool)
    occupied[:5, :5] = False                            # free only in a corner
    walled = OccupancyMap(occupied, ~occupied, 0.05, (0.0, 0.0), 1.0)
    assert not change_map(tracker, walled).kept_pose and tracker.globally_localizing


def test_same_map_compares_cells_resolution_and_origin():
    grid = room()
    assert same_map(grid, room()) and not same_map(None, grid)
    assert not same_map(grid, room([(5.0, 5.1, 5.0, 5.1)]))
    assert not same_map(grid, OccupancyMap(grid.occupied, grid.free, 0.06, grid.origin, 1.0))


# --- 6: no usable map yet ----------------------------------------------------------------------

def test_without_a_usable_map_diagnostics_warn_waiting(context):
    """A first map with no free cell is not installed: WARN "waiting for a usable map" (not
    "running"), map_received False; the next good map starts the tracker."""
    events = stream()
    black = (START, "on_map", grid_message(np.full((200, 200), 100)))
    run = Run(context, [black] + events[1:2] + events[2:20])
    assert run.stats["dropped_malformed_map"] == 1 and run.stats["used_map"] == 0
    assert run.stats["dropped_no_map"] == 6 and run.stats["dropped_internal_error"] == 0
    assert not run.node_state["map_received"]
    assert run.statuses and all(s.message.startswith("waiting for a usable map")
                                for s in run.statuses)
    assert run.worst_level == WARN
    run = Run(context, [black] + events)
    assert run.stats["used_map"] == 1 and run.stats["used_scan"] == STEPS
    assert np.linalg.norm(run.mean_pose() - POSE[:2]) < 0.1


# --- 7: REP 117 ranges carry no evidence -------------------------------------------------------

def person_beams() -> np.ndarray:
    with_person = cast_scan(room(), POSE, ANGLES, PERSON.reshape(1, 2), 12.0)
    without = cast_scan(room(), POSE, ANGLES, np.zeros((0, 2)), 12.0)
    return np.flatnonzero(with_person != without)


@pytest.mark.parametrize("value", [math.nan, -math.inf, -1.0, 0.01, 13.0])
def test_invalid_ranges_neither_remove_a_person_nor_create_one(context, clean_run, value):
    """Three scans whose beams on the tracked person read NaN, -inf, a negative range, one
    below range_min or one beyond range_max: no evidence, the person stays, no one new."""
    beams = person_beams()
    assert len(beams) >= 3

    def spoil(ranges):
        ranges = ranges.copy()
        ranges[beams] = value
        return ranges
    run = Run(context, stream(scans={k: spoil for k in (INJECT_AT, INJECT_AT + 1,
                                                        INJECT_AT + 2)}))
    assert run.stats["dropped_internal_error"] == 0
    assert run.stats["people_created"] == clean_run.stats["people_created"] == 1
    assert run.stats["people_removed"] == 0
    np.testing.assert_array_equal(run.estimate["keys"], clean_run.estimate["keys"])
    assert np.linalg.norm(run.estimate["people"][0] - PERSON) < 0.2
    assert run.worst_level == OK


def test_a_scan_of_nan_or_inf_only_keeps_the_person_or_removes_it_as_rep117_says(context):
    """All NaN: no evidence, the person stays. All +inf (nothing within range_max): the
    beams saw free space where the person was, so the person goes (missed three times)."""
    scans = (INJECT_AT, INJECT_AT + 1, INJECT_AT + 2)
    run = Run(context, stream(scans={k: (lambda r: np.full_like(r, np.nan)) for k in scans}))
    assert run.stats["people_removed"] == 0 and len(run.estimate["keys"]) == 1
    run = Run(context, stream(steps=INJECT_AT + 3,
                              scans={k: (lambda r: np.full_like(r, np.inf)) for k in scans}))
    assert run.stats["people_removed"] == 1


# --- 8: a lost tracker relocalizes -------------------------------------------------------------

def test_a_pose_in_a_wall_is_lost_says_warn_and_relocalizes(context):
    """initialpose inside the room's wall (on the map, not free): after LOST_READINGS scans
    that do not fit, the node says it is lost (WARN) and localizes globally again."""
    events = stream(steps=LOST_READINGS + 10)
    events[1] = (START, "on_initial_pose", initial_pose((0.05, 5.0, 0.0)))
    run = Run(context, events)
    assert run.stats["used_initialpose"] == 1
    # one at the map (before the initial pose arrives), one when lost
    assert run.stats["lost"] == 1 and run.stats["global_localizations"] == 2
    assert run.stats["dropped_internal_error"] == 0
    assert run.node_state["globally_localizing"]
    assert any(s.message.startswith("lost: localizing globally again") for s in run.statuses)
    assert run.worst_level == WARN


def test_an_initial_pose_before_the_map_is_checked_when_the_map_comes(context):
    events = stream()
    events[0], events[1] = (START, "on_initial_pose", initial_pose((50.0, 5.0, 0.0))), \
        events[0]
    run = Run(context, events)
    assert run.stats["dropped_initialpose_off_map"] == 1
    assert run.stats["global_localizations"] == 1 and run.stats["dropped_internal_error"] == 0


# --- issue 40: every output carries its scan's exact stamp -------------------------------------

def test_outputs_carry_the_scans_exact_stamp(context):
    """Stamps near 1.7e9 s with nanoseconds that float seconds cannot hold (a float has
    about 240 ns there): every output of a scan has the scan's sec and nanosec."""
    start = 1_700_000_000.0
    events, stamps = [], []
    for arrival, callback, msg in stream(start=start):
        if callback == "on_scan":
            exact = (msg.header.stamp.sec, msg.header.stamp.nanosec // 1000 * 1000 + 123)
            msg.header.stamp = TimeMsg(sec=exact[0], nanosec=exact[1])
            stamps.append(exact)
        events.append((arrival, callback, msg))
    # through float seconds these stamps would not come back (the old outputs' fault)
    assert any(ros_io.seconds_to_stamp(ros_io.stamp_to_seconds(TimeMsg(sec=s, nanosec=n)))
               .nanosec != n for s, n in stamps)
    run = Run(context, events, particles_rate=100.0, markers_rate=100.0)
    assert run.stats["used_scan"] == STEPS

    def stamp_of(msg):
        return (msg.header.stamp.sec, msg.header.stamp.nanosec)
    for suffix in ("/pose", "/people", "/map_to_odom"):
        assert [stamp_of(msg) for msg in run.messages(suffix)] == stamps, suffix
    particles = run.messages("/particles")
    assert particles and all(stamp_of(msg) in stamps for msg in particles)
    markers = [marker for msg in run.messages("/people_markers") for marker in msg.markers]
    assert markers and all(stamp_of(marker) in stamps for marker in markers)


# --- 11: bad map files at start: one line, exit 1 ----------------------------------------------

def write_map(tmp_path, resolution="0.05", thresholds="occupied_thresh: 0.65\nfree_thresh: 0.25",
              black=False):
    from PIL import Image
    grid = room()
    pixels = np.where(grid.occupied | black, 0, 254).astype(np.uint8)[::-1]
    Image.fromarray(pixels).save(tmp_path / "room.pgm")
    path = tmp_path / "room.yaml"
    path.write_text(f"image: room.pgm\nresolution: {resolution}\norigin: [0.0, 0.0, 0.0]\n"
                    f"negate: 0\n{thresholds}\n")
    return path


BAD_MAP_FILES = {
    "resolution 0": dict(resolution="0.0"),
    "resolution negative": dict(resolution="-0.05"),
    "resolution NaN": dict(resolution=".nan"),
    "threshold not a number": dict(thresholds="occupied_thresh: high\nfree_thresh: 0.25"),
    "threshold a list": dict(thresholds="occupied_thresh: [0.65]\nfree_thresh: 0.25"),
    "all-black image": dict(black=True),
}


@pytest.mark.parametrize("name", BAD_MAP_FILES)
def test_bad_map_file_is_one_line_and_exit_1(tmp_path, name):
    path = write_map(tmp_path, **BAD_MAP_FILES[name])
    with pytest.raises(people_io.MalformedMapError):
        people_io.load_map_file(path, 1.0)
    result = subprocess.run(
        [sys.executable, "-m", "fastslam_ros.people_node", "--ros-args", "-p",
         f"map_file:={path}"], capture_output=True, text=True, timeout=120,
        env={**os.environ, "ROS_DOMAIN_ID": str(DOMAIN_ID)})
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "map_file" in lines[0], result.stderr


def test_a_map_file_beyond_max_map_cells_is_refused(tmp_path):
    path = write_map(tmp_path)
    with pytest.raises(ros_io.OversizedError, match="max_map_cells"):
        people_io.load_map_file(path, 1.0, max_cells=39_999)
    assert people_io.load_map_file(path, 1.0, max_cells=40_000).shape == (200, 200)


# --- random messages (hypothesis) --------------------------------------------------------------

FLOATS = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32),
                   st.sampled_from([0.0, -0.0, 1e-30, 0.05, 12.0, math.nan, math.inf]))


@st.composite
def laser_scans(draw) -> LaserScan:
    """LaserScans, most nearly valid: beam counts around the cap, angle_max right or not,
    range limits crossed or NaN, ranges mixing returns, NaN, +-inf and out-of-limit values."""
    count = draw(st.sampled_from([0, 1, 2, 90, 360, 400, 401, 2000]))
    increment = draw(st.one_of(st.just(2.0 * math.pi / max(count, 1)), FLOATS))
    angle_min = draw(st.one_of(st.just(-math.pi), FLOATS))
    consistent = angle_min + (count - 1) * increment if count else 0.0
    angle_max = draw(st.one_of(st.just(consistent), FLOATS))
    range_min = draw(st.one_of(st.just(0.05), FLOATS))
    range_max = draw(st.one_of(st.just(12.0), FLOATS))
    pool = draw(st.lists(st.one_of(st.floats(0.0, 15.0, width=32), FLOATS), min_size=1,
                         max_size=8))
    picks = draw(st.lists(st.integers(0, len(pool) - 1), min_size=count, max_size=count))
    with np.errstate(all="ignore"):
        ranges = np.asarray([pool[i] for i in picks], dtype=np.float32)
    return LaserScan(header=Header(frame_id="laser"), angle_min=angle_min, angle_max=angle_max,
                     angle_increment=increment, range_min=range_min, range_max=range_max,
                     ranges=ranges.tolist())


@st.composite
def occupancy_grids(draw) -> OccupancyGrid:
    """OccupancyGrids: small sizes (claimed and real), resolutions and origins from any float,
    cells from nav2's values (-1, free, unknown, occupied) or any int8."""
    width, height = draw(st.integers(0, 30)), draw(st.integers(0, 30))
    if draw(st.booleans()):
        width, height = draw(st.sampled_from([(1, 10**6), (250, 250), (2**31 - 1, 2)]))
    size = width * height if width * height <= 900 else draw(st.integers(0, 50))
    size = draw(st.one_of(st.just(size), st.integers(0, 900)))
    cells = draw(st.lists(st.one_of(st.sampled_from([-1, 0, 10, 50, 100]),
                                    st.integers(-128, 127)), min_size=size, max_size=size))
    msg = OccupancyGrid(header=Header(frame_id="map"))
    msg.info.width, msg.info.height = width, height
    msg.info.resolution = draw(st.one_of(st.just(0.05), FLOATS))
    msg.info.origin.position.x = draw(st.one_of(st.just(0.0), FLOATS.map(float)))
    msg.info.origin.orientation.z = draw(st.one_of(st.just(0.0), st.floats(-1.0, 1.0)))
    msg.info.origin.orientation.w = draw(st.one_of(st.just(1.0), st.floats(-1.0, 1.0)))
    msg.data = cells
    return msg


@pytest.fixture(scope="module")
def running_node(context):
    node = make_node(context, **CAPS)
    clock = node.get_clock()
    for arrival, callback, msg in stream():
        clock.set_ros_time_override(Time(nanoseconds=round(arrival * 1e9)))
        getattr(node, callback)(msg)
    yield node
    node.destroy_node()


def accounted(node) -> int:
    return node.stats["used_scan"] + sum(v for k, v in node.stats.items()
                                         if k.startswith("dropped_"))


def check_state(node) -> None:
    tracker = node.tracker
    assert node.stats["dropped_internal_error"] == 0
    assert tracker.grid is not None and tracker.grid.free.any()
    assert np.isfinite(tracker.poses).all() and np.isfinite(tracker.log_weights).all()
    assert np.isfinite(tracker.people[tracker.alive]).all()


@settings(max_examples=80, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(msg=laser_scans(), offset=st.integers(1, 10**6))
def test_random_scans_are_used_or_dropped_and_counted(running_node, msg, offset):
    node = running_node
    msg.header.stamp = ros_io.seconds_to_stamp(node._odometry.latest_stamp - offset * 1e-7)
    before = accounted(node)
    node.on_scan(msg)
    node.flush()
    assert accounted(node) == before + 1
    check_state(node)


@settings(max_examples=80, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(msg=occupancy_grids())
def test_random_maps_are_installed_or_dropped_and_counted(running_node, msg):
    node = running_node
    stats = dict(node.stats)
    node.on_map(msg)
    changed = {k for k in node.stats if node.stats[k] != stats[k]} - {"received_map"}
    assert changed & {"used_map", "repeated_maps", "dropped_malformed_map",
                      "dropped_oversized_map"}
    if "used_map" not in changed:
        assert node.tracker.grid is not None
    check_state(node)
    node.on_map(map_message(room()))  # back to the room for the next example
    check_state(node)


# --- self-check and repair (the SLAM node's last line of defence) ------------------------------

@pytest.mark.parametrize("poison", ["pose", "weight", "person", "everything"])
def test_a_non_finite_filter_state_is_repaired_and_counted(context, poison):
    """A state made non-finite behind the gates (fault injected into the tracker): the next
    scan repairs it from the finite particles (counted, WARN) and tracking goes on."""
    node = make_node(context, **CAPS)
    outputs = []
    node.output_listeners.append(lambda topic, msg: outputs.append((topic, msg)))
    try:
        clock = node.get_clock()
        for index, (arrival, callback, msg) in enumerate(stream()):
            clock.set_ros_time_override(Time(nanoseconds=round(arrival * 1e9)))
            getattr(node, callback)(msg)
            if index == 2 + 3 * INJECT_AT:
                tracker = node.tracker
                rows = slice(None) if poison == "everything" else slice(0, 5)
                if poison in ("pose", "everything"):
                    tracker.poses[rows, 0] = math.nan
                elif poison == "weight":
                    tracker.log_weights[rows] = math.nan
                else:
                    tracker.people[rows][tracker.alive[rows]] = math.inf
        node.flush()
        check_state(node)
        assert node.stats["filter_recoveries"] == 1
        assert node.stats["used_scan"] == STEPS
        assert node.tracker.globally_localizing == (poison == "everything")
        statuses = [msg.status[0] for topic, msg in outputs if topic == "/diagnostics"]
        assert any("filter state repaired" in s.message for s in statuses)
    finally:
        node.destroy_node()
