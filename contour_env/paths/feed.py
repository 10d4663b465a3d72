"""Feed profile along the arc length: constant feedrate with jerk-bounded ("cosine") S-curve
start and stop, and an exact stop at every sharp corner (like G61)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .geometry import PathGeometry


def _ramp_time(feed: float, a_max: float, j_max: float) -> float:
    # v(t) = F (1 − cos(π t / Ta)) / 2: peak acceleration π F / (2 Ta), peak jerk π² F / (2 Ta²)
    return max(math.pi * feed / (2 * a_max), math.pi * math.sqrt(feed / (2 * j_max)))


@dataclass(frozen=True)
class Section:
    """One stop-to-stop stretch: arc lengths (m), peak feed (m/s), ramp Ta and cruise Tc (s)."""

    s_start: float
    s_end: float
    peak_feed: float
    ramp_time: float
    cruise_time: float
    t_start: float

    @property
    def t_end(self) -> float:
        return self.t_start + 2 * self.ramp_time + self.cruise_time


@dataclass(frozen=True)
class FeedProfile:
    """s(t), ṡ(t), s̈(t) along a path: sections split at sharp corners and feed changes, each a
    cosine S-curve (jerk-bounded) from rest to rest.

    In each section, with peak feed F and ramp time Ta = max(πF / (2 a_max), π √(F / (2 j_max))),
    the velocity rises as F (1 − cos(π t / Ta)) / 2, cruises at F and falls mirror-wise; peak
    acceleration ≤ a_max and peak jerk ≤ j_max. A section too short for both ramps at the
    programmed feed uses the lower peak feed F' with F' Ta(F') = its length.
    """

    total_length: float
    sections: tuple

    @classmethod
    def build(
        cls,
        path: PathGeometry,
        feedrate_m_s: float,
        *,
        max_accel_m_s2: float,
        max_jerk_m_s3: float,
        corner_tol_rad: float = 1e-3,
        segment_feeds=None,
    ) -> FeedProfile:
        for name, value in (
            ("feedrate_m_s", feedrate_m_s),
            ("max_accel_m_s2", max_accel_m_s2),
            ("max_jerk_m_s3", max_jerk_m_s3),
        ):
            if not (
                isinstance(value, (int, float, np.floating)) and math.isfinite(value) and value > 0
            ):
                raise ValueError(f"{name}: must be a finite number > 0, got {value!r}")
        L = path.total_length
        cuts = set(float(c) for c in path.corner_arc_lengths(corner_tol_rad))
        seg_feed = None
        if segment_feeds is not None:
            seg_feed = np.asarray(segment_feeds, dtype=np.float64)
            if (
                seg_feed.shape != (path.n_segments,)
                or np.any(~np.isfinite(seg_feed))
                or np.any(seg_feed <= 0)
            ):
                raise ValueError("segment_feeds: one finite feed > 0 per segment (m/s)")
            for k in range(1, path.n_segments):
                if seg_feed[k] != seg_feed[k - 1]:
                    cuts.add(float(path.seg_s0[k]))
        bounds = [0.0] + sorted(c for c in cuts if 0 < c < L) + [L]
        sections = []
        t = 0.0
        for s0, s1 in zip(bounds[:-1], bounds[1:], strict=True):
            length = s1 - s0
            if length <= 0:
                continue
            if seg_feed is not None:
                k = int(
                    np.clip(
                        np.searchsorted(path.seg_s0, 0.5 * (s0 + s1), side="right") - 1,
                        0,
                        path.n_segments - 1,
                    )
                )
                feed = float(seg_feed[k])
            else:
                feed = float(feedrate_m_s)
            ta = _ramp_time(feed, max_accel_m_s2, max_jerk_m_s3)
            if feed * ta > length:
                lo, hi = 0.0, feed
                for _ in range(200):
                    mid = 0.5 * (lo + hi)
                    if mid * _ramp_time(mid, max_accel_m_s2, max_jerk_m_s3) > length:
                        hi = mid
                    else:
                        lo = mid
                feed = lo
                ta = _ramp_time(feed, max_accel_m_s2, max_jerk_m_s3)
                # ramps share the whole section: the ramp distance is exactly length / 2
                ta = length / feed
            cruise = max(0.0, (length - feed * ta) / feed)
            sections.append(Section(s0, s1, feed, ta, cruise, t))
            t = sections[-1].t_end
        return cls(total_length=L, sections=tuple(sections))

    @property
    def duration(self) -> float:
        return self.sections[-1].t_end

    def sample(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s m, ṡ m/s, s̈ m/s²) at times t (s); before 0 at the start, after the end at rest."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        s = np.zeros_like(t)
        v = np.zeros_like(t)
        a = np.zeros_like(t)
        starts = np.array([sec.t_start for sec in self.sections])
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.sections) - 1)
        for k, sec in enumerate(self.sections):
            sel = idx == k
            if not np.any(sel):
                continue
            tau = np.clip(t[sel] - sec.t_start, 0.0, None)
            F, Ta, Tc = sec.peak_feed, sec.ramp_time, sec.cruise_time
            w = math.pi / Ta
            ss = np.empty_like(tau)
            vv = np.empty_like(tau)
            aa = np.empty_like(tau)
            up = tau < Ta
            ss[up] = 0.5 * F * (tau[up] - np.sin(w * tau[up]) / w)
            vv[up] = 0.5 * F * (1 - np.cos(w * tau[up]))
            aa[up] = 0.5 * F * w * np.sin(w * tau[up])
            cr = (tau >= Ta) & (tau < Ta + Tc)
            ss[cr] = 0.5 * F * Ta + F * (tau[cr] - Ta)
            vv[cr] = F
            aa[cr] = 0.0
            dn = tau >= Ta + Tc
            td = np.clip(tau[dn] - Ta - Tc, 0.0, Ta)
            ss[dn] = 0.5 * F * Ta + F * Tc + 0.5 * F * (td + np.sin(w * td) / w)
            vv[dn] = 0.5 * F * (1 + np.cos(w * td))
            aa[dn] = -0.5 * F * w * np.sin(w * td)
            ended = tau >= 2 * Ta + Tc
            ss[ended] = sec.s_end - sec.s_start
            vv[ended] = 0.0
            aa[ended] = 0.0
            s[sel] = sec.s_start + ss
            v[sel] = vv
            a[sel] = aa
        s = np.clip(s, 0.0, self.total_length)
        return s, v, a
