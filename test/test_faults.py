# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Fault injection: every class of bad input, interleaved with a valid simulated stream.

Each case puts one bad message (or a valid message with bad points added) into a short
simulated run and feeds it through the node's callbacks as a replay does. It asserts that
nothing raises, that the right counter (and no other drop counter) moved, and that the valid
messages give the same estimate as the clean run: bit-identical, since the bad input is only
dropped. Random malformed clouds (hypothesis) must be dropped or read, never break the filter.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticStatus
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.parameter import Parameter
from rclpy.time import Time
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header

from fastslam_ros import ros_io
from fastslam_ros.node import FastSLAMNode
from fastslam_ros.tools.bags.in_process import in_process
from fastslam_ros.tools.simulation.sim import SimConfig, recommended_params, simulate

DOMAIN_ID = 100 + os.getpid() % 100
PARAMS = dict(recommended_params(SimConfig()), num_particles=15, seed=5, use_sim_time=True,
              sensor_frame="base_link")
INJECT_AT = 200
"""Index in the stream after which the bad message arrives (about 4 s into the run)."""


@dataclass
class Event:
    arrival: float
    msg: object


def odometry_msg(stamp: float, pose) -> Odometry:
    msg = Odometry(header=Header(stamp=ros_io.seconds_to_stamp(stamp), frame_id="odom"),
                   child_frame_id="base_link")
    msg.pose.pose = ros_io.pose_msg(pose)
    return msg


def cloud_msg(stamp: float, points, ids=None) -> PointCloud2:
    return ros_io.landmark_cloud(Header(stamp=ros_io.seconds_to_stamp(stamp),
                                        frame_id="base_link"), np.asarray(points, float), ids)


def simulated_stream(duration: float = 10.0) -> list[Event]:
    """The simulated loop (40 Hz odometry, 5 Hz clouds) as messages, each arriving at its stamp."""
    bag = simulate(SimConfig(duration=duration, seed=3))
    events = [Event(t, odometry_msg(t, pose))
              for t, pose in zip(bag.odometry.stamps, bag.odometry.poses)]
    events += [Event(t, cloud_msg(t, points, ids))
               for t, points, ids in zip(bag.scans.stamps, bag.scans.points, bag.scans.ids)]
    return sorted(events, key=lambda e: (e.arrival, isinstance(e.msg, PointCloud2)))


STREAM = simulated_stream()


@pytest.fixture(scope="module")
def context():
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID)
    yield ctx
    rclpy.shutdown(context=ctx)


def run(context, events: list[Event], **changes) -> tuple[FastSLAMNode, dict]:
    """Feed the events; return the node's counters and its estimate (the node is destroyed)."""
    params = dict(PARAMS, **changes)
    node = in_process(FastSLAMNode)(context=context, enable_rosout=False, parameter_overrides=[
        Parameter(name, value=value) for name, value in params.items()])
    try:
        clock = node.get_clock()
        for event in events:
            clock.set_ros_time_override(Time(nanoseconds=round(event.arrival * 1e9)))
            (node.on_odometry if isinstance(event.msg, Odometry) else node.on_landmarks)(event.msg)
        node.flush()
        stamps, path = node.slam.best_path()
        landmark_map = node.slam.best_map()
        estimate = {"poses": node.slam.poses.copy(), "log_weights": node.slam.log_weights.copy(),
                    "path_stamps": stamps, "path": path, "map": landmark_map.means,
                    "map_cov": landmark_map.covariances, "keys": landmark_map.keys}
        return node, estimate
    finally:
        node.destroy_node()


@pytest.fixture(scope="module")
def clean(context):
    node, estimate = run(context, STREAM)
    assert not any(v for k, v in node.stats.items() if k.startswith("dropped_"))
    assert node.stats["used_landmarks"] == 50
    return node.stats, estimate


def assert_same_estimate(estimate: dict, reference: dict) -> None:
    for name, value in reference.items():
        np.testing.assert_array_equal(estimate[name], value, err_msg=name)


def mean_position(estimate: dict) -> np.ndarray:
    """The particles' weighted mean position at the end of a run."""
    weights = np.exp(estimate["log_weights"] - estimate["log_weights"].max())
    return weights @ estimate["poses"][:, :2] / weights.sum()


