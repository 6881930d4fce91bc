# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Parameter specs: one source for the validation, the node's descriptors and the shipped files."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
import yaml

from fastslam_ros.core import FastSLAMConfig
from fastslam_ros.core.params import ParameterValueError, Spec, check_fields, specs
from fastslam_ros.node import CORE_PARAMETERS, NODE_PARAMETERS, NodeSettings, read_params_file
from fastslam_ros.tools import params_doc

REPO = Path(__file__).resolve().parents[1]
SHIPPED_CONFIGS = sorted(path for path in (REPO / "config").glob("*.yaml")
                         if path.name not in ("people_tracker.yaml", "landmark_extractor.yaml"))
"""The SLAM node's files (the people tracker's is checked in test_people_node.py, the
extractor's in test_landmark_extractor_node.py)."""


@pytest.mark.parametrize("relative, text", params_doc.rendered().items())
def test_generated_files_are_what_the_specs_give(relative, text):
    assert (REPO / relative).read_text(encoding="utf-8") == text, (
        f"{relative} is out of date: run python3 -m fastslam_ros.tools.params_doc")


def test_generator_check_mode_reports_a_stale_file_and_keeps_foreign_files(tmp_path):
    assert params_doc.main(["--root", str(tmp_path), "--check"]) == 1
    assert params_doc.main(["--root", str(tmp_path)]) == 0
    assert params_doc.main(["--root", str(tmp_path), "--check"]) == 0
    foreign = tmp_path / params_doc.YAML_PATH
    foreign.write_text("# my own file\n")
    assert params_doc.main(["--root", str(tmp_path)]) == 1
    assert foreign.read_text() == "# my own file\n"


@pytest.mark.parametrize("settings", [FastSLAMConfig, NodeSettings])
def test_every_field_has_a_description_and_a_range_or_choices(settings):
    assert [f.name for f in dataclasses.fields(settings)] == list(specs(settings))
    for name, (default, spec) in specs(settings).items():
        assert len(spec.description) > 10 and spec.description.endswith("."), name
        if isinstance(default, bool):
            continue
        if isinstance(default, (int, float)):
            assert spec.low is not None and spec.high is not None, name
            assert math.isfinite(spec.low) and math.isfinite(spec.high), name
        if spec.choices is not None:
            assert default in spec.choices, name
        assert spec.problem(default) is None, name
    check_fields(settings())


def test_defaults_are_valid_and_every_shipped_config_loads():
    FastSLAMConfig().validate()
    NodeSettings().validate()
    for path in SHIPPED_CONFIGS:
        values = read_params_file(path)
        core = {k: v for k, v in values.items() if k in CORE_PARAMETERS}
        node = {k: v for k, v in values.items() if k in NODE_PARAMETERS}
        assert set(core) | set(node) == set(values), path.name
        FastSLAMConfig(**core).validate()
        NodeSettings(**node).validate()
        assert list(yaml.safe_load(path.read_text())) == ["/**"], path.name


@pytest.mark.parametrize("changes, names", [
    ({"min_range": 40.0, "max_range": 30.0}, ("min_range", "max_range")),
    ({"association_gate": 30.0}, ("association_gate", "new_landmark_gate")),
    ({"logodds_remove": 2.0}, ("logodds_remove", "logodds_observed")),
    ({"cell_size": 1e-300}, ("cell_size",)),
    ({"num_particles": 0}, ("num_particles",)),
    ({"num_particles": 2.5}, ("num_particles",)),
    ({"sigma_range": math.nan}, ("sigma_range",)),
    ({"outlier_probability": 1.0}, ("outlier_probability",)),
    ({"algorithm": "fastslam3"}, ("algorithm",)),
])
def test_validation_names_the_parameters_at_fault(changes, names):
    with pytest.raises(ParameterValueError) as failure:
        FastSLAMConfig().replace(**changes)
    assert failure.value.names == names
    assert str(failure.value).startswith(", ".join(names) + ": must be")


def test_spec_rules_read_as_written():
    assert Spec("x", low=0.0, low_exclusive=True, high=1.0).rule() == "in (0, 1]"
    assert Spec("x", low=0.5).rule() == ">= 0.5"
    assert Spec("x", choices=("a", "b")).rule() == "one of a | b"
    assert Spec("x", low=0.0, low_exclusive=True).problem(0.0) == "> 0"
    assert Spec("x", high=1.0, high_exclusive=True).problem(0.999) is None


def test_params_file_reader_takes_the_sections_of_the_node(tmp_path):
    path = tmp_path / "params.yaml"
    path.write_text("/**:\n  ros__parameters:\n    sigma_range: 1.0\n    num_particles: 7\n"
                    "fastslam:\n  ros__parameters:\n    num_particles: 9\n"
                    "/robot1/fastslam:\n  ros__parameters:\n    association: known\n"
                    "people_tracker:\n  ros__parameters:\n    other: 1\n")
    assert read_params_file(path) == {"sigma_range": 1.0, "num_particles": 9}
    assert read_params_file(path, "/robot1/fastslam") == {"sigma_range": 1.0,
                                                          "num_particles": 7,
                                                          "association": "known"}
