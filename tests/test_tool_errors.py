"""Tool-tip contour error and orientation error (contour_env.tool_errors) against closed
forms: point-to-segment distance, distance to an inclined circle, angles between vectors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contour_env.paths.builders import inclined_circle, line
from contour_env.paths.five_axis import five_axis_path
from contour_env.tool_errors import (
    ARCSEC_PER_RAD,
    orientation_error_rad,
    reference_polyline,
    tool_errors,
    tool_errors_from_samples,
)

X1 = np.array([0.08, 0.03, 0.02])
X2 = np.array([0.01, 0.05, 0.07])


def _segment_distance(p, a, b):
    d = b - a
    t = np.clip((p - a) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(p - a - t[:, None] * d, axis=1)


def _inclined_circle_distance(p, r, normal):
    # centre at the origin: out-of-plane h and in-plane radius ρ, distance √(h² + (ρ − r)²)
    n = normal / np.linalg.norm(normal)
    h = p @ n
    rho = np.linalg.norm(p - h[:, None] * n, axis=1)
    return np.hypot(h, rho - r)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_line_contour_error_is_the_point_to_segment_distance():
    rng = np.random.default_rng(10)
    # points around the segment and beyond both ends
    t = rng.uniform(-0.5, 1.5, 400)
    p = X1 + t[:, None] * (X2 - X1) + 0.01 * rng.standard_normal((400, 3))
    tools = _unit(rng.standard_normal((400, 3)))
    err = tool_errors(p, tools, line(X1, X2), lambda foot: np.tile([0.0, 0.0, 1.0], (len(foot), 1)))
    np.testing.assert_allclose(err.contour_error_m, _segment_distance(p, X1, X2), atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(p - err.foot_m, axis=1), err.contour_error_m)


def test_circle_contour_error_is_the_closed_form():
    rng = np.random.default_rng(11)
    r, tilt = 0.1, math.pi / 4
    p = 0.15 * rng.standard_normal((400, 3))
    path = inclined_circle((0.0, 0.0, 0.0), r, tilt)
    tools = np.tile([0.0, 0.0, 1.0], (400, 1))
    err = tool_errors(p, tools, path, lambda foot: np.tile([0.0, 0.0, 1.0], (len(foot), 1)))
    expected = _inclined_circle_distance(p, r, np.array([0.0, -math.sin(tilt), math.cos(tilt)]))
    np.testing.assert_allclose(err.contour_error_m, expected, atol=1e-14)
    np.testing.assert_allclose(err.orientation_error_rad, 0.0, atol=1e-15)


def test_orientation_error_is_the_rotation_angle():
    rng = np.random.default_rng(12)
    a = _unit(rng.standard_normal((200, 3)))
    axis = _unit(np.cross(a, rng.standard_normal((200, 3))))
    angle = np.concatenate([rng.uniform(0, math.pi, 190), 10.0 ** -np.arange(2, 12)])
    # Rodrigues with axis ⊥ a: b = a cos θ + (axis × a) sin θ
    b = a * np.cos(angle)[:, None] + np.cross(axis, a) * np.sin(angle)[:, None]
    got = orientation_error_rad(a, 3.0 * b)  # any length
    np.testing.assert_allclose(got, angle, rtol=1e-9, atol=1e-15)
    assert ARCSEC_PER_RAD == pytest.approx(206264.80624709636)


def test_on_reference_the_errors_vanish():
    for name in ("five-axis-line", "five-axis-circle"):
        path = five_axis_path(name)
        ref = path.reference
        err = tool_errors(ref.tip_m, ref.tool, path.tip_path, path.tool_at)
        assert err.contour_error_m.max() < 1e-9
        assert err.orientation_error_arcsec.max() < 1e-6


def test_orientation_error_of_a_tilted_tool_on_the_path():
    # the tip on the path, the tool turned by 10″ about an axis ⊥ to it
    path = five_axis_path("five-axis-circle")
    ref = path.reference
    k = np.arange(0, ref.n_steps, 50)
    o = ref.tool[k]
    axis = _unit(np.cross(o, [1.0, 0.0, 0.0]))
    theta = 10.0 / ARCSEC_PER_RAD
    tilted = o * math.cos(theta) + np.cross(axis, o) * math.sin(theta)
    err = tool_errors(ref.tip_m[k], tilted, path.tip_path, path.tool_at)
    np.testing.assert_allclose(err.orientation_error_arcsec, 10.0, rtol=1e-6)


def test_sampled_reference_matches_the_analytic_path():
    rng = np.random.default_rng(13)
    for name in ("five-axis-line", "five-axis-circle"):
        path = five_axis_path(name)
        ref = path.reference
        k = rng.integers(0, ref.n_steps, 100)
        tips = ref.tip_m[k] + 1e-4 * rng.standard_normal((100, 3))
        tools = _unit(ref.tool[k] + 1e-4 * rng.standard_normal((100, 3)))
        exact = tool_errors(tips, tools, path.tip_path, path.tool_at)
        sampled = tool_errors_from_samples(tips, tools, ref.tip_m, ref.tool)
        # the chord error of the polyline: r (1 − cos(Δθ / 2)) with Δθ ≤ peak feed T / r
        chord = 0.1 * (1 - math.cos(0.5 * 0.41 * 1e-3 / 0.1)) if name.endswith("circle") else 0
        np.testing.assert_allclose(
            sampled.contour_error_m, exact.contour_error_m, atol=chord + 1e-12
        )
        # a foot moved by ~ the chord error turns the reference tool by ~ chord / ‖p − X_c‖
        # (‖p − X_c‖ ≈ 1.14 m on the circle); allow twice that
        tol = 2 * chord / 1.1 * ARCSEC_PER_RAD + 1e-3
        np.testing.assert_allclose(
            sampled.orientation_error_arcsec, exact.orientation_error_arcsec, atol=tol
        )


def test_reference_polyline_drops_samples_at_rest():
    pts = np.array([[0, 0, 0], [0, 0, 0], [1, 0, 0], [1, 0, 0], [1, 1, 0]], dtype=float)
    poly, keep = reference_polyline(pts)
    assert keep.tolist() == [0, 2, 4]
    assert poly.total_length == pytest.approx(2.0)
    with pytest.raises(ValueError, match="does not move"):
        reference_polyline(np.zeros((5, 3)))


@pytest.mark.parametrize(
    "tip, tool",
    [
        (np.zeros((3, 2)), np.zeros((3, 2))),
        (np.zeros((3, 3)), np.ones((2, 3))),
        (np.full((3, 3), np.nan), np.ones((3, 3))),
    ],
)
def test_bad_input_is_refused(tip, tool):
    with pytest.raises(ValueError):
        tool_errors(tip, tool, line(X1, X2), lambda foot: np.ones_like(foot))


def test_zero_tool_vector_is_refused():
    with pytest.raises(ValueError, match="non-zero"):
        orientation_error_rad(np.zeros((1, 3)), np.ones((1, 3)))
