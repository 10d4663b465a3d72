"""Path builders: shapes, dimensions and planes against closed forms; spline against scipy."""

import math

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from contour_env.paths import (
    Arc,
    Cubic,
    Line,
    PathGeometry,
    arc,
    circle,
    helix,
    inclined_circle,
    line,
    polyline,
    spline,
)

X, Y, Z = np.eye(3)


def test_line():
    path = line((0, 0), (0.3, 0.4))
    assert isinstance(path, PathGeometry) and isinstance(path.segments[0], Line)
    assert path.dim == 2 and path.total_length == 0.5 and not path.closed
    assert line((0, 0, 0), (0, 0, 1)).dim == 3


def test_polyline():
    pts = [(0, 0), (0.03, 0), (0.03, 0.04), (0.0, 0.0)]
    path = polyline(pts)
    assert path.dim == 2 and path.closed and path.n_segments == 3
    assert path.total_length == pytest.approx(0.03 + 0.04 + 0.05, rel=1e-15)
    np.testing.assert_allclose(path.evaluate(path.seg_s0)["position"][:, :2], pts[:3])
    assert polyline([(0, 0, 0), (1, 0, 0.5)]).dim == 3


def test_circle_in_xy_is_2d():
    path = circle((0.1, 0.2), 0.05)
    assert path.dim == 2 and path.closed
    assert path.total_length == pytest.approx(2 * math.pi * 0.05, rel=1e-15)
    np.testing.assert_allclose(path.evaluate(0.0)["position"][0], [0.15, 0.2, 0])
    # normal −z: still the xy-plane (2-D), but clockwise seen from +z
    down = circle((0, 0), 0.05, normal=(0, 0, -1))
    assert down.dim == 2
    assert down.frames(0.1)[1][0] == pytest.approx(-20.0)
    # a centre above z = 0 makes it 3-D
    assert circle((0, 0, 0.1), 0.05).dim == 3


def test_partial_circle_and_direction():
    quarter = circle((0, 0), 1.0, sweep=math.pi / 2, ccw=False)
    assert not quarter.closed
    assert quarter.total_length == pytest.approx(math.pi / 2)
    np.testing.assert_allclose(quarter.segments[0].end_point, [0, -1, 0], atol=1e-15)


def test_circle_in_any_plane():
    n = np.array([1.0, 2.0, 2.0]) / 3
    path = circle((0.1, 0.2, 0.3), 0.05, normal=3 * n, start_angle=1.0)
    assert path.dim == 3
    np.testing.assert_allclose(path.planar_normal, n, atol=1e-15)
    pts = path.sample_points(200)
    np.testing.assert_allclose((pts - [0.1, 0.2, 0.3]) @ n, 0.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(pts - [0.1, 0.2, 0.3], axis=1), 0.05, rtol=1e-14)
    # u chooses where angles are measured from (orthogonalised against the normal)
    yz = circle((0, 0, 0), 1.0, normal=X, u=(1, 1, 0))
    np.testing.assert_allclose(yz.evaluate(0.0)["position"][0], Y, atol=1e-15)


@pytest.mark.parametrize(
    "axis, normal, start",
    [
        ("x", (0, -0.5, math.sqrt(3) / 2), (1, 0, 0)),
        ("y", (0.5, 0, math.sqrt(3) / 2), (math.sqrt(3) / 2, 0, -0.5)),
    ],
)
def test_inclined_circle_30_degrees(axis, normal, start):
    path = inclined_circle((0, 0, 0), 1.0, math.radians(30), tilt_axis=axis)
    assert path.dim == 3
    np.testing.assert_allclose(path.planar_normal, normal, atol=1e-15)
    np.testing.assert_allclose(path.evaluate(0.0)["position"][0], start, atol=1e-15)
    # it is the xy circle rotated: the point at 90° is the rotated +y
    p90 = path.evaluate(math.pi / 2)["position"][0]
    assert np.linalg.norm(p90) == pytest.approx(1.0)
    assert p90 @ np.array(normal) == pytest.approx(0.0, abs=1e-15)


def test_inclined_circle_rejects_normal_override():
    with pytest.raises(ValueError, match="normal"):
        inclined_circle((0, 0, 0), 1.0, 0.5, normal=(0, 0, 1))


def test_arc():
    path = arc((0, 0), 0.2, start_angle=math.pi / 2, sweep=-math.pi / 2)
    assert path.dim == 2 and isinstance(path.segments[0], Arc)
    np.testing.assert_allclose(path.segments[0].start_point, [0, 0.2, 0], atol=1e-15)
    np.testing.assert_allclose(path.segments[0].end_point, [0.2, 0, 0], atol=1e-15)
    assert path.total_length == pytest.approx(0.1 * math.pi)


