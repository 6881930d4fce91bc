"""Odometry motion model (Probabilistic Robotics, table 5.6) in its sampled and Gaussian forms.

Odometry between two poses is decomposed into (rot1, trans, rot2). FastSLAM 1.0 samples the
nonlinear model; FastSLAM 2.0 uses the Gaussian form s_t = h(s_{t-1}, u) + w, w ~ N(0, P_t),
with P_t = V M V^T, M the control noise and V = dh/du.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .geometry import wrap_angle


@dataclass(frozen=True)
class OdometryControl:
    """One odometry step: first rotation, translation, second rotation (rad, m, rad)."""

    rot1: float
    trans: float
    rot2: float

    @classmethod
    def from_delta(cls, delta) -> "OdometryControl":
        """Decompose a relative pose (dx, dy, dtheta) in the start frame.

        Backward motion keeps a small rot1 with a negative translation instead of turning by pi,
        so reversing does not look like a half turn to the noise model.
        """
        dx, dy, dtheta = (float(v) for v in delta)
        trans = math.hypot(dx, dy)
        rot1 = math.atan2(dy, dx) if trans > 1e-9 else 0.0
        if abs(rot1) > math.pi / 2.0:
            rot1 = wrap_angle(rot1 - math.pi)
            trans = -trans
        return cls(rot1, trans, wrap_angle(dtheta - rot1))


def control_variances(u: OdometryControl, alphas, min_translation_sigma: float,
                      min_rotation_sigma: float, linear=(0.0, 0.0, 0.0, 0.0)) -> np.ndarray:
    """Variances of (rot1, trans, rot2): alpha-scaled terms plus a fixed floor.

    ``linear`` = (rotation per radian, rotation per meter, translation per meter, translation
    per radian) adds random-walk terms, linear in the step's size, so that the variance of a
    motion does not depend on how many steps it is divided into.
    """
    a1, a2, a3, a4 = alphas
    rot1_sq, trans_sq, rot2_sq = u.rot1 ** 2, u.trans ** 2, u.rot2 ** 2
    variances = np.array([
        a1 * rot1_sq + a2 * trans_sq + min_rotation_sigma ** 2,
        a3 * trans_sq + a4 * (rot1_sq + rot2_sq) + min_translation_sigma ** 2,
        a1 * rot2_sq + a2 * trans_sq + min_rotation_sigma ** 2,
    ])
    k_rr, k_rt, k_tt, k_tr = linear
    if k_rr or k_rt or k_tt or k_tr:
        rot1, trans, rot2 = abs(u.rot1), abs(u.trans), abs(u.rot2)
        variances += np.array([k_rr * rot1 + 0.5 * k_rt * trans,
                               k_tt * trans + k_tr * (rot1 + rot2),
                               k_rr * rot2 + 0.5 * k_rt * trans])
    return variances


def apply_control(poses: np.ndarray, rot1, trans, rot2) -> np.ndarray:
    """h(s, u): move poses (M, 3) by the controls (scalars or (M,) arrays)."""
    heading = poses[:, 2] + rot1
    return np.stack([poses[:, 0] + trans * np.cos(heading),
                     poses[:, 1] + trans * np.sin(heading),
                     wrap_angle(poses[:, 2] + rot1 + rot2)], axis=1)


def sample_motion(poses: np.ndarray, u: OdometryControl, variances: np.ndarray,
                  standard_normals: np.ndarray) -> np.ndarray:
    """Sample the odometry model for every particle; ``standard_normals`` is (M, 3)."""
    noisy = np.array([u.rot1, u.trans, u.rot2]) - standard_normals * np.sqrt(variances)
    return apply_control(poses, noisy[:, 0], noisy[:, 1], noisy[:, 2])


def propagate_gaussian(mean: np.ndarray, cov: np.ndarray, u: OdometryControl,
                       variances: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """EKF prediction of N(mean, cov) through h: (h(mean, u), F cov F^T + V M V^T).

    F = dh/ds is the identity but for its heading column: F = I + f e^T, e = (0, 0, 1),
    f = (-trans sin(heading), trans cos(heading), 0). So F cov F^T = cov + f c^T + c f^T
    + cov_tt f f^T with c = cov e, written out instead of two stacked matmuls.
    """
    heading = mean[:, 2] + u.rot1
    f = np.zeros((mean.shape[0], 3))
    f[:, 0] = -u.trans * np.sin(heading)
    f[:, 1] = u.trans * np.cos(heading)
    c = cov[:, :, 2]
    outer = f[:, :, None] * c[:, None, :]
    predicted = (cov + outer + outer.transpose(0, 2, 1)
                 + cov[:, 2, 2, None, None] * f[:, :, None] * f[:, None, :])
    return (apply_control(mean, u.rot1, u.trans, u.rot2),
            predicted + motion_covariance(mean, u, variances))


def motion_covariance(poses: np.ndarray, u: OdometryControl, variances: np.ndarray) -> np.ndarray:
    """P_t = V M V^T for every particle (M, 3, 3), V = dh/d(rot1, trans, rot2)."""
    heading = poses[:, 2] + u.rot1
    c, s = np.cos(heading), np.sin(heading)
    jac = np.zeros((poses.shape[0], 3, 3))
    jac[:, 0, 0] = -u.trans * s
    jac[:, 0, 1] = c
    jac[:, 1, 0] = u.trans * c
    jac[:, 1, 1] = s
    jac[:, 2, 0] = 1.0
    jac[:, 2, 2] = 1.0
    return (jac * variances[None, None, :]) @ jac.transpose(0, 2, 1)
