# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The console commands on real files: sim -> replay -> eval (JSON, plot), errors, --help."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.highlevel import AnyReader

from fastslam_ros import node
from fastslam_ros.core.geometry import compose
from fastslam_ros.tools import demo
from fastslam_ros.tools.bags import play, poison, replay
from fastslam_ros.tools.benchmarks import bench, benchmark, live_load, soak
from fastslam_ros.tools.datasets import convert
from fastslam_ros.tools.evaluation import evaluate, people_eval
from fastslam_ros.tools.simulation import people_sim, sim
from fastslam_ros.tools.bags.bag_schema import (TYPESTORE, LandmarkSet, PoseSeries, bag_topics,
                                           open_writer, quaternion_to_yaw, read_schema_bag,
                                           read_topics, write_schema_bag)
from fastslam_ros.tools.simulation.sim import SimConfig, simulate

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("command", [sim, replay, play, evaluate, demo, bench, benchmark, convert])
def test_every_command_has_help(command, capsys):
    with pytest.raises(SystemExit) as exit_info:
        command.main(["--help"])
    assert exit_info.value.code == 0
    printed = capsys.readouterr().out
    assert "usage: fastslam-" in printed
    # One style: plain text (no reStructuredText literals), defaults shown, none empty.
    assert "``" not in printed and "(default:" in printed
    assert "(default: None)" not in printed and "(default: [])" not in printed
    assert "deg) (default:" not in " ".join(printed.split())  # one default per option


SECONDARY_COMMANDS = (people_sim, people_eval, poison, soak, live_load)
"""Tools with ``--help`` beside the main console scripts' (``python3 -m`` or a scenario)."""


@pytest.mark.parametrize("command", SECONDARY_COMMANDS)
def test_secondary_commands_have_help(command, capsys):
    with pytest.raises(SystemExit) as exit_info:
        command.main(["--help"])
    assert exit_info.value.code == 0
    printed = capsys.readouterr().out
    assert printed.startswith("usage: ") and "``" not in printed and "(default:" in printed


def test_every_option_has_help(monkeypatch):
    """Each command's parser, captured as it parses --help: no option without a help text."""
    import argparse

    parsers = []
    original = argparse.ArgumentParser.parse_known_args

    def capture(self, *args, **kwargs):
        parsers.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(argparse.ArgumentParser, "parse_known_args", capture)
    commands = (sim, replay, play, evaluate, demo, bench, benchmark, convert) + SECONDARY_COMMANDS
    for command in commands:
        with pytest.raises(SystemExit):
            command.main(["--help"])
    parsers = list({id(parser): parser for parser in parsers}.values())
    assert len(parsers) == len(commands)
    for parser in parsers:
        undocumented = [action.dest for action in parser._actions if not action.help]
        assert not undocumented, (parser.prog, undocumented)


