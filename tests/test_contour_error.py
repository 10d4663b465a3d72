"""Tests of the true contour error (distance to the whole path) and the task-frame error."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from contour_env.contour_error import (
    arc_distance,
    cubic_distance,
    frame_error,
    line_distance,
    path_distance,
    path_distance_with_index,
    segment_distance,
    task_frame_error,
    true_contour_error,
)

# ---------------------------------------------------------------------------------------
# packing helpers (ARCHITECTURE.md layouts), written independently of contour_env.paths
# ---------------------------------------------------------------------------------------


def pack_line(p0, p1):
    p0 = np.asarray(p0, float)
    p1 = np.asarray(p1, float)
    data = np.zeros(16)
    data[0:3] = p0
    data[3:6] = p1
    centre = 0.5 * (p0 + p1)
    bounds = np.r_[centre, 0.5 * np.linalg.norm(p1 - p0)]
    return 0, data, bounds


def pack_arc(centre, u, v, radius, theta0, sweep, pitch=0.0):
    c = np.asarray(centre, float)
    u = np.asarray(u, float)
    v = np.asarray(v, float)
    w = np.cross(u, v)
    data = np.r_[c, u, v, w, radius, theta0, sweep, pitch]
    # every point: |p − (c + pitch·sweep/2·w)|² = r² + pitch²(τ − sweep/2)² ≤ r² + (pitch·sweep/2)²
    half_rise = pitch * sweep / 2.0
    bounds = np.r_[c + half_rise * w, math.hypot(radius, half_rise)]
    return 1, data, bounds


def pack_cubic(a, b, c, d):
    coef = [np.asarray(x, float) for x in (a, b, c, d)]
    data = np.zeros(16)
    data[0:12] = np.concatenate(coef)
    a, b, c, d = coef
    # Bézier control points enclose the curve (convex hull property)
    ctrl = np.array([a, a + b / 3, a + 2 * b / 3 + c / 3, a + b + c + d])
    centre = ctrl.mean(axis=0)
    bounds = np.r_[centre, np.max(np.linalg.norm(ctrl - centre, axis=1))]
    return 2, data, bounds


def pack_path(*segments):
    seg_type = np.array([s[0] for s in segments], dtype=np.int64)
    seg_data = np.array([s[1] for s in segments])
    seg_bounds = np.array([s[2] for s in segments])
    return seg_type, seg_data, seg_bounds


def rot(ax, ay, az):
    """Rotation matrix Rz Ry Rx."""
    cx, sx, cy, sy, cz, sz = (f(t) for t in (ax, ay, az) for f in (math.cos, math.sin))
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


EX, EY, EZ = np.eye(3)


# ---------------------------------------------------------------------------------------
# lines
# ---------------------------------------------------------------------------------------


def test_line_interior_and_past_both_ends():
    _, data, _ = pack_line([1.0, 1.0, 0.0], [4.0, 5.0, 0.0])  # length 5, direction (0.6, 0.8)
    # interior: offset 2 along the left normal (−0.8, 0.6) from the point at s = 2.5
    p = np.array([1.0, 1.0, 0.0]) + 2.5 * np.array([0.6, 0.8, 0]) + 2.0 * np.array([-0.8, 0.6, 0])
    assert line_distance(data, *p) == pytest.approx(2.0, abs=1e-14)
    # also out of plane
    assert line_distance(data, p[0], p[1], 1.5) == pytest.approx(2.5, abs=1e-14)
    # before p0 along the line and off it: distance to p0
    p = np.array([1.0, 1.0, 0.0]) - 3.0 * np.array([0.6, 0.8, 0]) + np.array([-0.8, 0.6, 0])
    assert line_distance(data, *p) == pytest.approx(math.hypot(3.0, 1.0), abs=1e-14)
    # past p1
    assert line_distance(data, 4.0, 9.0, 0.0) == pytest.approx(4.0, abs=1e-14)
    # zero-length segment
    _, data0, _ = pack_line([1.0, 2.0, 3.0], [1.0, 2.0, 3.0])
    assert line_distance(data0, 1.0, 2.0, 5.0) == pytest.approx(2.0, abs=1e-14)


# ---------------------------------------------------------------------------------------
# arcs
# ---------------------------------------------------------------------------------------


def test_circle_inside_outside_2d():
    st, sd, sb = pack_path(pack_arc([0.3, -0.2, 0.0], EX, EY, 0.5, 0.0, 2 * math.pi))
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1.5, 1.5, size=(500, 2))
    expected = np.abs(np.linalg.norm(pts - [0.3, -0.2], axis=1) - 0.5)
    np.testing.assert_allclose(true_contour_error(st, sd, sb, pts), expected, atol=1e-14)
    # clockwise full circle gives the same
    st2, sd2, sb2 = pack_path(pack_arc([0.3, -0.2, 0.0], EX, EY, 0.5, 1.0, -2 * math.pi))
    np.testing.assert_allclose(true_contour_error(st2, sd2, sb2, pts), expected, atol=1e-14)


def test_inclined_circle_3d_with_out_of_plane_offset_and_axis():
    R = rot(0.4, -0.7, 1.1)
    u, v, w = R[:, 0], R[:, 1], R[:, 2]
    c = np.array([1.0, 2.0, 3.0])
    r = 0.25
    _, data, _ = pack_arc(c, u, v, r, 0.3, 2 * math.pi)
    for rho, phi, h in [(0.1, 0.2, 0.05), (0.4, 2.5, -0.3), (0.25, -1.0, 0.0), (1.0, 3.0, 0.7)]:
        p = c + rho * (math.cos(phi) * u + math.sin(phi) * v) + h * w
        assert arc_distance(data, *p) == pytest.approx(math.hypot(rho - r, h), abs=1e-14)
    # on the axis: every circle point is at sqrt(r² + h²)
    for h in (0.0, 0.2, -1.3):
        p = c + h * w
        assert arc_distance(data, *p) == pytest.approx(math.hypot(r, h), abs=1e-14)


def test_partial_arc_end_points_and_wrapping():
    # CCW quarter arc, angles 0 .. 90°, unit radius about the origin
    _, data, _ = pack_arc([0, 0, 0], EX, EY, 1.0, 0.0, math.pi / 2)
    assert arc_distance(data, 1.0, -0.5, 0.0) == pytest.approx(0.5, abs=1e-15)  # end (1, 0)
    assert arc_distance(data, -1.0, 0.1, 0.0) == pytest.approx(math.hypot(1.0, 0.9), abs=1e-15)
    assert arc_distance(data, 1.0, 1.0, 0.0) == pytest.approx(math.sqrt(2) - 1, abs=1e-15)
    assert arc_distance(data, -2.0, -2.0, 1.0) == pytest.approx(math.sqrt(4 + 9 + 1), abs=1e-14)
    # clockwise quarter arc, angles 0 .. −90°
    _, data, _ = pack_arc([0, 0, 0], EX, EY, 1.0, 0.0, -math.pi / 2)
    assert arc_distance(data, 0.0, -2.0, 0.0) == pytest.approx(1.0, abs=1e-15)
    assert arc_distance(data, 0.0, 2.0, 0.0) == pytest.approx(math.sqrt(5.0), abs=1e-15)
    # range crossing ±π (135° .. 225°), θ0 given with extra turns
    for th0 in (0.75 * math.pi, 0.75 * math.pi + 4 * math.pi, 0.75 * math.pi - 6 * math.pi):
        _, data, _ = pack_arc([0, 0, 0], EX, EY, 1.0, th0, 0.5 * math.pi)
        assert arc_distance(data, -2.0, 0.0, 0.0) == pytest.approx(1.0, abs=1e-14)
        assert arc_distance(data, 2.0, 0.0, 0.0) == pytest.approx(
            math.hypot(2 + math.sqrt(0.5), math.sqrt(0.5)), abs=1e-14
        )
    # on the axis of a partial arc: still equidistant
    assert arc_distance(data, 0.0, 0.0, 0.5) == pytest.approx(math.hypot(1.0, 0.5), abs=1e-15)


def test_partial_arc_matches_dense_sampling():
    rng = np.random.default_rng(2)
    for _ in range(20):
        R = rot(*rng.uniform(-3, 3, 3))
        th0 = rng.uniform(-10, 10)
        sweep = rng.uniform(-6, 6)
        r = rng.uniform(0.1, 2.0)
        c = rng.normal(size=3)
        _, data, _ = pack_arc(c, R[:, 0], R[:, 1], r, th0, sweep)
        th = th0 + np.linspace(0, sweep, 200001)
        curve = c + r * (np.cos(th)[:, None] * R[:, 0] + np.sin(th)[:, None] * R[:, 1])
        for p in c + rng.normal(scale=r, size=(10, 3)):
            ref = np.min(np.linalg.norm(curve - p, axis=1))
            got = arc_distance(data, *p)
            assert got <= ref + 1e-12
            assert ref - got < 1e-6 * r  # sampling resolution bound


# ---------------------------------------------------------------------------------------
# sharp corner
# ---------------------------------------------------------------------------------------


@pytest.fixture
def corner():
    return pack_path(pack_line([0, 0, 0], [1, 0, 0]), pack_line([1, 0, 0], [1, 1, 0]))


@pytest.mark.parametrize(
    ("point", "expected", "segment"),
    [
        # x < 1 suggests segment 0, but segment 1 is nearer
        ((0.95, 0.2), 0.05, 1),
        ((0.9, 0.5), 0.1, 1),
        # y small and x < 1: segment 0
        ((0.9, 0.05), 0.05, 0),
        # just outside the corner, beside segment 1 but below its start: nearest is segment 0
        ((0.7, -0.01), 0.01, 0),
        # outside the corner, beyond both: the vertex (1, 0)
        ((1.2, -0.1), math.hypot(0.2, 0.1), None),
        ((1.3, -0.4), 0.5, None),
        # on the inner bisector y = 1 − x: equidistant
        ((0.8, 0.2), 0.2, None),
        ((0.6, 0.4), 0.4, None),
        ((0.97, 0.03), 0.03, None),
        # past the open ends of the path
        ((-0.3, 0.4), 0.5, 0),
        ((-0.5, 0.0), 0.5, 0),
        ((1.3, 1.4), 0.5, 1),
        ((1.0, 1.25), 0.25, 1),
        # on the path
        ((1.0, 0.0), 0.0, None),
        ((0.4, 0.0), 0.0, 0),
    ],
)
def test_sharp_corner(corner, point, expected, segment):
    st, sd, sb = corner
    got = true_contour_error(st, sd, sb, np.array(point))
    assert isinstance(got, float)
    assert got == pytest.approx(expected, abs=1e-14)
    for start in (0, 1):
        d, k = path_distance_with_index(st, sd, sb, point[0], point[1], 0.0, start)
        assert d == pytest.approx(expected, abs=1e-14)
        if segment is not None:
            assert k == segment


def test_corner_brute_force(corner):
    st, sd, sb = corner
    rng = np.random.default_rng(3)
    pts = rng.uniform(-0.5, 1.5, size=(2000, 2))
    a = np.clip(pts[:, 0], 0, 1)
    d0 = np.hypot(pts[:, 0] - a, pts[:, 1])
    b = np.clip(pts[:, 1], 0, 1)
    d1 = np.hypot(pts[:, 0] - 1, pts[:, 1] - b)
    np.testing.assert_allclose(true_contour_error(st, sd, sb, pts), np.minimum(d0, d1), atol=1e-14)


# ---------------------------------------------------------------------------------------
# helix and cubic against brute force + scipy
# ---------------------------------------------------------------------------------------


def _reference_min(curve_fn, lo, hi, p, n_dense=20001):
    """min over [lo, hi] of |curve(t) − p|: dense sampling, then bounded Brent around every
    sampled local minimum."""
    t = np.linspace(lo, hi, n_dense)
    d2 = np.sum((curve_fn(t) - p) ** 2, axis=1)
    best = d2.min()
    idx = [0, n_dense - 1]
    inner = np.nonzero((d2[1:-1] <= d2[:-2]) & (d2[1:-1] <= d2[2:]))[0] + 1
    idx.extend(inner.tolist())
    dt = t[1] - t[0]

    for i in idx:
        # search the offset from the sample (Brent's tolerance is relative to |x|, so
        # centring it on 0 gives an absolute tolerance ~ xatol)
        t0 = t[i]
        a = max(lo, t0 - dt) - t0
        b = min(hi, t0 + dt) - t0

        def f(s, t0=t0):
            return float(np.sum((curve_fn(np.array([t0 + s]))[0] - p) ** 2))

        res = minimize_scalar(f, bounds=(a, b), method="bounded", options={"xatol": 1e-14})
        best = min(best, res.fun)
    return math.sqrt(best)


def _helix_fn(c, u, v, w, r, th0, sweep, pitch):
    def fn(tau):
        th = th0 + tau
        return (
            c + r * (np.cos(th)[:, None] * u + np.sin(th)[:, None] * v) + pitch * tau[:, None] * w
        )

    return fn


HELICES = [
    # (radius, theta0, sweep, pitch)
    (0.05, 0.3, 4 * math.pi, 0.004),  # two turns, moderate pitch
    (0.02, -1.0, -6 * math.pi, 0.001),  # three CW turns, fine pitch
    (0.05, 2.0, 3.0, 0.1),  # steep (pitch² > r·ρ for most points: convex)
    (0.1, 0.0, 20 * math.pi, 0.0005),  # ten tightly packed turns
]


@pytest.mark.parametrize("hel", HELICES)
def test_helix_vs_reference(hel):
    r, th0, sweep, pitch = hel
    rng = np.random.default_rng(4)
    R = rot(*rng.uniform(-3, 3, 3))
    u, v, w = R[:, 0], R[:, 1], R[:, 2]
    c = rng.normal(scale=0.1, size=3)
    typ, data, bounds = pack_arc(c, u, v, r, th0, sweep, pitch)
    fn = _helix_fn(c, u, v, w, r, th0, sweep, pitch)
    n_pts = 50
    taus = rng.uniform(min(0, sweep), max(0, sweep), n_pts)
    pts = fn(taus) + rng.normal(scale=0.5 * r, size=(n_pts, 3))
    pts[:5] = c + np.outer(rng.uniform(-0.2, 1.2, 5) * pitch * sweep, w)  # on the axis
    pts[5:8] = fn(taus[5:8])  # on the curve
    for p in pts:
        ref = _reference_min(fn, min(0, sweep), max(0, sweep), p)
        got = arc_distance(data, *p)
        assert abs(got - ref) < 1e-9, (p, got, ref)
        # bounding sphere contains the curve
        assert np.all(
            np.linalg.norm(fn(np.linspace(0, sweep, 1000)) - bounds[:3], axis=1)
            <= bounds[3] + 1e-12
        )
        assert segment_distance(typ, data, *p) == got


def _cubic_fn(a, b, c, d):
    def fn(q):
        q = q[:, None]
        return a + b * q + c * q**2 + d * q**3

    return fn


def test_cubic_vs_reference():
    rng = np.random.default_rng(5)
    checked = 0
    for k in range(8):
        if k == 0:
            # a planar cubic with a loop (self-intersecting): several local minima
            a = np.zeros(3)
            b = np.array([3.0, 1.0, 0.0])
            c = np.array([-9.0, -3.0, 0.0])
            d = np.array([7.0, 2.5, 0.0])
        elif k == 1:
            # degenerate: a straight line written as a cubic
            a, b, c, d = np.zeros(3), np.array([1.0, 2.0, 0.5]), np.zeros(3), np.zeros(3)
        elif k == 2:  # degenerate: a parabola
            a, b, c, d = np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.zeros(3)
        else:
            a, b, c, d = rng.normal(size=(4, 3)) * np.array([0.1, 1.0, 2.0, 2.0])[:, None]
        _, data, bounds = pack_cubic(a, b, c, d)
        fn = _cubic_fn(a, b, c, d)
        qs = rng.uniform(0, 1, 25)
        scale = np.ptp(fn(np.linspace(0, 1, 100)), axis=0).max()
        pts = fn(qs) + rng.normal(scale=0.3 * scale, size=(25, 3))
        pts[:3] = fn(qs[:3])  # on the curve
        for p in pts:
            ref = _reference_min(fn, 0.0, 1.0, p)
            got = cubic_distance(data, *p)
            assert abs(got - ref) < 1e-9, (k, p, got, ref)
            checked += 1
        assert np.all(
            np.linalg.norm(fn(np.linspace(0, 1, 1000)) - bounds[:3], axis=1) <= bounds[3] + 1e-12
        )
    assert checked == 200


def test_cubic_several_local_minima():
    # the parabola y = x², x = q − 1/2 ∈ [−1/2, 1/2], seen from (0, y0) with y0 > 1/2: a local
    # maximum at x = 0 and two symmetric minima at x = ±sqrt(y0 − 1/2)
    a = np.array([-0.5, 0.25, 0.0])
    b = np.array([1.0, -1.0, 0.0])
    c = np.array([0.0, 1.0, 0.0])
    _, data, _ = pack_cubic(a, b, c, np.zeros(3))
    y0 = 0.6
    xm = math.sqrt(y0 - 0.5)
    expected = math.hypot(xm, xm * xm - y0)
    assert cubic_distance(data, 0.0, y0, 0.0) == pytest.approx(expected, abs=1e-14)
    # nudged sideways, the global minimum is on the nearer branch
    got = cubic_distance(data, 0.01, y0, 0.0)
    fn = _cubic_fn(a, b, c, np.zeros(3))
    assert abs(got - _reference_min(fn, 0.0, 1.0, np.array([0.01, y0, 0.0]))) < 1e-12


# ---------------------------------------------------------------------------------------
# whole path, pruning, API
# ---------------------------------------------------------------------------------------


def _plain_min(st, sd, p):
    return min(segment_distance(st[i], sd[i], *p) for i in range(st.shape[0]))


def test_pruning_matches_plain_min_polyline():
    rng = np.random.default_rng(6)
    verts = np.cumsum(rng.normal(size=(51, 3)) * [1.0, 1.0, 0.3], axis=0)
    st, sd, sb = pack_path(*(pack_line(verts[i], verts[i + 1]) for i in range(50)))
    lo, hi = verts.min(axis=0) - 1, verts.max(axis=0) + 1
    pts = rng.uniform(lo, hi, size=(300, 3))
    got = true_contour_error(st, sd, sb, pts)
    for i, p in enumerate(pts):
        ref = _plain_min(st, sd, p)
        assert got[i] == ref
        for start in (0, 17, 49):
            assert path_distance_with_index(st, sd, sb, *p, start)[0] == ref
        assert path_distance(st, sd, sb, *p) == ref


def test_pruning_matches_plain_min_mixed_path():
    rng = np.random.default_rng(7)
    segs = []
    for _ in range(30):
        kind = rng.integers(3)
        if kind == 0:
            segs.append(pack_line(rng.normal(size=3), rng.normal(size=3)))
        elif kind == 1:
            R = rot(*rng.uniform(-3, 3, 3))
            segs.append(
                pack_arc(
                    rng.normal(size=3),
                    R[:, 0],
                    R[:, 1],
                    rng.uniform(0.1, 1),
                    rng.uniform(-3, 3),
                    rng.uniform(-7, 7),
                    rng.choice([0.0, 0.05]),
                )
            )
        else:
            segs.append(pack_cubic(*rng.normal(size=(4, 3))))
    st, sd, sb = pack_path(*segs)
    pts = rng.normal(scale=1.5, size=(200, 3))
    got = true_contour_error(st, sd, sb, pts)
    ref = np.array([_plain_min(st, sd, p) for p in pts])
    np.testing.assert_array_equal(got, ref)


def test_api_forms_and_parallel_batch(corner):
    st, sd, sb = corner
    path = SimpleNamespace(seg_type=st, seg_data=sd, seg_bounds=sb)
    rng = np.random.default_rng(8)
    pts2 = rng.uniform(-1, 2, size=(10000, 2))  # large enough for the parallel kernel
    pts3 = np.c_[pts2, np.zeros(len(pts2))]
    a = true_contour_error(st, sd, sb, pts2)
    b = true_contour_error(path, pts3)
    c = true_contour_error(path, points=pts2[:100])
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a[:100], c)
    serial = np.array([path_distance(st, sd, sb, *p) for p in pts3[:500]])
    np.testing.assert_array_equal(a[:500], serial)
    # z offset is part of the distance
    assert true_contour_error(path, [0.5, 0.0, 0.3]) == pytest.approx(0.3, abs=1e-15)
    assert true_contour_error(path, [0.5, 0.1]) == pytest.approx(0.1, abs=1e-15)
    assert true_contour_error(path, np.empty((0, 2))).shape == (0,)


def test_kernels_callable_from_numba(corner):
    from numba import njit

    st, sd, sb = corner

    @njit
    def loop(st, sd, sb, pts, frame):
        out = np.empty((pts.shape[0], 5))
        hint = 0
        for i in range(pts.shape[0]):
            px = pts[i, 0]
            py = pts[i, 1]
            out[i, 0] = path_distance(st, sd, sb, px, py, 0.0)
            d, hint = path_distance_with_index(st, sd, sb, px, py, 0.0, hint)
            out[i, 1] = d
            et, en, eb = frame_error(frame, 0.5, 0.0, 0.0, px, py, 0.0)
            out[i, 2] = et
            out[i, 3] = en
            out[i, 4] = eb
        return out

    pts = np.array([[0.95, 0.2], [0.5, -0.1], [1.3, 1.4]])
    out = loop(st, sd, sb, pts, np.eye(3))
    np.testing.assert_allclose(out[:, 0], [0.05, 0.1, 0.5], atol=1e-14)
    np.testing.assert_array_equal(out[:, 0], out[:, 1])
    np.testing.assert_allclose(out[:, 2], 0.5 - pts[:, 0], atol=1e-15)
    np.testing.assert_allclose(out[:, 3], -pts[:, 1], atol=1e-15)


# ---------------------------------------------------------------------------------------
# task-frame error
# ---------------------------------------------------------------------------------------


def _circle_frames(R, phis):
    xd = R * np.c_[np.cos(phis), np.sin(phis), np.zeros_like(phis)]
    t = np.c_[-np.sin(phis), np.cos(phis), np.zeros_like(phis)]  # CCW tangent
    n = np.c_[-np.cos(phis), -np.sin(phis), np.zeros_like(phis)]  # left normal → centre
    b = np.cross(t, n)
    F = np.stack([t, n, b], axis=2)  # columns [t n b]
    return xd, F


def test_task_frame_error_circle_signs():
    R = 0.05
    phis = np.linspace(0, 2 * np.pi, 13)
    xd, F = _circle_frames(R, phis)
    np.testing.assert_allclose(F[:, :, 2], np.tile([0, 0, 1.0], (13, 1)), atol=1e-15)
    radial = xd / R
    delta = 1e-4
    # point outside the CCW circle (further from the centre): x_d − x = −δ r̂ and n = −r̂,
    # so e_n = (x_d − x)·n = +δ
    x_out = xd + delta * radial
    e = task_frame_error(F, xd[:, :2], x_out[:, :2])
    assert e.shape == (13, 2)
    np.testing.assert_allclose(e[:, 0], 0.0, atol=1e-15)
    np.testing.assert_allclose(e[:, 1], +delta, rtol=1e-12)
    # inside: e_n = −δ; 3-D form adds a zero binormal component
    e3 = task_frame_error(F, xd, xd - delta * radial)
    np.testing.assert_allclose(e3, np.tile([0.0, -delta, 0.0], (13, 1)), atol=1e-15)
    # lagging behind the reference along t: e_t > 0; above the plane: e_b < 0
    t = F[:, :, 0]
    e3 = task_frame_error(F, xd, xd - 2e-4 * t + np.array([0, 0, 3e-5]))
    np.testing.assert_allclose(e3, np.tile([2e-4, 0.0, -3e-5], (13, 1)), atol=1e-15)
    # numba scalar version agrees
    for k in range(13):
        p = xd[k] - 2e-4 * t[k] + [0, 0, 3e-5]
        np.testing.assert_allclose(frame_error(F[k], *xd[k], *p), e3[k], atol=1e-18)
    # unbatched call
    np.testing.assert_allclose(task_frame_error(F[3], xd[3], x_out[3]), [0, delta, 0], atol=1e-15)


def test_task_frame_error_random_matches_definition():
    rng = np.random.default_rng(9)
    F = np.stack([rot(*a) for a in rng.uniform(-3, 3, size=(40, 3))])
    xd = rng.normal(size=(40, 3))
    x = rng.normal(size=(40, 3))
    e = task_frame_error(F, xd, x)
    ref = np.array([F[k].T @ (xd[k] - x[k]) for k in range(40)])
    np.testing.assert_allclose(e, ref, atol=1e-14)
    # preserves the norm (orthonormal frame)
    np.testing.assert_allclose(np.linalg.norm(e, axis=1), np.linalg.norm(xd - x, axis=1))
    e2 = task_frame_error(F, xd[:, :2], x[:, :2])
    ref2 = np.array([F[k, :2, :2].T @ (xd[k, :2] - x[k, :2]) for k in range(40)])
    np.testing.assert_allclose(e2, ref2, atol=1e-14)


# ---------------------------------------------------------------------------------------
# bad inputs
# ---------------------------------------------------------------------------------------


def test_true_contour_error_bad_inputs(corner):
    st, sd, sb = corner
    with pytest.raises(ValueError, match="points"):
        true_contour_error(st, sd, sb, np.zeros((4, 4)))
    with pytest.raises(ValueError, match="points"):
        true_contour_error(st, sd, sb, np.zeros((2, 2, 2)))
    with pytest.raises(ValueError, match="points"):
        true_contour_error(st, sd, sb, np.zeros(5))
    with pytest.raises(ValueError, match="points"):
        true_contour_error(st, sd, sb, np.array([[0.0, np.nan]]))
    with pytest.raises(ValueError, match="points"):
        true_contour_error(st, sd, sb, [0.0, np.inf, 0.0])
    with pytest.raises(ValueError, match="points"):
        true_contour_error(st, sd, sb, [["a", "b"]])
    with pytest.raises(ValueError, match="seg_data"):
        true_contour_error(st, sd[:, :12], sb, np.zeros((1, 2)))
    with pytest.raises(ValueError, match="seg_data"):
        bad = sd.copy()
        bad[0, 3] = np.nan
        true_contour_error(st, bad, sb, np.zeros((1, 2)))
    with pytest.raises(ValueError, match="seg_bounds"):
        true_contour_error(st, sd, sb[:1], np.zeros((1, 2)))
    with pytest.raises(ValueError, match="seg_type"):
        true_contour_error(np.array([0, 5]), sd, sb, np.zeros((1, 2)))
    with pytest.raises(ValueError, match="seg_type"):
        true_contour_error(np.array([], dtype=int), sd[:0], sb[:0], np.zeros((1, 2)))
    with pytest.raises(ValueError):
        true_contour_error(st, sd, points=np.zeros((1, 2)))  # seg_bounds missing


def test_task_frame_error_bad_inputs():
    F = np.tile(np.eye(3), (4, 1, 1))
    x = np.zeros((4, 3))
    with pytest.raises(ValueError, match="frame"):
        task_frame_error(F[:, :2, :], x, x)
    with pytest.raises(ValueError, match="reference"):
        task_frame_error(F, np.zeros((3, 3)), x)
    with pytest.raises(ValueError, match="reference"):
        task_frame_error(F, np.zeros((4, 4)), np.zeros((4, 4)))
    with pytest.raises(ValueError, match="position"):
        task_frame_error(F, x, np.zeros((4, 2)))
    bad = x.copy()
    bad[1, 1] = np.nan
    with pytest.raises(ValueError, match="position"):
        task_frame_error(F, x, bad)
    with pytest.raises(ValueError, match="reference"):
        task_frame_error(F, bad, x)
