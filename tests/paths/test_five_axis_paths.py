"""The paper's five-axis test paths (Chen, Khong & Hsieh 2022, §4): geometry, feed, tool
vectors, joint reference and the algebraic path functions of the equivalent errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contour_env.paths.five_axis import (
    FIVE_AXIS_PATHS,
    FiveAxisPath,
    feed_jerk,
    five_axis_path,
)
from contour_env.plants.five_axis import FiveAxisPlant, drift_and_gain, forward

X1 = np.array([0.08, 0.03, 0.02])
X2 = np.array([0.01, 0.05, 0.07])


@pytest.fixture(scope="module", params=FIVE_AXIS_PATHS)
def path(request) -> FiveAxisPath:
    return five_axis_path(request.param)


@pytest.fixture(scope="module")
def line_path() -> FiveAxisPath:
    return five_axis_path("five-axis-line")


@pytest.fixture(scope="module")
def circle_path() -> FiveAxisPath:
    return five_axis_path("five-axis-circle")


def _random_joints(path, n, seed):
    # poses near the reference (within a few mm / mrad), where the path functions are used
    rng = np.random.default_rng(seed)
    k = rng.integers(0, path.reference.n_steps, n)
    scale = np.array([3e-3, 3e-3, 3e-3, 5e-3, 5e-3])
    return path.reference.joints[k] + scale * rng.standard_normal((n, 5))


# ------------------------------------------------------------------------- geometry, feed


def test_duration_and_sampling(path):
    ref = path.reference
    assert ref.servo_period_s == 1e-3
    assert ref.n_steps == 2351
    assert path.profile.duration == pytest.approx(2.35, abs=1e-12)
    np.testing.assert_allclose(ref.time_s, np.arange(2351) * 1e-3)


def test_line_endpoints_and_straightness(line_path):
    tip = line_path.reference.tip_m
    np.testing.assert_allclose(tip[0], X1, atol=1e-15)
    np.testing.assert_allclose(tip[-1], X2, atol=1e-12)
    u = (X2 - X1) / np.linalg.norm(X2 - X1)
    rel = tip - X1
    off_line = rel - (rel @ u)[:, None] * u
    assert np.abs(off_line).max() < 1e-15
    assert np.all(np.diff(rel @ u) >= 0)  # monotone from X1 to X2


def test_circle_radius_plane_and_closure(circle_path):
    tip = circle_path.reference.tip_m
    np.testing.assert_allclose(np.linalg.norm(tip, axis=1), 0.1, atol=1e-15)
    np.testing.assert_allclose(tip[:, 1], tip[:, 2], atol=1e-15)  # the 45° plane y = z
    np.testing.assert_allclose(tip[:, 0] ** 2 + 2 * tip[:, 1] ** 2, 0.01, atol=1e-15)
    np.testing.assert_allclose(tip[0], [0.1, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(tip[-1], [0.1, 0.0, 0.0], atol=1e-12)
    # the plane is tilted 45° from the xy plane about x
    normal = np.cross(tip[300] - tip[0], tip[900] - tip[0])
    tilt = math.degrees(math.acos(abs(normal[2]) / np.linalg.norm(normal)))
    assert tilt == pytest.approx(45.0, abs=1e-9)


def test_s_curve_starts_and_ends_at_rest_and_is_smooth(path):
    ref = path.reference
    v, a = ref.feedrate_m_s, ref.feed_accel_m_s2
    assert v[0] == 0 and v[-1] == 0 and a[0] == 0 and a[-1] == 0
    assert np.all(v >= 0)
    a_max, j_max = np.abs(a).max(), np.abs(ref.feed_jerk_m_s3).max()
    # continuous velocity and acceleration: one sample changes them by at most a T, j T
    T = ref.servo_period_s
    assert np.abs(np.diff(v)).max() <= a_max * T * (1 + 1e-9)
    assert np.abs(np.diff(a)).max() <= j_max * T * (1 + 1e-9)
    # S-type: accelerate, cruise, decelerate over thirds of the 2.35 s
    third = ref.n_steps // 3
    assert np.all(np.diff(v[: third - 1]) > 0)
    assert np.ptp(v[third + 2 : 2 * third - 2]) < 1e-12
    # the arc length is the integral of the feed
    s_trap = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * T)])
    np.testing.assert_allclose(s_trap, ref.arc_length_m, atol=1e-6)
    assert ref.arc_length_m[-1] == pytest.approx(path.tip_path.total_length, abs=1e-12)


def test_feed_jerk_is_the_derivative_of_the_acceleration(path):
    t = np.linspace(0.0, 2.35, 4001)
    h = 1e-6
    _, _, a_plus = path.profile.sample(t + h)
    _, _, a_minus = path.profile.sample(t - h)
    jerk = feed_jerk(path.profile, t)
    fd = (a_plus - a_minus) / (2 * h)
    ta = path.profile.sections[0].ramp_time
    smooth = np.min(np.abs(t[:, None] - np.array([0, ta, 2.35 - ta, 2.35])[None]), axis=1) > 2 * h
    np.testing.assert_allclose(jerk[smooth], fd[smooth], atol=1e-5 * np.abs(jerk).max())


# ------------------------------------------------------------------ tool and joint reference


def test_tool_points_at_xc(path):
    ref = path.reference
    d = ref.tip_m - path.xc_m
    np.testing.assert_allclose(np.linalg.norm(ref.tool, axis=1), 1.0, atol=1e-15)
    assert np.abs(np.cross(d, ref.tool)).max() < 1e-15
    assert np.all(np.einsum("ij,ij->i", d, ref.tool) > 0)  # from X_c through the tip


def test_joint_reference_reproduces_tip_and_tool(path):
    ref = path.reference
    tip, tool = forward(ref.joints, path.geometry)
    assert np.abs(tip - ref.tip_m).max() < 1e-12
    assert np.abs(tool - ref.tool).max() < 1e-12
    path.geometry.check_joint(ref.joints)  # within the travel
    assert np.abs(np.diff(ref.joints[:, 4])).max() < 1e-2  # C unwrapped: no 2π jumps


def test_joint_time_derivatives_match_finite_differences(path):
    ref = path.reference
    T = ref.servo_period_s
    fd_rate = (ref.joints[2:] - ref.joints[:-2]) / (2 * T)
    fd_accel = (ref.joint_rate[2:] - ref.joint_rate[:-2]) / (2 * T)
    fd_jerk = (ref.joint_accel[2:] - ref.joint_accel[:-2]) / (2 * T)
    scale = np.abs(ref.joint_rate).max(axis=0)
    assert np.all(np.abs(fd_rate - ref.joint_rate[1:-1]).max(axis=0) < 1e-4 * scale)
    scale = np.abs(ref.joint_accel).max(axis=0)
    assert np.all(np.abs(fd_accel - ref.joint_accel[1:-1]).max(axis=0) < 2e-3 * scale)
    # the jerk away from the S-curve's phase changes (where s⃛ jumps)
    ta = path.profile.sections[0].ramp_time
    t = ref.time_s[1:-1]
    edges = np.array([0.0, ta, 2.35 - ta, 2.35])
    smooth = np.min(np.abs(t[:, None] - edges[None]), axis=1) > 1.5 * T
    scale = np.abs(ref.joint_jerk).max(axis=0)
    err = np.abs(fd_jerk[smooth] - ref.joint_jerk[1:-1][smooth]).max(axis=0)
    assert np.all(err < 2e-3 * scale)


# ------------------------------------------------------------------------- path functions


def test_contour_errors_vanish_on_the_reference(path):
    eps = path.contour_errors(path.reference.joints)
    assert eps.shape == (path.reference.n_steps, 4)
    assert np.abs(eps).max() < 1e-9


def test_line_functions_are_the_papers_eq_13(line_path):
    q = _random_joints(line_path, 50, seed=1)
    tip, _ = forward(q, line_path.geometry)
    x, y, z = tip.T
    eps = line_path.contour_errors(q)
    np.testing.assert_allclose(eps[:, 0], 2 / 7 * x + y - 37 / 700, atol=1e-15)
    np.testing.assert_allclose(eps[:, 1], y - 2 / 5 * z - 11 / 500, atol=1e-15)


def test_circle_and_tool_functions(circle_path):
    q = _random_joints(circle_path, 50, seed=2)
    tip, _ = forward(q, circle_path.geometry)
    x, y, z = tip.T
    xc = circle_path.xc_m
    eps = circle_path.contour_errors(q)
    np.testing.assert_allclose(eps[:, 0], x**2 + 2 * y**2 - 0.01, atol=1e-15)
    np.testing.assert_allclose(eps[:, 1], y - z, atol=1e-15)
    a, c = q[:, 3], q[:, 4]
    np.testing.assert_allclose(eps[:, 2], (x - xc[0]) * np.cos(c) - (y - xc[1]) * np.sin(c))
    dist2 = np.sum((tip - xc) ** 2, axis=1)
    np.testing.assert_allclose(eps[:, 3], (z - xc[2]) ** 2 - dist2 * np.cos(a) ** 2)


def test_tool_functions_vanish_only_when_the_tool_points_at_xc(line_path):
    # at the reference pose, tilt A (or turn C) alone: the tool leaves X_c, ε₃ / ε₄ ≠ 0
    q = line_path.reference.joints[1000].copy()
    for j in (3, 4):
        moved = q.copy()
        moved[j] += 1e-3
        eps = line_path.contour_errors(moved)
        assert np.abs(eps[2:]).max() > 1e-6


def test_jacobian_matches_central_differences(path):
    q = _random_joints(path, 20, seed=3)
    jac = path.contour_jacobian(q)
    assert jac.shape == (20, 4, 5)
    h = 1e-6
    fd = np.empty_like(jac)
    for i in range(5):
        dq = np.zeros(5)
        dq[i] = h
        fd[:, :, i] = (path.contour_errors(q + dq) - path.contour_errors(q - dq)) / (2 * h)
    np.testing.assert_allclose(jac, fd, rtol=1e-6, atol=1e-9)


def test_hessian_term_matches_second_differences(path):
    rng = np.random.default_rng(4)
    q = _random_joints(path, 20, seed=5)
    qd = rng.standard_normal((20, 5)) * np.array([0.05, 0.05, 0.05, 0.5, 0.5])
    h_term = path.contour_hessian_term(q, qd)
    step = 1e-4
    fd = (
        path.contour_errors(q + step * qd)
        - 2 * path.contour_errors(q)
        + path.contour_errors(q - step * qd)
    ) / step**2
    np.testing.assert_allclose(h_term, fd, rtol=1e-5, atol=1e-7)


def test_jacobian_has_full_rank_and_the_tangent_in_its_null_space(path):
    ref = path.reference
    for k in (0, 700, 1500, 2350):
        jac = path.contour_jacobian(ref.joints[k])
        assert np.linalg.matrix_rank(jac) == 4
        t = ref.joints_ds[k]
        assert np.abs(jac @ t).max() < 1e-9 * np.abs(jac).max() * np.linalg.norm(t)


@pytest.mark.parametrize("floor", [0.0, 0.004])
def test_error_dynamics_predict_the_second_difference_of_eta(path, floor):
    """η̈ = Ω + Γ u (eq. 7) against η sampled along ξ(t) = ξ + ξ̇ τ + ½ ξ̈ τ² at k − 1, k, k + 1."""
    rng = np.random.default_rng(6)
    ref = path.reference
    inertia = FiveAxisPlant("nxv560a", ideal=True).nominal.inertia
    T = ref.servo_period_s
    for k in (400, 1200, 2000):
        q = ref.joints[k] + 1e-3 * rng.standard_normal(5)
        qd = ref.joint_rate[k] + 1e-2 * rng.standard_normal(5)
        u = rng.standard_normal(5) * np.array([500.0, 500.0, 5000.0, 50.0, 20.0])
        f, gain = drift_and_gain(q, qd, inertia)
        qdd = f + gain @ u
        omega, gamma = path.error_dynamics(q, qd, k, f, gain, tangent_floor_m_s=floor)
        eta = []
        for step in (-1, 0, 1):
            tau = step * T
            e, _ = path.equivalent_errors(
                q + qd * tau + 0.5 * qdd * tau**2, qd + qdd * tau, k + step, floor
            )
            eta.append(e)
        fd = (eta[2] - 2 * eta[1] + eta[0]) / T**2
        np.testing.assert_allclose(omega + gamma @ u, fd, rtol=2e-3, atol=1e-9)
        # and η̇ against the first difference
        _, eta_dot = path.equivalent_errors(q, qd, k, floor)
        np.testing.assert_allclose(eta_dot, (eta[2] - eta[0]) / (2 * T), rtol=5e-3, atol=1e-9)


def test_tangential_error_is_the_papers_with_no_floor(line_path):
    ref = line_path.reference
    k = 1000
    q = ref.joints[k] + 1e-4
    e, _ = line_path.tangential_error(q, ref.joint_rate[k], k)
    assert e == pytest.approx(ref.joint_rate[k] @ (q - ref.joints[k]), rel=1e-12)
    w0, _, _ = line_path.tangent_weights(0)
    assert np.all(w0 == 0)  # the paper's weight vanishes at rest
    w0, _, _ = line_path.tangent_weights(0, tangent_floor_m_s=0.01)
    assert np.linalg.norm(w0) > 0


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(name="five-axis-helix"),
        dict(name="five-axis-line", ramp_fraction=0.5),
        dict(name="five-axis-line", duration_s=-1.0),
        dict(name="five-axis-line", servo_period_s=0.0),
        dict(name="five-axis-line", geometry="nxv560a"),
    ],
)
def test_bad_arguments_are_refused(kwargs):
    with pytest.raises(ValueError):
        five_axis_path(**kwargs)


def test_settle_time_holds_the_end_pose():
    p = five_axis_path("five-axis-line", settle_time_s=0.1)
    ref = p.reference
    assert ref.n_steps == 2451
    assert np.ptp(ref.joints[-100:], axis=0).max() == 0.0
    assert np.all(ref.joint_rate[-100:] == 0)
