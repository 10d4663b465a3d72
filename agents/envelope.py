"""The envelope of a residual agent: the ranges of what it was trained on, and the fade that
hands control back to its base outside them (issue 48).

An agent learned its corrections on the parts it saw, at their feeds, curvatures, axis
speeds and errors. On a part outside that — a feed five times the top training feed, a
fillet tighter than any it saw, an error larger than any its base left — nothing says its
correction still applies, and the held-out parts that found the agents of the previous release
worse than their base were such parts. So an agent records, per input below, the largest
value met in training (the teacher's parts and the RL episodes), and at run time multiplies
its gate by

    f = clip(1 − max_j (x_j / hi_j − 1) / margin, 0, 1)          (margin = 0.25)

— 1 inside every range, 0 from 25 % beyond any of them on: the base runs alone there. The
inputs (SI units; upper bounds — every part starts and ends at rest, so every lower bound is 0):

| input | unit |
|---|---|
| ``feed``: the reference's path speed ṡ | m/s |
| ``curvature``: the reference's curvature |κ| | 1/m |
| ``axis_velocity`` (per axis): |ẋ_d,i| | m/s |
| ``axis_acceleration`` (per axis): |ẍ_d,i| | m/s² |
| ``error`` (per task-frame direction t, n(, b)): the measured error |Fᵀ(x_d − x)|, as the
  observation carries it | m |

and, per part, the **programmed feed** F (the part's feed, m/s: the case's, the program's F)
with a lower bound as well as an upper one — the fade then acts on F / hi (above) or lo / F
(below) the same way: a part programmed slower or faster than any the agent trained on is
outside, from its first decision (a linear-motor agent trained at 20–150 mm/s was 1.05x its
base on a star at 13 mm/s).

The fade acts on the gate (an agent without a gate: on its whole push), at every agent
decision, in the Python and the compiled loop alike (:func:`envelope_factor`); ``evaluate`` and
``compare`` report the share of the agent's decisions taken outside (f < 1) as
``outside_envelope_fraction``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

ENVELOPE_FORMAT = "contour_env.envelope/1"
DEFAULT_MARGIN = 0.25
# a bound is never below this fraction of the largest bound of its kind: an input that was 0
# all through training (the z axis of planar parts) closes the gate at the first motion on it
_FLOOR = 1e-12


def feature_names(n_axes: int) -> list[str]:
    axes = "xyz"[:n_axes]
    dirs = "tnb"[:n_axes]
    return (
        ["feed_m_s", "curvature_1_m"]
        + [f"axis_velocity_{a}_m_s" for a in axes]
        + [f"axis_acceleration_{a}_m_s2" for a in axes]
        + [f"error_{d}_m" for d in dirs]
    )


def features_of_core(core) -> np.ndarray:
    """(B, 2 + 3n) the envelope's inputs of every env of ``core`` at its current sample."""
    A = core.dim
    kk = np.minimum(core.k, core.n_steps - 1)
    err = np.abs(np.asarray(core.obs[:, :A], dtype=np.float64)) * float(
        core.config.error_obs_scale_m
    )
    return np.concatenate(
        [
            np.abs(core.scal[kk, 0])[:, None],
            np.abs(core.scal[kk, 2])[:, None],
            np.abs(core.ref_pav[kk, 1, :A]),
            np.abs(core.ref_pav[kk, 2, :A]),
            err,
        ],
        axis=1,
    )


@njit(cache=True)
def envelope_factor(A, k, n_steps, scal, ref_pav, obs, err_scale, hi, margin, part_excess):
    """f (float) of env 0 at its current sample (module docstring); ``hi`` (2 + 3A,);
    ``part_excess``: the part's own ratio to its bounds (the programmed feed's, 1 inside)."""
    kk = k[0] if k[0] < n_steps - 1 else n_steps - 1
    worst = part_excess
    x = abs(scal[kk, 0]) / hi[0]
    if x > worst:
        worst = x
    x = abs(scal[kk, 2]) / hi[1]
    if x > worst:
        worst = x
    for i in range(A):
        x = abs(ref_pav[kk, 1, i]) / hi[2 + i]
        if x > worst:
            worst = x
        x = abs(ref_pav[kk, 2, i]) / hi[2 + A + i]
        if x > worst:
            worst = x
        x = abs(np.float64(obs[0, i])) * err_scale / hi[2 + 2 * A + i]
        if x > worst:
            worst = x
    f = 1.0 - (worst - 1.0) / margin
    if f > 1.0:
        return 1.0
    if f < 0.0 or f != f:
        return 0.0
    return f


