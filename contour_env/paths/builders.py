"""Path constructors returning PathGeometry: line, polyline, circle and arc in any plane,
inclined circle, helix and smooth C² spline. Lengths in metres, angles in radians."""

from __future__ import annotations

import math

import numpy as np

from .checks import finite_number as _number
from .geometry import PathGeometry
from .segments import Arc, Cubic, Line, _vec3


def _points(name: str, points) -> np.ndarray:
    """(n, 2) or (n, 3) finite points as (n, 3) float64 (2-D padded with z = 0)."""
    try:
        pts = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected an (n, 2) or (n, 3) array of numbers") from None
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise ValueError(f"{name}: expected an (n, 2) or (n, 3) array of points, got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError(f"{name}: values must be finite")
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    return pts


def _positive(name: str, value, unit: str) -> float:
    v = _number(name, value)
    if not v > 0:
        raise ValueError(f"{name}: must be > 0 {unit}, got {value!r}")
    return v


def _no_duplicates(name: str, pts: np.ndarray) -> np.ndarray:
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if np.any(steps == 0):
        k = int(np.argmax(steps == 0))
        raise ValueError(f"{name}: consecutive duplicate points at index {k} and {k + 1}")
    return steps


def line(start, end) -> PathGeometry:
    """Straight line from ``start`` to ``end`` (2-D or 3-D points, m; end != start).

    2-D when both points have z == 0.
    """
    return PathGeometry.from_segments([Line(start, end)])


def polyline(points) -> PathGeometry:
    """Straight segments through ``points`` ((n, 2) or (n, 3) m, n ≥ 2, no consecutive
    duplicates) with sharp corners (the feed profile stops at each). 2-D when all z == 0."""
    pts = _points("points", points)
    if len(pts) < 2:
        raise ValueError(f"points: a polyline needs at least 2 points, got {len(pts)}")
    _no_duplicates("points", pts)
    return PathGeometry.from_segments([Line(pts[k], pts[k + 1]) for k in range(len(pts) - 1)])


def _plane_basis(normal, u=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orthonormal (u, v, w) with w ∥ normal and u the part of ``u`` (default: x, or y when
    the normal is near x) orthogonal to w; v = w × u, so u × v = w."""
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
    if np.linalg.norm(uu) <= 1e-12 * max(1.0, float(np.linalg.norm(ref))):
        raise ValueError("u: must not be zero or parallel to the normal")
    uu = uu / np.linalg.norm(uu)
    v = np.cross(w, uu)
    # normalise again: w and uu are unit to ~1 ulp, keep the Arc check far from its tolerance
    return uu, v / np.linalg.norm(v), w


def arc(
    center,
    radius,
    *,
    start_angle=0.0,
    sweep=math.pi / 2,
    normal=(0.0, 0.0, 1.0),
    u=None,
) -> PathGeometry:
    """Arc of a circle: ``radius`` > 0 m about ``center`` (2-D or 3-D, m) in the plane normal
    to ``normal``, from ``start_angle`` (rad, measured from ``u``; default u: the x axis
    projected on the plane) through the signed ``sweep`` (rad, ≠ 0; > 0 counter-clockwise about
    the normal). 2-D when the normal is ±z and the centre has z = 0."""
    r = _positive("radius", radius, "m")
    sw = _number("sweep", sweep)
    if sw == 0:
        raise ValueError("sweep: must be non-zero (rad)")
    th0 = _number("start_angle", start_angle)
    c = _vec3("center", center)
    uu, v, _ = _plane_basis(normal, u)
    return PathGeometry.from_segments([Arc(c, uu, v, r, th0, sw)])


def circle(
    center,
    radius,
    *,
    normal=(0.0, 0.0, 1.0),
    start_angle=0.0,
    sweep=2 * math.pi,
    ccw=True,
    u=None,
) -> PathGeometry:
    """Circle of ``radius`` > 0 m about ``center`` in the plane normal to ``normal`` (any plane
    in 3-D), starting at ``start_angle`` (rad from ``u``), running ``sweep`` > 0 rad (2π: a full
    circle; less: a partial one), counter-clockwise about the normal when ``ccw``. 2-D when the
    normal is ±z and the centre has z = 0."""
    sw = _positive("sweep", sweep, "rad")
    return arc(
        center, radius, start_angle=start_angle, sweep=sw if ccw else -sw, normal=normal, u=u
    )


def inclined_circle(center, radius, tilt_rad, *, tilt_axis="x", **kw) -> PathGeometry:
    """A circle of the xy-plane rotated by ``tilt_rad`` (rad, finite) about the x (or y) axis,
    centred at ``center`` (m): normal (0, −sin, cos) about x, (sin, 0, cos) about y. Angles are
    measured from the rotated x axis. Other keywords as `circle` (start_angle, sweep, ccw).
    A 3-D path unless the tilt is 0."""
    tilt = _number("tilt_rad", tilt_rad)
    c, s = math.cos(tilt), math.sin(tilt)
    if tilt_axis == "x":
        normal, u = (0.0, -s, c), (1.0, 0.0, 0.0)
    elif tilt_axis == "y":
        normal, u = (s, 0.0, c), (c, 0.0, -s)
    else:
        raise ValueError(f"tilt_axis: 'x' or 'y', got {tilt_axis!r}")
    for key in ("normal", "u"):
        if key in kw:
            raise ValueError(f"{key}: set by tilt_rad and tilt_axis, do not pass it")
    return circle(center, radius, normal=normal, u=u, **kw)


def helix(
    center,
    radius,
    pitch_per_rev,
    turns,
    *,
    axis=(0.0, 0.0, 1.0),
    start_angle=0.0,
    ccw=True,
) -> PathGeometry:
    """Helix of ``radius`` > 0 m about ``axis`` through ``center`` (m), rising
    ``pitch_per_rev`` (m, finite; along +axis when > 0, in either direction of turning) per
    revolution for ``turns`` > 0 revolutions, counter-clockwise about the axis when ``ccw``.
    Always a 3-D path. Curvature r/(r² + h²), torsion h/(r² + h²) with h = pitch_per_rev/2π
    (torsion sign follows the handedness)."""
    r = _positive("radius", radius, "m")
    n = _positive("turns", turns, "revolutions")
    pitch = _number("pitch_per_rev", pitch_per_rev)
    th0 = _number("start_angle", start_angle)
    uu, v, _ = _plane_basis(axis)
    sign = 1.0 if ccw else -1.0
    # Arc.pitch is the rise per radian of θ − θ0; with a negative sweep it must flip sign so
    # that the helix still rises along +axis
    seg = Arc(
        _vec3("center", center), uu, v, r, th0, sign * 2 * math.pi * n, sign * pitch / (2 * math.pi)
    )
    return PathGeometry.from_segments([seg], dim=3)


def spline(points, closed=False) -> PathGeometry:
    """Smooth C² cubic spline through ``points`` ((n, 2) or (n, 3) m, no consecutive
    duplicates; n ≥ 3 open, ≥ 3 distinct points closed) with chord-length parameterisation
    (scipy CubicSpline: not-a-knot ends, or periodic when ``closed``, which joins the last
    point back to the first). One Cubic per interval, rescaled to q ∈ [0, 1]. 2-D when all
    z == 0."""
    pts = _points("points", points)
    if closed and np.linalg.norm(pts[-1] - pts[0]) > 0:
        pts = np.vstack([pts, pts[:1]])
    need = 4 if closed else 3  # closed: 3 distinct points plus the repeated first
    if len(pts) < need:
        raise ValueError(
            f"points: a{' closed' if closed else 'n open'} spline needs at least 3 "
            f"{'distinct ' if closed else ''}points, got {len(pts) - (1 if closed else 0)}"
        )
    chords = _no_duplicates("points", pts)
    knots = np.concatenate([[0.0], np.cumsum(chords)])
    # scipy.interpolate where a spline is built, not with the module (half a second of
    # start-up for every command)
    from scipy.interpolate import CubicSpline

    cs = CubicSpline(knots, pts, bc_type="periodic" if closed else "not-a-knot", axis=0)
    segs = []
    start = pts[0]
    for i, h in enumerate(chords):
        # local variable x = h q: p = c0 + c1 x + c2 x² + c3 x³ = a + b q + c q² + d q³
        c3, c2, c1 = cs.c[0, i], cs.c[1, i], cs.c[2, i]
        b, c, d = c1 * h, c2 * h**2, c3 * h**3
        # start each piece exactly where the previous one ends (power-basis round-off)
        seg = Cubic(start, b, c, d)
        segs.append(seg)
        start = seg.end_point
    return PathGeometry.from_segments(segs)
