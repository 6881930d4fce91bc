# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""No tool deletes or overwrites what the user owns: existing outputs need --overwrite, and even
then only a bag folder or a file the tool writes is replaced, never an input or '.'."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from fastslam_ros.tools import demo
from fastslam_ros.tools.bags import replay
from fastslam_ros.tools.datasets import convert
from fastslam_ros.tools.evaluation import evaluate
from fastslam_ros.tools.simulation import sim
from fastslam_ros.tools.bags.bag_schema import write_schema_bag
from fastslam_ros.output import OutputExistsError, check_output, staged_output
from fastslam_ros.tools.simulation.sim import SimConfig, simulate


@pytest.fixture(scope="module")
def bag(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("output") / "input"
    return write_schema_bag(path, simulate(SimConfig(duration=3.0, seed=1)))


def precious_folder(root: Path) -> Path:
    folder = root / "precious"
    folder.mkdir()
    (folder / "thesis.tex").write_text("years of work")
    return folder


def test_helper_refuses_without_overwrite_and_replaces_only_bags_and_files(tmp_path, bag):
    with pytest.raises(OutputExistsError, match="--overwrite"):
        check_output(bag, overwrite=False)
    folder = precious_folder(tmp_path)
    with pytest.raises(OutputExistsError, match="not a rosbag2 bag"):
        check_output(folder, overwrite=True)
    (folder / "metadata.yaml").write_text("looks like a bag")  # but holds other files too
    with pytest.raises(OutputExistsError, match="not a rosbag2 bag"):
        check_output(folder, overwrite=True)
    assert (folder / "thesis.tex").read_text() == "years of work"
    with pytest.raises(OutputExistsError, match="not a file"):
        check_output(folder, overwrite=True, kind="file")
    with pytest.raises(OutputExistsError, match="input"):
        check_output(bag, overwrite=True, inputs=[bag])
    with pytest.raises(OutputExistsError, match="input"):
        check_output(bag / "inside", overwrite=True, inputs=[bag])
    with pytest.raises(OutputExistsError, match="input"):
        check_output(bag.parent, overwrite=True, inputs=[bag])
    assert (bag / "metadata.yaml").exists()
    copy = tmp_path / "old_out"
    write_schema_bag(copy, simulate(SimConfig(duration=1.0, seed=1)))
    with staged_output(copy, overwrite=True) as staged:
        write_schema_bag(staged, simulate(SimConfig(duration=2.0, seed=1)))
    assert sorted(os.listdir(tmp_path)) == ["old_out", "precious"]  # no stage left
    note = tmp_path / "note.json"
    note.write_text("{}")
    assert check_output(note, overwrite=True, kind="file") and note.read_text() == "{}"
    with staged_output(note, overwrite=True, kind="file") as staged:
        staged.write_text("[]")
    assert note.read_text() == "[]"
    assert not check_output(tmp_path / "new", overwrite=False)
    with pytest.raises(OutputExistsError, match="does not exist"):
        check_output(tmp_path / "new" / "deep", overwrite=False)


def test_helper_never_removes_the_working_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "metadata.yaml").write_text("")
    for path in (".", tmp_path, tmp_path.parent):
        with pytest.raises(OutputExistsError, match="working directory"):
            check_output(path, overwrite=True)
    assert (tmp_path / "metadata.yaml").exists()


def test_replay_keeps_user_folders_the_working_directory_and_its_input(tmp_path, bag, capsys,
                                                                       monkeypatch):
    folder = precious_folder(tmp_path)
    for extra in ([], ["--overwrite"]):
        assert replay.main([str(bag), "--set", "num_particles=5", "--out", str(folder)]
                           + extra) == 2
        assert "precious" in capsys.readouterr().err
        assert (folder / "thesis.tex").read_text() == "years of work"
        assert replay.main([str(bag), "--set", "num_particles=5", "--out", str(bag)] + extra) == 2
        assert (bag / "metadata.yaml").exists()
    monkeypatch.chdir(tmp_path)
    (tmp_path / "keep.txt").write_text("mine")
    assert replay.main([str(bag), "--set", "num_particles=5", "--out", ".", "--overwrite"]) == 2
    assert (tmp_path / "keep.txt").exists()
    out = tmp_path / "out"
    assert replay.main([str(bag), "--set", "num_particles=5", "--out", str(out)]) == 0
    assert replay.main([str(bag), "--set", "num_particles=5", "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert replay.main([str(bag), "--set", "num_particles=5", "--out", str(out),
                        "--overwrite"]) == 0
    with pytest.raises(FileExistsError):
        replay.replay_bag(bag, {"num_particles": 5}, out_path=out)


def test_sim_convert_demo_and_eval_refuse_existing_outputs(tmp_path, bag, capsys):
    folder = precious_folder(tmp_path)
    assert sim.main(["--out", str(folder), "--duration", "1", "--overwrite"]) == 2
    assert (folder / "thesis.tex").exists() and not (tmp_path / "precious.yaml").exists()
    params = tmp_path / "mine.yaml"
    params.write_text("mine")
    assert sim.main(["--out", str(tmp_path / "s"), "--params-out", str(params),
                     "--duration", "1"]) == 2
    assert params.read_text() == "mine" and not (tmp_path / "s").exists()
    assert sim.main(["--out", str(tmp_path / "s"), "--params-out", str(params),
                     "--duration", "1", "--overwrite"]) == 0
    assert params.read_text() != "mine"

    source = tmp_path / "dataset"
    source.mkdir()
    assert convert.main(["freiburg", str(source), "--out", str(folder), "--overwrite"]) == 2
    assert convert.main(["freiburg", str(source), "--out", str(source), "--overwrite"]) == 2
    assert (folder / "thesis.tex").exists()

    out = tmp_path / "replayed"
    replay.replay_bag(bag, {"num_particles": 5, "seed": 1}, out_path=out)
    mine = tmp_path / "metrics.json"
    mine.write_text("mine")
    assert evaluate.main([str(out), "--json", str(mine)]) == 2
    # A folder (here the input bag, or the user's folder) is no file to write: a usage error.
    assert evaluate.main([str(out), "--json", str(out)]) == 2
    assert evaluate.main([str(out), "--plot", str(folder), "--overwrite"]) == 2
    assert mine.read_text() == "mine" and (out / "metadata.yaml").exists()
    assert evaluate.main([str(out), "--json", str(mine), "--overwrite"]) == 0
    assert mine.read_text().startswith("{")

    demo_dir = tmp_path / "demo"
    demo_dir.mkdir()
    (demo_dir / "summary.md").write_text("mine")
    args = ["--out-dir", str(demo_dir), "--particles", "5", "--duration", "3"]
    assert demo.main(args) == 2
    assert (demo_dir / "summary.md").read_text() == "mine" and len(os.listdir(demo_dir)) == 1
    assert "--overwrite" in capsys.readouterr().err
