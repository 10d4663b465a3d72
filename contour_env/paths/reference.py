"""The per-servo-period reference table: position, velocity, acceleration, task frame,
curvature and torsion along a path with its feed profile (what the env kernel reads)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .feed import FeedProfile
from .geometry import PathGeometry


@dataclass(frozen=True, eq=False)
class ReferenceTrajectory:
    """Reference at t_k = k T, k = 0 .. n_steps − 1 (SI units; arrays float64, C-contiguous).

    time (n,) s; arc_length (n,) m; feedrate ṡ (n,) m/s; feed_accel s̈ (n,) m/s²;
    position, velocity (= ṡ t), acceleration (= s̈ t + ṡ² d²p/ds²) (n, 3); frame (n, 3, 3)
    columns [t n b]; curvature (n,) 1/m (signed for planar paths); torsion (n,) 1/m.
    After the feed profile ends the reference holds the end point at rest (settle time).
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
        return self.time.shape[0]

    @classmethod
    def build(
        cls,
        path: PathGeometry,
        profile: FeedProfile,
        servo_period_s: float,
        settle_time_s: float = 0.0,
    ) -> ReferenceTrajectory:
        T = float(servo_period_s)
        if not (math.isfinite(T) and T > 0):
            raise ValueError(f"servo_period_s: must be > 0 s, got {servo_period_s!r}")
        settle = float(settle_time_s)
        if not (math.isfinite(settle) and settle >= 0):
            raise ValueError(f"settle_time_s: must be >= 0 s, got {settle_time_s!r}")
        n = int(math.ceil((profile.duration + settle) / T - 1e-9)) + 1
        t = np.arange(n) * T
        s, sd, sdd = profile.sample(t)
        d = path.evaluate(s)
        frame, kappa, tau = path.frames(s, d)
        vel = sd[:, None] * d["d1"]
        acc = sdd[:, None] * d["d1"] + (sd**2)[:, None] * d["d2"]
        c = np.ascontiguousarray
        return cls(
            c(t),
            c(s),
            c(sd),
            c(sdd),
            c(d["position"]),
            c(vel),
            c(acc),
            c(frame),
            c(kappa),
            c(tau),
            T,
            path.dim,
        )
