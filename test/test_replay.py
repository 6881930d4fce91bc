# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Replay through the real node: recorded outputs, determinism, errors, parameter files."""
from __future__ import annotations

import gc
import json

import numpy as np
import pytest

from fastslam_ros.tools.bags.bag_schema import (REPLAY_INFO_TOPIC, LandmarkScans, PoseSeries,
                                           SchemaBag, SchemaError, read_last, read_topic,
                                           read_topics, write_schema_bag)
from fastslam_ros.tools.bags.in_process import node_parameters
from fastslam_ros.tools.bags.replay import load_params_file, parse_assignment, replay_bag
from fastslam_ros.tools.simulation.sim import SimConfig, recommended_params, simulate

PARAMS = dict(recommended_params(SimConfig()), num_particles=20)


@pytest.fixture(scope="module")
def short_bag(tmp_path_factory):
    path = tmp_path_factory.mktemp("replay") / "short"
    return write_schema_bag(path, simulate(SimConfig(duration=20.0, seed=2)))


def test_replay_records_outputs_at_bag_time(tmp_path, short_bag):
    result = replay_bag(short_bag, dict(PARAMS, seed=4), out_path=tmp_path / "out")
    assert result.stats["received_odom"] == 801
    assert result.stats["used_landmarks"] == result.stats["received_landmarks"] == 100
    assert result.bag_duration == pytest.approx(20.0)
    assert result.params["num_particles"] == 20

    data = read_topics(tmp_path / "out", ["/fastslam/pose", "/ground_truth/pose", "/odom"])
    log_stamps, poses = data["/fastslam/pose"]
    _, scans = read_topic(short_bag, "/landmarks")
    scan_stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in scans]
    pose_stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in poses]
    np.testing.assert_allclose(pose_stamps, scan_stamps, atol=1e-9)  # one pose per reading
    assert np.all(log_stamps >= np.array(pose_stamps) - 1e-9)  # logged when it was computed
    assert len(data["/ground_truth/pose"][1]) == 801 and len(data["/odom"][1]) == 801
    last = read_last(tmp_path / "out", ["/fastslam/map_cloud", "/diagnostics", REPLAY_INFO_TOPIC])
    assert last["/fastslam/map_cloud"][1].width > 0
    info = json.loads(last[REPLAY_INFO_TOPIC][1].data)
    assert info["stats"] == result.stats and info["real_time_factor"] > 0
    values = {kv.key: kv.value for status in last["/diagnostics"][1].status for kv in status.values}
    assert int(values["associations_checked"]) > 0


def test_replay_saves_the_refined_map_and_never_replaces_a_file(tmp_path, short_bag):
    from fastslam_ros import map_files
    map_file = tmp_path / "map.yaml"
    result = replay_bag(short_bag, dict(PARAMS, seed=4), save_map=map_file)
    assert "refined by least squares" in result.saved_map
    saved = map_files.read_map_file(map_file)
    assert len(saved.means) > 0 and np.isfinite(saved.covariances).all()
    with pytest.raises(FileExistsError):
        replay_bag(short_bag, dict(PARAMS, seed=4), save_map=map_file)
    replay_bag(short_bag, dict(PARAMS, seed=4), save_map=map_file, overwrite=True)


def test_same_bag_params_and_seed_give_identical_estimates(tmp_path, short_bag):
    for name in ("a", "b"):
        replay_bag(short_bag, dict(PARAMS, seed=11), out_path=tmp_path / name)
        assert gc.get_freeze_count() == 0  # the start's objects were frozen for the run only
    first = read_topic(tmp_path / "a", "/fastslam/pose")[1]
    second = read_topic(tmp_path / "b", "/fastslam/pose")[1]
    assert len(first) == len(second) == 100
    for a, b in zip(first, second):
        assert (a.pose.pose.position.x, a.pose.pose.position.y) == \
               (b.pose.pose.position.x, b.pose.pose.position.y)
        np.testing.assert_array_equal(a.pose.covariance, b.pose.covariance)
    cloud_a = read_last(tmp_path / "a", ["/fastslam/map_cloud"])["/fastslam/map_cloud"][1]
    cloud_b = read_last(tmp_path / "b", ["/fastslam/map_cloud"])["/fastslam/map_cloud"][1]
    np.testing.assert_array_equal(cloud_a.data, cloud_b.data)


