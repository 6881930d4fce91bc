# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Shared test fixtures: where the real datasets live (../shared/datasets beside the repo)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from fastslam_ros.core.config import numba_available

REPO_ROOT = Path(__file__).resolve().parents[1]


def datasets_root() -> Path:
    """The shared datasets folder: $FASTSLAM_DATASETS, else ../shared/datasets beside the repo."""
    return Path(os.environ.get("FASTSLAM_DATASETS", REPO_ROOT.parent / "shared" / "datasets"))


@pytest.fixture
def dataset_dir():
    """Return a function giving a dataset subfolder, skipping the test when it is absent."""
    def get(relative: str) -> Path:
        path = datasets_root() / relative
        if not path.exists():
            pytest.skip(f"dataset not available: {path} (set FASTSLAM_DATASETS or place "
                        "shared/datasets beside the repository)")
        return path
    return get


@pytest.fixture(params=["numpy", pytest.param("numba", marks=pytest.mark.skipif(
    not numba_available(), reason="numba is not installed (pip install numba): the compiled "
    "backend cannot run, the numpy one is tested"))])
def backend(request) -> str:
    """Each filter test runs on the numpy reference and on the compiled backend."""
    return request.param


@pytest.fixture
def context():
    """A fresh rclpy ``Context`` per test (a file that needs another domain or scope defines
    its own)."""
    import rclpy  # noqa: PLC0415 (only the node tests need ROS)
    from rclpy.context import Context  # noqa: PLC0415
    ctx = Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.shutdown(context=ctx)
