# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Every console command on bad inputs, paths and option values: exit status 1 (the run failed
on usable inputs) or 2 (usage), one line on stderr, never a traceback (tools/cli.py's rule)."""
from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader

from conftest import REPO_ROOT
from fastslam_ros.tools import demo
from fastslam_ros.tools.bags import play, poison, replay
from fastslam_ros.tools.benchmarks import bench, benchmark
from fastslam_ros.tools.datasets import convert
from fastslam_ros.tools.evaluation import calibrate, evaluate
from fastslam_ros.tools.simulation import sim
from fastslam_ros.tools.bags.bag_schema import (LANDMARKS_TOPIC, ODOM_TOPIC, TYPESTORE, open_writer,
                                           write_schema_bag)
from fastslam_ros.tools.simulation.sim import SimConfig, simulate

TOOLS = {"fastslam-sim": sim, "fastslam-replay": replay, "fastslam-play": play,
         "fastslam-eval": evaluate, "fastslam-demo": demo, "fastslam-convert": convert,
         "fastslam-benchmark": benchmark, "fastslam-bench": bench, "fastslam-poison": poison,
         "fastslam-calibrate": calibrate}
"""Console scripts run in this process (``main(argv)``)."""
NODES = {"fastslam_node": "fastslam_ros.node", "people_tracker_node": "fastslam_ros.people_node",
         "landmark_extractor_node": "fastslam_ros.landmark_extractor_node"}
"""Console scripts run as processes (they own rclpy's global context)."""
DURATION = 2.0
"""s of the small simulated bag (81 odometry messages at 40 Hz, 10 clouds)."""


def console_scripts() -> set[str]:
    """The names setup.py installs."""
    text = (REPO_ROOT / "setup.py").read_text()
    return set(re.findall(r'"([\w-]+) = fastslam_ros[\w.]*:main"', text))


def test_every_console_script_is_covered():
    assert console_scripts() == set(TOOLS) | set(NODES)


def copy_bag(source: Path, target: Path, change) -> Path:
    """A copy of ``source`` with ``change(topic, msgtype, raw) -> (msgtype, raw)`` applied to
    every message (raw None: the connection only)."""
    with AnyReader([source]) as reader, open_writer(target) as writer:
        connections = {c.id: writer.add_connection(c.topic, change(c.topic, c.msgtype, None)[0],
                                                    typestore=TYPESTORE)
                       for c in reader.connections}
        for connection, stamp_ns, raw in reader.messages():
            writer.write(connections[connection.id], stamp_ns,
                         change(connection.topic, connection.msgtype, raw)[1])
    return target


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    """A good bag and the bad inputs a careless user hands over."""
    root = tmp_path_factory.mktemp("inputs")
    good = write_schema_bag(root / "good", simulate(SimConfig(duration=DURATION, seed=1)))
    (root / "empty").mkdir()
    tum = root / "tum"
    tum.mkdir()
    (tum / "estimate.txt").write_text("100.0 1.0 2.0 0.0 0.0 0.0 0.0 1.0\n")
    corrupt = root / "corrupt"
    shutil.copytree(good, corrupt)
    (corrupt / "metadata.yaml").write_text("rosbag2_bagfile_information: [\n")
    text = TYPESTORE.serialize_cdr(TYPESTORE.types["std_msgs/msg/String"](data="x"),
                                   "std_msgs/msg/String")
    inputs_to_text = {ODOM_TOPIC, LANDMARKS_TOPIC}
    copy_bag(good, root / "wrong_types", lambda topic, msgtype, raw: (
        ("std_msgs/msg/String", text) if topic in inputs_to_text else (msgtype, raw)))
    # Every odometry message: a valid CDR header, then bytes of no Odometry.
    copy_bag(good, root / "garbage", lambda topic, msgtype, raw: (
        msgtype, b"\x00\x01\x00\x00" + b"\xff" * 7 if topic == ODOM_TOPIC else raw))
    copy_bag(good, root / "garbage_clouds", lambda topic, msgtype, raw: (
        msgtype, b"\x00\x01\x00\x00" + b"\xff" * 7 if topic == LANDMARKS_TOPIC else raw))
    (root / "notes.mcap").write_text("not a bag")
    return {"good": good, "empty": root / "empty", "tum": tum, "corrupt": corrupt,
            "wrong_types": root / "wrong_types", "garbage": root / "garbage",
            "garbage_clouds": root / "garbage_clouds",
            "not_a_bag": root / "notes.mcap", "missing": root / "absent"}


def run(prog: str, argv: list[str], capsys) -> tuple[int, str]:
    """Exit status and stderr of one command run in this process."""
    try:
        status = TOOLS[prog].main(argv)
    except SystemExit as exit_info:  # argparse
        status = exit_info.code
    return status, capsys.readouterr().err


def assert_one_line(prog: str, err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"{prog}: "), err
    assert "Traceback" not in err
    return lines[0]


BAG_COMMANDS = {
    "fastslam-eval": lambda bag, out: [str(bag)],
    "fastslam-replay": lambda bag, out: [str(bag), "--no-record", "--set", "num_particles=5"],
    "fastslam-poison": lambda bag, out: [str(bag), "--out", str(out / "poisoned")],
    "fastslam-calibrate": lambda bag, out: [str(bag)],
}
"""Commands that read a bag, with the arguments of a run on ``bag``."""
NOT_A_BAG = ("missing", "empty", "tum", "corrupt", "not_a_bag")


@pytest.mark.parametrize("prog", list(BAG_COMMANDS) + ["fastslam-play"])
@pytest.mark.parametrize("case", NOT_A_BAG)
def test_what_is_not_a_bag_is_a_usage_error(prog, case, inputs, tmp_path, capsys):
    argv = BAG_COMMANDS.get(prog, lambda bag, out: [str(bag)])(inputs[case], tmp_path)
    status, err = run(prog, argv, capsys)
    assert status == 2
    assert str(inputs[case]) in assert_one_line(prog, err)
    assert not (tmp_path / "poisoned").exists()


@pytest.mark.parametrize("prog", list(BAG_COMMANDS))
def test_topics_of_another_type_fail_at_start_naming_them(prog, inputs, tmp_path, capsys):
    status, err = run(prog, BAG_COMMANDS[prog](inputs["wrong_types"], tmp_path), capsys)
    assert status == 1
    line = assert_one_line(prog, err)
    assert "/odom is std_msgs/msg/String, expected nav_msgs/msg/Odometry" in line
    assert not (tmp_path / "poisoned").exists()


@pytest.mark.parametrize("prog", ["fastslam-eval", "fastslam-calibrate"])
def test_messages_that_do_not_decode_fail_in_one_line(prog, inputs, tmp_path, capsys):
    status, err = run(prog, BAG_COMMANDS[prog](inputs["garbage"], tmp_path), capsys)
    assert status == 1
    line = assert_one_line(prog, err)
    assert f"{inputs['garbage']}: a /odom message does not decode" in line


def test_a_ground_truth_that_does_not_decode_is_named(inputs, tmp_path, capsys):
    run_out = tmp_path / "run"
    assert replay.main([str(inputs["good"]), "--set", "num_particles=5", "--out",
                        str(run_out)]) == 0
    capsys.readouterr()
    status, err = run("fastslam-eval", [str(run_out), "--ground-truth",
                                        str(inputs["garbage_clouds"])], capsys)
    assert status == 1
    line = assert_one_line("fastslam-eval", err)
    assert f"{inputs['garbage_clouds']}: a /landmarks message does not decode" in line


def test_replay_drops_and_counts_messages_that_do_not_decode(inputs, tmp_path, capsys):
    clean = replay.replay_bag(inputs["good"], {"num_particles": 5, "seed": 1})
    result = replay.replay_bag(inputs["garbage"], {"num_particles": 5, "seed": 1})
    odometry = clean.stats["received_odom"]
    assert odometry == round(DURATION / 0.025) + 1
    assert result.stats["dropped_undecodable"] == odometry and result.stats["received_odom"] == 0
    assert result.stats["received_landmarks"] == clean.stats["received_landmarks"]
    assert replay.main([str(inputs["garbage"]), "--no-record", "--set", "num_particles=5"]) == 0
    assert f"undecodable {odometry}" in capsys.readouterr().out
    # Recorded: the sensor frame comes from the first reading that decodes (none here).
    out = tmp_path / "out"
    assert replay.main([str(inputs["garbage_clouds"]), "--set", "num_particles=5",
                        "--out", str(out)]) == 0
    assert f"undecodable {clean.stats['received_landmarks']}" in capsys.readouterr().out


def test_poison_copies_messages_that_do_not_decode(inputs, tmp_path, capsys):
    out = tmp_path / "poisoned"
    assert poison.main([str(inputs["garbage"]), "--out", str(out)]) == 0
    assert capsys.readouterr().err == ""
    with AnyReader([out]) as reader:
        odometry = [c for c in reader.connections if c.topic == ODOM_TOPIC]
        assert sum(c.msgcount for c in odometry) == round(DURATION / 0.025) + 1


def test_a_remapped_topic_is_named_as_read(inputs, capsys):
    status, err = run("fastslam-replay", [str(inputs["good"]), "--no-record",
                                          "-r", "/odom:=/nothing"], capsys)
    assert status == 1
    line = assert_one_line("fastslam-replay", err)
    assert "missing topic(s) /odom (has: " in line
    assert "/nothing (the bag's /odom, remapped)" in line and ", /odom," not in line


@pytest.mark.parametrize("prog, argv, named", [
    ("fastslam-play", ["{good}", "--rate", "0"], "--rate"),
    ("fastslam-play", ["{good}", "--rate", "nan"], "--rate"),
    ("fastslam-sim", ["--out", "{out}/s", "--speed", "-3"], "speed"),
    ("fastslam-sim", ["--out", "{out}/s", "--duration", "x"], "--duration"),
    ("fastslam-sim", ["--scenario", "people", "--out", "{out}/s", "--people", "-1"], "people"),
    ("fastslam-sim", ["--scenario", "people", "--out", "{out}/s", "--seed", "x"], "--seed"),
    ("fastslam-bench", ["--particles", "0"], "--particles"),
    ("fastslam-bench", ["--repeat", "0"], "--repeat"),
    ("fastslam-bench", ["--steps", "0"], "--steps"),
    ("fastslam-bench", ["--sweep", "10,a"], "--sweep"),
    ("fastslam-benchmark", ["--jobs", "0"], "--jobs"),
    ("fastslam-poison", ["{good}", "--out", "{out}/p", "--rate", "0"], "--rate"),
    ("fastslam-eval", ["{good}", "--cutoff", "-1"], "--cutoff"),
    ("fastslam-calibrate", ["{good}", "--step", "0"], "--step"),
    ("fastslam-replay", ["{good}", "--no-such-option"], "--no-such-option"),
    ("fastslam-replay", ["{good}", "-r", "odom"], "FROM:=TO"),
    ("fastslam-replay", ["{good}", "-p", "num_particles:=[1"], "not a YAML value"),
    ("fastslam-demo", ["--particles", "x"], "--particles"),
    ("fastslam-convert", ["no-such-kind", "{good}", "--out", "{out}/c"], "no-such-kind"),
])
def test_bad_option_values_are_usage_errors(prog, argv, named, inputs, tmp_path, capsys):
    argv = [a.format(good=inputs["good"], out=tmp_path) for a in argv]
    status, err = run(prog, argv, capsys)
    assert status == 2
    assert named in assert_one_line(prog, err)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("prog, argv", [
    ("fastslam-sim", ["--out", "{missing}/s", "--duration", "1"]),
    ("fastslam-replay", ["{good}", "--out", "{missing}/o"]),
    ("fastslam-replay", ["{good}", "--params", "{missing}/p.yaml"]),
    ("fastslam-eval", ["{good}", "--json", "{missing}/m.json"]),
    ("fastslam-demo", ["--out-dir", "{missing}/d"]),
    ("fastslam-convert", ["freiburg", "{empty}", "--out", "{out}/c"]),
    ("fastslam-convert", ["mrclam", "{tum}", "--out", "{out}/c"]),
    ("fastslam-benchmark", ["--datasets", "{empty}", "--out-dir", "{out}/b"]),
    ("fastslam-bench", ["--json", "{missing}/b.json"]),
    ("fastslam-calibrate", ["{good}", "--out", "{missing}/c.yaml"]),
    ("fastslam-poison", ["{good}", "--out", "{missing}/p"]),
])
def test_paths_that_cannot_be_used_are_usage_errors(prog, argv, inputs, tmp_path, capsys):
    argv = [a.format(good=inputs["good"], missing=inputs["missing"], empty=inputs["empty"],
                     tum=inputs["tum"], out=tmp_path) for a in argv]
    status, err = run(prog, argv, capsys)
    assert status == 2
    assert_one_line(prog, err)
    assert os.listdir(tmp_path) == []


def test_an_existing_output_without_overwrite_is_a_usage_error(inputs, tmp_path, capsys):
    existing = tmp_path / "existing.yaml"
    existing.write_text("mine")
    folder = tmp_path / "folder"
    folder.mkdir()
    (folder / "file.txt").write_text("mine")
    good = str(inputs["good"])
    for prog, argv in (("fastslam-sim", ["--out", str(folder), "--duration", "1"]),
                       ("fastslam-sim", ["--out", str(tmp_path / "s"), "--params-out",
                                         str(existing), "--duration", "1"]),
                       ("fastslam-sim", ["--scenario", "people", "--out", str(folder),
                                         "--duration", "1"]),
                       ("fastslam-replay", [good, "--out", str(folder)]),
                       ("fastslam-replay", [good, "--no-record", "--save-map", str(existing)]),
                       ("fastslam-calibrate", [good, "--out", str(existing)]),
                       ("fastslam-bench", ["--json", str(existing)]),
                       ("fastslam-poison", [good, "--out", str(folder)])):
        status, err = run(prog, argv, capsys)
        assert status == 2, (prog, argv)
        assert "exists" in assert_one_line(prog, err) or "--overwrite" in err
    assert existing.read_text() == "mine" and os.listdir(folder) == ["file.txt"]
    assert sorted(os.listdir(tmp_path)) == ["existing.yaml", "folder"]


def test_a_parameter_file_of_which_nothing_applies_fails(inputs, tmp_path, capsys):
    params = tmp_path / "params.yaml"
    params.write_text("fastslam_node:\n  ros__parameters:\n    num_particles: 5\n")
    status, err = run("fastslam-replay", [str(inputs["good"]), "--no-record",
                                          "--params", str(params)], capsys)
    assert status == 1
    line = assert_one_line("fastslam-replay", err)
    assert "no section for node /fastslam" in line and "fastslam_node" in line
    params.write_text("speed: 1\n")  # YAML, but no parameter file
    status, err = run("fastslam-replay", [str(inputs["good"]), "--no-record",
                                          "--params", str(params)], capsys)
    assert status == 2
    assert "not a ROS 2 parameter file" in assert_one_line("fastslam-replay", err)


def test_a_parameter_file_for_no_node_fails_the_calibration(inputs, tmp_path, capsys):
    params = tmp_path / "params.yaml"
    params.write_text("fastslam_node:\n  ros__parameters:\n    sensor_x: 0.5\n")
    status, err = run("fastslam-calibrate", [str(inputs["good"]), "--params", str(params)],
                      capsys)
    assert status == 1
    assert "no section for node /fastslam" in assert_one_line("fastslam-calibrate", err)


def test_a_dataset_that_does_not_read_fails_the_benchmark(tmp_path, capsys):
    dataset = tmp_path / "datasets" / "MRCLAM_garbage"
    dataset.mkdir(parents=True)
    for name in ("Robot1_Odometry.dat", "Robot1_Groundtruth.dat", "Robot1_Measurement.dat",
                 "Barcodes.dat", "Landmark_Groundtruth.dat"):
        (dataset / name).write_text("not numbers\n")
    status, err = run("fastslam-benchmark", ["--datasets", str(tmp_path / "datasets"),
                                             "--quick", "--out-dir", str(tmp_path / "out")],
                      capsys)
    assert status == 1
    assert "cannot convert the datasets: " in assert_one_line("fastslam-benchmark", err)


def test_a_section_for_no_node_is_named_in_a_warning(inputs, tmp_path, capsys):
    params = tmp_path / "params.yaml"
    params.write_text("/**:\n  ros__parameters:\n    num_particles: 5\n"
                      "fastslam_node:\n  ros__parameters:\n    num_particles: 7\n"
                      "people_tracker:\n  ros__parameters:\n    num_particles: 9\n")
    assert replay.main([str(inputs["good"]), "--no-record", "--params", str(params)]) == 0
    captured = capsys.readouterr()
    warning = assert_one_line("fastslam-replay", captured.err)
    assert "warning" in warning and "fastslam_node" in warning
    assert "people_tracker" not in warning  # the package's other node reads that one
    assert "received_odom" in captured.out


def run_node(module: str, *arguments: str) -> subprocess.CompletedProcess:
    """A node started as its console script would be, stopped at once by a failure."""
    return subprocess.run([sys.executable, "-m", module, *arguments], capture_output=True,
                          text=True, timeout=120,
                          env={**os.environ, "ROS_DOMAIN_ID": str(150 + os.getpid() % 50)})


@pytest.mark.parametrize("name", list(NODES))
@pytest.mark.parametrize("arguments, status, named", [
    (["--ros-args", "--params-file", "/nonexistent/params.yaml"], 2, "/nonexistent/params.yaml"),
    (["--no-such-option"], 2, "--no-such-option"),
    (["--ros-args", "--params-file", "{not_params}"], 2, "not a ROS 2 parameter file"),
    (["--ros-args", "--params-file", "{other_node}"], 1, "no section for node"),
    (["--ros-args", "-p", "no_such_parameter:=1"], 1, "no_such_parameter"),
    (["--ros-args", "-p", "map_file:={not_yaml}"], 1, "map_file"),  # a multi-line YAML error
])
def test_nodes_follow_the_same_exit_status_rule(name, arguments, status, named, tmp_path):
    not_params = tmp_path / "not_params.yaml"
    not_params.write_text("speed: 1\n")
    other_node = tmp_path / "other_node.yaml"
    other_node.write_text(f"{name}:\n  ros__parameters:\n    seed: 1\n")
    not_yaml = tmp_path / "map.yaml"
    not_yaml.write_text("landmarks: [\n")
    arguments = [a.format(not_params=not_params, other_node=other_node, not_yaml=not_yaml)
                 for a in arguments]
    result = run_node(NODES[name], *arguments)
    assert result.returncode == status, result.stderr
    # The node's own log lines ([INFO] ...) may come first.
    lines = [line for line in result.stderr.strip().splitlines() if not line.startswith("[")]
    assert len(lines) == 1 and lines[0].startswith(f"{name}: ") and named in lines[0], \
        result.stderr


@pytest.mark.parametrize("name", list(NODES))
def test_a_node_warns_of_a_section_for_no_node_before_it_starts(name, tmp_path):
    params = tmp_path / "params.yaml"
    params.write_text("/**:\n  ros__parameters:\n    no_such_parameter: 0\n"
                      f"{name}:\n  ros__parameters:\n    seed: 1\n")
    result = run_node(NODES[name], "--ros-args", "--params-file", str(params))
    assert result.returncode == 1  # the /** section applied, and names an unknown parameter
    lines = [line for line in result.stderr.strip().splitlines() if not line.startswith("[")]
    assert len(lines) == 2 and "Traceback" not in result.stderr, result.stderr
    assert lines[0].startswith(f"{name}: warning: ") and f"section(s) {name} name" in lines[0]
    assert lines[1].startswith(f"{name}: ") and "no_such_parameter" in lines[1]


def test_ctrl_c_ends_a_tool_in_one_line(inputs, monkeypatch, capsys):
    """Ctrl-C, also when the code it interrupts (numba compiling) raises an error of its own."""
    monkeypatch.setattr(sys, "unraisablehook", sys.unraisablehook)  # the tool silences it

    def interrupted_compile(*args, **kwargs):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(10.0)  # the signal arrives long before
        except KeyboardInterrupt:
            raise RuntimeError("no compiled object yet") from None

    monkeypatch.setattr(replay, "replay_through", interrupted_compile)
    status, err = run("fastslam-replay", [str(inputs["good"]), "--no-record"], capsys)
    assert status == 130
    assert assert_one_line("fastslam-replay", err) == "fastslam-replay: interrupted"
    monkeypatch.setattr(replay, "replay_through", lambda *a, **k: (_ for _ in ()).throw(
        ValueError("a real failure")))
    status, err = run("fastslam-replay", [str(inputs["good"]), "--no-record"], capsys)
    assert status == 1 and "a real failure" in assert_one_line("fastslam-replay", err)


def test_a_namespaced_node_takes_the_sections_of_its_full_name(tmp_path):
    """A namespace given as a remap (as ros2 launch passes it): the file is checked against
    the node's full name, once the node exists."""
    keyed = tmp_path / "keyed.yaml"
    keyed.write_text("/robot1/fastslam:\n  ros__parameters:\n    no_such_parameter: 1\n")
    result = run_node(NODES["fastslam_node"], "--ros-args", "--params-file", str(keyed),
                      "-r", "__ns:=/robot1", "-p", "backend:=numpy")
    assert result.returncode == 1 and "'no_such_parameter'" in result.stderr  # it applied
    plain = tmp_path / "plain.yaml"
    plain.write_text("fastslam:\n  ros__parameters:\n    num_particles: 5\n")
    result = run_node(NODES["fastslam_node"], "--ros-args", "--params-file", str(plain),
                      "-r", "__ns:=/robot1", "-p", "backend:=numpy")
    assert result.returncode == 1
    lines = [line for line in result.stderr.strip().splitlines() if not line.startswith("[")]
    assert len(lines) == 1 and "no section for node /robot1/fastslam" in lines[0], result.stderr
