"""Segments and PathGeometry against closed forms, scipy quadrature and finite differences,
including the frame equation dFᵀ/ds = R Fᵀ (Lee 2012 eq. 14 divided by the feedrate)."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from contour_env.paths import (
    Arc,
    Cubic,
    Line,
    PathGeometry,
    circle,
    helix,
    inclined_circle,
    line,
    polyline,
    spline,
)

X, Y, Z = np.eye(3)


def _R(kappa, tau):
    return np.array([[0, kappa, 0], [-kappa, 0, tau], [0, -tau, 0]])


def check_frame_equation(path, s_values, h=1e-6, rtol=1e-6):
    """Central differences of Fᵀ against R Fᵀ, plus orthonormality and right-handedness."""
    for s in s_values:
        F, k, t = path.frames(np.array([s - h, s, s + h]))
        dFT = (F[2].T - F[0].T) / (2 * h)
        expected = _R(k[1], t[1]) @ F[1].T
        scale = max(1.0, abs(k[1]) + abs(t[1]))
        np.testing.assert_allclose(dFT, expected, atol=rtol * scale)
        np.testing.assert_allclose(F[1].T @ F[1], np.eye(3), atol=1e-12)
        assert np.linalg.det(F[1]) == pytest.approx(1.0, abs=1e-12)


def mixed_path():
    """Line, tangent arc, then a cubic piece: one of each segment type, 2-D."""
    a = Arc((0.05, 0.02), X, Y, 0.02, -math.pi / 2, math.pi / 2)
    e = a.end_point
    c = Cubic(e, (0.0, 0.03), (-0.01, 0.01), (0.004, -0.002))
    return PathGeometry.from_segments([Line((0, 0), (0.05, 0)), a, c])


# ----------------------------------------------------------------------------- segments
def test_line_and_arc_lengths_are_exact():
    assert Line((0, 0, 0), (0.3, 0.4, 0)).length == 0.5
    a = Arc((0, 0, 0), X, Y, 0.2, 0.0, -1.5)
    assert a.length == pytest.approx(0.3, rel=1e-15)
    h = Arc((0, 0, 0), X, Y, 0.03, 0.0, 4 * math.pi, pitch=0.04)
    assert h.length == pytest.approx(4 * math.pi * 0.05, rel=1e-15)
    np.testing.assert_allclose(h.end_point, [0.03, 0, 0.04 * 4 * math.pi], atol=1e-15)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cubic_length_matches_quad(seed):
    rng = np.random.default_rng(seed)
    c = Cubic(*(rng.standard_normal((4, 3)) * np.array([[1.0], [0.3], [0.5], [0.4]])))

    def speed(q):
        return np.linalg.norm(c.b + 2 * c.c * q + 3 * c.d * q**2)

    exact = quad(speed, 0, 1, epsabs=0, epsrel=1e-13, limit=200)[0]
    assert c.length == pytest.approx(exact, rel=1e-12)
    s = np.linspace(0, c.length, 41)
    q = c.q_of_s(s)
    np.testing.assert_allclose(c.arc_length_to(q), s, atol=1e-13)
    partial = quad(speed, 0, q[17], epsabs=0, epsrel=1e-13)[0]
    assert partial == pytest.approx(s[17], rel=1e-12)


def test_sharply_curved_cubic_length_uses_composite_quadrature():
    # a near-hairpin: the speed falls to ~1 % of its peak; one 16-point panel is not enough
    c = Cubic((0, 0, 0), (1, 0, 0), (-1.47, 0.5, 0), (0.49, 0, 0))

    def speed(q):
        return np.linalg.norm(c.b + 2 * c.c * q + 3 * c.d * q**2)

    exact = quad(speed, 0, 1, epsabs=0, epsrel=1e-13, limit=500)[0]
    assert c.n_panels > 1
    assert c.length == pytest.approx(exact, rel=1e-12)


def test_pack_layout_matches_architecture():
    t, data, _ = Line((1, 2), (3, 4, 5)).pack()
    assert t == 0
    np.testing.assert_array_equal(data, [1, 2, 0, 3, 4, 5] + [0] * 10)
    a = Arc((1, 2, 3), Y, -X, 0.5, 0.1, -2.0, 0.01)
    t, data, _ = a.pack()
    assert t == 1
    np.testing.assert_array_equal(data[:9], [1, 2, 3, 0, 1, 0, -1, 0, 0])
    np.testing.assert_array_equal(data[9:12], [0, 0, 1])  # w = u × v
    np.testing.assert_array_equal(data[12:], [0.5, 0.1, -2.0, 0.01])
    c = Cubic((1, 2), (3, 4), (5, 6), (7, 8, 9))
    t, data, _ = c.pack()
    assert t == 2
    np.testing.assert_array_equal(data, [1, 2, 0, 3, 4, 0, 5, 6, 0, 7, 8, 9, 0, 0, 0, 0])


def _dense_points(seg, n=2001):
    return seg.derivatives(np.linspace(0, seg.length, n))[0]


@pytest.mark.parametrize("seed", range(6))
def test_bounding_spheres_contain_every_point(seed):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(3)
    u /= np.linalg.norm(u)
    v = np.cross(u, rng.standard_normal(3))
    v /= np.linalg.norm(v)
    segs = [
        Line(rng.standard_normal(3), rng.standard_normal(3)),
        Arc(rng.standard_normal(3), u, v, 0.3, rng.uniform(-4, 4), rng.uniform(0.01, 1.0)),
        Arc(rng.standard_normal(3), u, v, 0.3, 0.0, rng.uniform(-3.1, -2.0)),
        Arc(rng.standard_normal(3), u, v, 0.3, 1.0, rng.uniform(4, 9), rng.uniform(-0.1, 0.1)),
        Arc(rng.standard_normal(3), u, v, 0.3, 1.0, rng.uniform(0.1, 3), rng.uniform(-0.1, 0.1)),
        Cubic(*rng.standard_normal((4, 3))),
    ]
    for seg in segs:
        _, _, bounds = seg.pack()
        dist = np.linalg.norm(_dense_points(seg) - bounds[:3], axis=1)
        assert np.all(dist <= bounds[3])


def test_small_arc_bounds_are_tight():
    a = Arc((0, 0, 0), X, Y, 1.0, 0.0, 0.01)
    assert a.pack()[2][3] == pytest.approx(math.sin(0.005), rel=1e-9)


def test_segment_derivatives_match_finite_differences():
    h = 1e-5
    segs = [
        Arc((0.1, 0, 0.2), Y, Z, 0.05, 0.3, -2.0, 0.01),
        Cubic((0, 0, 0), (0.1, 0.02, 0.0), (-0.03, 0.05, 0.01), (0.01, -0.02, 0.004)),
    ]
    for seg in segs:
        s = np.array([0.2, 0.5, 0.8]) * seg.length
        p, d1, d2, d3 = seg.derivatives(s)
        pm, d1m, d2m, _ = seg.derivatives(s - h)
        pp, d1p, d2p, _ = seg.derivatives(s + h)
        np.testing.assert_allclose(np.linalg.norm(d1, axis=1), 1.0, atol=1e-14)
        np.testing.assert_allclose((pp - pm) / (2 * h), d1, atol=1e-8)
        np.testing.assert_allclose((d1p - d1m) / (2 * h), d2, atol=1e-6 * np.max(abs(d2)))
        np.testing.assert_allclose((d2p - d2m) / (2 * h), d3, atol=1e-5 * np.max(abs(d3)))


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: Line((0, 0), (0, 0)), "zero-length line"),
        (lambda: Line((0, 0), (1, float("inf"))), "end"),
        (lambda: Line((0, 0, 0, 0), (1, 0)), "start"),
        (lambda: Arc((0, 0, 0), X, Y, 0.0, 0.0, 1.0), "radius"),
        (lambda: Arc((0, 0, 0), X, Y, -1.0, 0.0, 1.0), "radius"),
        (lambda: Arc((0, 0, 0), X, Y, 1.0, 0.0, 0.0), "sweep"),
        (lambda: Arc((0, 0, 0), X, Y, 1.0, 0.0, float("nan")), "sweep"),
        (lambda: Arc((0, 0, 0), X, Y, 1.0, 0.0, 1.0, float("inf")), "pitch"),
        (lambda: Arc((0, float("nan"), 0), X, Y, 1.0, 0.0, 1.0), "center"),
        (lambda: Arc((0, 0, 0), X, X, 1.0, 0.0, 1.0), "orthonormal"),
        (lambda: Arc((0, 0, 0), 2 * X, Y, 1.0, 0.0, 1.0), "orthonormal"),
        (lambda: Cubic((0, 0), (0, 0), (0, 0), (0, 0)), "zero length"),
        (lambda: Cubic((0, 0), (1, 0), (-1.5, 0), (0.5, 0)), "not regular"),  # p'(1) = 0
        (lambda: Cubic((0, 0), (1, 0), (0, float("nan")), (0, 0)), "c"),
    ],
)
def test_bad_segments_name_the_parameter(make, match):
    with pytest.raises(ValueError, match=match):
        make()


# ---------------------------------------------------------------------------- from_segments
def test_from_segments_packs_lengths_and_offsets():
    path = mixed_path()
    assert path.n_segments == 3 and path.dim == 2 and not path.closed
    np.testing.assert_array_equal(path.seg_type, [0, 1, 2])
    assert path.seg_type.dtype == np.int64
    assert path.seg_data.shape == (3, 16) and path.seg_data.flags.c_contiguous
    assert path.seg_bounds.shape == (3, 4) and path.seg_bounds.flags.c_contiguous
    np.testing.assert_allclose(path.seg_length[:2], [0.05, 0.01 * math.pi])
    np.testing.assert_allclose(path.seg_s0, [0, 0.05, 0.05 + 0.01 * math.pi])
    assert path.total_length == pytest.approx(path.seg_length.sum(), rel=1e-15)
    np.testing.assert_array_equal(path.planar_normal, Z)


@pytest.mark.parametrize(
    "segments, dim, match",
    [
        ([], None, "zero-length path"),
        ([Line((0, 0), (1, 0)), Line((1, 1e-6), (2, 0))], None, r"segments\[1\].*continuous"),
        ([Line((0, 0), (1, 0)), "arc"], None, r"segments\[1\]"),
        ([Line((0, 0, 0), (1, 0, 1e-3))], 2, "dim"),
        ([Line((0, 0), (1, 0))], 4, "dim"),
    ],
)
def test_bad_paths(segments, dim, match):
    with pytest.raises(ValueError, match=match):
        PathGeometry.from_segments(segments, dim=dim)


def test_small_gap_within_tolerance_is_accepted():
    path = PathGeometry.from_segments([Line((0, 0), (1, 0)), Line((1, 5e-10), (1, 1))])
    assert path.n_segments == 2


def test_dim_inference_and_override():
    flat = [Line((0, 0, 0), (1, 0, 0)), Line((1, 0, 0), (1, 1, 0))]
    assert PathGeometry.from_segments(flat).dim == 2
    p3 = PathGeometry.from_segments(flat, dim=3)
    assert p3.dim == 3
    np.testing.assert_array_equal(p3.planar_normal, Z)
    lifted = [Line((0, 0, 1e-3), (1, 0, 1e-3))]
    assert PathGeometry.from_segments(lifted).dim == 3
    assert helix((0, 0, 0), 0.01, 0.0, 1.0).dim == 3


def test_planar_normal_detection():
    # clockwise xy arc given as 3-D: the plane is the xy-plane, so +z (not the arc's w = −z)
    cw = PathGeometry.from_segments([Arc((0, 0, 0), X, -Y, 1.0, 0.0, 1.0)], dim=3)
    np.testing.assert_array_equal(cw.planar_normal, Z)
    # an inclined plane: the first arc's w
    w = np.array([0.0, -0.6, 0.8])
    u = np.array([1.0, 0.0, 0.0])
    a = Arc((0, 0, 0), u, np.cross(w, u), 0.1, 0.0, -0.5)
    np.testing.assert_allclose(PathGeometry.from_segments([a]).planar_normal, w, atol=1e-15)
    # a tiny arc, whose points are nearly collinear, still gives its own plane
    tiny = Arc((0, 0, 0), u, np.cross(w, u), 1e-3, 0.0, 1e-4)
    np.testing.assert_allclose(PathGeometry.from_segments([tiny]).planar_normal, w, atol=1e-15)
    # a 3-D polyline in a tilted plane (z = x): normal ∝ (−1, 0, 1), sign with +z
    tilted = polyline([(0, 0, 0), (1, 0, 1), (1, 1, 1), (0, 2, 0)])
    np.testing.assert_allclose(tilted.planar_normal, [-(0.5**0.5), 0, 0.5**0.5], atol=1e-15)
    # not planar
    assert polyline([(0, 0, 0), (1, 0, 0), (1, 1, 0), (1, 1, 1)]).planar_normal is None
    assert helix((0, 0, 0), 0.01, 0.002, 1.0).planar_normal is None
    # a straight 3-D line: the plane through it that is closest to horizontal
    n = line((0, 0, 0), (1, 0, 1)).planar_normal
    assert abs(n @ np.array([1, 0, 1])) < 1e-15 and n[2] > 0


# -------------------------------------------------------------------------------- evaluate
def test_circle_evaluate_closed_form():
    r, c = 0.1, np.array([0.01, -0.02, 0.0])
    path = circle(c[:2], r, start_angle=0.3)
    assert path.dim == 2 and path.closed
    s = np.linspace(0, path.total_length, 50)
    d = path.evaluate(s)
    th = 0.3 + s / r
    radial = np.column_stack([np.cos(th), np.sin(th), 0 * th])
    tang = np.column_stack([-np.sin(th), np.cos(th), 0 * th])
    np.testing.assert_allclose(d["position"], c + r * radial, atol=1e-15)
    np.testing.assert_allclose(d["d1"], tang, atol=1e-14)
    np.testing.assert_allclose(d["d2"], -radial / r, atol=1e-12)
    np.testing.assert_allclose(d["d3"], -tang / r**2, atol=1e-10)


def test_evaluate_clamps_and_joins_segments():
    path = mixed_path()
    d = path.evaluate(np.array([-1.0, 0.0, path.total_length, 5.0]))
    np.testing.assert_allclose(d["position"][0], [0, 0, 0])
    np.testing.assert_allclose(d["position"][1], [0, 0, 0])
    np.testing.assert_allclose(d["position"][2:], [path.segments[-1].end_point] * 2, atol=1e-15)
    # positions and tangents continuous at the junctions
    for s0 in path.seg_s0[1:]:
        dd = path.evaluate(np.array([s0 - 1e-12, s0, s0 + 1e-12]))
        np.testing.assert_allclose(dd["position"][0], dd["position"][2], atol=1e-11)
        np.testing.assert_allclose(dd["d1"][0], dd["d1"][2], atol=1e-9)
    # a scalar works too
    assert path.evaluate(0.01)["position"].shape == (1, 3)


def test_path_derivatives_match_finite_differences():
    path = mixed_path()
    h = 1e-6
    s = np.array([0.02, 0.06, path.seg_s0[2] + 0.01, path.total_length - 0.005])
    d, dm, dp = path.evaluate(s), path.evaluate(s - h), path.evaluate(s + h)
    np.testing.assert_allclose((dp["position"] - dm["position"]) / (2 * h), d["d1"], atol=1e-8)
    np.testing.assert_allclose((dp["d1"] - dm["d1"]) / (2 * h), d["d2"], atol=1e-5)
    np.testing.assert_allclose((dp["d2"] - dm["d2"]) / (2 * h), d["d3"], atol=1e-2)


def test_corner_arc_lengths():
    path = polyline([(0, 0), (0.03, 0), (0.03, 0.03), (0.0, 0.06), (-0.03, 0.09)])
    np.testing.assert_allclose(path.corner_arc_lengths(), [0.03, 0.06])  # last turn is 0 rad
    # tangent line -> arc -> cubic: no corners
    assert mixed_path().corner_arc_lengths().size == 0
    # a turn smaller than the tolerance is not a corner
    slight = polyline([(0, 0), (1, 0), (2, 1e-4)])
    assert slight.corner_arc_lengths(1e-3).size == 0
    np.testing.assert_allclose(slight.corner_arc_lengths(1e-5), [1.0])
    # closed square: the closure junction only on request
    square = polyline([(0, 0), (1, 0), (1, 1), (0, 1), (0, 0)])
    assert square.closed
    np.testing.assert_allclose(square.corner_arc_lengths(), [1, 2, 3])
    np.testing.assert_allclose(square.corner_arc_lengths(include_closure=True), [0, 1, 2, 3])
    assert circle((0, 0), 1.0).corner_arc_lengths(include_closure=True).size == 0
    with pytest.raises(ValueError, match="angle_tol_rad"):
        square.corner_arc_lengths(-1.0)


# ---------------------------------------------------------------------------------- frames
def test_circle_frame_and_signed_curvature():
    path = circle((0.01, -0.02), 0.1, start_angle=-math.pi / 2)
    s = np.linspace(0, path.total_length, 50)
    d = path.evaluate(s)
    F, kappa, tau = path.frames(s)
    assert F.shape == (50, 3, 3) and F.flags.c_contiguous
    np.testing.assert_allclose(kappa, 10.0)  # CCW: positive
    np.testing.assert_allclose(tau, 0.0)
    # t = (cos θ, sin θ), n = (−sin θ, cos θ): the left normal, towards the centre here
    to_centre = np.array([0.01, -0.02, 0]) - d["position"]
    np.testing.assert_allclose(F[:, :, 0], d["d1"], atol=1e-15)
    np.testing.assert_allclose(F[:, :, 1], to_centre / 0.1, atol=1e-12)
    np.testing.assert_allclose(F[:, :, 2], np.tile(Z, (50, 1)))
    check_frame_equation(path, [0.1, 0.3, 0.5])
    cw = circle((0, 0), 0.05, ccw=False)
    F, kappa, _ = cw.frames(np.array([0.1]))
    assert kappa[0] == pytest.approx(-20.0)
    np.testing.assert_allclose(F[0][:, 2], Z)
    check_frame_equation(cw, [0.1, 0.2])


def test_inclined_circle_frame():
    path = inclined_circle((0.1, 0, 0.2), 0.5, math.radians(30))
    assert path.dim == 3
    nrm = np.array([0, -0.5, math.sqrt(3) / 2])
    np.testing.assert_allclose(path.planar_normal, nrm, atol=1e-15)
    s = np.linspace(0, path.total_length, 40)
    F, kappa, tau = path.frames(s)
    np.testing.assert_allclose(kappa, 2.0, rtol=1e-12)
    np.testing.assert_allclose(tau, 0.0)
    np.testing.assert_allclose(F[:, :, 2], np.tile(nrm, (40, 1)), atol=1e-15)
    check_frame_equation(path, [0.2, 1.0, 2.5])


@pytest.mark.parametrize("ccw", [True, False])
def test_helix_curvature_and_torsion_closed_form(ccw):
    r, pitch_rev = 0.02, 0.005
    path = helix((0, 0, 0), r, pitch_rev, 2.0, ccw=ccw)
    h = pitch_rev / (2 * math.pi)
    assert path.total_length == pytest.approx(2 * 2 * math.pi * math.hypot(r, h), rel=1e-15)
    s = np.linspace(0, path.total_length, 21)
    _, kappa, tau = path.frames(s)
    np.testing.assert_allclose(kappa, r / (r**2 + h**2), rtol=1e-12)
    # right-handed when it turns counter-clockwise about the direction it rises in
    np.testing.assert_allclose(tau, (1 if ccw else -1) * h / (r**2 + h**2), rtol=1e-10)
    check_frame_equation(path, [0.05, 0.15])


def test_spline_frame_equation_and_inflection():
    rng = np.random.default_rng(0)
    pts = np.column_stack([np.linspace(0, 0.1, 7), 0.02 * rng.standard_normal(7)])
    path = spline(pts)
    _, kappa, _ = path.frames(np.linspace(0, path.total_length, 500))
    assert kappa.min() < 0 < kappa.max()  # inflections: the signed curvature changes sign
    knots = np.concatenate([[0], np.cumsum(path.seg_length)])
    check_frame_equation(path, np.concatenate([knots[1:-1] + 1e-3, knots[1:-1] - 2e-3]))


def test_3d_spline_frenet_frame_equation():
    t = np.linspace(0, 1.5 * math.pi, 9)
    pts = np.column_stack([0.05 * np.cos(t), 0.05 * np.sin(t), 0.02 * t + 0.01 * t**2])
    path = spline(pts)
    assert path.planar_normal is None
    s = np.linspace(0.01, path.total_length - 0.01, 7)
    check_frame_equation(path, s, rtol=1e-5)
    _, kappa, tau = path.frames(s)
    assert np.all(kappa > 0)
    # against the curvature and torsion from the q-derivatives of each piece
    seg = path.segments[3]
    q = 0.4
    p1 = seg.b + 2 * seg.c * q + 3 * seg.d * q**2
    p2 = 2 * seg.c + 6 * seg.d * q
    p3 = 6 * seg.d
    cr = np.cross(p1, p2)
    s_q = path.seg_s0[3] + seg.arc_length_to(q)[0]
    _, k_num, t_num = path.frames(s_q)
    assert k_num[0] == pytest.approx(np.linalg.norm(cr) / np.linalg.norm(p1) ** 3, rel=1e-9)
    assert t_num[0] == pytest.approx(cr @ p3 / (cr @ cr), rel=1e-8)


def test_non_planar_path_with_straight_segment():
    hx = helix((0, 0, 0), 0.02, 0.01, 0.75)
    seg = hx.segments[0]
    e, t_end = seg.end_point, seg.derivatives(np.array([seg.length]))[1][0]
    path = PathGeometry.from_segments([seg, Line(e, e + 0.05 * t_end)])
    assert path.planar_normal is None
    s_line = path.seg_s0[1] + np.array([0.01, 0.02, 0.04])
    F, kappa, tau = path.frames(s_line)
    np.testing.assert_array_equal(kappa, 0.0)
    np.testing.assert_array_equal(tau, 0.0)
    for f in F:
        np.testing.assert_allclose(f.T @ f, np.eye(3), atol=1e-14)
        np.testing.assert_allclose(f, F[0], atol=1e-15)  # constant on the straight
    # n on the straight: the helix's end binormal, already orthogonal to the shared tangent
    Fh, _, _ = path.frames(np.array([seg.length]))
    b_end = path.frames(np.array([seg.length - 1e-15]))[0][0][:, 2]
    np.testing.assert_allclose(F[0][:, 1], b_end, atol=1e-9)
    np.testing.assert_allclose(F[0][:, 0], Fh[0][:, 0], atol=1e-12)
    check_frame_equation(path, [path.seg_s0[1] + 0.02, 0.05])


def test_straight_non_planar_start_uses_z_then_x():
    # a vertical line then a bend out of its plane: n on the first line comes from x (t ∥ z)
    path = polyline([(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 1, 2)])
    assert path.planar_normal is None
    F, _, _ = path.frames(np.array([0.5, 1.5]))
    np.testing.assert_allclose(F[0][:, 1], X, atol=1e-15)
    np.testing.assert_allclose(F[1][:, 1], Z, atol=1e-15)


def test_planar_frame_on_straight_segments():
    path = polyline([(0, 0), (0.03, 0), (0.03, 0.03)])
    F, kappa, _ = path.frames(np.array([0.01, 0.04]))
    np.testing.assert_array_equal(kappa, 0.0)
    np.testing.assert_allclose(F[0], np.eye(3), atol=1e-15)
    np.testing.assert_allclose(F[1][:, 0], Y, atol=1e-15)
    np.testing.assert_allclose(F[1][:, 1], -X, atol=1e-15)  # left normal
