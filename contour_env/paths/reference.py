"""The per-servo-period reference table along a path with its feed profile: position,
velocity, acceleration, task frame, curvature and torsion (what the env kernel reads)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .checks import finite_number as _number
from .feed import FeedProfile
from .geometry import PathGeometry

# Longest reference (samples) `ReferenceTrajectory.build` makes. The table stores 23 float64 per
# step (time, s, ṡ, s̈, position 3, velocity 3, acceleration 3, frame 9, curvature, torsion):
# 184 B, so 5,000,000 steps ≈ 0.92 GB; the env core adds ~0.1 kB per step of its own tables
# (position/velocity/acceleration stack, scalars, float32 observation table) and building needs
# transient copies of similar size, so such a setup peaks near 2-3 GB, what a workstation or a
# CI runner can still hold. That is 500 s (8.3 min) of program at a 0.1 ms servo period, 83 min
# at 1 ms.
MAX_REFERENCE_STEPS = 5_000_000
BYTES_PER_REFERENCE_STEP = 23 * 8


@dataclass(frozen=True, eq=False)
class ReferenceTrajectory:
    """Reference at t_k = k T for k = 0 .. n_steps − 1 (SI; float64, C-contiguous arrays).

    ``time`` (n,) s; ``arc_length`` s (n,) m; ``feedrate`` ṡ (n,) m/s; ``feed_accel`` s̈ (n,)
    m/s²; ``position`` (n, 3) m; ``velocity`` = ṡ t (n, 3) m/s; ``acceleration``
    = s̈ t + ṡ² d²p/ds² (n, 3) m/s²; ``frame`` (n, 3, 3) columns [t n b]; ``curvature`` (n,)
    1/m (signed for planar paths); ``torsion`` (n,) 1/m; ``servo_period_s`` T; ``dim`` (2 or 3,
    the path's). Frame convention: `PathGeometry`. n_steps = ceil((duration + settle) / T) + 1;
    after the feed profile ends the reference holds the end point at rest. `build` refuses more
    than ``MAX_REFERENCE_STEPS`` (5,000,000, ≈ 0.92 GB of table) before allocating anything.
    """

    time: np.ndarray
    arc_length: np.ndarray
    feedrate: np.ndarray
    feed_accel: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    frame: np.ndarray
    curvature: np.ndarray
    torsion: np.ndarray
    servo_period_s: float
    dim: int

    @property
    def n_steps(self) -> int:
        return int(self.time.shape[0])

    @classmethod
    def build(
        cls,
        path: PathGeometry,
        profile: FeedProfile,
        servo_period_s: float,
        settle_time_s: float = 0.0,
    ) -> ReferenceTrajectory:
        """Sample ``path`` with ``profile`` (built for this path) every ``servo_period_s`` > 0 s,
        for the profile's duration plus ``settle_time_s`` ≥ 0 s."""
        T = _number("servo_period_s", servo_period_s)
        if not T > 0:
            raise ValueError(f"servo_period_s: must be > 0 s, got {servo_period_s!r}")
        settle = _number("settle_time_s", settle_time_s)
        if not settle >= 0:
            raise ValueError(f"settle_time_s: must be ≥ 0 s, got {settle_time_s!r}")
        if abs(profile.total_length - path.total_length) > 1e-12 * max(1.0, path.total_length):
            raise ValueError(
                f"profile: built for a path of length {profile.total_length:.9g} m, "
                f"this path is {path.total_length:.9g} m"
            )
        n_float = (profile.duration + settle) / T
        n = math.ceil(n_float) + 1 if n_float < MAX_REFERENCE_STEPS else MAX_REFERENCE_STEPS + 1
        if n > MAX_REFERENCE_STEPS:
            raise ValueError(
                f"reference too long: a {profile.duration:.6g} s program plus {settle:g} s "
                f"settle at servo_period_s = {T:g} s needs {n_float + 1:,.0f} steps, more than "
                f"MAX_REFERENCE_STEPS = {MAX_REFERENCE_STEPS:,} (≈ "
                f"{MAX_REFERENCE_STEPS * BYTES_PER_REFERENCE_STEP / 1e9:.2f} GB of reference, "
                f"{MAX_REFERENCE_STEPS * T:,.0f} s at this servo period); shorten or split the "
                "program, raise the feed, or blend its corners (G64)"
            )
        t = np.arange(n, dtype=np.float64) * T
        s, sd, sdd = profile.sample(t)
        d = path.evaluate(s)
        frame, kappa, tau = path.frames(s, d)
        # d2 is the true second derivative: right on straights and in both frame conventions
        vel = sd[:, None] * d["d1"]
        acc = sdd[:, None] * d["d1"] + (sd * sd)[:, None] * d["d2"]
        c = np.ascontiguousarray
        return cls(
            time=c(t),
            arc_length=c(s),
            feedrate=c(sd),
            feed_accel=c(sdd),
            position=c(d["position"]),
            velocity=c(vel),
            acceleration=c(acc),
            frame=c(frame),
            curvature=c(kappa),
            torsion=c(tau),
            servo_period_s=T,
            dim=int(path.dim),
        )
