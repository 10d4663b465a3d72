"""Jee & Lee 2007 analysis: eq. (9) discretisation, Jury range of K_P (eqs. 16–17) against the
roots and a plant simulation, and the steady-state circle errors (eqs. 20–31) against the plant."""

import json
import math

import numpy as np
import pytest
from scipy import signal

from contour_env.analysis import (
    AxisModel,
    axial_gain_limit,
    axis_models,
    discretize_axis,
    format_stability_report,
    jury_stable,
    simulate_circle,
    simulate_step_response,
    stability_report,
    steady_state_prediction,
)
from contour_env.plants import Plant

TABLE1 = {"x": (121.0, 0.025), "y": (118.0, 0.03), "z": (83.0, 0.01)}
T = 1e-3


def _eq9(K, tau, T):
    """Jee eq. (9), written exactly as printed."""
    r = math.exp(-T / tau)
    return K * (T - tau + tau * r), K * (tau - tau * r - T * r), r


def _velocity_plant(K, tau, *, axes=("x", "y", "z"), T=1e-3):
    n = len(axes)
    return {
        "axes": list(axes),
        "mass": list(np.broadcast_to(np.asarray(tau) / np.asarray(K), n)),
        "viscous": list(np.broadcast_to(1.0 / np.asarray(K), n)),
        "force_limit": 1.0,
        "servo_period": T,
        "input_kind": "velocity-command",
    }


@pytest.fixture(scope="module")
def report():
    return stability_report("jee-triaxial")


# --------------------------------------------------------------------------- eq. 9


def test_axis_models_are_eq9_of_table1():
    models = axis_models("jee-triaxial")
    assert [m.name for m in models] == ["x", "y", "z"]
    for m in models:
        K, tau = TABLE1[m.name]
        H1, H0, r = _eq9(K, tau, T)
        assert m.K == pytest.approx(K, rel=1e-12) and m.tau == pytest.approx(tau, rel=1e-12)
        assert m.r == pytest.approx(r, rel=1e-14)
        assert m.H1 == pytest.approx(H1, rel=1e-10) and m.H0 == pytest.approx(H0, rel=1e-10)


def test_eq9_is_the_zoh_discretisation_of_K_over_s_taus_plus_1():
    for m in axis_models("jee-triaxial"):
        num, den, _ = signal.cont2discrete(([m.K], [m.tau, 1.0, 0.0]), T, method="zoh")
        num = np.trim_zeros(np.ravel(num), "f")
        np.testing.assert_allclose(den, np.polymul([1, -1], [1, -m.r]), rtol=1e-12)
        np.testing.assert_allclose(num, [m.H1, m.H0], rtol=1e-8)


def test_eq9_is_accurate_as_viscous_friction_vanishes():
    mass = 2.0
    # the double-integrator limit T²/(2m) and continuity across the series switch (T/τ = 1e-3)
    d = discretize_axis(mass, 1e-12, T)
    assert d["H0"] == pytest.approx(T**2 / (2 * mass), rel=1e-9)
    assert d["H1"] == pytest.approx(T**2 / (2 * mass), rel=1e-9)
    b_switch = 1e-3 * mass / T
    lo, hi = discretize_axis(mass, b_switch * (1 - 1e-9), T), discretize_axis(mass, b_switch, T)
    assert lo["H0"] == pytest.approx(hi["H0"], rel=1e-8)
    assert lo["H1"] == pytest.approx(hi["H1"], rel=1e-8)
    # agrees with scipy's ZOH (expm) for a small T/τ
    b = 1e-4
    d = discretize_axis(mass, b, T)
    num, _, _ = signal.cont2discrete(([1.0], [mass, b, 0.0]), T, method="zoh")
    np.testing.assert_allclose(np.trim_zeros(np.ravel(num), "f"), [d["H1"], d["H0"]], rtol=1e-6)


# --------------------------------------------------------------------------- Jury (eqs. 16-17)


