# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Nothing a user owns is lost: every tool and service that writes refuses an existing file
without an explicit overwrite, replaces a link (never its target), never takes a folder that
only looks like a bag, makes no folder, and leaves nothing behind when it fails. Each case
compares a checksum of the user's tree before and after."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from std_srvs.srv import Trigger

from fastslam_ros import map_files
from fastslam_ros.core import LandmarkMap
from fastslam_ros.node import ParameterError
from fastslam_ros.output import OutputExistsError, is_bag, staged_output
from fastslam_ros.tools import demo
from fastslam_ros.tools.bags import replay
from fastslam_ros.tools.datasets import convert
from fastslam_ros.tools.evaluation import evaluate
from fastslam_ros.tools.simulation import sim
from fastslam_ros.tools.bags.bag_schema import write_schema_bag
from fastslam_ros.tools.simulation.sim import SimConfig, simulate
from test_map_lifecycle import node_with

DOMAIN_ID = 100 + os.getpid() % 100
PARTICLES = ["--set", "num_particles=5"]


def tree_digest(root: Path) -> dict[str, str]:
    """Every entry under ``root``: a link's target, a file's SHA-256, a folder's name."""
    digest = {}
    for path in sorted(root.rglob("*")):
        name = str(path.relative_to(root))
        if path.is_symlink():
            digest[name] = "-> " + os.readlink(path)
        elif path.is_file():
            digest[name] = hashlib.sha256(path.read_bytes()).hexdigest()
        else:
            digest[name] = "folder"
    return digest


@pytest.fixture(scope="module")
def bag(tmp_path_factory) -> Path:
    return write_schema_bag(tmp_path_factory.mktemp("safety") / "input",
                            simulate(SimConfig(duration=3.0, seed=1)))


@pytest.fixture
def user_tree(tmp_path) -> Path:
    """A user's folder: notes, data, a folder that looks like a bag, a link to a file."""
    home = tmp_path / "home"
    home.mkdir()
    (home / "notes.yaml").write_text("meeting: tuesday\n")
    (home / "data.csv").write_text("a,b\n1,2\n")
    looks_like_bag = home / "cfg"
    looks_like_bag.mkdir()
    (looks_like_bag / "metadata.yaml").write_text("project: x\n")
    (looks_like_bag / "robot.yaml").write_text("speed: 1\n")
    (home / "link.yaml").symlink_to(home / "notes.yaml")
    return home


def tiny_map() -> LandmarkMap:
    return LandmarkMap(np.array([[1.0, 2.0]]), np.array([np.eye(2) * 0.01]), np.array([0.9]),
                       np.array([3]), np.array([0]))


# --- the one writing function -------------------------------------------------------------

def test_a_failed_write_leaves_nothing_and_the_old_output_intact(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with staged_output(target, overwrite=True, kind="file") as staged:
            staged.write_text("half")
            raise RuntimeError("the tool failed midway")
    assert target.read_text() == "old" and sorted(os.listdir(tmp_path)) == ["out.txt"]
    with pytest.raises(OutputExistsError, match="nothing was written"):
        with staged_output(tmp_path / "never", overwrite=False, kind="file"):
            pass
    assert sorted(os.listdir(tmp_path)) == ["out.txt"]


def test_a_folder_is_a_bag_only_with_rosbag2_metadata_and_its_listed_files(tmp_path, bag,
                                                                           user_tree):
    assert is_bag(bag)
    assert not is_bag(user_tree / "cfg")
    extra = tmp_path / "bag_plus"
    write_schema_bag(extra, simulate(SimConfig(duration=1.0, seed=1)))
    assert is_bag(extra)
    (extra / "readme.yaml").write_text("mine")  # a storage-like suffix, but not listed
    assert not is_bag(extra)


def test_map_file_never_replaces_a_user_file_follows_a_link_or_makes_a_folder(user_tree):
    before = tree_digest(user_tree)
    for name in ("notes.yaml", "data.csv", "link.yaml"):
        with pytest.raises(OutputExistsError, match="exists"):
            map_files.write_map_file(user_tree / name, tiny_map(), "map", 0.0)
    with pytest.raises(OutputExistsError, match="does not exist"):
        map_files.write_map_file(user_tree / "new" / "map.yaml", tiny_map(), "map", 0.0)
    assert tree_digest(user_tree) == before
    map_files.write_map_file(user_tree / "link.yaml", tiny_map(), "map", 0.0, overwrite=True)
    assert not (user_tree / "link.yaml").is_symlink()  # the link was replaced ...
    assert (user_tree / "notes.yaml").read_text() == "meeting: tuesday\n"  # ... not its target
    assert len(map_files.read_map_file(user_tree / "link.yaml").means) == 1


@pytest.mark.parametrize("text", ["", "x,y,cov_xx\n", "landmarks: []\n"])
def test_an_empty_map_is_an_error(tmp_path, text):
    path = tmp_path / ("map.csv" if "," in text or not text else "map.yaml")
    path.write_text(text)
    with pytest.raises(map_files.MapFileError, match="no landmark"):
        map_files.read_map_file(path)


# --- the node's services (the node as test_map_lifecycle makes it) ----------------------

@pytest.fixture
def context():
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID)
    yield ctx
    rclpy.shutdown(context=ctx)


