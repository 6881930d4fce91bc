"""Shared test fixtures: where the real datasets live (../shared/datasets beside the repo)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

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
