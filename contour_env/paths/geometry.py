"""A path as a continuous chain of segments: the packed table the kernels read, vectorised
evaluation by arc length, and the task frame F = [t n b] with curvature and torsion (Lee 2012)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .segments import (
    SEG_ARC,
    SEG_CUBIC,
    SEG_LINE,
    Arc,
    Cubic,
    CubicTable,
    Line,
    arc_derivatives,
)

CONTINUITY_TOL_M = 1e-9  # largest gap between consecutive segments, m
PLANAR_TOL_M = 1e-9  # largest distance of a segment point from the fitted plane, m
STRAIGHT_KAPPA = 1e-9  # below this curvature (1/m) the Frenet normal is undefined
_PARALLEL_COS = 0.99  # a reference vector this close to the tangent is not used for n

_Z = np.array([0.0, 0.0, 1.0])
_X = np.array([1.0, 0.0, 0.0])


def _plane_points(seg) -> np.ndarray:
    """Points whose affine span is the smallest flat holding the segment (m)."""
    if isinstance(seg, Line):
        return np.array([seg.start, seg.end])
    if isinstance(seg, Arc):
        # three non-collinear points of a plane arc fix its plane, which holds c, c + r u, c + r v
        return np.array(
            [seg.center, seg.center + seg.radius * seg.u, seg.center + seg.radius * seg.v]
        )
    # a cubic lies in the convex hull of its Bézier control points, and spans their flat
    a, b, c = seg.a, seg.b, seg.c
    return np.array([a, a + b / 3, a + 2 * b / 3 + c / 3, seg.end_point])


def _exactly_xy(seg) -> bool:
    """True if every point of the segment has z == 0 exactly."""
    if isinstance(seg, Line):
        return seg.start[2] == 0.0 and seg.end[2] == 0.0
    if isinstance(seg, Arc):
        return seg.center[2] == 0.0 and seg.u[2] == 0.0 and seg.v[2] == 0.0 and seg.pitch == 0.0
    return bool(np.all(seg.coef[:, 2] == 0.0))


def _plane_normal(segments) -> np.ndarray | None:
    """Unit normal of a plane holding every segment (within PLANAR_TOL_M), or None.

    Sign: +z when the plane is the xy-plane; else the first arc's w; else the one with a
    positive z (then y, then x) component, so that it is deterministic.
    """
    if any(isinstance(s, Arc) and s.pitch != 0.0 for s in segments):
        return None  # a helix is not planar
    pts = np.concatenate([_plane_points(s) for s in segments])
    arcs = [s for s in segments if isinstance(s, Arc)]
    if arcs:
        # a plane holding an arc is the arc's plane: every arc must share it
        normal = arcs[0].w / np.linalg.norm(arcs[0].w)
        origin = arcs[0].center
    else:
        origin = pts.mean(axis=0)
        # thin SVD: a full one would build an (m, m) U for m points
        _, sv, vt = np.linalg.svd(pts - origin, full_matrices=False)
        if len(sv) < 3 or sv[1] <= PLANAR_TOL_M:
            # collinear: every plane through the line holds it; take the one whose normal is
            # the part of z orthogonal to the line (the xy-plane for a line in it), or of x
            direction = vt[0]
            ref = _Z if abs(direction[2]) < _PARALLEL_COS else _X
            normal = ref - (ref @ direction) * direction
            normal = normal / np.linalg.norm(normal)
        else:
            normal = vt[2]
    if np.max(np.abs((pts - origin) @ normal)) > PLANAR_TOL_M:
        return None
    if abs(abs(normal[2]) - 1.0) <= 1e-12:
        return _Z.copy()  # the xy-plane (or parallel to it): +z
    if arcs:
        return normal
    for k in (2, 1, 0):
        if normal[k] != 0.0:
            return normal if normal[k] > 0 else -normal
    return normal


@dataclass(frozen=True, eq=False)
class PathGeometry:
    """A continuous chain of Line/Arc/Cubic segments (metres), packed per docs/ARCHITECTURE.md.

    Build it with `from_segments` (or a builder in `contour_env.paths.builders`). Fields:
    ``segments``; ``seg_type`` (n,) int64; ``seg_data`` (n, 16); ``seg_bounds`` (n, 4)
    bounding spheres; ``seg_length`` (n,) m; ``seg_s0`` (n,) arc length at each segment start,
    m; ``closed``; ``planar_normal`` (3,) or None; ``dim`` (2: the whole path lies in z = 0
    and is meant for a 2-axis machine; else 3); ``total_length`` m.

    Frame convention (`frames`; columns [t n b]):

    - planar path (``planar_normal`` set; +z for a 2-D path): b = planar normal, t = dp/ds,
      n = b × t (the left normal; in 2-D, as Lee 2012 eq. 36, t = (cos θ, sin θ),
      n = (−sin θ, cos θ)); SIGNED curvature κ = d²p/ds² · n (> 0 when turning towards n,
      i.e. counter-clockwise about b); torsion 0. Consistent on straight segments and through
      inflections.
    - non-planar path (e.g. a helix): Frenet frame, κ = |d²p/ds²| ≥ 0, n = d²p/ds² / κ,
      b = t × n, τ = (p' × p'') · p''' / κ². Where κ < 1e-9 1/m (straight pieces), n is the
      part orthogonal to t of a reference vector (the binormal at the end of the last curved
      segment before this one; else z; else x when t ∥ z), b = t × n, κ = τ = 0.

    In both, dFᵀ/ds = R Fᵀ with R = [[0, κ, 0], [−κ, 0, τ], [0, −τ, 0]], i.e. Lee 2012
    eq. 14, Ḟᵀ = v R Fᵀ, divided by the feedrate v = ṡ.
    """

    segments: tuple
    seg_type: np.ndarray
    seg_data: np.ndarray
    seg_bounds: np.ndarray
    seg_length: np.ndarray
    seg_s0: np.ndarray
    closed: bool
    planar_normal: np.ndarray | None
    dim: int
    total_length: float

    @classmethod
    def from_segments(cls, segments: Sequence, dim: int | None = None) -> PathGeometry:
        """Pack a continuous chain of segments.

        ``segments``: Line/Arc/Cubic, each starting within 1e-9 m of the previous one's end.
        ``dim``: 2 (the caller wants a 2-axis path: every point must have z == 0 exactly),
        3, or None (2 when every point has z == 0 exactly, else 3).
        """
        segments = tuple(segments)
        if not segments:
            raise ValueError("segments: no segments (zero-length path)")
        for k, seg in enumerate(segments):
            if not isinstance(seg, (Line, Arc, Cubic)):
                raise ValueError(
                    f"segments[{k}]: expected Line, Arc or Cubic, got {type(seg).__name__}"
                )
        if len(segments) > 1:
            # one vectorised check (the same norms as per pair), report the first gap
            starts = np.array([s.start_point for s in segments[1:]])
            ends_prev = np.array([s.end_point for s in segments[:-1]])
            gaps = np.linalg.norm(starts - ends_prev, axis=1)
            bad = np.nonzero(~(gaps <= CONTINUITY_TOL_M))[0]
            if bad.size:
                k = int(bad[0]) + 1
                gap = float(gaps[k - 1])
                raise ValueError(
                    f"segments[{k}]: starts {gap:.3g} m from the end of segments[{k - 1}] "
                    f"(a path must be continuous, gap ≤ {CONTINUITY_TOL_M:g} m)"
                )
        seg_length = np.array([s.length for s in segments], dtype=np.float64)
        ends = np.cumsum(seg_length)
        total = float(ends[-1])
        if not total > 0:
            raise ValueError("segments: zero-length path")
        seg_s0 = np.concatenate([[0.0], ends[:-1]])
        packed = [s.pack() for s in segments]
        seg_type = np.array([p[0] for p in packed], dtype=np.int64)
        seg_data = np.ascontiguousarray(np.array([p[1] for p in packed], dtype=np.float64))
        seg_bounds = np.ascontiguousarray(np.array([p[2] for p in packed], dtype=np.float64))
        closed = bool(
            np.linalg.norm(segments[-1].end_point - segments[0].start_point) <= CONTINUITY_TOL_M
        )
        xy = all(_exactly_xy(s) for s in segments)
        if dim is None:
            dim = 2 if xy else 3
        if dim not in (2, 3) or isinstance(dim, bool):
            raise ValueError(f"dim: must be 2, 3 or None, got {dim!r}")
        if dim == 2 and not xy:
            raise ValueError(
                "dim: a 2-D path must have every point in the plane z = 0 exactly "
                "(use dim=3 or None for this path)"
            )
        planar_normal = _Z.copy() if dim == 2 else _plane_normal(segments)
        return cls(
            segments=segments,
            seg_type=seg_type,
            seg_data=seg_data,
            seg_bounds=seg_bounds,
            seg_length=seg_length,
            seg_s0=seg_s0,
            closed=closed,
            planar_normal=planar_normal,
            dim=int(dim),
            total_length=total,
        )

    @property
    def n_segments(self) -> int:
        return len(self.segments)

    # ----------------------------------------------------------------- evaluation
    @cached_property
    def _cubics(self) -> tuple[np.ndarray, CubicTable | None]:
        """Row of each segment in the path's cubic table (−1 for non-cubics), and the table."""
        row = np.full(self.n_segments, -1, dtype=np.int64)
        cubic_idx = np.nonzero(self.seg_type == SEG_CUBIC)[0]
        if cubic_idx.size == 0:
            return row, None
        row[cubic_idx] = np.arange(cubic_idx.size)
        coef = self.seg_data[cubic_idx, :12].reshape(-1, 4, 3)
        panels = max(self.segments[k].n_panels for k in cubic_idx)
        return row, CubicTable(coef, panels)

    def segment_index(self, s) -> np.ndarray:
        """Index of the segment holding each arc length s (m; a junction belongs to the next)."""
        s = np.clip(np.asarray(s, dtype=np.float64).reshape(-1), 0.0, self.total_length)
        return np.clip(np.searchsorted(self.seg_s0, s, side="right") - 1, 0, self.n_segments - 1)

    @cached_property
    def _lines(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per segment (rows of non-lines unused): start p0, chord p1 − p0, length |chord| and
        unit tangent, exactly as `line_derivatives` computes them from a packed row."""
        p0 = np.ascontiguousarray(self.seg_data[:, 0:3])
        chord = self.seg_data[:, 3:6] - p0
        length = np.linalg.norm(chord, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            tangent = chord / length[:, None]
        return p0, chord, length, tangent

    def _eval_local(self, idx: np.ndarray, local: np.ndarray) -> dict:
        """Derivatives on segments idx at local arc lengths (clamped to [0, length])."""
        local = np.clip(local, 0.0, self.seg_length[idx])
        n = local.shape[0]
        out = {key: np.empty((n, 3)) for key in ("position", "d1", "d2", "d3")}
        types = self.seg_type[idx]
        for typ in (SEG_LINE, SEG_ARC, SEG_CUBIC):
            sel = types == typ
            if typ == SEG_LINE and sel.all():
                sel = slice(None)  # only lines: no index lists, no gathers of the outputs
            else:
                sel = np.nonzero(sel)[0]
                if sel.size == 0:
                    continue
            k = idx[sel]
            if typ == SEG_LINE:
                # line_derivatives' formulas on per-segment arrays (no (n, 16) row gather)
                p0, chord, length, tangent = self._lines
                out["position"][sel] = p0[k] + (local[sel] / length[k])[:, None] * chord[k]
                out["d1"][sel] = tangent[k]
                out["d2"][sel] = 0.0
                out["d3"][sel] = 0.0
                continue
            if typ == SEG_ARC:
                res = arc_derivatives(self.seg_data[k], local[sel])
            else:
                row, table = self._cubics
                res = table.derivatives(row[k], local[sel])
            for key, val in zip(("position", "d1", "d2", "d3"), res, strict=True):
                out[key][sel] = val
        return out

    def evaluate(self, s) -> dict:
        """Position and derivatives at arc lengths s (m, clamped to [0, total_length]).

        Returns a dict of (n, 3) arrays: ``position`` (m), ``d1`` = dp/ds (unit tangent),
        ``d2`` = d²p/ds² (1/m), ``d3`` = d³p/ds³ (1/m²). Closed form on lines and arcs/helices;
        on cubic pieces q(s) comes from Newton on the arc-length integral (1e-13 m), then the
        chain rule.
        """
        s = np.clip(np.asarray(s, dtype=np.float64).reshape(-1), 0.0, self.total_length)
        idx = self.segment_index(s)
        return self._eval_local(idx, s - self.seg_s0[idx])

    def sample_points(self, n: int = 2000) -> np.ndarray:
        """n ≥ 2 points evenly spaced in arc length, (n, 3) m (for plots)."""
        return self.evaluate(np.linspace(0.0, self.total_length, int(n)))["position"]

    # ----------------------------------------------------------------- corners
    def _junction_tangents(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit tangents at the end of each segment and at the start of each segment."""
        k = np.arange(self.n_segments)
        t_end = self._eval_local(k, self.seg_length.copy())["d1"]
        t_start = self._eval_local(k, np.zeros(self.n_segments))["d1"]
        return t_end, t_start

    def corner_arc_lengths(
        self, angle_tol_rad: float = 1e-3, *, include_closure: bool = False
    ) -> np.ndarray:
        """Arc lengths (m) of interior junctions where the tangent direction jumps by more than
        ``angle_tol_rad`` (≥ 0 rad): the sharp corners, where the feed must stop.

        ``include_closure``: for a closed path, also report s = 0 when the end-to-start junction
        is sharp (information only; a path starts and ends at rest anyway).
        """
        tol = float(angle_tol_rad)
        if not (math.isfinite(tol) and tol >= 0):
            raise ValueError(
                f"angle_tol_rad: must be a finite angle ≥ 0 rad, got {angle_tol_rad!r}"
            )
        t_end, t_start = self._junction_tangents()
        a, b = t_end[:-1], t_start[1:]
        # atan2(|a × b|, a · b) stays accurate for tiny angles, where arccos does not
        ang = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))
        out = self.seg_s0[1:][ang > tol]
        if include_closure and self.closed:
            a, b = t_end[-1], t_start[0]
            if math.atan2(float(np.linalg.norm(np.cross(a, b))), float(a @ b)) > tol:
                out = np.concatenate([[0.0], out])
        return np.asarray(out, dtype=np.float64)

    # ------------------------------------------------------------------ frames
    @cached_property
    def _straight_ref(self) -> np.ndarray:
        """Per segment: the binormal at the end of the last segment before it whose end is
        curved (κ ≥ 1e-9 1/m), else z. Used for n on straight parts of non-planar paths."""
        ref = np.tile(_Z, (self.n_segments, 1))
        k = np.arange(self.n_segments)
        d = self._eval_local(k, self.seg_length.copy())
        kappa = np.linalg.norm(d["d2"], axis=1)
        last = None
        for i in range(self.n_segments):
            if last is not None:
                ref[i] = last
            if kappa[i] >= STRAIGHT_KAPPA:
                b = np.cross(d["d1"][i], d["d2"][i] / kappa[i])
                last = b / np.linalg.norm(b)
        return ref

    def frames(self, s, derivs: dict | None = None):
        """Task frame at arc lengths s (m): (frame (n, 3, 3) with columns [t n b],
        curvature (n,) 1/m, torsion (n,) 1/m), per the class docstring's convention.

        ``derivs``: the result of ``evaluate(s)`` for the same s, to avoid recomputing it.
        """
        s = np.clip(np.asarray(s, dtype=np.float64).reshape(-1), 0.0, self.total_length)
        d = derivs if derivs is not None else self.evaluate(s)
        d1, d2, d3 = d["d1"], d["d2"], d["d3"]
        n_pts = d1.shape[0]
        if self.planar_normal is not None:
            b = np.broadcast_to(self.planar_normal, (n_pts, 3))
            # drop the (≤ 1e-9-level) out-of-plane part so that the frame is orthonormal
            t = d1 - np.sum(d1 * b, axis=1, keepdims=True) * b
            t /= np.linalg.norm(t, axis=1, keepdims=True)
            nrm = np.cross(b, t)
            kappa = np.sum(d2 * nrm, axis=1)
            tau = np.zeros(n_pts)
            frame = np.stack([t, nrm, b], axis=2)
            return np.ascontiguousarray(frame), kappa, tau
        t = d1 / np.linalg.norm(d1, axis=1, keepdims=True)
        kappa = np.linalg.norm(d2, axis=1)
        curved = kappa >= STRAIGHT_KAPPA
        safe_k = np.where(curved, kappa, 1.0)
        nrm = d2 / safe_k[:, None]
        if not np.all(curved):
            flat = np.nonzero(~curved)[0]
            tf = t[flat]
            ref = self._straight_ref[self.segment_index(s[flat])]
            for fallback in (_Z, _X):
                par = np.abs(np.sum(ref * tf, axis=1)) > _PARALLEL_COS
                ref[par] = fallback
            proj = ref - np.sum(ref * tf, axis=1, keepdims=True) * tf
            nrm[flat] = proj / np.linalg.norm(proj, axis=1, keepdims=True)
        b = np.cross(t, nrm)
        tau = np.where(curved, np.sum(np.cross(d1, d2) * d3, axis=1) / safe_k**2, 0.0)
        kappa = np.where(curved, kappa, 0.0)
        frame = np.stack([t, nrm, b], axis=2)
        return np.ascontiguousarray(frame), kappa, tau


def path_polyline(path, n: int = 4000) -> np.ndarray:
    """Points of the path for drawing, (m, 3) m: ``n`` evenly spaced in arc length plus every
    segment junction (so that sharp corners are drawn sharp)."""
    s = np.union1d(np.linspace(0.0, path.total_length, int(n)), path.seg_s0)
    return path.evaluate(np.append(s, path.total_length))["position"]