def previous(kind: type, index: int = INJECT_AT) -> Event:
    """The last event of a message type at or before ``index``."""
    return next(e for e in reversed(STREAM[:index + 1]) if isinstance(e.msg, kind))


def odometry_between() -> tuple[float, np.ndarray]:
    """A stamp between two odometry messages around INJECT_AT and the pose there."""
    event = previous(Odometry)
    pose = event.msg.pose.pose
    return (ros_io.stamp_to_seconds(event.msg.header.stamp) + 0.0125,
            np.array([pose.position.x, pose.position.y,
                      ros_io.quaternion_to_yaw(pose.orientation)]))


def with_points(extra, dtype_changes=None) -> tuple[int, PointCloud2]:
    """The valid cloud before INJECT_AT with extra points added (ids 999)."""
    index = max(i for i, e in enumerate(STREAM[:INJECT_AT + 1]) if isinstance(e.msg, PointCloud2))
    cloud = ros_io.read_landmark_cloud(STREAM[index].msg)
    points = np.vstack([np.column_stack([cloud.x, cloud.y]), np.asarray(extra, float)])
    ids = np.append(cloud.ids, np.full(len(extra), 999))
    return index, cloud_msg(ros_io.stamp_to_seconds(STREAM[index].msg.header.stamp), points, ids)


def byte_swapped_cloud() -> PointCloud2:
    """Little-endian floats declared big-endian: 5.0 and 2.0 read as denormals (~1e-41)."""
    stamp, _ = odometry_between()
    msg = cloud_msg(stamp, [[5.0, 2.0], [3.0, -1.0]], [1, 2])
    msg.is_bigendian = True
    return msg


def modified_odometry(change) -> Odometry:
    stamp, pose = odometry_between()
    msg = odometry_msg(stamp, pose)
    change(msg)
    return msg


def set_attr(path: str, value):
    def change(msg):
        target = msg
        *parents, name = path.split(".")
        for parent in parents:
            target = getattr(target, parent)
        setattr(target, name, value)
    return change


def modified_cloud(change) -> PointCloud2:
    stamp, _ = odometry_between()
    source = previous(PointCloud2).msg
    msg = cloud_msg(stamp, np.column_stack([ros_io.read_landmark_cloud(source).x,
                                            ros_io.read_landmark_cloud(source).y]))
    change(msg)
    return msg


def jump(offset) -> Odometry:
    stamp, pose = odometry_between()
    return odometry_msg(stamp, pose + np.asarray(offset, float))


def late(msg, seconds: float):
    msg.header.stamp = ros_io.seconds_to_stamp(ros_io.stamp_to_seconds(msg.header.stamp)
                                               + seconds)
    return msg


def oversized_cloud() -> PointCloud2:
    stamp, _ = odometry_between()
    rng = np.random.default_rng(0)
    return cloud_msg(stamp, rng.uniform(-20.0, 20.0, (10_000, 2)))