class Envelope:
    """Upper bounds of the envelope's inputs (module docstring) and the fade margin."""

    def __init__(self, n_axes: int, hi=None, margin: float = DEFAULT_MARGIN, feed_range=None):
        self.n_axes = int(n_axes)
        # (lo, hi) of the programmed feeds trained on (m/s); None: not checked
        self.feed_range = None
        if feed_range is not None:
            lo, up = (float(v) for v in feed_range)
            if not (math.isfinite(lo) and math.isfinite(up) and 0 < lo <= up):
                raise ValueError(
                    f"envelope: programmed_feed_m_s must be [lo, hi] with 0 < lo <= hi, got "
                    f"{list(feed_range)!r}"
                )
            self.feed_range = (lo, up)
        size = 2 + 3 * self.n_axes
        self.hi = np.zeros(size) if hi is None else np.asarray(hi, dtype=np.float64).copy()
        if self.hi.shape != (size,):
            raise ValueError(f"envelope: {size} bounds for {n_axes} axes, got {self.hi.shape}")
        if not np.all(np.isfinite(self.hi)) or np.any(self.hi < 0):
            raise ValueError(f"envelope: bounds must be finite and >= 0, got {self.hi.tolist()}")
        m = float(margin)
        if not (math.isfinite(m) and m > 0):
            raise ValueError(f"envelope: margin must be > 0, got {margin!r}")
        self.margin = m

    def update_feed(self, feed_m_s: float) -> None:
        """Widen the programmed-feed range to cover ``feed_m_s`` (a part trained on)."""
        f = float(feed_m_s)
        if not (math.isfinite(f) and f > 0):
            return
        lo, up = self.feed_range or (f, f)
        self.feed_range = (min(lo, f), max(up, f))

    def part_excess(self, feed_m_s: float) -> float:
        """The programmed feed's ratio to its range: F / hi above it, lo / F below, 1 inside
        (and without a range)."""
        if self.feed_range is None:
            return 1.0
        lo, up = self.feed_range
        f = float(feed_m_s)
        if not (math.isfinite(f) and f > 0):
            return math.inf
        return max(f / up, lo / f, 1.0) if (f > up or f < lo) else 1.0

    def update(self, features: np.ndarray) -> None:
        """Widen the bounds to cover ``features`` (B, 2 + 3n) (rows with a non-finite value
        are left out)."""
        f = np.asarray(features, dtype=np.float64).reshape(-1, self.hi.shape[0])
        f = f[np.all(np.isfinite(f), axis=1)]
        if f.size:
            np.maximum(self.hi, f.max(axis=0), out=self.hi)

    def bounds(self) -> np.ndarray:
        """The bounds the fade divides by (never 0)."""
        return np.maximum(self.hi, _FLOOR)

    def factor(self, features: np.ndarray, feed_m_s: float | None = None) -> np.ndarray:
        """f per row of ``features`` (B, 2 + 3n) on a part programmed at ``feed_m_s``."""
        x = np.abs(np.asarray(features, dtype=np.float64)) / self.bounds()
        worst = np.maximum(x.max(axis=1), 1.0 if feed_m_s is None else self.part_excess(feed_m_s))
        f = 1.0 - (worst - 1.0) / self.margin
        f = np.where(np.isfinite(f), f, 0.0)
        return np.clip(f, 0.0, 1.0)

    def copy(self) -> Envelope:
        return Envelope(self.n_axes, self.hi, self.margin, self.feed_range)

    def to_dict(self) -> dict:
        out = {
            "format": ENVELOPE_FORMAT,
            "margin": self.margin,
            "upper_bounds": dict(zip(feature_names(self.n_axes), self.hi.tolist(), strict=True)),
        }
        if self.feed_range is not None:
            out["programmed_feed_m_s"] = list(self.feed_range)
        return out

    @classmethod
    def from_dict(cls, data, n_axes: int, where: str = "agent.json: envelope") -> Envelope:
        if not isinstance(data, dict) or data.get("format") != ENVELOPE_FORMAT:
            raise ValueError(f"{where}: expected an object with format {ENVELOPE_FORMAT!r}")
        bounds = data.get("upper_bounds")
        names = feature_names(n_axes)
        if not isinstance(bounds, dict) or sorted(bounds) != sorted(names):
            raise ValueError(f"{where}: upper_bounds must hold exactly {', '.join(names)}")
        hi = []
        for name in names:
            v = bounds[name]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"{where}: {name}: must be a finite number >= 0, got {v!r}")
            if v < 0:
                raise ValueError(f"{where}: {name}: must be >= 0, got {v!r}")
            hi.append(float(v))
        margin = data.get("margin", DEFAULT_MARGIN)
        if (
            isinstance(margin, bool)
            or not isinstance(margin, (int, float))
            or not (math.isfinite(margin) and margin > 0)
        ):
            raise ValueError(f"{where}: margin: must be a number > 0, got {margin!r}")
        feed = data.get("programmed_feed_m_s")
        if feed is not None and (
            not isinstance(feed, list)
            or len(feed) != 2
            or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in feed)
        ):
            raise ValueError(f"{where}: programmed_feed_m_s: [lo, hi] in m/s, got {feed!r}")
        return cls(n_axes, hi, margin, feed)


__all__ = ["DEFAULT_MARGIN", "Envelope", "envelope_factor", "feature_names", "features_of_core"]
