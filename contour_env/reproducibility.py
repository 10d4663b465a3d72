"""What reproduces to the bit, and the tolerance figures agree within across CPUs
(docs/reproducibility.md).

**Bit-identical** on one machine (same installed versions, same seed and inputs): every env
episode and vector-env step whatever numba's thread count, the compiled and the Python paths
of a controller, and a residual agent's evaluation whatever BLAS's thread count.

**Within a tolerance** across CPUs of one machine kind: numba compiles for the host CPU
(``NUMBA_CPU_NAME`` defaults to the host: AVX-512 on one machine, AVX2 on another, each with
its own vector widths and math-library paths), and OpenBLAS, which runs the residual agent's
float32 actor in NumPy, picks its kernels by CPU, so a few operations round differently in the
last bit. The realistic
plants then amplify that bit: stick–slip friction switches between sticking and sliding, the
encoder rounds to whole counts and a residual agent's envelope gates on thresholds, so one
differently rounded bit becomes a different trajectory a few servo periods later. A figure of
a run (RMS or max contour error, µm) moves by up to ~1e-3 relative (measured: 4.358137 against
4.364485 µm on friction-table between two CPUs of this kind); :func:`agree_across_cpus` is the
documented rule, and the tests that compare a file of figures written on one machine with a
recomputation use it.
"""

from __future__ import annotations

import math

# a figure (µm) recomputed on another CPU of the same kind agrees with the stored one within
# this relative difference, or within one encoder count, whichever is larger
CROSS_CPU_RTOL = 0.01


def agree_across_cpus(stored: float, again: float, resolution_um: float = 0.0) -> bool:
    """Whether a recomputed figure ``again`` agrees with ``stored`` (both µm, finite) within
    the cross-CPU tolerance: ``|again − stored| ≤ max(CROSS_CPU_RTOL · |stored|,
    resolution_um)`` (``resolution_um``: the encoder count, 0 for none)."""
    for name, v in (("stored", stored), ("again", again), ("resolution_um", resolution_um)):
        if not (isinstance(v, (int, float)) and math.isfinite(v)):
            raise ValueError(f"{name}: must be a finite number (µm), got {v!r}")
    if resolution_um < 0:
        raise ValueError(f"resolution_um: must be >= 0 µm, got {resolution_um!r}")
    return abs(again - stored) <= max(CROSS_CPU_RTOL * abs(stored), resolution_um)
