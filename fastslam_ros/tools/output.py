# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The one rule every tool follows before it writes: never lose what the user owns.

An existing output path is refused unless the user passed ``--overwrite``; with it, only what
the tool itself would write is removed: a rosbag2 bag folder (``metadata.yaml`` and storage files
only) for a bag output, a regular file for a file output. Never the working directory or one
of its parents, never a tool's own input, nor a folder that holds it, nor anything inside an
input bag (a new file inside an input folder, a dataset, is fine).
"""
from __future__ import annotations

import shutil
from pathlib import Path
from typing import Iterable

import yaml

BAG_FILE_SUFFIXES = (".mcap", ".db3", ".db3-shm", ".db3-wal", ".yaml")
"""Files a rosbag2 folder holds: ``metadata.yaml`` and the storage files (MCAP or sqlite3)."""


class OutputExistsError(FileExistsError):
    """An output path that may not be written (it exists and is not the tool's to replace)."""


def _is_bag(path: Path) -> bool:
    """Whether ``path`` is a rosbag2 folder: ``metadata.yaml`` and only storage files."""
    if not (path / "metadata.yaml").is_file():
        return False
    return all(entry.is_file() and entry.name.endswith(BAG_FILE_SUFFIXES)
               for entry in path.iterdir())


def _endangers(output: Path, source: Path) -> bool:
    """Whether writing ``output`` could change the input ``source`` (both resolved): it is the
    input or holds it, or lies inside a bag input or replaces something inside any input."""
    if output == source or output in source.parents:
        return True
    return source in output.parents and ((source / "metadata.yaml").exists() or output.exists())


def check_output(path: str | Path, overwrite: bool, kind: str = "bag",
                 inputs: Iterable[str | Path] = ()) -> bool:
    """Raise ``OutputExistsError`` unless ``prepare_output`` may free ``path``; True when the
    path exists (and will be replaced). Removes nothing: a tool with several outputs checks
    them all before it writes any.

    ``kind`` is ``bag`` (a rosbag2 folder) or ``file``. An existing path is replaced only with
    ``overwrite`` and only when it is what the tool writes; ``inputs`` (the tool's own inputs)
    are refused as outputs even then, as is the working directory or any folder above it.
    """
    if kind not in ("bag", "file"):
        raise ValueError(f"kind: must be 'bag' or 'file' (got {kind!r})")
    path = Path(path)
    resolved = path.expanduser().resolve()
    for source in inputs:
        if _endangers(resolved, Path(source).expanduser().resolve()):
            raise OutputExistsError(f"{path}: is (or holds, or lies in) the input {source}; "
                                    "choose another output")
    if resolved == Path.cwd().resolve() or resolved in Path.cwd().resolve().parents:
        raise OutputExistsError(f"{path}: is the working directory or above it; choose another "
                                "output")
    if not path.exists() and not path.is_symlink():
        return False
    if not overwrite:
        raise OutputExistsError(f"{path} exists (pass --overwrite to replace it, or choose "
                                "another output)")
    if path.is_symlink():
        return True  # the link is ours to replace, never what it points to
    if kind == "bag" and not (path.is_dir() and _is_bag(path)):
        raise OutputExistsError(f"{path} exists and is not a rosbag2 bag (metadata.yaml and "
                                "storage files only): not removed, even with --overwrite")
    if kind == "file" and not path.is_file():
        raise OutputExistsError(f"{path} exists and is not a file: not removed, even with "
                                "--overwrite")
    return True


def prepare_output(path: str | Path, overwrite: bool, kind: str = "bag",
                   inputs: Iterable[str | Path] = ()) -> Path:
    """``check_output``, then remove the old output and create the parent folders; returns
    ``path`` ready to be written."""
    path = Path(path)
    if check_output(path, overwrite, kind, inputs):
        if path.is_symlink() or path.is_file():
            path.unlink()
        else:
            shutil.rmtree(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def write_params_yaml(path: str | Path, params: dict[str, float | int | str],
                      comment: str, overwrite: bool = False) -> Path:
    """A ROS 2 parameter file holding ``params``, keyed ``/**`` so that it applies to the node
    under any name and namespace; an existing file is replaced only with ``overwrite``."""
    lines = [f"# {line}" for line in comment.splitlines()]
    body = yaml.safe_dump({"/**": {"ros__parameters": params}}, default_flow_style=False,
                          sort_keys=False)
    path = prepare_output(path, overwrite, "file")
    path.write_text("\n".join(lines) + "\n" + body)
    return path
