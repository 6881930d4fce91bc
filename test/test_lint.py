"""The lint a ROS 2 Python package carries (ruff with the flake8 and pep257 rules of ruff.toml),
and one license across the package's files."""
from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def ruff_command() -> list[str] | None:
    """The ruff executable: the Python package's binary, else one on PATH; None without it."""
    try:
        from ruff.__main__ import find_ruff_bin
        return [str(find_ruff_bin())]
    except (ImportError, FileNotFoundError):
        found = shutil.which("ruff")
        return [found] if found else None


def test_ruff_finds_nothing():
    command = ruff_command()
    if command is None:
        pytest.skip("ruff is not installed (pip install -e '.[test]' installs it)")
    result = subprocess.run(command + ["check", "--no-cache", "--config", str(ROOT / "ruff.toml"),
                                       str(ROOT)],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr


def test_one_license_everywhere():
    license_text = (ROOT / "LICENSE").read_text()
    assert "Apache License" in license_text and "Version 2.0" in license_text
    package_xml = (ROOT / "package.xml").read_text()
    assert re.findall(r"<license>(.*?)</license>", package_xml) == ["Apache-2.0"]
    assert re.search(r'license="Apache-2.0"', (ROOT / "setup.py").read_text())
