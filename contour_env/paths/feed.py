"""Feed profile s(t) along a path: jerk-bounded ("cosine") S-curves. By default from rest to
rest on each section, with an exact stop (like G61) at every sharp corner and feed change; with
per-segment blend tolerances or dwells, the look-ahead planner of `contour_env.paths.planner`
(G64 junction speeds, dwells, the programmed feed through gentle bends)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import planner
from .checks import finite_number
from .geometry import PathGeometry
from .planner import Block


def _positive(name: str, value, unit: str) -> float:
    need = f"must be a finite number > 0 {unit}"
    v = finite_number(name, value, expected=need, bad=need)
    if not v > 0:
        raise ValueError(f"{name}: {need}, got {value!r}")
    return v


def ramp_time(feed: float, a_max: float, j_max: float) -> float:
    """Ramp time Ta (s) of a cosine ramp 0 -> ``feed`` (m/s) within a_max (m/s²), j_max (m/s³).

    v(t) = F (1 − cos(π t / Ta)) / 2 peaks at acceleration π F / (2 Ta) and jerk π² F / (2 Ta²).
    """
    return max(math.pi * feed / (2 * a_max), math.pi * math.sqrt(feed / (2 * j_max)))


def fitting_feed(length: float, a_max: float, j_max: float) -> float:
    """Largest peak feed F' (m/s) whose two ramps exactly fill ``length`` m: F' Ta(F') = length.

    F Ta(F) = max(π F² / (2 a), π F^1.5 / sqrt(2 j)) is increasing, so F' is the smaller of
    the two branch solutions sqrt(2 a L / π) and (L sqrt(2 j) / π)^(2/3).
    """
    return min(
        math.sqrt(2 * a_max * length / math.pi),
        (length * math.sqrt(2 * j_max) / math.pi) ** (2 / 3),
    )


__all__ = ["Block", "FeedProfile", "Section", "fitting_feed", "ramp_time"]


class Section(NamedTuple):
    """One stop-to-stop stretch: arc lengths (m), peak feed (m/s), start and end times (s)."""

    s_start: float
    s_end: float
    peak_feed: float
    t_start: float
    t_end: float

    @property
    def ramp_time(self) -> float:
        """Ta (s), from L = F (Ta + Tc) and t_end − t_start = 2 Ta + Tc."""
        return (self.t_end - self.t_start) - (self.s_end - self.s_start) / self.peak_feed

    @property
    def cruise_time(self) -> float:
        """Tc (s) at the peak feed (0 for a section too short to reach the programmed feed)."""
        return max(0.0, (self.t_end - self.t_start) - 2 * self.ramp_time)


@dataclass(frozen=True, eq=False)
class FeedProfile:
    """s(t), ṡ(t), s̈(t) along a path (m, m/s, m/s²), built with `FeedProfile.build`.

    Exact-stop profile (the default, ``segment_blend_m`` and ``segment_dwell_s`` None): the
    path is cut into sections at sharp corners (tangent jump > ``corner_tol_rad``) and, with
    per-segment feeds, where the feed changes. The tool stops exactly at each cut (like G61
    exact-stop mode), so the reference velocity is continuous in direction everywhere.
    Each section runs a cosine S-curve from rest to rest: with peak feed F and ramp time
    Ta = max(π F / (2 a_max), π sqrt(F / (2 j_max))), ṡ = F (1 − cos(π t / Ta)) / 2 while
    accelerating (covering F Ta / 2), F while cruising, mirrored while decelerating; so
    |s̈| ≤ a_max and |s⃛| ≤ j_max. A section shorter than F Ta runs at the lower peak feed F'
    with F' Ta(F') = its length (no cruise). ``sections``: tuple of `Section`.

    Look-ahead profile (``segment_blend_m`` and/or ``segment_dwell_s`` given; see
    `contour_env.paths.planner` and docs/FEED_PLANNER.md): the path is cut into blocks at
    junctions (a corner sharper than ``corner_tol_rad``, a feed change or a dwell; not a G64
    corner that allows the feed of both sides, which constrains nothing). A corner
    with blend tolerance δ > 0 (G64) is passed at grbl's junction-deviation speed
    v_j = min(sqrt(a_max R), (j_max R²)^(1/3)), R = δ sin(φ/2) / (1 − sin(φ/2)), φ = π − θ,
    capped by the feeds of both sides; δ = 0 (G61) or a dwell stops there. A feed change
    without a corner under G64 is passed at the lower feed (no stop). Backward and forward
    passes over all blocks fix the junction speeds; each block then runs cosine transitions
    v_in → peak (≤ its feed) → cruise → v_out, each v0 → v1 as
    v = v0 + (v1 − v0)(1 − cos(π t / Ta)) / 2, Ta = max(π |Δv| / (2 a_max), π sqrt(|Δv| /
    (2 j_max))), so |s̈| ≤ a_max and |s⃛| ≤ j_max along the path. At a G64 corner the path
    speed ṡ is continuous but the axis velocity ṡ t changes direction in one step (by
    2 v_j sin(θ/2)): as in grbl the reference stays exactly on the programmed path and the
    servo loop rounds the corner. ``sections``: tuple of `Block` (s_start, s_end, v_in,
    peak_feed, v_out, t_start, t_end, dwell_s).

    Fields: ``total_length`` (m), ``sections``, ``duration`` (s, property: to the end of the
    motion, plus a dwell after the last segment; a start dwell, ``start_dwell_s``, comes first:
    at rest on s = 0 until it is over).
    """

    total_length: float
    sections: tuple
    # per-section rows for vectorised sampling: s_start, s_end, F, Ta, Tc, t_start, t_end
    _table: np.ndarray = field(repr=False)
    # look-ahead profile: the planner's table (planner.T0 … planner.TEND), else None
    _plan: np.ndarray | None = field(default=None, repr=False)

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
        segment_blend_m=None,
        segment_dwell_s=None,
        start_dwell_s=0.0,
    ) -> FeedProfile:
        """Profile for ``path`` at ``feedrate_m_s`` > 0 m/s within ``max_accel_m_s2`` > 0 m/s²
        and ``max_jerk_m_s3`` > 0 m/s³; corners are joints whose tangent jumps by more than
        ``corner_tol_rad`` (≥ 0 rad). ``segment_feeds``: optional feed per segment (m/s, each
        > 0), used instead of ``feedrate_m_s`` on that segment (e.g. G-code F words).

        ``segment_blend_m``: optional, one path-deviation tolerance per segment (m, ≥ 0) for
        the junction at the END of segment k (G64 P; 0 = exact stop, G61). ``segment_dwell_s``:
        optional, one dwell per segment (s, ≥ 0): the tool stops at the end of segment k and
        waits that long (G4). ``start_dwell_s`` (s, ≥ 0, default 0): the tool waits that long
        at rest on the start point before it moves (a G4 before the first move). With either
        per-segment array given or a start dwell > 0, the look-ahead planner runs (class
        docstring); otherwise the exact-stop profile: a stop at every corner and feed change."""
        feed = _positive("feedrate_m_s", feedrate_m_s, "m/s")
        a_max = _positive("max_accel_m_s2", max_accel_m_s2, "m/s²")
        j_max = _positive("max_jerk_m_s3", max_jerk_m_s3, "m/s³")
        tol = float(corner_tol_rad)
        if not (math.isfinite(tol) and tol >= 0):
            raise ValueError(
                f"corner_tol_rad: must be a finite angle ≥ 0 rad, got {corner_tol_rad!r}"
            )
        start = start_dwell_s
        if isinstance(start, bool) or not isinstance(start, (int, float, np.number)):
            raise ValueError(f"start_dwell_s: must be a finite number ≥ 0 s, got {start!r}")
        if not (math.isfinite(start) and start >= 0):
            raise ValueError(f"start_dwell_s: must be a finite number ≥ 0 s, got {start!r}")
        L = path.total_length
        seg_feed = None
        if segment_feeds is not None:
            try:
                seg_feed = np.asarray(segment_feeds, dtype=np.float64).reshape(-1)
            except (TypeError, ValueError):
                raise ValueError("segment_feeds: expected one number per segment") from None
            if seg_feed.shape != (path.n_segments,):
                raise ValueError(
                    f"segment_feeds: expected {path.n_segments} feeds (one per segment), "
                    f"got {seg_feed.shape[0]}"
                )
            if not np.all(np.isfinite(seg_feed) & (seg_feed > 0)):
                raise ValueError("segment_feeds: every feed must be a finite number > 0 m/s")
        if segment_blend_m is not None or segment_dwell_s is not None or start > 0:
            n = path.n_segments
            blend = (
                None
                if segment_blend_m is None
                else planner._per_segment("segment_blend_m", segment_blend_m, n, "m")
            )
            dwell = (
                None
                if segment_dwell_s is None
                else planner._per_segment("segment_dwell_s", segment_dwell_s, n, "s")
            )
            feeds = seg_feed if seg_feed is not None else np.full(n, feed)
            tab = planner.plan(path, feeds, a_max, j_max, tol, blend, dwell, float(start))
            return cls(
                total_length=L, sections=planner.blocks(tab), _table=np.empty((0, 7)), _plan=tab
            )
        cuts = {float(c) for c in path.corner_arc_lengths(tol)}
        if seg_feed is not None:
            change = np.nonzero(seg_feed[1:] != seg_feed[:-1])[0] + 1
            cuts.update(float(path.seg_s0[k]) for k in change)
        bounds = [0.0] + sorted(c for c in cuts if 0.0 < c < L) + [L]
        if seg_feed is not None:
            # feeds are constant inside a section (it is cut where they change); one
            # vectorised look-up of the segment at each section's middle
            mids = 0.5 * (np.array(bounds[:-1]) + np.array(bounds[1:]))
            mid_feed = seg_feed[path.segment_index(mids)].tolist()
        sections, rows = [], []
        t = 0.0
        for i, (s0, s1) in enumerate(zip(bounds[:-1], bounds[1:], strict=True)):
            length = s1 - s0
            if not length > 0:
                continue
            F = mid_feed[i] if seg_feed is not None else feed
            ta = ramp_time(F, a_max, j_max)
            if F * ta > length:
                F = fitting_feed(length, a_max, j_max)
                ta = length / F  # = Ta(F') up to rounding; makes the two ramps fill it exactly
            tc = max(0.0, length / F - ta)
            t_end = t + 2 * ta + tc
            sections.append(Section(s0, s1, F, t, t_end))
            rows.append((s0, s1, F, ta, tc, t, t_end))
            t = t_end
        return cls(total_length=L, sections=tuple(sections), _table=np.array(rows))

    @property
    def duration(self) -> float:
        """Time (s) from the start to the stop at the end of the path (and its dwell, if any)."""
        if self._plan is not None:
            return float(self._plan[-1, planner.TEND])
        return self.sections[-1].t_end

    def sample(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s m, ṡ m/s, s̈ m/s²), each (n,), at times t (s, any real; closed form).

        Before t = 0 the tool is at rest at s = 0, after `duration` at rest at the end.
        """
        if self._plan is not None:
            return planner.sample(self._plan, self.total_length, t)
        t = np.atleast_1d(np.asarray(t, dtype=np.float64)).reshape(-1)
        tab = self._table
        k = np.clip(np.searchsorted(tab[:, 5], t, side="right") - 1, 0, len(tab) - 1)
        s0, s1, F, Ta, Tc, t0 = (tab[k, i] for i in range(6))
        tau = np.maximum(t - t0, 0.0)
        w = math.pi / Ta
        # three phases, each in closed form; pick per sample
        up = tau < Ta
        dn = tau >= Ta + Tc
        # decelerating: measured back from the section end, r = time left ∈ [0, Ta]
        r = np.clip(Ta + Tc + Ta - tau, 0.0, Ta)
        tu = np.minimum(tau, Ta)
        s_up = s0 + 0.5 * F * (tu - np.sin(w * tu) / w)
        s_cr = s0 + 0.5 * F * Ta + F * (tau - Ta)
        s_dn = s1 - 0.5 * F * (r - np.sin(w * r) / w)
        s = np.where(up, s_up, np.where(dn, s_dn, s_cr))
        v = np.where(
            up, 0.5 * F * (1 - np.cos(w * tu)), np.where(dn, 0.5 * F * (1 - np.cos(w * r)), F)
        )
        a = np.where(
            up, 0.5 * F * w * np.sin(w * tu), np.where(dn, -0.5 * F * w * np.sin(w * r), 0.0)
        )
        # at rest exactly at a stop (t_end, compared as stored: t − t0 may round below 2Ta+Tc)
        ended = t >= tab[k, 6]
        s[ended], v[ended], a[ended] = s1[ended], 0.0, 0.0
        before = t < 0.0
        s[before], v[before], a[before] = 0.0, 0.0, 0.0
        return np.clip(s, 0.0, self.total_length), v, a
