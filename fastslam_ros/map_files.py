# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The landmark map file that ``~/save_map`` writes and ``map_file`` / ``~/load_map`` read, as
YAML or CSV; ROS-free (the nodes and the tools share it)."""
from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Protocol

import numpy as np
import yaml

from fastslam_ros.output import write_text

MAP_FILE_COLUMNS = ("key", "id", "x", "y", "cov_xx", "cov_xy", "cov_yy", "existence")


class LandmarkMapLike(Protocol):
    """What the converters need of ``fastslam_ros.core.LandmarkMap``."""

    means: np.ndarray
    covariances: np.ndarray
    existence: np.ndarray
    ids: np.ndarray
    keys: np.ndarray


def write_map_file(file_path: str | Path, landmark_map: LandmarkMapLike, frame_id: str,
                   stamp: float, overwrite: bool = False, inputs: Iterable[str | Path] = ()
                   ) -> Path:
    """Write the map as CSV (``.csv``) or YAML (any other suffix); return the path written.
    Through ``output.write_text``: an existing file is replaced only with ``overwrite`` (a
    link, never its target), never one of ``inputs``, and no folder is made.

    One row per landmark with the columns of ``MAP_FILE_COLUMNS``: stable key, external id
    (-1 unknown), mean (m), covariance entries (m^2) and existence probability.
    """
    file_path = Path(file_path).expanduser()
    rows = [(int(key), int(landmark_id), *map(float, mean), float(cov[0, 0]), float(cov[0, 1]),
             float(cov[1, 1]), float(existence))
            for key, landmark_id, mean, cov, existence in zip(
                landmark_map.keys, landmark_map.ids, landmark_map.means,
                landmark_map.covariances, landmark_map.existence)]
    if file_path.suffix.lower() == ".csv":
        stream = io.StringIO(newline="")
        writer = csv.writer(stream)
        writer.writerow(MAP_FILE_COLUMNS)
        writer.writerows(rows)
        text = stream.getvalue()
    else:
        document = {"frame_id": frame_id, "stamp": float(stamp), "count": len(rows),
                    "landmarks": [dict(zip(MAP_FILE_COLUMNS, row)) for row in rows]}
        text = "# fastslam_ros landmark map of the best particle\n" + yaml.safe_dump(
            document, sort_keys=False, default_flow_style=None, width=1000)
    return write_text(file_path, text, overwrite, inputs)


@dataclass
class MapFile:
    """A landmark map read back from a ``write_map_file`` file (YAML or CSV)."""

    means: np.ndarray
    """(N, 2) positions (m)."""
    covariances: np.ndarray
    """(N, 2, 2) position covariances (m^2)."""
    ids: np.ndarray
    """(N,) external ids (-1 unknown)."""
    frame_id: str = ""
    """The map's frame ('' when the file does not say, as CSV)."""


class MapFileError(ValueError):
    """A map file that cannot be read; the message names the file."""


def read_map_file(file_path: str | Path) -> MapFile:
    """Read a map written by ``write_map_file`` (``.csv``: CSV, else YAML); MapFileError names
    the file and what is wrong with it."""
    file_path = Path(file_path).expanduser()
    try:
        if file_path.suffix.lower() == ".csv":
            with file_path.open(newline="") as stream:
                rows = list(csv.DictReader(stream))
            frame_id = ""
        else:
            document = yaml.safe_load(file_path.read_text())
            if not isinstance(document, dict) or not isinstance(document.get("landmarks"), list):
                raise MapFileError(f"map file '{file_path}': no 'landmarks:' list")
            rows, frame_id = document["landmarks"], str(document.get("frame_id", ""))
        table = np.array([[float(row[name]) for name in MAP_FILE_COLUMNS] for row in rows],
                         dtype=float).reshape(-1, len(MAP_FILE_COLUMNS))
    except OSError as error:
        raise MapFileError(f"map file '{file_path}': {error.strerror or error}") from None
    except (yaml.YAMLError, KeyError, TypeError, ValueError) as error:
        if isinstance(error, MapFileError):
            raise
        raise MapFileError(f"map file '{file_path}': not a landmark map "
                           f"({type(error).__name__}: {error})") from None
    if len(table) == 0:
        raise MapFileError(f"map file '{file_path}': holds no landmark (an empty map is not "
                           "loaded)")
    column = {name: table[:, index] for index, name in enumerate(MAP_FILE_COLUMNS)}
    covariances = np.stack([np.stack([column["cov_xx"], column["cov_xy"]], -1),
                            np.stack([column["cov_xy"], column["cov_yy"]], -1)], -2)
    means = np.column_stack([column["x"], column["y"]])
    if not (np.isfinite(means).all() and np.isfinite(covariances).all()):
        raise MapFileError(f"map file '{file_path}': non-finite landmark values")
    determinants = column["cov_xx"] * column["cov_yy"] - column["cov_xy"] ** 2
    if ((column["cov_xx"] <= 0.0) | (determinants <= 0.0)).any():
        raise MapFileError(f"map file '{file_path}': a landmark covariance is not positive "
                           "definite")
    return MapFile(means, covariances, column["id"].astype(np.int64), frame_id)
