# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""What every numba twin shares: the compile options, the cache's invalidation across the
twins (``drop_stale_cache``), and the scalar helpers (angle wrap, sensor lever arm,
log-add-exp) that the numpy modules write as array operations."""
from __future__ import annotations

import hashlib
import math
from pathlib import Path

from numba import njit

from ..geometry import TWO_PI

LOG2 = math.log(2.0)
_JIT = dict(cache=True, nogil=True, error_model="numpy")
_INLINED = dict(_JIT, inline="always")
"""A kernel called per particle (or per entry) with records: inlined into its caller, since a
call copies every field of its records (hundreds of words) and costs more than its work."""


def drop_stale_cache(folder: Path = Path(__file__).parent) -> bool:
    """Remove numba's cache files beside the sources in ``folder`` when the sources differ from
    those the cache was made from (their digest, kept beside the cache); True if removed. A
    read-only install (numba then caches in its user folder) is left as it is."""
    digest = hashlib.sha256(b"".join(path.read_bytes()
                                     for path in sorted(folder.glob("*.py")))).hexdigest()
    cache = folder / "__pycache__"
    stamp = cache / "sources.sha256"
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    try:
        stale = list(cache.glob("*.nbi")) + list(cache.glob("*.nbc"))
        for path in stale:
            path.unlink()
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        return False
    return bool(stale)


drop_stale_cache()


@njit(**_JIT)
def _wrap(angle):
    """``geometry.wrap_scalar``."""
    return min(angle - TWO_PI * math.ceil(angle * (1.0 / TWO_PI) - 0.5), math.pi)


@njit(**_JIT)
def _lever(theta, ox, oy):
    """Sensor position relative to the robot in the world frame (0 without an offset)."""
    if ox == 0.0 and oy == 0.0:
        return 0.0, 0.0
    c, s = math.cos(theta), math.sin(theta)
    return c * ox - s * oy, s * ox + c * oy


@njit(**_JIT)
def _logaddexp(x, y):
    """``numpy.logaddexp`` of two floats (same branches)."""
    if x == y:
        return x + LOG2
    difference = x - y
    if difference > 0.0:
        return x + math.log1p(math.exp(-difference))
    if difference <= 0.0:
        return y + math.log1p(math.exp(difference))
    return difference