def test_missing_topics_and_unreadable_bags_are_reported(tmp_path):
    stamps = np.array([0.0, 1.0])
    odom_only = write_schema_bag(tmp_path / "odom_only",
                                 SchemaBag(PoseSeries(stamps, np.zeros((2, 3))),
                                           LandmarkScans(np.zeros(0), [], [])))
    with pytest.raises(SchemaError, match="/landmarks"):
        replay_bag(odom_only, PARAMS)
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "metadata.yaml").write_text("not: [a bag")
    with pytest.raises(SchemaError, match="cannot read"):
        replay_bag(broken, PARAMS, out_path=tmp_path / "never")
    assert not (tmp_path / "never").exists()
    with pytest.raises(FileNotFoundError):
        replay_bag(tmp_path / "absent", PARAMS)


def test_bad_and_unknown_parameters_are_named(short_bag):
    with pytest.raises(ValueError, match="num_particles"):
        replay_bag(short_bag, {"num_particles": 0})
    with pytest.raises(ValueError, match="no_such_parameter"):
        replay_bag(short_bag, {"no_such_parameter": 1.0})


def test_parameter_file_sections_merge_and_integers_widen(tmp_path):
    path = tmp_path / "params.yaml"
    path.write_text("/**:\n  ros__parameters:\n    sigma_range: 1\n    num_particles: 7\n"
                    "fastslam:\n  ros__parameters:\n    num_particles: 9\n    association: known\n")
    params = load_params_file(path)
    assert params == {"sigma_range": 1, "num_particles": 9, "association": "known"}
    overrides = {p.name: p.value for p in node_parameters(params)}
    assert overrides["sigma_range"] == 1.0 and isinstance(overrides["sigma_range"], float)
    assert overrides["num_particles"] == 9 and overrides["use_sim_time"] is True
    assert parse_assignment("alpha1=0.5") == ("alpha1", 0.5)
    assert parse_assignment("alpha2=2e-4") == ("alpha2", 2e-4)
    assert parse_assignment("num_particles=30") == ("num_particles", 30)
    assert parse_assignment("association=ml") == ("association", "ml")
    with pytest.raises(ValueError):
        parse_assignment("alpha1")


def test_message_types_come_from_a_fixed_table_never_from_an_import():
    import sys

    from fastslam_ros.tools.bags.bag_schema import ros_message_class
    from nav_msgs.msg import Odometry
    assert ros_message_class("nav_msgs/msg/Odometry") is Odometry
    sys.modules.pop("this", None)
    for name in ("this/msg/Odometry", "os/msg/system", "nav_msgs/msg/Nope", "garbage"):
        with pytest.raises(SchemaError, match="not one the tools handle"):
            ros_message_class(name, "/odom")
    assert "this" not in sys.modules


