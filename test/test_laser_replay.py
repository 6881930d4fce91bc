# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""``fastslam-replay`` of a bag with /scan and no /landmarks: the extractor runs in-process
ahead of the SLAM node, its clouds are the extractor's on each scan and both nodes take their
parameters from one file."""
from __future__ import annotations

import json

import numpy as np
import pytest

from fastslam_ros.extractor import ExtractorSettings, extract_landmarks
from fastslam_ros.extractor_io import EXTRACTED_CLOUD_DTYPE, read_scan
from fastslam_ros.tools.bags import replay
from fastslam_ros.tools.simulation import sim
from fastslam_ros.tools.bags.bag_schema import REPLAY_INFO_TOPIC, read_topic


@pytest.fixture(scope="module")
def laser_bag(tmp_path_factory):
    out = tmp_path_factory.mktemp("laser") / "bag"
    assert sim.main(["--laser", "--duration", "12", "--seed", "4", "--out", str(out)]) == 0
    return out


def test_scans_without_landmarks_go_through_the_extractor(tmp_path, laser_bag):
    out = tmp_path / "out"
    result = replay.replay_bag(laser_bag, {"seed": 1}, out_path=out,
                               remap={"/landmarks": "/hidden"})
    _, scans = read_topic(laser_bag, "/scan")
    assert result.stats["used_landmarks"] == len(scans) == 60
    assert result.stats["extractor_used_scan"] == 60 and result.stats["extractor_landmarks"] > 0
    assert not any(v for k, v in result.stats.items() if k.startswith("dropped_"))
    stamps, clouds = read_topic(out, "/landmarks")
    assert len(clouds) == len(scans)
    for scan, cloud in zip(scans[::15], clouds[::15]):
        assert cloud.header.stamp == scan.header.stamp
        points = np.frombuffer(bytes(cloud.data), EXTRACTED_CLOUD_DTYPE)
        expected = extract_landmarks(read_scan(scan), ExtractorSettings()).landmarks
        assert points["x"] == pytest.approx(expected.x.astype(np.float32))
    assert read_topic(out, "/fastslam/pose")[1]


def test_the_static_filter_gets_the_bags_odometry(tmp_path, laser_bag):
    """With static_window the extractor reads the bag's /odom too: every scan finds its
    odometry pose and becomes a cloud at its stamp, and in a world of poles (no people) only
    a few landmarks are dropped as moved."""
    result = replay.replay_bag(laser_bag, {"seed": 1, "static_window": 0.5},
                               out_path=tmp_path / "out", remap={"/landmarks": "/hidden"})
    _, scans = read_topic(laser_bag, "/scan")
    stats = result.stats
    assert stats["extractor_used_odom"] == stats["used_odom"] > 0
    assert stats["used_landmarks"] == len(scans) == 60
    assert not any(v for k, v in stats.items() if k.startswith(("dropped_", "extractor_dropped")))
    published, moved = stats["extractor_landmarks"], stats["extractor_rejected_moving"]
    assert published > 0 and moved <= 0.05 * (published + moved)
    _, clouds = read_topic(tmp_path / "out", "/landmarks")
    assert [c.header.stamp for c in clouds] == [s.header.stamp for s in scans]


def test_one_parameter_file_sets_both_nodes(tmp_path, laser_bag):
    params = tmp_path / "params.yaml"
    params.write_text("fastslam:\n  ros__parameters:\n    num_particles: 30\n"
                      "    sigma_range: 0.05\n"
                      "landmark_extractor:\n  ros__parameters:\n    detector: both\n"
                      "    segment_jump: 0.25\n")
    result = replay.replay_bag(laser_bag, {"seed": 2, "reflector_radius": 0.04},
                               params_file=params, out_path=tmp_path / "out",
                               remap={"/landmarks": "/hidden"})
    assert result.params["detector"] == "both" and result.params["segment_jump"] == 0.25
    assert result.params["num_particles"] == 30 and result.params["reflector_radius"] == 0.04
    _, infos = read_topic(tmp_path / "out", REPLAY_INFO_TOPIC)
    assert json.loads(infos[0].data)["params"]["sigma_range"] == 0.05
    _, clouds = read_topic(tmp_path / "out", "/landmarks")
    reflectors = sum(int(np.sum(np.frombuffer(bytes(c.data), EXTRACTED_CLOUD_DTYPE)["radius"]
                            == np.float32(0.04))) for c in clouds)
    assert reflectors > 0


def test_a_bad_extractor_parameter_names_it(tmp_path, laser_bag):
    with pytest.raises(ValueError, match="segment_jump"):
        replay.replay_bag(laser_bag, {"segment_jump": -1.0}, remap={"/landmarks": "/hidden"})
    with pytest.raises(ValueError, match="segment_jmp"):
        replay.replay_bag(laser_bag, {"segment_jmp": 0.2}, remap={"/landmarks": "/hidden"})


def test_laser_demo_writes_every_artefact(tmp_path, capsys):
    from fastslam_ros.tools import demo
    out_dir = tmp_path / "demo"
    assert demo.main(["--scenario", "laser", "--out-dir", str(out_dir), "--particles", "10",
                      "--duration", "15"]) == 0
    assert "| estimate (at the time) |" in capsys.readouterr().out
    for name in ("summary.md", "metrics.json", "result.png", "sim_laser", "sim_laser.yaml",
                 "replay"):
        assert (out_dir / name).exists(), name
    info = json.loads(read_topic(out_dir / "replay", REPLAY_INFO_TOPIC)[1][0].data)
    assert info["params"]["detector"] == "both" and info["stats"]["extractor_used_scan"] == 75
    assert info["stats"]["used_landmarks"] == 75
    # Every output exists now: a second demo without --overwrite refuses (exit status 2).
    assert demo.main(["--scenario", "laser", "--out-dir", str(out_dir), "--duration", "15"]) == 2
