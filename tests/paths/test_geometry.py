"""Path geometry and frames against closed forms and finite differences (Lee 2012 eq. 14)."""

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


def _R(kappa, tau):
    return np.array([[0, kappa, 0], [-kappa, 0, tau], [0, -tau, 0]])


def _check_frenet(path, s_values, h=1e-6, rtol=1e-5):
    """dFᵀ/ds = R Fᵀ (Lee 2012 eq. 14 divided by the feedrate), by central differences."""
    for s in s_values:
        F, k, t = path.frames(np.array([s - h, s, s + h]))
        dFT = (F[2].T - F[0].T) / (2 * h)
        expected = _R(k[1], t[1]) @ F[1].T
        np.testing.assert_allclose(dFT, expected, atol=rtol * max(1.0, abs(k[1]) + abs(t[1])))
        np.testing.assert_allclose(F[1].T @ F[1], np.eye(3), atol=1e-12)
        assert np.linalg.det(F[1]) == pytest.approx(1.0)


def test_circle_point_curvature_and_frame():
    path = circle((0.01, -0.02), 0.1, start_angle=-math.pi / 2)
    assert path.dim == 2 and path.closed
    assert path.total_length == pytest.approx(2 * math.pi * 0.1)
    s = np.linspace(0, path.total_length, 50)
    d = path.evaluate(s)
    np.testing.assert_allclose(
        np.linalg.norm(d["position"] - [0.01, -0.02, 0], axis=1), 0.1, atol=1e-15
    )
    F, kappa, tau = path.frames(s)
    np.testing.assert_allclose(kappa, 10.0)  # CCW: positive signed curvature
    np.testing.assert_allclose(tau, 0.0)
    # n is the left normal, pointing to the centre on a CCW circle
    to_centre = np.array([0.01, -0.02, 0]) - d["position"]
    np.testing.assert_allclose(F[:, :, 1], to_centre / 0.1, atol=1e-12)
    _check_frenet(path, [0.1, 0.3, 0.5])


def test_clockwise_circle_has_negative_signed_curvature():
    path = circle((0, 0), 0.05, ccw=False)
    _, kappa, _ = path.frames(np.array([0.1]))
    assert kappa[0] == pytest.approx(-20.0)


def test_inclined_circle_is_3d_and_planar():
    path = inclined_circle((0, 0, 0), 0.5, math.radians(30))
    assert path.dim == 3
    np.testing.assert_allclose(path.planar_normal, [0, -0.5, math.sqrt(3) / 2], atol=1e-12)
    pts = path.sample_points(100)
    np.testing.assert_allclose(pts @ path.planar_normal, 0.0, atol=1e-15)
    _check_frenet(path, [0.2, 1.0, 2.5])


def test_helix_curvature_and_torsion_closed_form():
    r, pitch_rev = 0.02, 0.005
    path = helix((0, 0, 0), r, pitch_rev, 2.0)
    h = pitch_rev / (2 * math.pi)
    assert path.planar_normal is None
    assert path.total_length == pytest.approx(2 * 2 * math.pi * math.hypot(r, h))
    s = np.linspace(0.01, path.total_length - 0.01, 20)
    _, kappa, tau = path.frames(s)
    np.testing.assert_allclose(kappa, r / (r**2 + h**2), rtol=1e-10)
    np.testing.assert_allclose(tau, h / (r**2 + h**2), rtol=1e-8)
    _check_frenet(path, [0.05, 0.15])


def test_spline_passes_through_points_is_c2_and_has_a_consistent_frame():
    rng = np.random.default_rng(0)
    pts = np.column_stack([np.linspace(0, 0.1, 7), 0.02 * rng.standard_normal(7)])
    path = spline(pts)
    knots = np.concatenate([[0], np.cumsum(path.seg_length)])
    d = path.evaluate(knots)
    np.testing.assert_allclose(d["position"][:, :2], pts, atol=1e-12)
    # C² at interior knots: d1 and d2 agree from both sides
    for k in range(1, path.n_segments):
        left = path.segments[k - 1].derivatives(np.array([path.seg_length[k - 1]]))
        right = path.segments[k].derivatives(np.array([0.0]))
        np.testing.assert_allclose(left[1], right[1], atol=1e-9)
        np.testing.assert_allclose(left[2], right[2], rtol=1e-6, atol=1e-6)
    _check_frenet(path, knots[1:-1] + 1e-3, rtol=1e-4)


def test_cubic_length_matches_quad():
    c = Cubic([0, 0, 0], [0.1, 0.02, 0.0], [-0.03, 0.05, 0.01], [0.01, -0.02, 0.004])

    def speed(q):
        return np.linalg.norm(c.b + 2 * c.c * q + 3 * c.d * q**2)

    assert c.length == pytest.approx(quad(speed, 0, 1, epsabs=1e-15)[0], rel=1e-12)
    s = np.array([0.0, 0.3 * c.length, c.length])
    q = c.q_of_s(s)
    np.testing.assert_allclose(c.arc_length_to(q), s, atol=1e-13)


def test_polyline_corners_and_straight_frame():
    path = polyline([(0, 0), (0.03, 0), (0.03, 0.03), (0.0, 0.06)])
    np.testing.assert_allclose(path.corner_arc_lengths(), [0.03, 0.06])
    F, kappa, _ = path.frames(np.array([0.01, 0.04]))
    np.testing.assert_allclose(kappa, 0.0)
    np.testing.assert_allclose(F[0][:, 0], [1, 0, 0])
    np.testing.assert_allclose(F[0][:, 1], [0, 1, 0])  # left normal on a straight
    np.testing.assert_allclose(F[1][:, 0], [0, 1, 0])


def test_evaluate_clamps_past_the_ends():
    path = line((0, 0), (0.1, 0))
    d = path.evaluate(np.array([-1.0, 5.0]))
    np.testing.assert_allclose(d["position"], [[0, 0, 0], [0.1, 0, 0]])


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: circle((0, 0), 0.0), "radius"),
        (lambda: circle((0, 0), -1.0), "radius"),
        (lambda: circle((0, float("nan")), 1.0), "center"),
        (lambda: line((0, 0), (0, 0)), "zero-length"),
        (lambda: polyline([(0, 0)]), "at least 2"),
        (lambda: polyline([(0, 0), (0, 0), (1, 0)]), "duplicate"),
        (lambda: spline([(0, 0), (1, 0)]), "at least 3"),
        (lambda: helix((0, 0, 0), 0.01, 0.001, 0.0), "turns"),
        (lambda: PathGeometry.from_segments([]), "zero-length path"),
        (
            lambda: PathGeometry.from_segments([Line((0, 0), (1, 0)), Line((2, 0), (3, 0))]),
            "continuous",
        ),
        (lambda: Arc((0, 0, 0), (1, 0, 0), (1, 0, 0), 1.0, 0.0, 1.0), "orthonormal"),
    ],
)
def test_bad_geometry_names_the_parameter(make, match):
    with pytest.raises(ValueError, match=match):
        make()
