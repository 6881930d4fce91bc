# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""How a tracked person moves between two readings: the prediction of its position particles.

``brownian``: theta_t ~ N(theta_{t-1} + (w + w') dt / 2, q^2 dt I), q = ``person_diffusion``;
the particles carry no velocity of their own (a person is as likely to turn back as to walk
on), but drift with the person's walking velocity w, smoothed from its detections
(``walk_estimate``, time constant ``person_walk_time``); w' = w for a person detected at the
last reading, else w slowed towards rest with ``person_velocity_time`` (``walk_on``): a person
hidden for a moment walks on.

``constant_velocity``: each particle carries a velocity v (m/s) as well (people walk fairly
straight). Over a step of dt the velocity decays towards rest with time constant tau
(``person_velocity_time``) and takes the change u ~ N(0, sigma_a^2 dt I) of a white-noise
acceleration (sigma_a = ``person_acceleration``, m/s^1.5: the same motion whatever the scan
rate); the position moves by the step's mean velocity, plus a Brownian step w ~ N(0, s^2 dt
I), s = ``person_sway`` (a person's sway and the detections' jitter; it keeps the particles
apart after every resampling)::

    d = exp(-dt / tau),  v' = d v + u,  theta' = theta + (v + v') dt / 2 + w

so, per axis, E[theta'] = theta + (1 + d) v dt / 2, E[v'] = d v, Var[theta'] = sigma_a^2
dt^3 / 4 + s^2 dt, Var[v'] = sigma_a^2 dt, Cov[theta', v'] = sigma_a^2 dt^2 / 2. A velocity faster
than ``max_person_speed`` is scaled back to it (before the position moves). A new person's
particles start at rest plus N(0, INITIAL_SPEED_SIGMA^2 I): its velocity is unknown until
the detections that follow select the particles that move with it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

PERSON_MOTIONS = ("brownian", "constant_velocity")
"""The person motion models (``person_motion``)."""
INITIAL_SPEED_SIGMA = 0.5
"""Standard deviation (m/s, per axis) of a new person's particle velocities (constant_velocity):
walking speeds are 0.5-1.5 m/s, in any direction."""


@dataclass(frozen=True)
class PersonMotion:
    """One person motion model and its parameters (SI units)."""

    model: str = "brownian"
    diffusion: float = 0.4
    """Brownian: position standard deviation per sqrt(s) per axis (m/sqrt(s))."""
    sway: float = 0.2
    """constant_velocity: the Brownian step's standard deviation per sqrt(s) (m/sqrt(s))."""
    acceleration: float = 0.6
    """constant_velocity: white-noise acceleration per axis: over dt the velocity changes by
    N(0, acceleration^2 dt) (m/s^1.5)."""
    velocity_time: float = 2.0
    """constant_velocity: time constant (s) of the velocity's decay towards rest."""
    max_speed: float = 1.5
    """constant_velocity: fastest walking speed (m/s); faster velocities are scaled back."""
    walk_time: float = 0.0
    """brownian: time constant (s) of the walking velocity estimated from the detections
    (0: none)."""

    def __post_init__(self) -> None:
        if self.model not in PERSON_MOTIONS:
            raise ValueError(f"person_motion: must be one of {' | '.join(PERSON_MOTIONS)} "
                             f"(got {self.model!r})")

    @property
    def carries_velocity(self) -> bool:
        return self.model == "constant_velocity"

    def predict(self, positions: np.ndarray, velocities: np.ndarray, dt: float,
                rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities (each (..., 2), one row per particle) after ``dt`` s
        (new arrays; Brownian motion leaves the velocities as they are)."""
        if dt <= 0.0:
            return positions.copy(), velocities.copy()
        sigma = (self.sway if self.carries_velocity else self.diffusion) * math.sqrt(dt)
        moved = positions + rng.normal(0.0, sigma, positions.shape)
        if not self.carries_velocity:
            return moved, velocities.copy()
        decay = math.exp(-dt / self.velocity_time)
        after = decay * velocities + rng.normal(0.0, self.acceleration * math.sqrt(dt),
                                                velocities.shape)
        after = cap_speed(after, self.max_speed)
        return moved + 0.5 * dt * (velocities + after), after

    def walk_estimate(self, walk: np.ndarray, seen_mean: np.ndarray, mean: np.ndarray,
                      elapsed: np.ndarray) -> np.ndarray:
        """Walking velocities (K, 2) of people ``walk`` (K, 2) just detected: their mean moved
        from ``seen_mean`` to ``mean`` (K, 2) in ``elapsed`` (K,) s since their previous
        detection; exponential smoothing with time constant ``walk_time``, capped at
        ``max_speed`` (zero when it is off or for constant_velocity)."""
        if self.walk_time <= 0.0 or self.carries_velocity:
            return np.zeros_like(walk)
        elapsed = np.maximum(elapsed, 1e-9)[:, None]
        gain = 1.0 - np.exp(-elapsed / self.walk_time)
        return cap_speed(walk + gain * ((mean - seen_mean) / elapsed - walk), self.max_speed)

    def walk_on(self, walk: np.ndarray, unseen: np.ndarray, dt: float
                ) -> tuple[np.ndarray, np.ndarray]:
        """Shift (K, 2) of people walking at ``walk`` (K, 2) over ``dt`` s and their walk
        after it: the particles drift with it, and a person not detected at the last reading
        (``unseen`` (K,)) walks on, slowing towards rest with time constant
        ``velocity_time`` (a person hidden for a moment is looked for where it walked to,
        one hidden for long is predicted to stop)."""
        decay = np.where(unseen, math.exp(-dt / self.velocity_time), 1.0)[:, None]
        after = decay * walk
        return 0.5 * dt * (walk + after), after

    def initial_velocities(self, shape: tuple[int, ...], rng: np.random.Generator
                           ) -> np.ndarray:
        """Velocities (``shape``, last axis 2) of a new person's particles: zero for Brownian
        motion, else N(0, INITIAL_SPEED_SIGMA^2 I) capped at ``max_speed``."""
        if not self.carries_velocity:
            return np.zeros(shape)
        return cap_speed(rng.normal(0.0, INITIAL_SPEED_SIGMA, shape), self.max_speed)


def cap_speed(velocities: np.ndarray, max_speed: float) -> np.ndarray:
    """``velocities`` (..., 2) with those faster than ``max_speed`` scaled back to it."""
    speed = np.hypot(velocities[..., 0], velocities[..., 1])
    scale = np.where(speed > max_speed, max_speed / np.maximum(speed, 1e-300), 1.0)
    return velocities * scale[..., None]
