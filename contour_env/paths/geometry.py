"""A path as a chain of segments: packed table for the kernels, evaluation by arc length, and the
task frame F = [t n b] with curvature and torsion (Lee 2012 eqs. 14–16)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .segments import Arc, Cubic, Line

CONTINUITY_TOL_M = 1e-9
PLANAR_TOL_M = 1e-9


def _sample_points(seg, n=9) -> np.ndarray:
    s = np.linspace(0.0, seg.length, n)
    return seg.derivatives(s)[0]


@dataclass(frozen=True, eq=False)
class PathGeometry:
    """A continuous chain of segments (metres), packed per docs/ARCHITECTURE.md.

    Frame convention (``frames``):

    - planar paths (``planar_normal`` set; +z for 2-D paths): b = planar normal, t = dp/ds,
      n = b × t (the left normal; Lee 2012 eq. 36 in 2-D: t = (cos θ, sin θ), n = (−sin θ, cos θ)),
      signed curvature κ = d²p/ds² · n (> 0 turning counter-clockwise about b), torsion 0. The
      frame is defined and continuous on straight segments and through inflections.
    - non-planar paths: the Frenet frame, κ = |d²p/ds²| ≥ 0, n = d²p/ds² / κ, b = t × n,
      τ = (p' × p'') · p''' / κ². Where κ < 1e-9 1/m (straight pieces), n is the part of a
      reference vector (the previous curved piece's binormal, else z, else x) orthogonal to t.

    With these, dFᵀ/ds = R Fᵀ, R = [[0, κ, 0], [−κ, 0, τ], [0, −τ, 0]] (Lee eqs. 14–15 divided
    by the feedrate v).
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

    @classmethod
    def from_segments(cls, segments: Sequence, dim: int | None = None) -> PathGeometry:
        segments = tuple(segments)
        if not segments:
            raise ValueError("segments: a path needs at least one segment (zero-length path)")
        for k, seg in enumerate(segments):
            if not isinstance(seg, (Line, Arc, Cubic)):
                raise ValueError(
                    f"segments[{k}]: expected Line, Arc or Cubic, got {type(seg).__name__}"
                )
        for k in range(1, len(segments)):
            gap = np.linalg.norm(segments[k].start_point - segments[k - 1].end_point)
            if gap > CONTINUITY_TOL_M:
                raise ValueError(
                    f"segments[{k}]: starts {gap:.3g} m away from the end of "
                    f"segment {k - 1} (a path must be continuous)"
                )
        packed = [s.pack() for s in segments]
        seg_type = np.array([p[0] for p in packed], dtype=np.int64)
        seg_data = np.ascontiguousarray(np.array([p[1] for p in packed]))
        seg_bounds = np.ascontiguousarray(np.array([p[2] for p in packed]))
        seg_length = np.array([s.length for s in segments])
        total = float(seg_length.sum())
        if not total > 0:
            raise ValueError("path: zero-length path")
        seg_s0 = np.concatenate([[0.0], np.cumsum(seg_length)[:-1]])
        closed = bool(
            np.linalg.norm(segments[-1].end_point - segments[0].start_point) <= CONTINUITY_TOL_M
        )
        pts = np.concatenate([_sample_points(s) for s in segments])
        all_z0 = bool(np.all(pts[:, 2] == 0.0)) and all(
            not isinstance(s, Arc) or (s.pitch == 0.0 and abs(abs(s.w[2]) - 1) < 1e-12)
            for s in segments
        )
        if dim is None:
            dim = 2 if all_z0 else 3
        if dim not in (2, 3):
            raise ValueError(f"dim: 2 or 3, got {dim}")
        if dim == 2 and not np.all(np.abs(pts[:, 2]) <= PLANAR_TOL_M):
            raise ValueError("dim: a 2-D path must lie in the plane z = 0")
        planar_normal = np.array([0.0, 0.0, 1.0]) if dim == 2 else cls._plane_normal(segments, pts)
        return cls(
            segments,
            seg_type,
            seg_data,
            seg_bounds,
            seg_length,
            seg_s0,
            closed,
            planar_normal,
            int(dim),
        )

    @staticmethod
    def _plane_normal(segments, pts) -> np.ndarray | None:
        centred = pts - pts.mean(axis=0)
        _, sv, vt = np.linalg.svd(centred, full_matrices=True)
        normal = vt[2]
        if np.max(np.abs(centred @ normal)) > PLANAR_TOL_M:
            return None
        if len(sv) > 1 and sv[1] <= PLANAR_TOL_M:
            # collinear points: any plane through the line holds them; prefer one with z
            direction = vt[0]
            ref = (
                np.array([0.0, 0.0, 1.0]) if abs(direction[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
            )
            normal = np.cross(direction, np.cross(ref, direction))
            normal /= np.linalg.norm(normal)
        arcs = [s for s in segments if isinstance(s, Arc)]
        if arcs and abs(abs(float(arcs[0].w @ normal)) - 1) < 1e-9:
            if float(arcs[0].w @ normal) < 0:
                normal = -normal
        elif normal[2] < 0 or (normal[2] == 0 and normal[0] < 0):
            normal = -normal
        return normal

    @property
    def total_length(self) -> float:
        return float(self.seg_length.sum())

    @property
    def n_segments(self) -> int:
        return len(self.segments)

    def _locate(self, s: np.ndarray):
        s = np.clip(np.asarray(s, dtype=np.float64).reshape(-1), 0.0, self.total_length)
        idx = np.clip(np.searchsorted(self.seg_s0, s, side="right") - 1, 0, self.n_segments - 1)
        return s, idx

    def evaluate(self, s) -> dict:
        """Position and arc-length derivatives d1 (unit tangent), d2, d3 at arc lengths s (m)."""
        s, idx = self._locate(s)
        n = s.shape[0]
        out = {key: np.empty((n, 3)) for key in ("position", "d1", "d2", "d3")}
        for k in np.unique(idx):
            sel = idx == k
            local = np.clip(s[sel] - self.seg_s0[k], 0.0, self.seg_length[k])
            pos, d1, d2, d3 = self.segments[k].derivatives(local)
            out["position"][sel] = pos
            out["d1"][sel] = d1
            out["d2"][sel] = d2
            out["d3"][sel] = d3
        return out

    def frames(self, s, derivs: dict | None = None):
        """Task frame (n, 3, 3) with columns [t n b], curvature (n,), torsion (n,) at s."""
        d = derivs if derivs is not None else self.evaluate(s)
        t = d["d1"] / np.linalg.norm(d["d1"], axis=1, keepdims=True)
        n_pts = t.shape[0]
        if self.planar_normal is not None:
            b = np.broadcast_to(self.planar_normal, (n_pts, 3)).copy()
            nrm = np.cross(b, t)
            kappa = np.sum(d["d2"] * nrm, axis=1)
            tau = np.zeros(n_pts)
        else:
            kappa = np.linalg.norm(d["d2"], axis=1)
            curved = kappa >= 1e-9
            nrm = np.empty_like(t)
            nrm[curved] = d["d2"][curved] / kappa[curved, None]
            b = np.cross(t, nrm)
            if np.any(~curved):
                ref = np.tile([0.0, 0.0, 1.0], (n_pts, 1))
                last_b = None
                for i in range(n_pts):  # straight pieces: carry the last curved binormal
                    if curved[i]:
                        last_b = b[i]
                    elif last_b is not None:
                        ref[i] = last_b
                par = np.abs(np.sum(ref * t, axis=1)) > 0.99
                ref[par] = [1.0, 0.0, 0.0]
                proj = ref - np.sum(ref * t, axis=1, keepdims=True) * t
                nn = proj / np.linalg.norm(proj, axis=1, keepdims=True)
                nrm[~curved] = nn[~curved]
                b = np.cross(t, nrm)
                kappa = np.where(curved, kappa, 0.0)
            cross = np.cross(d["d1"], d["d2"])
            tau = np.where(
                curved, np.sum(cross * d["d3"], axis=1) / np.where(curved, kappa, 1.0) ** 2, 0.0
            )
        frame = np.stack([t, nrm, b], axis=2)
        return np.ascontiguousarray(frame), kappa, tau

    def corner_arc_lengths(self, angle_tol_rad: float = 1e-3) -> np.ndarray:
        """Arc lengths of interior junctions where the tangent turns by more than the tolerance."""
        out = []
        for k in range(1, self.n_segments):
            a = self.segments[k - 1].derivatives(np.array([self.seg_length[k - 1]]))[1][0]
            b = self.segments[k].derivatives(np.array([0.0]))[1][0]
            cosang = float(np.clip(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)), -1, 1))
            if np.arccos(cosang) > angle_tol_rad:
                out.append(float(self.seg_s0[k]))
        return np.array(out)

    def sample_points(self, n: int = 2000) -> np.ndarray:
        """n points evenly spaced in arc length, (n, 3) (for plots)."""
        return self.evaluate(np.linspace(0.0, self.total_length, n))["position"]
