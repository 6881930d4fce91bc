# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
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


SPDX_LINE = "# SPDX-License-Identifier: Apache-2.0"
COPYRIGHT_LINE = "# Copyright 2026 fastslam_ros maintainers"


def header_problem(path: Path) -> str | None:
    """Why ``path`` lacks the license header (the SPDX line, then the copyright line, first in
    the file or right after a shebang); None when it has it."""
    lines = path.read_text().splitlines()
    if lines and lines[0].startswith("#!"):
        lines = lines[1:]
    if lines[:1] != [SPDX_LINE]:
        return f"{path}: first line is not {SPDX_LINE!r}"
    if lines[1:2] != [COPYRIGHT_LINE]:
        return f"{path}: second line is not {COPYRIGHT_LINE!r}"
    return None


def test_every_python_file_carries_the_license_header():
    files = sorted(p for folder in ("fastslam_ros", "test") for p in (ROOT / folder).rglob("*.py"))
    assert len(files) > 50
    problems = [problem for problem in map(header_problem, files) if problem]
    assert not problems, "\n".join(problems)


def test_the_header_check_finds_a_file_without_it(tmp_path):
    bare = tmp_path / "bare.py"
    bare.write_text('"""A module."""\n')
    assert "SPDX" in header_problem(bare)
    no_copyright = tmp_path / "half.py"
    no_copyright.write_text(f'{SPDX_LINE}\n"""A module."""\n')
    assert "second line" in header_problem(no_copyright)
    script = tmp_path / "script.py"
    script.write_text(f'#!/usr/bin/env python3\n{SPDX_LINE}\n{COPYRIGHT_LINE}\n"""A script."""\n')
    assert header_problem(script) is None
