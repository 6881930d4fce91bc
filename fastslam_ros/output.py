# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The one way every tool and service writes: never lose what the user owns.

``staged_output`` is the only function that puts an output in place. It refuses, before any
work, a path that exists unless ``overwrite`` was given and the path is what the tool writes:
a rosbag2 bag folder (its ``metadata.yaml`` parses as rosbag2 metadata and every other file is
a storage file it lists) for a bag output, a regular file for a file output, a symbolic link
(the link is replaced, never what it points to). Never the working directory or one of its
parents, never a tool's own input, nor a folder that holds it, nor anything inside an input
bag. The output is written under a temporary name beside it and moved into place only when
the writing succeeded, so a failed run leaves nothing half-written and the old output intact.
No folder is created but the output itself: a missing parent folder is an error.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator

import yaml

KINDS = ("bag", "file")
"""What an output is: a rosbag2 folder or a regular file."""
SQLITE_COMPANIONS = ("-shm", "-wal")
"""Files sqlite3 keeps beside a ``.db3`` storage file while it is open."""


class OutputExistsError(FileExistsError):
    """An output path that may not be written (it exists and is not the tool's to replace,
    or its folder does not exist)."""


def _listed_storage_files(metadata: Path) -> set[str] | None:
    """The storage file names a rosbag2 ``metadata.yaml`` lists; None when it is not one."""
    try:
        document = yaml.safe_load(metadata.read_text())
        info = document["rosbag2_bagfile_information"]
        names = {str(name) for name in info["relative_file_paths"]}
    except (OSError, UnicodeDecodeError, yaml.YAMLError, KeyError, TypeError):
        return None
    if not isinstance(info.get("storage_identifier"), str):
        return None
    return names | {name + suffix for name in names for suffix in SQLITE_COMPANIONS}


def is_bag(path: Path) -> bool:
    """Whether ``path`` is a rosbag2 folder: a rosbag2 ``metadata.yaml`` and nothing but the
    storage files it lists (no sub-folder, no other file)."""
    if path.is_symlink() or not path.is_dir() or not (path / "metadata.yaml").is_file():
        return False
    listed = _listed_storage_files(path / "metadata.yaml")
    if listed is None:
        return False
    return all(entry.name == "metadata.yaml" or (entry.name in listed and entry.is_file()
                                                 and not entry.is_symlink())
               for entry in path.iterdir())


def _endangers(output: Path, source: Path) -> bool:
    """Whether writing ``output`` could change the input ``source`` (both resolved): it is the
    input or holds it, or lies inside a bag input or replaces something inside any input."""
    if output == source or output in source.parents:
        return True
    return source in output.parents and ((source / "metadata.yaml").exists() or output.exists())


def check_output(path: str | Path, overwrite: bool, kind: str = "bag",
                 inputs: Iterable[str | Path] = ()) -> bool:
    """Raise ``OutputExistsError`` unless ``staged_output`` may write ``path``; True when the
    path exists (and will be replaced). Changes nothing: a tool with several outputs checks
    them all before it writes any."""
    if kind not in KINDS:
        raise ValueError(f"kind: must be one of {KINDS} (got {kind!r})")
    path = Path(path).expanduser()
    resolved = path.parent.resolve() / path.name  # the link itself, not what it points to
    for source in inputs:
        source_path = Path(source).expanduser()
        if any(_endangers(candidate, source_path.resolve())
               for candidate in {resolved, path.resolve()}):
            raise OutputExistsError(f"{path}: is (or holds, or lies in) the input {source}; "
                                    "choose another output")
    cwd = Path.cwd().resolve()
    if path.resolve() == cwd or path.resolve() in cwd.parents:
        raise OutputExistsError(f"{path}: is the working directory or above it; choose another "
                                "output")
    if not path.parent.is_dir():
        raise OutputExistsError(f"{path}: folder {path.parent} does not exist (outputs never "
                                "create folders)")
    if not path.exists() and not path.is_symlink():
        return False
    if not overwrite:
        raise OutputExistsError(f"{path} exists (pass --overwrite to replace it, or choose "
                                "another output)")
    if path.is_symlink():
        return True  # the link is ours to replace, never what it points to
    if kind == "bag" and not is_bag(path):
        raise OutputExistsError(f"{path} exists and is not a rosbag2 bag (a rosbag2 "
                                "metadata.yaml and the storage files it lists only): not "
                                "removed, even with --overwrite")
    if kind == "file" and not path.is_file():
        raise OutputExistsError(f"{path} exists and is not a file: not removed, even with "
                                "--overwrite")
    return True


@contextmanager
def staged_output(path: str | Path, overwrite: bool, kind: str = "bag",
                  inputs: Iterable[str | Path] = ()) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` to write the output to (nothing exists there
    yet); when the block ends without an error, move it into place (``check_output`` once
    more, then a rename that replaces an old file or link atomically); on an error, remove
    it and leave ``path`` as it was."""
    path = Path(path).expanduser()
    check_output(path, overwrite, kind, inputs)
    stage = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent))
    try:
        staged = stage / path.name
        yield staged
        if not staged.exists():
            raise OutputExistsError(f"{path}: nothing was written")
        replaced = stage / ".replaced"
        old_bag = check_output(path, overwrite, kind, inputs) and not path.is_symlink() \
            and path.is_dir()
        if old_bag:
            os.rename(path, replaced)  # removed with the stage once the new one is in place
        elif staged.is_dir() and path.is_symlink():
            path.unlink()  # rename() cannot put a folder over a link
        try:
            os.replace(staged, path)
        except OSError:
            if old_bag:
                os.rename(replaced, path)
            raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def write_text(path: str | Path, text: str, overwrite: bool = False,
               inputs: Iterable[str | Path] = ()) -> Path:
    """Write ``text`` as the file ``path`` through ``staged_output``; returns ``path``."""
    with staged_output(path, overwrite, "file", inputs) as staged:
        staged.write_text(text, encoding="utf-8")
    return Path(path).expanduser()


def write_params_yaml(path: str | Path, params: dict[str, float | int | str],
                      comment: str, overwrite: bool = False) -> Path:
    """A ROS 2 parameter file holding ``params``, keyed ``/**`` so that it applies to the node
    under any name and namespace; an existing file is replaced only with ``overwrite``."""
    lines = [f"# {line}" for line in comment.splitlines()]
    body = yaml.safe_dump({"/**": {"ros__parameters": params}}, default_flow_style=False,
                          sort_keys=False)
    return write_text(path, "\n".join(lines) + "\n" + body, overwrite)


@contextmanager
def all_or_nothing(paths: Iterable[str | Path]) -> Iterator[None]:
    """For a tool that writes several outputs one after another: when the block fails, remove
    those of ``paths`` that did not exist when it began (a file or a bag this run wrote, a
    folder it made, once empty), so that a failed run leaves none of its outputs and a retry
    is not refused."""
    new = [Path(path) for path in paths if not os.path.lexists(path)]
    try:
        yield
    except BaseException:
        for path in reversed(new):  # a folder listed first is removed last, when empty
            if path.is_file() and not path.is_symlink():
                path.unlink()
            elif is_bag(path):
                shutil.rmtree(path)
            elif path.is_dir() and not path.is_symlink() and not any(path.iterdir()):
                path.rmdir()
        raise