INSERTED = {  # an extra message after INJECT_AT: name -> (builder, counter, points dropped)
    "odometry x = 1e308": (lambda: jump([1e308, 0.0, 0.0]), "dropped_implausible_odometry", 1),
    "odometry +1e6 m": (lambda: jump([1e6, 0.0, 0.0]), "dropped_implausible_odometry", 1),
    "odometry +100 m": (lambda: jump([100.0, 0.0, 0.0]), "dropped_implausible_odometry", 1),
    "odometry half turn": (lambda: jump([0.0, 0.0, 3.0]), "dropped_implausible_odometry", 1),
    "odometry 1 h ahead": (lambda: late(jump([0.0, 0.0, 0.0]), 3600.0),
                           "dropped_outlier_stamp", 1),
    "odometry 1 h behind": (lambda: late(jump([0.0, 0.0, 0.0]), -3600.0),
                            "dropped_outlier_stamp", 1),
    "cloud 1 h ahead": (lambda: late(modified_cloud(lambda m: None), 3600.0),
                        "dropped_outlier_stamp", 1),
    "odometry nanosec 2^32-1": (lambda: modified_odometry(set_attr("header.stamp.nanosec",
                                                                   2**32 - 1)),
                                "dropped_invalid_stamp", 1),
    "cloud negative sec": (lambda: modified_cloud(set_attr("header.stamp.sec", -5)),
                           "dropped_invalid_stamp", 1),
    "cloud of 1e4 points": (oversized_cloud, "dropped_oversized_cloud", 1),
    "byte-swapped cloud": (byte_swapped_cloud, "dropped_too_close", 2),
    "width 0 with data": (lambda: modified_cloud(set_attr("width", 0)),
                          "dropped_malformed_cloud", 1),
    "cloud without y": (lambda: modified_cloud(lambda m: setattr(
        m, "fields", [f for f in m.fields if f.name != "y"])), "dropped_malformed_cloud", 1),
    "cloud point_step 8": (lambda: modified_cloud(set_attr("point_step", 8)),
                           "dropped_malformed_cloud", 1),
    "cloud data short": (lambda: modified_cloud(lambda m: setattr(m, "data",
                                                                  bytes(m.data)[:-3])),
                         "dropped_malformed_cloud", 1),
    "cloud wrong frame": (lambda: modified_cloud(set_attr("header.frame_id", "camera")),
                          "dropped_wrong_frame", 1),
    "cloud repeated stamp": (lambda: previous(PointCloud2).msg, "dropped_duplicate_stamp", 1),
    "odometry zero quaternion": (lambda: modified_odometry(lambda m: (
        setattr(m.pose.pose.orientation, "z", 0.0), setattr(m.pose.pose.orientation, "w", 0.0))),
        "dropped_invalid_quaternion", 1),
    "odometry NaN quaternion": (lambda: modified_odometry(set_attr("pose.pose.orientation.w",
                                                                   math.nan)),
                                "dropped_invalid_quaternion", 1),
    "odometry NaN position": (lambda: modified_odometry(set_attr("pose.pose.position.x",
                                                                 math.nan)), "dropped_nan", 1),
    "odometry inf position": (lambda: modified_odometry(set_attr("pose.pose.position.y",
                                                                 -math.inf)), "dropped_nan", 1),
    "odometry wrong frame": (lambda: modified_odometry(set_attr("header.frame_id", "world")),
                             "dropped_wrong_frame", 1),
    "odometry wrong child": (lambda: modified_odometry(set_attr("child_frame_id", "x")),
                             "dropped_wrong_frame", 1),
    "odometry repeated stamp": (lambda: previous(Odometry).msg, "dropped_duplicate_stamp", 1),
    "odometry older": (lambda: late(modified_odometry(lambda m: None), -0.05),
                       "dropped_time_backwards", 1),
}

REPLACED = {  # the valid cloud before INJECT_AT with bad points added: name -> (points, counter)
    "point at 1e-12 m": ([[1e-12, 0.0]], "dropped_too_close"),
    "denormal point": ([[1e-40, -1e-41]], "dropped_too_close"),
    "point at the origin": ([[0.0, 0.0]], "dropped_too_close"),
    "NaN point": ([[math.nan, 1.0]], "dropped_nan"),
    "inf point": ([[1.0, math.inf]], "dropped_nan"),
    "point beyond max_range": ([[40.0, 0.0]], "dropped_out_of_range"),
    "float32 overflow point": ([[3e38, 3e38]], "dropped_out_of_range"),
}


def assert_only_counter(stats: dict, clean_stats: dict, counter: str, amount: int,
                        received: str | None = None) -> None:
    changed = {k: stats[k] - clean_stats[k] for k in stats if stats[k] != clean_stats[k]}
    assert changed.pop(counter) == amount
    if received:
        assert changed.pop(received) == 1
    assert changed.pop("dropped_internal_error", 0) == 0
    assert not changed, changed


@pytest.mark.parametrize("name", INSERTED)
def test_inserted_bad_message_is_dropped_counted_and_changes_nothing(context, clean, name):
    build, counter, amount = INSERTED[name]
    msg = build()
    events = STREAM[:INJECT_AT + 1] + [Event(STREAM[INJECT_AT].arrival, msg)] \
        + STREAM[INJECT_AT + 1:]
    node, estimate = run(context, events)
    received = "received_odom" if isinstance(msg, Odometry) else "received_landmarks"
    assert_only_counter(node.stats, clean[0], counter, amount, received)
    assert_same_estimate(estimate, clean[1])