def test_table1_limit_is_16_64_and_equals_eq17_of_the_x_axis(report):
    limit = axial_gain_limit("jee-triaxial")
    assert limit == pytest.approx(16.64, abs=0.005)
    H1, H0, r = _eq9(*TABLE1["x"], T)
    assert limit == pytest.approx((1 - r) / H0, rel=1e-9)
    assert report["axial_gain_limit_per_s"] == limit
    assert report["limiting_axis"] == "x"
    for ax in report["axes"]:
        H1, H0, r = _eq9(*TABLE1[ax["name"]], T)
        assert ax["kp_interval"][0] == 0.0
        assert ax["kp_interval"][1] == pytest.approx((1 - r) / H0, rel=1e-9)
        assert ax["binding_condition"] == "eq17_upper"


@pytest.mark.parametrize("name", ["x", "y", "z"])
def test_jury_interval_matches_the_roots(name):
    m = {m.name: m for m in axis_models("jee-triaxial")}[name]
    lo, hi = m.kp_interval()

    def rho(kp):
        return np.max(np.abs(np.roots(m.characteristic(kp))))

    assert rho(hi * (1 - 1e-6)) < 1 < rho(hi * (1 + 1e-6))
    assert rho(1e-6) < 1 < rho(-1e-6)
    assert lo == 0.0
    for kp in (-1.0, 1e-3, hi / 2, hi * 0.999, hi * 1.001, 3 * hi):
        assert jury_stable(m.characteristic(kp)) == (rho(kp) < 1)
        assert all(v > 0 for v in m.jury(kp).values()) == (rho(kp) < 1)


def test_omega1_at_minus1_binds_when_the_period_is_long_against_tau():
    """T/τ = 5: the Ω1(−1) > 0 condition, not eq. 17, gives the limit (all Jury conditions)."""
    m = AxisModel.from_mass_viscous("x", 2e-4 / 100.0, 1 / 100.0, 1e-3)
    lim = m.kp_limits()
    lo, hi = m.kp_interval()
    assert m.binding_condition() == "omega1_at_minus1_upper"
    assert hi == lim["omega1_at_minus1_upper"] < lim["eq17_upper"]
    rho = [np.max(np.abs(np.roots(m.characteristic(k)))) for k in (hi * 0.999, hi * 1.001)]
    assert rho[0] < 1 < rho[1]
    # the violated eq. 17 bound alone would have claimed stability
    assert np.max(np.abs(np.roots(m.characteristic(0.5 * (hi + lim["eq17_upper"]))))) > 1