def test_sim_replay_eval_chain(tmp_path, capsys):
    bag = tmp_path / "loop"
    assert sim.main(["--out", str(bag), "--duration", "30", "--seed", "4",
                     "--storage", "sqlite3"]) == 0
    assert (tmp_path / "loop.yaml").read_text().startswith("# Recommended")
    assert "wrote" in capsys.readouterr().out
    assert len(read_schema_bag(bag).scans.stamps) == 150

    out = tmp_path / "out"
    assert replay.main([str(bag), "--params", str(tmp_path / "loop.yaml"), "--seed", "3",
                        "--set", "num_particles=20", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "received_landmarks 150" in printed and "dropped: none" in printed

    metrics_path, plot_path = tmp_path / "metrics.json", tmp_path / "result.png"
    assert evaluate.main([str(out), "--json", str(metrics_path), "--plot", str(plot_path)]) == 0
    table = capsys.readouterr().out
    assert "| estimate (at the time) |" in table and "| dead reckoning |" in table
    metrics = json.loads(metrics_path.read_text())
    assert metrics["estimate"]["samples"] == 150
    assert metrics["landmarks"]["truth"] + metrics["landmarks_never_observed"] == 85
    # The recommended file associates by maximum likelihood: the map is matched by position.
    assert metrics["params"]["association"] == "ml"
    assert metrics["landmarks"]["match_method"] == "assignment"
    assert metrics["association"]["checked"] > 0
    assert metrics["runtime"]["bag_duration"] == pytest.approx(30.0)
    assert metrics["params"]["num_particles"] == 20
    # A working filter tracks a 30 s drive to well under a metre.
    assert metrics["estimate"]["aligned"]["rmse"] < 1.0
    assert metrics["final_path"]["aligned"]["rmse"] < 1.0
    assert plot_path.read_bytes()[:8] == PNG_SIGNATURE

    # The ground truth can also come from the input bag.
    assert evaluate.main([str(out), "--ground-truth", str(bag)]) == 0
    assert capsys.readouterr().out == table


def test_commands_fail_cleanly_on_missing_input(tmp_path, capsys):
    assert replay.main([str(tmp_path / "absent")]) == 2
    assert "bag not found" in capsys.readouterr().err
    assert evaluate.main([str(tmp_path / "absent")]) == 2
    assert "absent" in capsys.readouterr().err
    assert play.main([str(tmp_path / "absent")]) == 2
    assert "absent" in capsys.readouterr().err
    assert convert.main(["mrclam", str(tmp_path / "absent"), "--out", str(tmp_path / "o")]) == 2
    assert "absent" in capsys.readouterr().err
    bag = tmp_path / "bag"
    assert sim.main(["--out", str(bag), "--duration", "2"]) == 0
    assert sim.main(["--out", str(bag), "--duration", "2"]) == 2  # exists, no --overwrite
    assert "exists" in capsys.readouterr().err
    assert evaluate.main([str(bag)]) == 1  # an input bag holds no estimate
    assert "/fastslam/pose" in capsys.readouterr().err
    assert replay.main([str(bag), "--set", "num_particles=0", "--no-record"]) == 1
    assert "num_particles" in capsys.readouterr().err


def one_line_error(capsys, prog: str) -> str:
    """The stderr of a failed command: one line naming the command, no traceback."""
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"{prog}: ") and "\n" not in err and "Traceback" not in err, err
    return err


def test_bad_files_and_paths_give_one_line_and_status_2(tmp_path, capsys):
    bag = tmp_path / "bag"
    assert sim.main(["--out", str(bag), "--duration", "2"]) == 0
    run = tmp_path / "run"
    assert replay.main([str(bag), "--set", "num_particles=5", "--out", str(run)]) == 0
    capsys.readouterr()
    assert evaluate.main([str(run), "--plot", str(tmp_path / "x.xyz")]) == 2
    assert "unsupported format '.xyz'" in one_line_error(capsys, "fastslam-eval")
    assert evaluate.main([str(run), "--json", "/no/dir/f"]) == 2
    assert "/no/dir does not exist" in one_line_error(capsys, "fastslam-eval")
    assert evaluate.main([str(run), "--tum", str(bag / "metadata.yaml")]) == 2
    assert "is a file" in one_line_error(capsys, "fastslam-eval")
    not_a_bag = tmp_path / "notes.mcap"
    not_a_bag.write_text("not a bag")
    assert evaluate.main([str(not_a_bag)]) == 2
    assert "cannot read bag" in one_line_error(capsys, "fastslam-eval")
    assert replay.main([str(not_a_bag)]) == 2
    one_line_error(capsys, "fastslam-replay")
    for content, message in ((b"\xff\xfe\x00", "utf-8"), (b"a: [", "not a ROS 2 parameter file"),
                             (b"- 1", "not a ROS 2 parameter file")):
        params = tmp_path / "params.yaml"
        params.write_bytes(content)
        assert replay.main([str(bag), "--params", str(params), "--no-record"]) == 2
        assert message in one_line_error(capsys, "fastslam-replay")
    assert replay.main([str(bag), "--params", str(tmp_path), "--no-record"]) == 2
    assert "not a file" in one_line_error(capsys, "fastslam-replay")
    assert replay.main([str(bag), "--out", str(tmp_path / "no" / "such" / "out")]) == 2
    assert "does not exist" in one_line_error(capsys, "fastslam-replay")
    assert replay.main([str(bag), "--no-record", "--save-map", "/no/dir/map.yaml"]) == 2
    assert "/no/dir does not exist" in one_line_error(capsys, "fastslam-replay")
    map_file = tmp_path / "map.yaml"
    assert replay.main([str(bag), "--no-record", "--save-map", str(map_file)]) == 0
    assert "map saved: " in capsys.readouterr().out and map_file.exists()
    assert replay.main([str(bag), "--no-record", "--save-map", str(map_file)]) == 2
    assert "exists" in one_line_error(capsys, "fastslam-replay")


def test_replay_takes_the_node_syntax_for_parameters_and_remaps(tmp_path, capsys):
    bag = simulate(SimConfig(duration=3.0, seed=1))
    write_schema_bag(tmp_path / "bag", bag)
    renamed = tmp_path / "renamed"
    with AnyReader([tmp_path / "bag"]) as reader, open_writer(renamed) as writer:
        names = {"/odom": "/wheel/odom"}
        connections = {c.id: writer.add_connection(names.get(c.topic, c.topic), c.msgtype,
                                                   typestore=TYPESTORE)
                       for c in reader.connections}
        for connection, stamp_ns, raw in reader.messages():
            writer.write(connections[connection.id], stamp_ns, raw)
    assert "/wheel/odom" in bag_topics(renamed) and "/odom" not in bag_topics(renamed)
    assert replay.main([str(renamed), "--no-record"]) == 1
    assert "--remap" in one_line_error(capsys, "fastslam-replay")
    out = tmp_path / "out"
    assert replay.main([str(renamed), "-r", "/wheel/odom:=/odom", "-p", "num_particles:=7",
                        "--set", "seed=2", "--out", str(out)]) == 0
    assert "received_odom 121" in capsys.readouterr().out
    assert evaluate.evaluate(out)["params"]["num_particles"] == 7
    assert replay.parse_assignment("sigma_range:=0.2") == ("sigma_range", 0.2)
    assert replay.parse_remap("wheel/odom:=odom") == ("/wheel/odom", "/odom")
    for text in ("odom", ":=/odom", "/odom:="):
        with pytest.raises(ValueError):
            replay.parse_remap(text)


def test_node_help_prints_usage_without_starting(capsys):
    with pytest.raises(SystemExit) as exit_info:
        node.main(["fastslam_node", "--help"])
    assert exit_info.value.code == 0
    printed = capsys.readouterr().out
    assert printed.startswith("usage: fastslam_node") and "--ros-args" in printed
    with pytest.raises(SystemExit) as exit_info:
        node.main(["fastslam_node", "--no-such-option", "--ros-args", "-p", "seed:=1"])
    assert exit_info.value.code == 2


def test_demo_writes_every_artefact(tmp_path, capsys):
    out_dir = tmp_path / "demo"
    assert demo.main(["--out-dir", str(out_dir), "--particles", "10", "--duration", "15"]) == 0
    printed = capsys.readouterr().out
    assert "| best particle, final path |" in printed
    for name in ("summary.md", "metrics.json", "result.png", "sim_loop", "sim_loop.yaml",
                 "replay"):
        assert (out_dir / name).exists(), name
    assert (out_dir / "summary.md").read_text().strip() in printed
    assert json.loads((out_dir / "metrics.json").read_text())["params"]["num_particles"] == 10


def test_position_only_sparse_ground_truth_is_evaluated(tmp_path, capsys):
    bag = simulate(SimConfig(duration=20.0, seed=6))
    truth = bag.ground_truth
    every_second = slice(0, None, 40)  # a 1 Hz GPS-like reference without heading
    bag.ground_truth = PoseSeries(truth.stamps[every_second], truth.poses[every_second], "map",
                                  position_only=True)
    bag.landmarks_truth = None  # like Victoria Park: GPS only
    write_schema_bag(tmp_path / "gps", bag)
    assert replay.main([str(tmp_path / "gps"), "--seed", "1", "--set", "num_particles=10",
                        "--out", str(tmp_path / "out")]) == 0
    metrics_path = tmp_path / "metrics.json"
    assert evaluate.main([str(tmp_path / "out"), "--json", str(metrics_path),
                          "--plot", str(tmp_path / "gps.png")]) == 0
    metrics = json.loads(metrics_path.read_text())
    assert metrics["ground_truth_position_only"] is True
    # 5 Hz estimates between 1 Hz fixes 1 s apart are all interpolated (20 s: 100 readings).
    assert metrics["estimate"]["samples"] == 100
    assert metrics["dead_reckoning"]["samples"] == 801
    assert metrics["estimate"]["aligned"]["rmse"] < 1.0
    assert "landmarks" not in metrics and metrics["landmarks_estimated"] > 0


def test_ground_truth_of_an_antenna_is_compared_at_the_antenna(tmp_path, capsys):
    # GPS 3 m ahead and 1 m left of the base, declared on /tf_static.
    bag = simulate(SimConfig(duration=90.0, seed=6))
    truth = bag.ground_truth
    antenna = compose(truth.poses, np.array([3.0, 1.0, 0.0]))
    bag.ground_truth = PoseSeries(truth.stamps, antenna, "map", "gps_antenna",
                                  position_only=True, reference_offset=np.array([3.0, 1.0]))
    write_schema_bag(tmp_path / "gps", bag)
    assert replay.main([str(tmp_path / "gps"), "--seed", "1", "--set", "num_particles=20",
                        "--out", str(tmp_path / "out")]) == 0
    errors = {}
    for flags in ([], ["--at-base"]):
        metrics_path = tmp_path / f"metrics{len(flags)}.json"
        assert evaluate.main([str(tmp_path / "out"), "--ground-truth", str(tmp_path / "gps"),
                              "--json", str(metrics_path)] + flags) == 0
        errors[len(flags)] = json.loads(metrics_path.read_text())["estimate"]["aligned"]["rmse"]
    # At the antenna the filter's own error; at the base also the 3.2 m lever, which the
    # rigid alignment cannot remove on a path that turns.
    assert errors[0] < 1.0 and errors[1] > errors[0] + 0.7


def test_landmarks_never_observed_are_not_counted_as_missed(tmp_path, capsys):
    bag = simulate(SimConfig(duration=10.0, seed=2))
    truth = bag.landmarks_truth
    bag.landmarks_truth = LandmarkSet(np.vstack([truth.positions, [[500.0, 500.0]]]),
                                      np.append(truth.ids, 999).astype(np.int32))
    write_schema_bag(tmp_path / "bag", bag)
    assert replay.main([str(tmp_path / "bag"), "--seed", "1", "--set", "num_particles=10",
                        "--out", str(tmp_path / "out")]) == 0
    metrics = evaluate.evaluate(tmp_path / "out")
    seen = set(np.concatenate(bag.scans.ids).tolist())
    assert metrics["landmarks_never_observed"] == len(truth.ids) + 1 - len(seen)
    assert metrics["landmarks"]["truth"] == len(seen)
    assert metrics["landmarks"]["missed"] == 0


def test_bench_prints_and_writes_its_figures(tmp_path, capsys):
    """A tiny run of every part: the rows it promises, with positive rates and best >= median
    (figures themselves are not asserted: speed belongs to the benchmark, not to tests)."""
    figures = tmp_path / "bench.json"
    assert bench.main(["--particles", "10", "--steps", "30", "--repeat", "2", "--backend",
                       "numpy", "--sweep", "5,10", "--json", str(figures)]) == 0
    printed = capsys.readouterr().out
    assert "### Throughput" in printed and "### Landmark store memory" in printed
    assert "### Fit per reading" in printed
    results = json.loads(figures.read_text())
    assert {(r["algorithm"], r["association"], r["backend"]) for r in results["throughput"]} == {
        (a, m, "numpy") for a in ("fastslam1", "fastslam2")
        for m in ("ml", "known", "monte_carlo", "two_gate")}
    for row in results["throughput"]:
        assert row["runs"] == 2 and row["obs_per_s_best"] >= row["obs_per_s_median"] > 0
    assert [r["particles"] for r in results["sweep"]] == [5, 10]
    assert results["fit"][0]["backend"] == "numpy"
    assert [r["landmarks"] for r in results["scaling"]][-1] > 40000
    assert [r["landmarks"] for r in results["memory"]] == [10000, 50000]
    assert all(r["ratio"] < 1.0 for r in results["memory"])


def test_benchmark_plan_resolves_the_shipped_association_per_family():
    mrclam = benchmark.Sequence("mrclam", "MRCLAM_Dataset6 R1", Path("unused"))
    park = benchmark.Sequence("victoria-park", "VictoriaPark", Path("unused"), has_ids=False)
    specs = benchmark.plan([mrclam, park], ["fastslam2"], ["known", "config", "ml"], [100], 2)
    runs = [(spec.sequence.kind, spec.association, spec.seed) for spec in specs]
    # MRCLAM's file names monte_carlo; Victoria Park's names ml, which is then planned once,
    # and it has no ids, so no known association.
    assert runs == [("mrclam", "known", 1), ("mrclam", "known", 2),
                    ("mrclam", "monte_carlo", 1), ("mrclam", "monte_carlo", 2),
                    ("mrclam", "ml", 1), ("mrclam", "ml", 2),
                    ("victoria-park", "ml", 1), ("victoria-park", "ml", 2)]


def test_benchmark_table_gives_the_jumps_of_each_run_and_their_mean():
    rows = [{"sequence": f"MRCLAM_Dataset6 R{robot}", "algorithm": "fastslam2",
             "association": "known", "particles": 100, "seed": 1, "estimate_aligned": ate,
             "estimate_jumps": jumps} for robot, ate, jumps in ((1, 0.2, 3), (2, 0.4, 6))]
    lines = benchmark.markdown(rows, {}).splitlines()
    header = [cell.strip() for cell in lines[0].strip("|").split("|")]
    column = header.index("jumps")
    assert header[column - 1] == "ATE aligned (m)"
    cells = [[cell.strip() for cell in line.strip("|").split("|")] for line in lines[2:6]]
    assert [row[column] for row in cells] == ["3", "6", "4.5", "6.0"]   # runs, mean, worst


def read_tum(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Stamps (N,) and positions (N, 2) of a TUM file (``t x y z qx qy qz qw``)."""
    rows = np.loadtxt(path, ndmin=2)
    assert rows.shape[1] == 8 and np.all(rows[:, 3] == 0.0)
    np.testing.assert_allclose(np.linalg.norm(rows[:, 4:], axis=1), 1.0, atol=1e-9)
    return rows[:, 0], rows[:, 1:3]


def test_tum_files_give_the_evaluation_figures_to_trajectory_tools(tmp_path):
    bag = tmp_path / "bag"
    write_schema_bag(bag, simulate(SimConfig(duration=20.0, seed=3)))
    out = tmp_path / "out"
    assert replay.main([str(bag), "--set", "num_particles=10", "--seed", "1",
                        "--out", str(out)]) == 0
    metrics_path, tum = tmp_path / "metrics.json", tmp_path / "tum"
    assert evaluate.main([str(out), "--json", str(metrics_path), "--tum", str(tum)]) == 0
    metrics = json.loads(metrics_path.read_text())
    truth_stamps, truth = read_tum(tum / "ground_truth.tum")
    for name in ("estimate", "final_path", "dead_reckoning"):
        stamps, positions = read_tum(tum / f"{name}.tum")
        assert len(stamps) == metrics[name]["samples"]
        # Pair by stamp as evo does, then score as evo_ape does: raw, and after the
        # least-squares rigid fit (Umeyama through an SVD, a method independent of align_se2).
        reference = truth[np.searchsorted(truth_stamps, stamps)]
        np.testing.assert_array_equal(truth_stamps[np.searchsorted(truth_stamps, stamps)], stamps)
        raw = np.sqrt(np.mean(np.sum((positions - reference) ** 2, axis=1)))
        centred_e, centred_r = positions - positions.mean(0), reference - reference.mean(0)
        u, _, vt = np.linalg.svd(centred_r.T @ centred_e)
        rotation = u @ np.diag([1.0, np.linalg.det(u @ vt)]) @ vt
        aligned = centred_e @ rotation.T - centred_r
        aligned_rmse = np.sqrt(np.mean(np.sum(aligned**2, axis=1)))
        assert raw == pytest.approx(metrics[name]["raw"]["rmse"], rel=1e-6)
        assert aligned_rmse == pytest.approx(metrics[name]["aligned"]["rmse"], rel=1e-6)


def test_replay_output_carries_the_transform_tree(tmp_path):
    bag = tmp_path / "bag"
    write_schema_bag(bag, simulate(SimConfig(duration=5.0, seed=2, sensor_frame="laser")))
    out = tmp_path / "out"
    assert replay.main([str(bag), "--set", "num_particles=10", "--set", "sensor_x=0.25",
                        "--set", "sensor_yaw=0.5", "--out", str(out)]) == 0
    recorded = bag_topics(out)
    # The shipped RViz config and Foxglove layout show topics this bag carries.
    root = Path(__file__).resolve().parents[1]
    rviz = yaml.safe_load((root / "rviz" / "fastslam.rviz").read_text())
    rviz_topics = {d["Topic"]["Value"] for d in rviz["Visualization Manager"]["Displays"]
                   if "Topic" in d}
    layout = json.loads((root / "foxglove" / "fastslam.json").read_text())
    foxglove_topics = set(layout["configById"]["3D!fastslam"]["topics"])
    assert len(rviz_topics) == 5 and rviz_topics | foxglove_topics <= set(recorded)
    topics = read_topics(out, ["/tf", "/tf_static", "/fastslam/pose"])
    static = [t for msg in topics["/tf_static"][1] for t in msg.transforms]
    assert [(t.header.frame_id, t.child_frame_id) for t in static] == [("base_link", "laser")]
    assert static[0].transform.translation.x == pytest.approx(0.25)
    assert quaternion_to_yaw(0.0, 0.0, static[0].transform.rotation.z,
                             static[0].transform.rotation.w) == pytest.approx(0.5)
    chains: dict[tuple[str, str], dict[int, np.ndarray]] = {}
    for msg in topics["/tf"][1]:
        for t in msg.transforms:
            stamp = t.header.stamp.sec * 10**9 + t.header.stamp.nanosec
            q = t.transform.rotation
            chains.setdefault((t.header.frame_id, t.child_frame_id), {})[stamp] = np.array(
                [t.transform.translation.x, t.transform.translation.y,
                 quaternion_to_yaw(q.x, q.y, q.z, q.w)])
    assert set(chains) == {("map", "odom"), ("odom", "base_link")}
    assert len(chains["odom", "base_link"]) == 201  # every odometry message, 40 Hz
    # map -> odom -> base_link at a pose's stamp is the published pose.
    for msg in topics["/fastslam/pose"][1]:
        stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        chained = compose(chains["map", "odom"][stamp], chains["odom", "base_link"][stamp])
        p = msg.pose.pose
        np.testing.assert_allclose(chained[:2], [p.position.x, p.position.y], atol=1e-9)


def test_poison_without_its_bag_is_a_usage_error(tmp_path, capsys):
    assert poison.main([str(tmp_path / "no_such_bag"), "--out", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err
    assert error.startswith("fastslam-poison: ") and error.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_people_eval_refuses_options_it_does_not_have(tmp_path, capsys):
    """An option of the landmark evaluation (``--tum``) on a people run: one line, status 2."""
    assert people_eval.main([str(tmp_path / "run"), "--tum", str(tmp_path / "tum")]) == 2
    error = capsys.readouterr().err
    assert error.startswith("fastslam-eval: ") and "--tum" in error and error.count("\n") == 1


def test_people_eval_checks_the_plot_format_first(tmp_path, capsys):
    assert people_eval.main([str(tmp_path / "run"), "--plot", str(tmp_path / "x.xyz")]) == 2
    error = capsys.readouterr().err
    assert "unsupported format" in error and error.count("\n") == 1


def test_bench_checks_its_json_output_before_measuring(tmp_path, capsys):
    tiny = ["--only", "sweep", "--sweep", "5", "--steps", "5", "--repeat", "1",
            "--backend", "numpy"]
    assert bench.main(tiny + ["--json", str(tmp_path / "no_dir" / "f.json")]) == 2
    captured = capsys.readouterr()
    assert "does not exist" in captured.err and "Time per reading" not in captured.out
    existing = tmp_path / "figures.json"
    existing.write_text("{}")
    assert bench.main(tiny + ["--json", str(existing)]) == 2
    assert "--overwrite" in capsys.readouterr().err and existing.read_text() == "{}"
    assert bench.main(tiny + ["--json", str(existing), "--overwrite"]) == 0
    assert "sweep" in json.loads(existing.read_text())


def test_benchmark_makes_its_own_workspace_and_writes_its_tables(tmp_path, dataset_dir, capsys):
    """A first run into a new --out-dir: the converted bags and the runs go into folders of its
    own (the one rule of outputs makes no folder for a tool that did not say so)."""
    world = dataset_dir("FreiburgRobotMapping")
    out = tmp_path / "bench"
    assert benchmark.main(["--datasets", str(world), "--quick", "--seeds", "1",
                           "--algorithms", "fastslam2", "--associations", "config",
                           "--out-dir", str(out)]) == 0
    assert (out / "benchmark.md").read_text().startswith("|")
    assert any((out / "bags").iterdir()) and any((out / "runs").iterdir())
    capsys.readouterr()