def test_replay_is_invisible_to_other_processes(tmp_path):
    """A replay in one process, a plain node in another, a probe here, one domain: the probe
    sees the plain node (discovery works) and never the replay's node."""
    import os
    import subprocess
    import sys
    import time

    import rclpy
    from rclpy.context import Context

    domain = str(150 + os.getpid() % 80)
    env = {**os.environ, "ROS_DOMAIN_ID": domain}
    bag = write_schema_bag(tmp_path / "long", simulate(SimConfig(duration=60.0, seed=2)))
    replay_process = subprocess.Popen(
        [sys.executable, "-m", "fastslam_ros.tools.bags.replay", str(bag), "--no-record",
         "--set", "num_particles=30", "--set", "seed=1"], env=env,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    control = subprocess.Popen(
        [sys.executable, "-c", "import rclpy, time; rclpy.init(); "
         "n = rclpy.create_node('visible_control'); time.sleep(8)"], env=env)
    context = Context()
    rclpy.init(context=context, domain_id=int(domain))
    probe = rclpy.create_node("probe", context=context)
    seen: set[str] = set()
    try:
        deadline = time.monotonic() + 6.0
        while time.monotonic() < deadline and replay_process.poll() is None:
            seen |= set(probe.get_node_names())
            time.sleep(0.1)
        assert "visible_control" in seen
        assert "fastslam" not in seen
    finally:
        probe.destroy_node()
        rclpy.shutdown(context=context)
        replay_process.kill()
        control.kill()
        replay_process.wait()
        control.wait()


@pytest.mark.parametrize("stamp_ns, parent, child, translation, rotation", [
    (0, "odom", "base_link", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
    (1_700_000_000_123_456_789, "map", "odom", (-12.5, 3e5, 0.0), (0.0, 0.0, -0.997, 0.0707)),
    (5, "", "a_frame_with_a_longer_name", (1.0, 2.0, -0.25), (0.1, -0.2, 0.3, 0.927)),
])
def test_direct_tf_bytes_are_the_serializers(stamp_ns, parent, child, translation, rotation):
    from fastslam_ros.tools.bags.bag_schema import TYPESTORE, TF_TYPE, tf_message_bytes
    from fastslam_ros.tools.bags.cdr import tf_message_cdr
    types = TYPESTORE.types
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    transform = types["geometry_msgs/msg/TransformStamped"](
        header=types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
            frame_id=parent),
        child_frame_id=child,
        transform=types["geometry_msgs/msg/Transform"](
            translation=types["geometry_msgs/msg/Vector3"](*translation),
            rotation=types["geometry_msgs/msg/Quaternion"](*rotation)))
    assert TF_TYPE == "tf2_msgs/msg/TFMessage"
    for _ in range(2):  # the second time from the cached frame bytes
        assert tf_message_cdr(sec, nanosec, parent, child, translation, rotation) == \
            tf_message_bytes([transform])


def test_marker_arrays_serialized_from_pieces_read_back_as_rclpy_writes_them():
    """MarkerArrayCdr against rclpy's serializer over a changing map (landmarks moved, added,
    removed; ids of every length, so markers start at both alignments), and the lean builder's
    MarkerViews give the bytes of the rclpy markers."""
    from types import SimpleNamespace

    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import Header
    from visualization_msgs.msg import MarkerArray

    from fastslam_ros import ros_markers
    from fastslam_ros.tools.bags.recorder import MarkerArrayCdr

    from fastslam_ros.tools.bags.bag_schema import TYPESTORE

    rng = np.random.default_rng(3)
    builder, cdr = ros_markers.MarkerBuilder(), MarkerArrayCdr()
    lean_builder, lean_cdr = ros_markers.MarkerBuilder(lean=True), MarkerArrayCdr()
    keys = np.arange(40)
    means = rng.normal(0.0, 20.0, (40, 2))
    for step in range(6):
        moved = rng.uniform(size=len(keys)) < 0.3
        means[moved] += rng.normal(0.0, 0.1, (int(moved.sum()), 2))
        landmark_map = SimpleNamespace(
            means=means, keys=keys,
            ids=np.where(keys % 3 == 0, -1, keys * 7919 % 10 ** (1 + keys % 5)),
            covariances=np.tile(np.diag([0.2, 0.1]), (len(keys), 1, 1)),
            existence=np.where(moved, 0.5, 0.9))
        msg = builder.build(Header(frame_id="map"), landmark_map, removed_keys=[1000 + step])
        expected = deserialize_message(serialize_message(msg), MarkerArray)
        assert deserialize_message(cdr.serialize(msg), MarkerArray) == expected
        lean = lean_builder.build(Header(frame_id="map"), landmark_map, [1000 + step])
        assert isinstance(lean, ros_markers.MarkerArrayView)
        assert lean_cdr.serialize(lean) == bytes(TYPESTORE.serialize_cdr(TYPESTORE.deserialize_cdr(
            serialize_message(msg), "visualization_msgs/msg/MarkerArray"),
            "visualization_msgs/msg/MarkerArray"))
        keep = rng.uniform(size=len(keys)) < 0.9
        keys, means = np.append(keys[keep], 100 + step), np.vstack([means[keep], [[1.0, 2.0]]])


def test_lean_mcap_writer_writes_rosbags_bytes(tmp_path):
    """The same messages (several topics, out-of-order stamps, enough to close chunks) through
    rosbags' MCAP writer and through the replay's (its storage, the recorder's writes) give
    identical files and metadata."""
    from importlib.metadata import version

    from fastslam_ros.tools.bags.bag_schema import open_writer
    from fastslam_ros.tools.bags.recorder import (LEAN_WRITER_ROSBAGS, LeanMcapWriter,
                                                  OutputRecorder, lean_writer)

    if not version("rosbags").startswith(LEAN_WRITER_ROSBAGS):
        pytest.skip(f"rosbags {version('rosbags')}: the replay records through rosbags' writer")

    rng = np.random.default_rng(8)
    messages = [(int(rng.integers(3)), int(stamp), rng.bytes(int(size)))
                for stamp, size in zip(rng.integers(0, 10**12, 6000), rng.integers(0, 900, 6000))]
    files = []
    for name, wrap in (("rosbags", lambda writer: writer), ("lean", lean_writer)):
        (tmp_path / name).mkdir()
        with open_writer(tmp_path / name / "bag", wrap=wrap) as writer:  # one name: in the file
            assert (type(writer.storage) is LeanMcapWriter) == (name == "lean")
            recorder = OutputRecorder(writer)
            assert (recorder._write == writer.write) == (name == "rosbags")
            for index, stamp, data in messages:
                recorder.copy(f"/topic{index}", "std_msgs/msg/String", stamp, data)
        files.append([(tmp_path / name / "bag" / file).read_bytes()
                      for file in ("bag.mcap", "metadata.yaml")])
    assert len(files[0][0]) > 2 * 2**20 and files[0] == files[1]