def test_save_map_service_refuses_user_files_unless_told(context, user_tree):
    before = tree_digest(user_tree)
    for name in ("notes.yaml", "data.csv", "link.yaml", "cfg", "missing/map.yaml"):
        node = node_with(context, save_map_file=str(user_tree / name))
        try:
            response = node._on_save_map(Trigger.Request(), Trigger.Response())
            assert not response.success and name.split("/")[0] in response.message
        finally:
            node.destroy_node()
    assert tree_digest(user_tree) == before
    node = node_with(context, save_map_file=str(user_tree / "link.yaml"), save_map_overwrite=True)
    try:
        response = node._on_save_map(Trigger.Request(), Trigger.Response())
        assert response.success, response.message
    finally:
        node.destroy_node()
    assert (user_tree / "notes.yaml").read_text() == "meeting: tuesday\n"
    assert not (user_tree / "link.yaml").is_symlink()


def test_an_empty_map_is_refused_at_start_and_load_map_keeps_the_old_one(context, tmp_path):
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(ParameterError, match="map_file"):
        node_with(context, map_file=str(empty))
    good = map_files.write_map_file(tmp_path / "good.yaml", tiny_map(), "map", 0.0)
    node = node_with(context, map_file=str(good))
    try:
        assert len(node.slam.best_map()) == 1
        (tmp_path / "good.yaml").write_text("landmarks: []\n")
        response = node._on_load_map(Trigger.Request(), Trigger.Response())
        assert not response.success and "no landmark" in response.message
        assert len(node.slam.best_map()) == 1
    finally:
        node.destroy_node()


# --- the tools ----------------------------------------------------------------------------

def test_replay_and_convert_never_take_a_folder_that_only_looks_like_a_bag(bag, user_tree):
    before = tree_digest(user_tree)
    cfg = user_tree / "cfg"
    assert replay.main([str(bag), *PARTICLES, "--out", str(cfg), "--overwrite"]) != 0
    assert convert.main(["freiburg", str(bag), "--out", str(cfg), "--overwrite"]) != 0
    assert sim.main(["--out", str(cfg), "--duration", "1", "--overwrite"]) != 0
    assert tree_digest(user_tree) == before


def test_replay_save_map_replaces_a_link_never_its_target(bag, user_tree, capsys):
    before = tree_digest(user_tree)
    link = user_tree / "link.yaml"
    assert replay.main([str(bag), *PARTICLES, "--no-record", "--save-map", str(link)]) != 0
    assert tree_digest(user_tree) == before
    assert replay.main([str(bag), *PARTICLES, "--no-record", "--save-map", str(link),
                        "--overwrite"]) == 0
    assert (user_tree / "notes.yaml").read_text() == "meeting: tuesday\n"
    assert not link.is_symlink() and "landmarks" in link.read_text()
    capsys.readouterr()


