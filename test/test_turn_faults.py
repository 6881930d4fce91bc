# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Turn faults in the motion model (``turn_fault_probability``): the shift of one faulty
motion against its closed form, the mixture's statistics over many particles, and the filter
on the ``faults`` scenario (a robot that sometimes does not make the turns its odometry
reports), where it keeps its map with the faults and loses it without."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fastslam_ros.core import FastSLAM, FastSLAMConfig
from fastslam_ros.core.motion import OdometryControl, turn_fault_shift
from fastslam_ros.core.params import ParameterValueError
from fastslam_ros.tools.simulation.sim import SimConfig, simulate


def test_turn_fault_shift_is_the_motion_with_the_rotations_off():
    """A pose at the origin moved by (rot1 0.5, trans 1, rot2 0.2) with the rotations off by
    (-0.5, -0.2) ends at (1, 0, 0) instead of (cos 0.5, sin 0.5, 0.7)."""
    control = OdometryControl(0.5, 1.0, 0.2)
    shift = turn_fault_shift(np.zeros((1, 3)), control, np.array([[-0.5, -0.2]]))
    np.testing.assert_allclose(shift[0], [1.0 - math.cos(0.5), -math.sin(0.5), -0.7],
                               atol=1e-12)
    heading = turn_fault_shift(np.array([[0.0, 0.0, 3.1]]), control, np.array([[0.3, 0.0]]))
    assert abs(heading[0, 2] - 0.3) < 1e-12  # wrapped, not 0.3 - 2 pi


@pytest.mark.parametrize("backend", ["numpy", "auto"])
def test_a_share_of_the_particles_takes_the_turn_as_not_executed(backend):
    """FastSLAM 1.0, a turn on the spot of 0.4 rad with almost no odometry noise: a share p of
    the particles gets an extra N(0, 0.4^2) on each of the motion's two rotations (here rot1
    0.2 and rot2 0.2, as the odometry model splits a turn on the spot), so the heading
    variance is p (0.2^2 + 0.2^2) and about p of the particles lie off the turn."""
    fraction, count = 0.2, 40000
    config = FastSLAMConfig(num_particles=count, algorithm="fastslam1", backend=backend,
                            alpha1=0.0, alpha2=0.0, alpha3=0.0, alpha4=0.0,
                            min_rotation_sigma=1e-6, min_translation_sigma=1e-6,
                            turn_fault_probability=fraction, seed=5)
    slam = FastSLAM(config)
    slam.predict((0.0, 0.0, 0.0), (0.0, 0.0, 0.4))
    slam.update(np.zeros(0), np.zeros(0))
    error = slam.particle_poses()[:, 2] - 0.4
    control = OdometryControl.from_delta((0.0, 0.0, 0.4))
    variance = fraction * (control.rot1 ** 2 + control.rot2 ** 2)
    standard_error = variance * math.sqrt(2.0 / (fraction * count)) * 2.0
    assert abs(np.mean(error ** 2) - variance) < 4.0 * standard_error
    off = np.mean(np.abs(error) > 1e-4)
    assert abs(off - fraction) < 4.0 * math.sqrt(fraction * (1 - fraction) / count)


def test_turn_fault_probability_is_checked():
    with pytest.raises(ParameterValueError, match="turn_fault_probability"):
        FastSLAMConfig(turn_fault_probability=1.0).validate()


def faults_run(seed: int, fraction: float, duration: float = 120.0, **settings) -> float:
    """RMS position error (m) of the reported pose over a ``faults`` run (two commanded turns
    not executed and two slips a minute) of a filter configured as a user would, unknown
    association, ``turn_fault_probability`` ``fraction`` (and other ``settings``). The filter
    starts at the true pose, so its map frame is the world's."""
    bag = simulate(SimConfig(scenario="faults", duration=duration))
    config = FastSLAMConfig(max_range=5.6, min_range=0.4, field_of_view=4.2, sensor_x=0.219,
                            sigma_range=0.03, sigma_bearing=0.026, seed=seed,
                            turn_fault_probability=fraction, **settings)
    odometry, truth = bag.odometry, bag.ground_truth
    step_of = {round((t - odometry.stamps[0]) * 40): i for i, t in enumerate(odometry.stamps)}
    slam = FastSLAM(config, initial_pose=odometry.poses[0])
    previous, errors = odometry.poses[0], []
    for stamp, points in zip(bag.scans.stamps, bag.scans.points):
        step = step_of[round((stamp - odometry.stamps[0]) * 40)]
        slam.predict(previous, odometry.poses[step])
        previous = odometry.poses[step]
        slam.update(np.hypot(points[:, 0], points[:, 1]), np.arctan2(points[:, 1], points[:, 0]),
                    stamp=float(stamp))
        errors.append(np.hypot(*(slam.best_pose()[:2] - truth.poses[step][:2])))
    return float(np.sqrt(np.mean(np.square(errors))))


def test_turn_faults_keep_the_robot_on_its_map_when_turns_are_not_made():
    """The faults scenario, seeds 1-3: without the mixture a turn not made puts every particle
    off its map (the association founds the landmarks again) and the error reaches metres on
    some seed; with 10 % of the particles taking each turn as not executed, every seed stays
    within 0.2 m (the sensor's tube bias bounds it near 0.1 m)."""
    with_faults = [faults_run(seed, 0.1) for seed in (1, 2, 3)]
    without = [faults_run(seed, 0.0) for seed in (1, 2, 3)]
    assert max(with_faults) < 0.2, with_faults
    assert max(without) > 0.5, without
