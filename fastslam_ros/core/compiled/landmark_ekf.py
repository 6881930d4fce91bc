# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""numba twin of ``core/landmark_ekf.py``: one particle's map step of a reading (Joseph-form
updates of the associated landmarks, new landmarks by the inverse model, negative evidence for
landmarks in view not seen) and the placing of new landmarks in its working set."""
from __future__ import annotations

import math

from numba import njit

from ..association import IGNORE, NEW
from ..geometry import TWO_PI
from .jit import _INLINED, _JIT, _lever, _wrap


@njit(**_INLINED)
def _joseph(m, slot, k, state, sensor, obs, settings):
    """Joseph-form EKF update (``update_landmarks``) of particle m's landmark ``slot`` by
    observation k (``Observations``) seen from ``sensor`` (x, y, heading), its log-odds raised
    (``existence.observed_logodds``: to ``logodds_max`` from ``confirmed`` on); False if the
    result is not finite."""
    sensor_x, sensor_y, heading = sensor
    ranges, bearings = obs.ranges, obs.bearings
    mx, my = state[m, slot, 0], state[m, slot, 1]
    sxx, sxy, syy = state[m, slot, 2], state[m, slot, 3], state[m, slot, 4]
    dx = mx - sensor_x
    dy = my - sensor_y
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    r0, r1 = obs.range_variance[k], settings.bearing_variance
    g00, g01 = dx / r, dy / r
    g10, g11 = -dy / q, dx / q
    a0, a1 = sxx * g00 + sxy * g01, sxy * g00 + syy * g01
    b0, b1 = sxx * g10 + sxy * g11, sxy * g10 + syy * g11
    s00 = g00 * a0 + g01 * a1 + r0
    s01 = g10 * a0 + g11 * a1
    s11 = g10 * b0 + g11 * b1 + r1
    det = s00 * s11 - s01 * s01
    i00, i01, i11 = s11 / det, -s01 / det, s00 / det
    k00, k01 = a0 * i00 + b0 * i01, a0 * i01 + b0 * i11
    k10, k11 = a1 * i00 + b1 * i01, a1 * i01 + b1 * i11
    nu0 = ranges[k] - r
    nu1 = _wrap(bearings[k] + heading - math.atan2(dy, dx))
    state[m, slot, 0] = mx + (k00 * nu0 + k01 * nu1)
    state[m, slot, 1] = my + (k10 * nu0 + k11 * nu1)
    a00, a01 = 1.0 - (k00 * g00 + k01 * g10), -(k00 * g01 + k01 * g11)
    a10, a11 = -(k10 * g00 + k11 * g10), 1.0 - (k10 * g01 + k11 * g11)
    m00, m01 = a00 * sxx + a01 * sxy, a00 * sxy + a01 * syy
    m10, m11 = a10 * sxx + a11 * sxy, a10 * sxy + a11 * syy
    state[m, slot, 2] = m00 * a00 + m01 * a01 + k00 * k00 * r0 + k01 * k01 * r1
    state[m, slot, 3] = m00 * a10 + m01 * a11 + k00 * k10 * r0 + k01 * k11 * r1
    state[m, slot, 4] = m10 * a10 + m11 * a11 + k10 * k10 * r0 + k11 * k11 * r1
    logodds_max = settings.logodds_max
    if state[m, slot, 5] >= settings.confirmed:
        state[m, slot, 5] = logodds_max
    else:
        state[m, slot, 5] = min(state[m, slot, 5] + settings.logodds_observed, logodds_max)
    finite = True
    for i in range(6):
        if not math.isfinite(state[m, slot, i]):
            finite = False
    return finite


@njit(**_INLINED)
def _map_particle(m, table, existing, choice, poses, obs, settings, observed, fresh):
    """``FastSLAM._apply_to_map`` and ``_missed_evidence`` for particle m, but for placing
    its new landmarks: the mean and packed covariance of each landmark it creates into
    ``fresh[k, m]`` (``_place_new`` puts them in their columns, known once every particle
    has chosen), the Joseph-form updates of its associated landmarks (observations in turn),
    then the log-odds of the landmarks in the perceptual range it did not observe and no
    observation it rejected explains (``existence``). False if an updated landmark is not
    finite (``FastSLAM.check_state`` then repairs)."""
    count = choice.shape[0]
    state, valid, dirty = table.state, table.valid, table.dirty
    ranges, bearings, noise_r, creator = obs.ranges, obs.bearings, obs.range_variance, obs.creator
    ox, oy, oyaw = settings.sensor_x, settings.sensor_y, settings.sensor_yaw
    noise_b = settings.bearing_variance
    px, py, pth = poses[m, 0], poses[m, 1], poses[m, 2]
    lx, ly = _lever(pth, ox, oy)
    heading = pth + oyaw
    sensor = (px + lx, py + ly, heading)
    finite = True
    for j in range(existing):
        observed[j] = False
    for k in range(count):
        if choice[k, m] != NEW or creator[k] != k:
            continue
        # Mean g^-1(z, s), covariance G_m^-1 R G_m^-T (``initialize_landmarks``).
        c, s = math.cos(pth), math.sin(pth)
        sensor_x = px + c * ox - s * oy
        sensor_y = py + s * ox + c * oy
        angle = pth + oyaw + bearings[k]
        mx = sensor_x + ranges[k] * math.cos(angle)
        my = sensor_y + ranges[k] * math.sin(angle)
        dx = mx - (px + lx)
        dy = my - (py + ly)
        q = dx * dx + dy * dy
        r = math.sqrt(q)
        inv00, inv01 = r * dx / q, -dy
        inv10, inv11 = r * dy / q, dx
        r0 = noise_r[k]
        fresh[k, m, 0], fresh[k, m, 1] = mx, my
        fresh[k, m, 2] = inv00 * inv00 * r0 + inv01 * inv01 * noise_b
        fresh[k, m, 3] = inv00 * inv10 * r0 + inv01 * inv11 * noise_b
        fresh[k, m, 4] = inv10 * inv10 * r0 + inv11 * inv11 * noise_b
    for k in range(count):
        # Before ``_place_new`` every landmark chosen existed before this reading.
        slot = choice[k, m]
        if slot < 0:
            continue
        if not _joseph(m, slot, k, state, sensor, obs, settings):
            finite = False
        dirty[m, slot] = True
        observed[slot] = True
    logodds_missed = settings.logodds_missed
    if logodds_missed == 0.0:
        return finite
    # Negative evidence on the landmarks that existed before this reading (the new ones were
    # all observed).
    min_range, max_range = settings.min_range, settings.max_range
    field_of_view = settings.field_of_view
    logodds_remove = settings.logodds_remove
    confirmed, confirmed_missed = settings.confirmed, settings.confirmed_missed
    gate = settings.explained_gate
    limited = field_of_view < TWO_PI
    cos_half = math.cos(0.5 * field_of_view)
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    for j in range(existing):
        if not valid[m, j] or observed[j]:
            continue
        dx = state[m, j, 0] - (px + lx)
        dy = state[m, j, 1] - (py + ly)
        r = math.sqrt(dx * dx + dy * dy)
        if r < min_range or r > max_range:
            continue
        if limited and dx * cos_h + dy * sin_h < r * cos_half:
            continue
        # An observation the association rejected (it founded a landmark, not as a repeat of
        # an id, or was an outlier) near the landmark explains its absence
        # (``existence.explains``).
        predicted = math.atan2(dy, dx) - heading
        near = False
        for k in range(count):
            rejected = choice[k, m] == IGNORE or (choice[k, m] == NEW and creator[k] == k)
            if not rejected:
                continue
            range_error = ranges[k] - r
            bearing_error = _wrap(bearings[k] - predicted)
            if (range_error * range_error / noise_r[k]
                    + bearing_error * bearing_error / noise_b) <= gate:
                near = True
                break
        if near:
            continue
        if state[m, j, 5] >= confirmed:
            state[m, j, 5] += confirmed_missed
        else:
            state[m, j, 5] += logodds_missed
        dirty[m, j] = True
        if state[m, j, 5] < logodds_remove:
            valid[m, j] = False
    return finite


@njit(**_JIT)
def _place_new(table, existing, choice, new, fresh, poses, obs, settings, finite):
    """The new landmarks (``NewLandmarks``) into their columns (``fresh``, from
    ``_map_particle``), then, with known ids, the updates of each by the later observations of
    its id in this reading (``choice`` points them at its column); ``finite[m]`` False for a
    non-finite update."""
    count, num_particles = choice.shape
    state, ident, valid, dirty, is_new = (table.state, table.ident, table.valid, table.dirty,
                                          table.is_new)
    creator, labels = obs.creator, obs.labels
    creating, column, keys = new.creating, new.column, new.keys
    repeated = False
    for k in range(count):
        repeated = repeated or creator[k] != k
        slot = column[k]
        if slot < 0:
            continue
        for m in range(num_particles):
            if not creating[k, m]:
                continue
            for i in range(5):
                state[m, slot, i] = fresh[k, m, i]
            state[m, slot, 5] = settings.logodds_observed
            ident[m, slot, 0] = labels[k]
            ident[m, slot, 1] = keys[k, m]
            valid[m, slot] = True
            is_new[m, slot] = True
            choice[k, m] = slot
    if not repeated:
        return
    ox, oy, oyaw = settings.sensor_x, settings.sensor_y, settings.sensor_yaw
    for m in range(num_particles):
        for k in range(count):
            slot = choice[k, m]
            if slot < existing or creating[k, m]:
                continue
            px, py, pth = poses[m, 0], poses[m, 1], poses[m, 2]
            lx, ly = _lever(pth, ox, oy)
            if not _joseph(m, slot, k, state, (px + lx, py + ly, pth + oyaw), obs, settings):
                finite[m] = False
            dirty[m, slot] = True
