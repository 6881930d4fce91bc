# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Figure of an evaluated run: paths and landmarks in the ground-truth frame, error over time."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection  # noqa: E402

from fastslam_ros.core.geometry import ellipse_axes  # noqa: E402


def plot_evaluation(evaluation, path: str | Path, title: str | None = None) -> Path:
    """Write the figure of an ``evaluate.Evaluation``: estimated paths after their alignment,
    ground truth, landmarks with 2-sigma ellipses and truth (left); position error over time
    (right); this module imports nothing of evaluate, which imports it."""
    run = evaluation.run
    trajectories = evaluation.trajectories
    figure, (map_axes, error_axes) = plt.subplots(
        1, 2, figsize=(14, 6.5), gridspec_kw={"width_ratios": [1.25, 1.0]})
    start = run.ground_truth.stamps[0] if run.ground_truth is not None else 0.0
    if run.ground_truth is not None:
        truth = run.ground_truth.poses
        map_axes.plot(truth[:, 0], truth[:, 1], color="black", linewidth=1.2, label="ground truth")
    styles = {"dead_reckoning": ("tab:red", ":", "dead reckoning"),
              "estimate": ("tab:blue", "-", "estimate (at the time)"),
              "final_path": ("tab:green", "--", "best particle, final path")}
    for name, (color, line, label) in styles.items():
        if name in trajectories:
            result = trajectories[name]
            aligned = result.alignment.apply(result.estimate)
            map_axes.plot(aligned[:, 0], aligned[:, 1], color=color, linestyle=line,
                          linewidth=1.0, label=f"{label}, aligned")
            error_axes.plot(result.stamps - start, result.aligned_errors, color=color,
                            linestyle=line, linewidth=1.0,
                            label=f"{label}, aligned")
    if "estimate" in trajectories:
        result = trajectories["estimate"]
        error_axes.plot(result.stamps - start, result.raw_errors, color="tab:blue",
                        linewidth=0.6, alpha=0.5, label="estimate, raw")
    if run.landmarks_truth is not None:
        map_axes.scatter(*run.landmarks_truth.positions.T, marker="x", color="black", s=14,
                         linewidths=0.8, label="landmarks, truth", zorder=3)
    if run.landmarks is not None and len(run.landmarks.positions):
        _draw_landmarks(map_axes, run.landmarks.positions, run.landmarks.covariances,
                        evaluation.landmark_alignment)
    map_axes.set_aspect("equal", adjustable="datalim")
    map_axes.set_xlabel("x (m)")
    map_axes.set_ylabel("y (m)")
    map_axes.legend(loc="best", fontsize=8)
    map_axes.set_title(title or "paths and landmarks (ground-truth frame)")
    error_axes.set_xlabel("time (s)")
    error_axes.set_ylabel("position error (m)")
    error_axes.set_title("position error over time")
    error_axes.grid(True, alpha=0.3)
    error_axes.legend(loc="best", fontsize=8)
    figure.tight_layout()
    path = Path(path)
    figure.savefig(path, dpi=120)
    plt.close(figure)
    return path


def _draw_landmarks(axes, positions: np.ndarray, covariances: np.ndarray, alignment) -> None:
    """Estimated landmarks (aligned by a ``metrics.Transform2D``, if any) as dots with their
    2-sigma covariance ellipses."""
    if alignment is not None:
        positions = alignment.apply(positions)
        covariances = alignment.rotation @ covariances @ alignment.rotation.T
    aligned = positions
    widths, heights, angles = ellipse_axes(covariances)
    axes.add_collection(EllipseCollection(
        widths, heights, np.degrees(angles), units="xy", offsets=aligned,
        offset_transform=axes.transData,
        facecolors="none", edgecolors="tab:purple", linewidths=0.8))
    axes.scatter(*aligned.T, s=6, color="tab:purple", label="landmarks, estimate (2-sigma)",
                 zorder=4)


def plot_formats() -> tuple[str, ...]:
    """File suffixes matplotlib can write (``--plot``)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    return tuple(sorted(FigureCanvasAgg(Figure()).get_supported_filetypes()))
