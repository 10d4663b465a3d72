"""Path constructors: line, polyline (sharp corners), circle and arc in any plane, inclined
circle, helix and smooth spline. All lengths in metres, angles in radians."""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline

from .geometry import PathGeometry
from .segments import Arc, Cubic, Line, _vec3


def _points(name: str, points) -> np.ndarray:
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise ValueError(
            f"{name}: expected an (n, 2) or (n, 3) array of points, got shape {pts.shape}"
        )
    if not np.all(np.isfinite(pts)):
        raise ValueError(f"{name}: values must be finite")
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    return pts


def _positive(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number > 0, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name}: must be a finite number > 0, got {value!r}")
    return v


def line(start, end) -> PathGeometry:
    """Straight line from ``start`` to ``end`` (m)."""
    return PathGeometry.from_segments([Line(start, end)])


def polyline(points) -> PathGeometry:
    """Straight segments through ``points`` (n ≥ 2, (n, 2) or (n, 3) m) with sharp corners."""
    pts = _points("points", points)
    if len(pts) < 2:
        raise ValueError(f"points: a polyline needs at least 2 points, got {len(pts)}")
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if np.any(steps == 0):
        k = int(np.argmax(steps == 0))
        raise ValueError(f"points: consecutive duplicate points at index {k} and {k + 1}")
    dim = 2 if np.asarray(points).shape[1] == 2 or np.all(pts[:, 2] == 0) else 3
    return PathGeometry.from_segments(
        [Line(pts[k], pts[k + 1]) for k in range(len(pts) - 1)], dim=dim
    )


def _plane_basis(normal, u=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    w = _vec3("normal", normal)
    nw = np.linalg.norm(w)
    if nw == 0:
        raise ValueError("normal: must be a non-zero vector")
    w = w / nw
    if u is None:
        ref = np.array([1.0, 0.0, 0.0]) if abs(w[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    else:
        ref = _vec3("u", u)
    uu = ref - (ref @ w) * w
    if np.linalg.norm(uu) < 1e-12:
        raise ValueError("u: must not be parallel to the normal")
    uu /= np.linalg.norm(uu)
    v = np.cross(w, uu)
    return uu, v, w


def arc(
    center, radius, *, start_angle=0.0, sweep=math.pi / 2, normal=(0.0, 0.0, 1.0), u=None
) -> PathGeometry:
    """Arc of a circle of ``radius`` (m) about ``center`` in the plane normal to ``normal``,
    from ``start_angle`` through the signed ``sweep`` (rad; > 0 counter-clockwise about the
    normal). Angles are measured from ``u`` (default: the x axis projected on the plane)."""
    r = _positive("radius", radius)
    sw = float(sweep)
    if not math.isfinite(sw) or sw == 0:
        raise ValueError(f"sweep: must be finite and non-zero (rad), got {sweep!r}")
    c = _vec3("center", center)
    uu, v, _ = _plane_basis(normal, u)
    seg = Arc(c, uu, v, r, float(start_angle), sw)
    return PathGeometry.from_segments([seg])


def circle(
    center, radius, *, normal=(0.0, 0.0, 1.0), start_angle=0.0, sweep=2 * math.pi, ccw=True, u=None
) -> PathGeometry:
    """Circle (or partial circle with ``sweep`` < 2π) of ``radius`` > 0 m about ``center`` in
    any plane (normal vector ``normal``); ``ccw`` runs it counter-clockwise about the normal.
    A circle in the xy-plane (normal ±z, centre z = 0) is a 2-D path."""
    sw = abs(float(sweep)) if ccw else -abs(float(sweep))
    return arc(center, radius, start_angle=start_angle, sweep=sw, normal=normal, u=u)


def inclined_circle(center, radius, tilt_rad, *, tilt_axis="x", **kw) -> PathGeometry:
    """Circle in the xy-plane rotated by ``tilt_rad`` about the x (or y) axis (3-D)."""
    c, s = math.cos(tilt_rad), math.sin(tilt_rad)
    if tilt_axis == "x":
        normal, u = (0.0, -s, c), (1.0, 0.0, 0.0)
    elif tilt_axis == "y":
        normal, u = (s, 0.0, c), (c, 0.0, -s)
    else:
        raise ValueError(f"tilt_axis: 'x' or 'y', got {tilt_axis!r}")
    return circle(center, radius, normal=normal, u=u, **kw)


def helix(
    center, radius, pitch_per_rev, turns, *, axis=(0.0, 0.0, 1.0), start_angle=0.0, ccw=True
) -> PathGeometry:
    """Helix of ``radius`` (m) about ``axis`` through ``center``, rising ``pitch_per_rev`` (m)
    per revolution, for ``turns`` revolutions (> 0)."""
    r = _positive("radius", radius)
    n = _positive("turns", turns)
    pitch = float(pitch_per_rev)
    if not math.isfinite(pitch):
        raise ValueError(f"pitch_per_rev: must be finite, got {pitch_per_rev!r}")
    uu, v, _ = _plane_basis(axis)
    sweep = 2 * math.pi * n * (1 if ccw else -1)
    seg = Arc(
        _vec3("center", center),
        uu,
        v,
        r,
        float(start_angle),
        sweep,
        pitch / (2 * math.pi) * (1 if ccw else -1),
    )
    return PathGeometry.from_segments([seg], dim=3)


def spline(points, *, closed=False) -> PathGeometry:
    """Smooth C² cubic spline through ``points`` ((n, 2) or (n, 3) m, n ≥ 3 open, ≥ 3 distinct
    closed) with chord-length parameterisation (scipy CubicSpline, not-a-knot ends, or
    periodic when ``closed``)."""
    pts = _points("points", points)
    if closed and np.linalg.norm(pts[-1] - pts[0]) > 0:
        pts = np.vstack([pts, pts[:1]])
    if len(pts) < 3:
        raise ValueError(f"points: a spline needs at least 3 points, got {len(pts)}")
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if np.any(chords == 0):
        k = int(np.argmax(chords == 0))
        raise ValueError(f"points: consecutive duplicate points at index {k} and {k + 1}")
    knots = np.concatenate([[0.0], np.cumsum(chords)])
    bc = "periodic" if closed else "not-a-knot"
    cs = CubicSpline(knots, pts, bc_type=bc, axis=0)
    segs = []
    for i, h in enumerate(chords):
        c3, c2, c1, c0 = cs.c[0, i], cs.c[1, i], cs.c[2, i], cs.c[3, i]
        segs.append(Cubic(c0, c1 * h, c2 * h**2, c3 * h**3))
    # pin exact continuity at the knots (round-off in the power basis)
    fixed = [segs[0]]
    for k in range(1, len(segs)):
        s = segs[k]
        fixed.append(Cubic(fixed[-1].end_point, s.b, s.c, s.d))
    dim = 2 if np.asarray(points).shape[1] == 2 or np.all(pts[:, 2] == 0) else 3
    return PathGeometry.from_segments(fixed, dim=dim)