def test_jury_table_agrees_with_roots_on_random_polynomials():
    rng = np.random.default_rng(3)
    for _ in range(400):
        n = int(rng.integers(1, 7))
        roots = rng.uniform(0.2, 1.3, n // 2) * np.exp(1j * rng.uniform(0, np.pi, n // 2))
        real = rng.uniform(-1.3, 1.3, n - 2 * (n // 2))
        all_roots = np.concatenate([roots, roots.conj(), real])
        coeffs = np.real(np.poly(all_roots)) * rng.uniform(0.5, 2.0) * rng.choice([-1, 1])
        rho = np.max(np.abs(all_roots))
        if abs(rho - 1) < 1e-6:
            continue
        assert jury_stable(coeffs) == (rho < 1), all_roots


# --------------------------------------------------------------------------- simulation


def test_simulation_confirms_stable_below_and_diverging_above(report):
    s = report["simulation"]
    limit = report["axial_gain_limit_per_s"]
    assert s["kp_below"] == pytest.approx(0.98 * limit) and s["kp_above"] == pytest.approx(
        1.02 * limit
    )
    assert s["stable_below"] and s["diverged_above"]
    assert s["growth_below"] < 0.8 and s["growth_above"] > 1.25
    # the envelope's exponential rate is the one of the dominant closed-loop root
    assert s["rate_below_per_s"] == pytest.approx(s["predicted_rate_below_per_s"], rel=0.1)
    assert s["rate_above_per_s"] == pytest.approx(s["predicted_rate_above_per_s"], rel=0.1)


def test_plant_closed_loop_equals_dlsim_of_eq9():
    kp = 12.0
    out = simulate_step_response("jee-triaxial", kp, duration_s=0.3, step_m=1e-5)
    for i, m in enumerate(axis_models("jee-triaxial")):
        n = out["time_s"].size
        _, y = signal.dlsim(m.closed_loop(kp), np.full(n, 1e-5))
        err_model = 1e-5 - np.ravel(y)
        assert np.max(np.abs(out["error_m"][:, 0, i] - err_model)) < 1e-13


def test_overflow_guard_stops_a_violently_unstable_loop():
    out = simulate_step_response("jee-triaxial", [100.0, 5.0], duration_s=2.0)
    assert out["stopped_at_s"][0] is not None and out["stopped_at_s"][1] is None
    assert np.all(np.isfinite(out["error_m"])) and out["growth"][0] > 1 > out["growth"][1]


# --------------------------------------------------------------------------- steady state


def test_steady_state_predicted_matches_simulated(report):
    rows = report["steady_state"]
    assert [r["feedrate_m_s"] for r in rows] == pytest.approx([5 / 60, 10 / 60, 20 / 60])
    assert report["kp_used"] == pytest.approx(0.5 * report["axial_gain_limit_per_s"])
    for r in rows:
        assert r["radius_m"] == 0.05
        assert r["contour_ratio"] == pytest.approx(1.0, abs=0.1)
        assert r["tracking_ratio"] == pytest.approx(1.0, abs=0.1)
        # tracking ≈ v/(K K_P) for the slower axis, contour well below tracking
        v_over_gain = r["feedrate_m_s"] / (118.0 * report["kp_used"]) * 1e6
        assert r["predicted_tracking_error_um"] == pytest.approx(v_over_gain, rel=0.05)
        assert r["predicted_contour_error_um"] < 0.25 * r["predicted_tracking_error_um"]
    contour = [r["simulated_contour_error_um"] for r in rows]
    assert contour[0] < contour[1] < contour[2]


def test_matched_axes_reduce_to_eqs_29_and_31():
    plant = _velocity_plant(121.0, 0.025)
    models = axis_models(plant)
    kp, R, F = 8.0, 0.05, 10 / 60
    p = steady_state_prediction(models, kp, R, F, plane=(1.0, 1.0, 1.0))
    H = models[0].closed_loop_response(kp, F / R)
    assert p["contour_error_m"] == pytest.approx(R * abs(abs(H) - 1), rel=1e-6)
    assert p["tracking_error_m"] == pytest.approx(R * abs(1 - H), rel=1e-9)
    # the lag d of eq. 18/32: −∠H/(ωT) periods, ≈ the velocity-error time 1/(K K_P) / T
    d = p["matched_formula"]["x"]["lag_steps_d"]
    assert d == pytest.approx(1 / (121.0 * kp) / T, rel=0.05)
    sim = simulate_circle(plant, kp, R, [F], plane=(1.0, 1.0, 1.0))[0]
    assert sim["contour_error_m"] == pytest.approx(p["contour_error_m"], rel=1e-3)
    assert sim["tracking_error_m"] == pytest.approx(p["tracking_error_m"], rel=1e-3)


def test_unmatched_axes_in_a_3d_plane_predicted_vs_simulated():
    kp, R, F = 8.0, 0.05, 10 / 60
    models = axis_models("jee-triaxial")
    p = steady_state_prediction(models, kp, R, F, plane=(1.0, 1.0, 1.0))
    s = simulate_circle("jee-triaxial", kp, R, [F], plane=(1.0, 1.0, 1.0))[0]
    assert s["contour_error_m"] == pytest.approx(p["contour_error_m"], rel=0.01)
    assert s["tracking_error_m"] == pytest.approx(p["tracking_error_m"], rel=0.01)
    # mismatched lags tilt the orbit: more contour error than any single axis' radial term
    radial = max(d["contour_error_m"] for d in p["matched_formula"].values())
    assert p["contour_error_m"] > radial


# --------------------------------------------------------------------------- custom plants


def test_custom_plant_gets_its_own_limit():
    plant = _velocity_plant(50.0, 0.02)
    H1, H0, r = _eq9(50.0, 0.02, T)
    limit = axial_gain_limit(plant)
    assert limit == pytest.approx((1 - r) / H0, rel=1e-9)
    assert abs(limit - 16.64) > 1.0
    rep = stability_report(plant, feedrates_m_s=(0.1, 0.2))
    assert rep["axial_gain_limit_per_s"] == pytest.approx(limit)
    assert rep["simulation"]["stable_below"] and rep["simulation"]["diverged_above"]
    for row in rep["steady_state"]:
        assert row["contour_ratio"] == pytest.approx(1.0, abs=0.1)
    json.dumps(rep, allow_nan=False)


def test_force_input_plant_is_allowed():
    plant = Plant(
        {"axes": ["x", "y"], "mass": [20.0, 15.0], "viscous": [400.0, 300.0],
         "force_limit": 5000.0, "servo_period": 1e-3}
    )  # fmt: skip
    rep = stability_report(plant, feedrates_m_s=(0.05,), radius_m=0.02)
    assert rep["input_kind"] == "force" and "N/m" in rep["kp_units"]
    m = axis_models(plant)[0]
    H1, H0, r = _eq9(1 / 400.0, 20.0 / 400.0, 1e-3)
    assert rep["axes"][0]["kp_interval"][1] == pytest.approx((1 - r) / H0, rel=1e-9)
    assert m.K == pytest.approx(1 / 400.0)
    assert rep["simulation"]["stable_below"] and rep["simulation"]["diverged_above"]


# --------------------------------------------------------------------------- report and errors


def test_report_is_json_and_prints(report):
    text = json.dumps(report, allow_nan=False)
    back = json.loads(text)
    for key in ("plant", "servo_period_s", "axes", "axial_gain_limit_per_s", "simulation",
                "kp_used", "steady_state"):  # fmt: skip
        assert key in back
    for ax in back["axes"]:
        assert {"K", "tau", "H1", "H0", "r", "kp_interval"} <= set(ax)
    row_keys = {
        "feedrate_m_s", "radius_m", "predicted_contour_error_um", "simulated_contour_error_um",
        "predicted_tracking_error_um", "simulated_tracking_error_um", "contour_ratio",
        "tracking_ratio",
    }  # fmt: skip
    assert all(row_keys <= set(r) for r in back["steady_state"])
    out = format_stability_report(report)
    assert "16.63985" in out and "stable" in out and "diverging" in out


def test_bad_input():
    with pytest.raises(ValueError, match="known plants: .*jee-triaxial"):
        stability_report("no-such-plant")
    with pytest.raises(ValueError, match="viscous"):
        axis_models({"axes": ["x", "y"], "mass": 1.0, "viscous": [0.0, 1.0],
                     "force_limit": 1.0, "servo_period": 1e-3})  # fmt: skip
    with pytest.raises(ValueError, match="viscous"):
        discretize_axis(1.0, 0.0, 1e-3)
    with pytest.raises(ValueError, match="kp"):
        stability_report("jee-triaxial", kp=17.0)
    with pytest.raises(ValueError, match="kp"):
        stability_report("jee-triaxial", kp=-1.0)
    with pytest.raises(ValueError, match="feedrates_m_s"):
        stability_report("jee-triaxial", feedrates_m_s=(0.1, -0.1))
    with pytest.raises(ValueError, match="radius_m"):
        stability_report("jee-triaxial", radius_m=0.0)
    with pytest.raises(ValueError, match="plane"):
        stability_report("jee-triaxial", plane="xw")
    with pytest.raises(ValueError, match="computation_delay"):
        axis_models(Plant("jee-triaxial").params)  # the realistic plant has a delay
    with pytest.raises(ValueError, match="servo_period"):
        discretize_axis(1.0, 1.0, 0.0)


def test_realistic_plant_with_delay_is_flagged_not_overflowed():
    """Eq. (9) has no computation delay: the realistic plant's one-period delay makes even
    0.98 × limit unstable; the report says so and stays finite (no overflow, no NaN)."""
    rep = stability_report("jee-triaxial", ideal=False, feedrates_m_s=(10 / 60,))
    assert rep["axial_gain_limit_per_s"] == pytest.approx(16.64, abs=0.005)  # nominal model
    assert not rep["simulation"]["stable_below"] and rep["simulation"]["diverged_above"]
    row = rep["steady_state"][0]
    assert row["simulation_diverged"] and row["simulated_contour_error_um"] is None
    assert "computation delay" in rep["notes"]
    json.dumps(rep, allow_nan=False)
    assert "diverged" in format_stability_report(rep)