@pytest.mark.parametrize("ccw", [True, False])
def test_helix(ccw):
    r, p, turns = 0.02, 0.004, 2.5
    path = helix((0.1, 0, 0), r, p, turns, axis=(0, 0, 2), ccw=ccw)
    assert path.dim == 3 and not path.closed
    assert path.total_length == pytest.approx(
        2 * math.pi * turns * math.hypot(r, p / (2 * math.pi))
    )
    s = np.linspace(0, path.total_length, 101)
    pos = path.evaluate(s)["position"]
    np.testing.assert_allclose(np.hypot(pos[:, 0] - 0.1, pos[:, 1]), r, rtol=1e-14)
    # rises along +axis at pitch per revolution, whichever way it turns
    np.testing.assert_allclose(pos[:, 2], p * turns * s / path.total_length, atol=1e-15)
    np.testing.assert_allclose(pos[-1], [0.1 - r, 0, p * turns], atol=1e-15)
    ang = np.unwrap(np.arctan2(pos[:, 1], pos[:, 0] - 0.1))
    assert (ang[-1] - ang[0]) == pytest.approx((1 if ccw else -1) * 2 * math.pi * turns)


def test_helix_about_another_axis():
    path = helix((0, 0, 0), 0.01, 0.002, 1.0, axis=(1, 0, 0))
    end = path.segments[0].end_point
    assert end[0] == pytest.approx(0.002)


def _knot_s(path):
    return np.concatenate([[0.0], np.cumsum(path.seg_length)])


@pytest.mark.parametrize("dim", [2, 3])
def test_open_spline_interpolates_and_is_c2(dim):
    rng = np.random.default_rng(3)
    pts = np.cumsum(rng.uniform(0.01, 0.03, (8, dim)), axis=0)
    path = spline(pts)
    assert path.dim == dim and path.n_segments == 7
    assert all(isinstance(s, Cubic) for s in path.segments)
    np.testing.assert_allclose(path.evaluate(_knot_s(path))["position"][:, :dim], pts, atol=1e-15)
    for k in range(1, path.n_segments):
        left = path.segments[k - 1].derivatives(np.array([path.seg_length[k - 1]]))
        right = path.segments[k].derivatives(np.array([0.0]))
        np.testing.assert_allclose(left[0], right[0], atol=1e-15)
        np.testing.assert_allclose(left[1], right[1], atol=1e-12)  # tangent
        np.testing.assert_allclose(left[2], right[2], atol=1e-9 * np.abs(left[2]).max())
    # the same curve as scipy's chord-length spline
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    knots = np.concatenate([[0], np.cumsum(chords)])
    cs = CubicSpline(knots, pts, bc_type="not-a-knot", axis=0)
    x = np.linspace(knots[2], knots[3], 9)
    q = (x - knots[2]) / chords[2]
    np.testing.assert_allclose(path.segments[2].point(q)[:, :dim], cs(x), atol=1e-15)


def test_closed_spline_is_periodic_c2():
    t = np.linspace(0, 2 * math.pi, 9)[:-1]
    pts = np.column_stack([np.cos(t), 0.6 * np.sin(t)])
    path = spline(pts, closed=True)
    assert path.closed and path.dim == 2 and path.n_segments == 8
    last, first = path.segments[-1], path.segments[0]
    left = last.derivatives(np.array([last.length]))
    right = first.derivatives(np.array([0.0]))
    for k in range(3):
        np.testing.assert_allclose(left[k], right[k], atol=1e-12)
    assert path.corner_arc_lengths(include_closure=True).size == 0


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: line((0, 0), (0, 0)), "zero-length"),
        (lambda: line((0, 0), (1, float("nan"))), "end"),
        (lambda: polyline([(0, 0)]), "at least 2"),
        (lambda: polyline([(0, 0), (0, 0), (1, 0)]), "duplicate"),
        (lambda: polyline([(0, 0), (1, float("inf"))]), "points.*finite"),
        (lambda: polyline([0, 1, 2]), "points"),
        (lambda: circle((0, 0), 0.0), "radius"),
        (lambda: circle((0, 0), -1.0), "radius"),
        (lambda: circle((0, 0), float("inf")), "radius"),
        (lambda: circle((0, float("nan")), 1.0), "center"),
        (lambda: circle((0, 0), 1.0, sweep=0.0), "sweep"),
        (lambda: circle((0, 0), 1.0, normal=(0, 0, 0)), "normal"),
        (lambda: circle((0, 0), 1.0, u=(0, 0, 1)), "u"),
        (lambda: arc((0, 0), 1.0, sweep=0.0), "sweep"),
        (lambda: arc((0, 0), 1.0, start_angle=float("nan")), "start_angle"),
        (lambda: inclined_circle((0, 0, 0), 1.0, 0.5, tilt_axis="z"), "tilt_axis"),
        (lambda: inclined_circle((0, 0, 0), 1.0, float("nan")), "tilt_rad"),
        (lambda: helix((0, 0, 0), 0.0, 0.001, 1.0), "radius"),
        (lambda: helix((0, 0, 0), 0.01, 0.001, 0.0), "turns"),
        (lambda: helix((0, 0, 0), 0.01, float("nan"), 1.0), "pitch_per_rev"),
        (lambda: spline([(0, 0), (1, 0)]), "at least 3"),
        (lambda: spline([(0, 0), (1, 0), (0, 0)], closed=True), "at least 3 distinct"),
        (lambda: spline([(0, 0), (1, 0), (1, 0), (2, 1)]), "duplicate"),
    ],
)
def test_bad_builder_inputs_name_the_parameter(make, match):
    with pytest.raises(ValueError, match=match):
        make()
