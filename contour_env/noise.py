"""Counter-based random numbers for the compiled kernels.

A value is a pure function of (seed, step, axis, stream), so an env of a vector env and a single
env with the same seed draw exactly the same noise, in any order and with any batch size.
"""

from __future__ import annotations

import math

from numba import njit, uint64

_GOLDEN = uint64(0x9E3779B97F4A7C15)
_M1 = uint64(0xBF58476D1CE4E5B9)
_M2 = uint64(0x94D049BB133111EB)
_INV_2_53 = 1.0 / 9007199254740992.0


@njit(cache=True, inline="always")
def splitmix64(x):
    x = x + _GOLDEN
    x = (x ^ (x >> uint64(30))) * _M1
    x = (x ^ (x >> uint64(27))) * _M2
    return x ^ (x >> uint64(31))


@njit(cache=True)
def uniform01(seed, step, axis, stream):
    """Uniform in (0, 1) from the counter (seed, step, axis, stream)."""
    h = splitmix64(
        uint64(seed)
        ^ splitmix64(uint64(step) * uint64(8) + uint64(axis) + (uint64(stream) << uint64(56)))
    )
    return ((h >> uint64(11)) + 0.5) * _INV_2_53


@njit(cache=True)
def standard_normal(seed, step, axis, stream):
    """Standard normal (Box–Muller) from the counter (seed, step, axis, stream)."""
    u1 = uniform01(seed, step, axis, 2 * stream)
    u2 = uniform01(seed, step, axis, 2 * stream + 1)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)
