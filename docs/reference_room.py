# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The reference estimators (``../shared/reference/run_reference.py``) on a ``fastslam-sim
--scenario room`` bag.

Their loader assumes the car of the other scenarios, with the sensor at its origin: here the
laser sits ``sensor_x`` (from the bag's parameter file) ahead of the centre and the odometry
noise is the differential drive's, N(0, sigma_speed) on the speed and N(0, sigma_turn_rate) on
the turn rate at every control step (the room's defaults below), propagated to each
keyframe's odometry increment; readings without a detection make no keyframe, so the scores
are taken at the readings with one. Run it with the reference's environment:

    REFERENCE=../shared/reference .venv-ref/bin/python docs/reference_room.py room ref.json
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.environ.get("REFERENCE", "../shared/reference"))
import load_sim  # noqa: E402
from core import between, compose  # noqa: E402

SIGMA_SPEED, SIGMA_TURN_RATE = 0.05, 0.1
"""The room scenario's control noise per step (``tools/simulation/sim.py``, ``ROOM_DEFAULTS``)."""
_load = load_sim.load


def load(bag_dir, yaml_path=None):
    """The reference's loader, with the laser's offset and the differential drive's noise."""
    run, raw, noise = _load(bag_dir, yaml_path)
    run.sensor = (float(noise["yaml"].get("sensor_x", 0.0)), 0.0)
    noise.update(sigma_speed=SIGMA_SPEED, sigma_steer=SIGMA_TURN_RATE)
    seen = np.array([scan[0] - run.info["t0"] for scan in raw["scans"] if len(scan[1])])
    run.info.update(n_scans=len(seen), scan_t=seen)
    return run, raw, noise


def model_increment_cov(run, t_kf, noise, floor=(1e-8, 1e-8, 1e-10)):
    """Covariance of the odometry increment between keyframes (linearised at the odometry)."""
    poses = run.info["odom_pose"]
    steps = between(poses[:-1], poses[1:])
    dt = np.diff(run.odo_t)
    speed = np.hypot(steps[:, 0], steps[:, 1]) / dt
    half = steps[:, 2] / 2
    jacobian = np.zeros((len(dt), 3, 2))
    jacobian[:, 0, 0], jacobian[:, 1, 0] = dt * np.cos(half), dt * np.sin(half)
    jacobian[:, 0, 1] = -speed * dt * np.sin(half) * dt / 2
    jacobian[:, 1, 1] = speed * dt * np.cos(half) * dt / 2
    jacobian[:, 2, 1] = dt
    per_step = (jacobian @ np.diag([SIGMA_SPEED ** 2, SIGMA_TURN_RATE ** 2])
                @ jacobian.transpose(0, 2, 1))
    index = np.searchsorted(run.odo_t, t_kf - 1e-9)
    covs = np.zeros((len(t_kf) - 1, 3, 3))
    for k in range(len(t_kf) - 1):
        delta, cov = np.zeros(3), np.zeros((3, 3))
        for i in range(index[k], index[k + 1]):
            d = steps[i]
            c, s = np.cos(delta[2]), np.sin(delta[2])
            move = np.array([[1, 0, -s * d[0] - c * d[1]], [0, 1, c * d[0] - s * d[1]],
                             [0, 0, 1.0]])
            rotate = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
            cov = move @ cov @ move.T + rotate @ per_step[i] @ rotate.T
            delta = compose(delta, d)
        covs[k] = cov + np.diag(floor)
    return covs


if __name__ == "__main__":
    load_sim.load = load
    load_sim.model_increment_cov = model_increment_cov
    sys.argv = ["run_reference.py", *sys.argv[1:], "--no-q"]
    import run_reference  # noqa: E402
    run_reference.main()