@pytest.mark.parametrize("name", REPLACED)
def test_bad_points_in_a_valid_cloud_are_dropped_and_change_nothing(context, clean, name):
    points, counter = REPLACED[name]
    index, msg = with_points(points)
    events = STREAM[:index] + [Event(STREAM[index].arrival, msg)] + STREAM[index + 1:]
    node, estimate = run(context, events)
    assert_only_counter(node.stats, clean[0], counter, len(points))
    assert_same_estimate(estimate, clean[1])


def test_with_sensor_frame_empty_a_cloud_in_another_frame_than_the_first_is_dropped(context,
                                                                                  clean):
    msg = modified_cloud(set_attr("header.frame_id", "camera"))
    events = STREAM[:INJECT_AT + 1] + [Event(STREAM[INJECT_AT].arrival, msg)] \
        + STREAM[INJECT_AT + 1:]
    node, estimate = run(context, events, sensor_frame="")
    assert_only_counter(node.stats, clean[0], "dropped_wrong_frame", 1, "received_landmarks")
    assert_same_estimate(estimate, clean[1])


def test_bare_cloud_and_width_zero_are_the_same_empty_reading(context):
    stamp, _ = odometry_between()
    bare = PointCloud2(header=Header(stamp=ros_io.seconds_to_stamp(stamp), frame_id="base_link"))
    width_zero = cloud_msg(stamp, np.zeros((0, 2)))
    results = []
    for msg in (bare, width_zero):
        events = STREAM[:INJECT_AT + 1] + [Event(stamp, msg)] + STREAM[INJECT_AT + 1:]
        node, estimate = run(context, events)
        assert node.stats["used_landmarks"] == 51
        assert not any(v for k, v in node.stats.items() if k.startswith("dropped_"))
        results.append(estimate)
    assert_same_estimate(results[0], results[1])


def test_a_stray_stamp_never_resets_a_confirmed_loop_does(context, clean):
    stray = late(modified_cloud(lambda m: None), 3600.0)
    events = STREAM[:INJECT_AT + 1] + [Event(STREAM[INJECT_AT].arrival, stray)] \
        + STREAM[INJECT_AT + 1:]
    node, _ = run(context, events)
    assert node.stats["resets"] == node.stats["time_jumps"] == 0
    # The stream played twice: the second pass resets once, after three messages agree.
    second = [Event(e.arrival + STREAM[-1].arrival + 0.025, e.msg) for e in STREAM]
    node, estimate = run(context, STREAM + second)
    assert node.stats["time_jumps"] == node.stats["resets"] == 1
    assert node.stats["dropped_outlier_stamp"] == 2
    assert np.isfinite(estimate["poses"]).all() and len(estimate["keys"]) > 0


def test_an_odometry_restart_is_bridged_after_confirmation(context, clean):
    """From INJECT_AT on the odometry reads 100 m further east (a driver restart)."""
    def shifted(event: Event) -> Event:
        if not isinstance(event.msg, Odometry):
            return event
        pose = event.msg.pose.pose
        msg = odometry_msg(ros_io.stamp_to_seconds(event.msg.header.stamp),
                           (pose.position.x + 100.0, pose.position.y,
                            ros_io.quaternion_to_yaw(pose.orientation)))
        return Event(event.arrival, msg)
    node, estimate = run(context, STREAM[:INJECT_AT] + [shifted(e) for e in STREAM[INJECT_AT:]])
    assert node.stats["odometry_jumps"] == 1
    assert node.stats["dropped_implausible_odometry"] == 4
    assert node.stats["used_landmarks"] == 50
    # Four odometry steps (0.1 s at 3 m/s) are bridged with no motion: the estimate (the
    # particles' weighted mean) stays within a metre of the clean run's, not 100 m off.
    assert np.linalg.norm(mean_position(estimate) - mean_position(clean[1])) < 1.0


