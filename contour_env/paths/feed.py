"""Feed profile s(t) along a path: jerk-bounded ("cosine") S-curve from rest to rest on each
section, with an exact stop (like G61) at every sharp corner and feed change."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .geometry import PathGeometry


def _positive(name: str, value, unit: str) -> float:
    if isinstance(value, bool):
        raise ValueError(f"{name}: must be a finite number > 0 {unit}, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be a finite number > 0 {unit}, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name}: must be a finite number > 0 {unit}, got {value!r}")
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

    The path is cut into sections at sharp corners (tangent jump > ``corner_tol_rad``) and,
    with per-segment feeds, where the feed changes. The tool stops exactly at each cut (like
    G61 exact-stop mode), so the reference velocity is continuous in direction everywhere.
    Each section runs a cosine S-curve from rest to rest: with peak feed F and ramp time
    Ta = max(π F / (2 a_max), π sqrt(F / (2 j_max))), ṡ = F (1 − cos(π t / Ta)) / 2 while
    accelerating (covering F Ta / 2), F while cruising, mirrored while decelerating; so
    |s̈| ≤ a_max and |s⃛| ≤ j_max. A section shorter than F Ta runs at the lower peak feed F'
    with F' Ta(F') = its length (no cruise).

    Fields: ``total_length`` (m), ``sections`` (tuple of `Section`: s_start, s_end, peak_feed,
    t_start, t_end), ``duration`` (s, property).
    """

    total_length: float
    sections: tuple
    # per-section rows for vectorised sampling: s_start, s_end, F, Ta, Tc, t_start, t_end
    _table: np.ndarray = field(repr=False)

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
        """Profile for ``path`` at ``feedrate_m_s`` > 0 m/s within ``max_accel_m_s2`` > 0 m/s²
        and ``max_jerk_m_s3`` > 0 m/s³, stopping at corners sharper than ``corner_tol_rad``
        (≥ 0 rad). ``segment_feeds``: optional feed per segment (m/s, each > 0), used instead of
        ``feedrate_m_s`` on that segment (e.g. G-code F words); sections also split where it
        changes."""
        feed = _positive("feedrate_m_s", feedrate_m_s, "m/s")
        a_max = _positive("max_accel_m_s2", max_accel_m_s2, "m/s²")
        j_max = _positive("max_jerk_m_s3", max_jerk_m_s3, "m/s³")
        tol = float(corner_tol_rad)
        if not (math.isfinite(tol) and tol >= 0):
            raise ValueError(
                f"corner_tol_rad: must be a finite angle ≥ 0 rad, got {corner_tol_rad!r}"
            )
        L = path.total_length
        cuts = {float(c) for c in path.corner_arc_lengths(tol)}
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
            change = np.nonzero(seg_feed[1:] != seg_feed[:-1])[0] + 1
            cuts.update(float(path.seg_s0[k]) for k in change)
        bounds = [0.0] + sorted(c for c in cuts if 0.0 < c < L) + [L]
        sections, rows = [], []
        t = 0.0
        for s0, s1 in zip(bounds[:-1], bounds[1:], strict=True):
            length = s1 - s0
            if not length > 0:
                continue
            if seg_feed is not None:
                # feeds are constant inside a section (it is cut where they change)
                k = int(path.segment_index(0.5 * (s0 + s1))[0])
                F = float(seg_feed[k])
            else:
                F = feed
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
        """Time (s) from the start to the stop at the end of the path."""
        return self.sections[-1].t_end

    def sample(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s m, ṡ m/s, s̈ m/s²), each (n,), at times t (s, any real; closed form).

        Before t = 0 the tool is at rest at s = 0, after `duration` at rest at the end.
        """
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