def test_eval_json_replaces_a_link_never_its_target(tmp_path, bag, user_tree):
    run = tmp_path / "run"
    replay.replay_bag(bag, {"num_particles": 5, "seed": 1}, out_path=run)
    assert evaluate.main([str(run), "--json", str(user_tree / "link.yaml"), "--overwrite"]) == 0
    assert (user_tree / "notes.yaml").read_text() == "meeting: tuesday\n"
    assert (user_tree / "link.yaml").read_text().startswith("{")


def test_a_failed_conversion_leaves_no_bag(tmp_path, capsys):
    dataset = tmp_path / "victoria"
    dataset.mkdir()
    for name in ("inputs.dat", "measurements.dat", "gps.dat"):
        (dataset / name).write_text("")
    assert convert.main(["victoria-park", str(dataset), "--out", str(tmp_path / "out")]) == 1
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert sorted(os.listdir(tmp_path)) == ["victoria"]


def test_a_failed_demo_leaves_nothing_and_its_retry_runs(tmp_path, monkeypatch, capsys):
    def broken_replay(*_args, **_kwargs):
        raise OSError("disk full")

    out_dir = tmp_path / "demo"
    args = ["--out-dir", str(out_dir), "--particles", "5", "--duration", "3"]
    monkeypatch.setattr(demo, "replay_bag", broken_replay)
    assert demo.main(args) == 1
    assert "disk full" in capsys.readouterr().err
    assert sorted(os.listdir(tmp_path)) == []
    monkeypatch.undo()
    assert demo.main(args) == 0
    assert {"summary.md", "metrics.json", "result.png", "replay", "sim_loop"} <= set(
        os.listdir(out_dir))
    assert sorted(name for name in os.listdir(out_dir) if name.startswith(".")) == []


def test_every_writing_tool_leaves_a_user_tree_as_it_was(tmp_path, bag, user_tree, capsys):
    """Each tool pointed at the user's files (a file, a link, a bag look-alike, a missing
    folder), without and with --overwrite where only a bag may be replaced: exit 1 or 2, one
    line, and not one byte of the tree changed."""
    from fastslam_ros.tools.bags import poison
    from fastslam_ros.tools.benchmarks import bench, soak
    from fastslam_ros.tools.evaluation import calibrate

    run = tmp_path / "run"
    replay.replay_bag(bag, {"num_particles": 5, "seed": 1}, out_path=run)
    capsys.readouterr()
    before = tree_digest(user_tree)
    files = [user_tree / "notes.yaml", user_tree / "link.yaml", user_tree / "missing" / "x.yaml"]
    folders = [user_tree / "cfg", user_tree / "notes.yaml", user_tree / "missing" / "bag"]
    calls = []
    for path in files:
        calls += [(calibrate.main, [str(bag), "--out", str(path)]),
                  (evaluate.main, [str(run), "--json", str(path)]),
                  (bench.main, ["--only", "memory", "--json", str(path)]),
                  (soak.main, ["--hours", "0.001", "--json", str(path)]),
                  (sim.main, ["--out", str(tmp_path / "s"), "--params-out", str(path),
                              "--duration", "1"])]
    for path in folders:
        for extra in ([], ["--overwrite"]):
            calls += [(poison.main, [str(bag), "--out", str(path), *extra]),
                      (replay.main, [str(bag), *PARTICLES, "--out", str(path), *extra]),
                      (sim.main, ["--out", str(path), "--duration", "1", *extra]),
                      (sim.main, ["--scenario", "people", "--out", str(path), "--duration", "1",
                                  *extra])]
    for main, args in calls:
        status = main(args)
        err = capsys.readouterr().err.strip().splitlines()
        assert status in (1, 2), (main.__module__, args)
        assert err and "Traceback" not in "\n".join(err), (main.__module__, args, err)
        assert tree_digest(user_tree) == before, (main.__module__, args)