def test_a_non_finite_filter_state_is_repaired_and_counted(context, clean):
    params = dict(PARAMS)
    node = FastSLAMNode(context=context, enable_rosout=False, parameter_overrides=[
        Parameter(name, value=value) for name, value in params.items()])
    try:
        clock = node.get_clock()

        def feed(events):
            for event in events:
                clock.set_ros_time_override(Time(nanoseconds=round(event.arrival * 1e9)))
                (node.on_odometry if isinstance(event.msg, Odometry)
                 else node.on_landmarks)(event.msg)
        feed(STREAM[:INJECT_AT])
        ws = node.slam.working.current      # one particle's landmarks in view poisoned
        ws.cov[3, ws.valid[3]] = math.nan
        feed(STREAM[INJECT_AT:INJECT_AT + 40])
        assert node.stats["filter_recoveries"] == 1
        assert node.stats["dropped_internal_error"] == 0
        assert np.isfinite(node.slam.poses).all()
        node.slam.poses[:] = math.inf        # every particle poisoned: reset at the last pose
        feed(STREAM[INJECT_AT + 40:])
        node.flush()
        assert node.stats["filter_recoveries"] == 2
        assert node.stats["dropped_internal_error"] == 1  # the reading that found it
        assert node.stats["used_landmarks"] == 49
        assert np.isfinite(node.slam.poses).all() and len(node.slam.best_map()) > 0
        assert np.isfinite(node.slam.best_map().covariances).all()
    finally:
        node.destroy_node()


# --- random malformed clouds ----------------------------------------------------------------

FIELD_NAMES = st.sampled_from(["x", "y", "z", "id", "intensity"])
FIELDS = st.lists(st.builds(lambda name, offset, datatype, count: PointField(
    name=name, offset=offset, datatype=datatype, count=count),
    FIELD_NAMES, st.integers(0, 24), st.integers(0, 9), st.integers(0, 2)), max_size=6)


@st.composite
def malformed_clouds(draw) -> PointCloud2:
    """PointCloud2 messages with random layouts: mostly unreadable, some odd but valid."""
    width, height = draw(st.integers(0, 6)), draw(st.integers(0, 3))
    point_step = draw(st.integers(0, 24))
    row_step = draw(st.one_of(st.just(width * point_step), st.integers(0, 160)))
    size = draw(st.one_of(st.just(row_step * height), st.integers(0, 400)))
    data = draw(st.one_of(
        st.binary(min_size=size, max_size=size),
        st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), min_size=size // 4,
                 max_size=size // 4).map(lambda v: np.array(v, "<f4").tobytes())))
    return PointCloud2(height=height, width=width, fields=draw(FIELDS),
                       is_bigendian=draw(st.booleans()), point_step=point_step,
                       row_step=row_step, data=data, is_dense=draw(st.booleans()))


@settings(max_examples=300, deadline=None)
@given(malformed_clouds())
def test_read_landmark_cloud_reads_or_rejects_any_layout(msg):
    try:
        cloud = ros_io.read_landmark_cloud(msg)
    except ros_io.MalformedCloudError:
        return
    count = msg.width * msg.height
    assert len(cloud.x) == len(cloud.y) == count
    assert cloud.ids is None or len(cloud.ids) == count


@pytest.fixture(scope="module")
def running_node(context):
    node = in_process(FastSLAMNode)(context=context, enable_rosout=False, parameter_overrides=[
        Parameter(name, value=value) for name, value in PARAMS.items()])
    clock = node.get_clock()
    for event in STREAM[:INJECT_AT]:
        clock.set_ros_time_override(Time(nanoseconds=round(event.arrival * 1e9)))
        (node.on_odometry if isinstance(event.msg, Odometry) else node.on_landmarks)(event.msg)
    yield node
    node.destroy_node()


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(msg=malformed_clouds(), offset=st.integers(1, 10_000))
def test_random_clouds_never_break_the_node(running_node, msg, offset):
    node = running_node
    stamp = node._odometry.latest_stamp  # each cloud a little older: none is a duplicate
    msg.header = Header(stamp=ros_io.seconds_to_stamp(stamp - offset * 1e-6),
                        frame_id="base_link")
    before = node.stats["dropped_internal_error"]
    node.on_landmarks(msg)
    node.flush()
    assert node.stats["dropped_internal_error"] == before
    assert np.isfinite(node.slam.poses).all() and np.isfinite(node.slam.log_weights).all()
    landmark_map = node.slam.best_map()
    assert np.isfinite(landmark_map.means).all() and np.isfinite(landmark_map.covariances).all()


def test_poisoned_bag_replays_to_the_clean_estimate(tmp_path):
    """fastslam-poison mixes every class into a bag; the replay drops exactly the faults, and
    fastslam-eval scores it as the clean one."""
    from fastslam_ros.tools.bags.bag_schema import read_topic, write_schema_bag
    from fastslam_ros.tools.bags.poison import poison_bag
    from fastslam_ros.tools.bags.replay import replay_bag
    from fastslam_ros.tools.evaluation.evaluate import evaluate

    bag = write_schema_bag(tmp_path / "clean", simulate(SimConfig(duration=25.0, seed=4)))
    counts = poison_bag(bag, tmp_path / "poisoned", rate=2.0, seed=1)
    assert min(counts.values()) >= 1  # every class at least once
    params = {"num_particles": 10, "seed": 2}
    clean = replay_bag(bag, params, out_path=tmp_path / "clean_out")
    poisoned = replay_bag(tmp_path / "poisoned", params, out_path=tmp_path / "poisoned_out")
    assert poisoned.stats["dropped_internal_error"] == 0
    assert poisoned.stats["used_landmarks"] == clean.stats["used_landmarks"]
    dropped = sum(v for k, v in poisoned.stats.items() if k.startswith("dropped_"))
    assert dropped >= sum(counts.values())
    poses = [read_topic(tmp_path / name, "/fastslam/pose")[1]
             for name in ("clean_out", "poisoned_out")]
    assert [(p.pose.pose.position.x, p.pose.pose.position.y) for p in poses[0]] == \
        [(p.pose.pose.position.x, p.pose.pose.position.y) for p in poses[1]]
    # fastslam-eval scores both runs (the poisoned inputs recorded with the outputs) alike.
    scores = [evaluate(tmp_path / name)["estimate"]["aligned"]["rmse"]
              for name in ("clean_out", "poisoned_out")]
    assert scores[0] == scores[1]


def test_lost_odometry_shows_in_diagnostics_with_the_gap(context):
    """Ten odometry messages missing at 5 s: counted, and the next report WARNs naming the gap."""
    odometry_indices = [i for i, e in enumerate(STREAM) if isinstance(e.msg, Odometry)]
    lost = set(odometry_indices[200:210])
    node = in_process(FastSLAMNode)(context=context, enable_rosout=False, parameter_overrides=[
        Parameter(name, value=value) for name, value in PARAMS.items()])
    reports = []
    node.output_listeners.append(lambda topic, msg: reports.append(msg)
                                 if topic == "/diagnostics" else None)
    try:
        clock = node.get_clock()
        for index, event in enumerate(STREAM):
            if index in lost:
                continue
            clock.set_ros_time_override(Time(nanoseconds=round(event.arrival * 1e9)))
            (node.on_odometry if isinstance(event.msg, Odometry) else node.on_landmarks)(event.msg)
        assert node.stats["odom_missing"] == 10 and node.stats["landmarks_missing"] == 0
        gap_at = ros_io.stamp_to_seconds(STREAM[odometry_indices[210]].msg.header.stamp)
        warnings = [ros_io.stamp_to_seconds(r.header.stamp) for r in reports
                    if r.status[0].level == DiagnosticStatus.WARN
                    and "~10 odom message(s) lost" in r.status[0].message]
        assert len(warnings) == 1 and gap_at <= warnings[0] <= gap_at + 2.0
        values = {kv.key: kv.value for kv in reports[-1].status[0].values}
        assert float(values["odom_interval"]) == pytest.approx(0.025)
        assert float(values["odom_largest_gap"]) == pytest.approx(0.275)
        assert reports[-1].status[0].level == DiagnosticStatus.OK  # reported once
    finally:
        node.destroy_node()
