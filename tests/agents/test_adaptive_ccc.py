"""Adaptive CCC: coupling gains reach the law, Γ by the τ_a rule, adaptation on the payload case
(issue 13), boundedness with the structural mode."""

import math

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller
from agents.adaptive_ccc import (
    DEFAULT_TAU_A_S,
    TUNING_CIRCLE,
    tuning_excitation,
)
from agents.compare import compare
from contour_env import ENV_ID
from contour_env.app.cli import main
from contour_env.evaluation import run_episode
from contour_env.metrics import score
from contour_env.paths import circle
from contour_env.plants import Plant

PAYLOAD = 1.3


def _signals(n, rng, *, curvature=0.0, torsion=0.0, feedrate=0.0, frame=None):
    """Batched (B = 1) servo signals at a frozen path point, random reference and errors."""
    if frame is None:
        q, _ = np.linalg.qr(rng.normal(size=(n, n)))
        frame = q
    return {
        "reference_position": rng.normal(scale=1e-2, size=(1, n)),
        "measured_position": rng.normal(scale=1e-2, size=(1, n)),
        "reference_velocity": rng.normal(scale=0.2, size=(1, n)),
        "measured_velocity": rng.normal(scale=0.2, size=(1, n)),
        "reference_acceleration": rng.normal(size=(1, n)),
        "frame": np.asarray(frame, dtype=float)[None],
        "curvature": np.array([curvature]),
        "torsion": np.array([torsion]),
        "feedrate": np.array([feedrate]),
    }


def _jacobians(ctrl, sig, h=1e-7):
    """dT/dE and dT/dĖ of act() by central differences (θ̂ restored around every call)."""
    n = ctrl.n_axes
    theta = ctrl.theta_hat.copy()

    def T(dpos, dvel):
        s = dict(sig)
        s["measured_position"] = sig["measured_position"] - dpos  # E = x_d − x grows by dpos
        s["measured_velocity"] = sig["measured_velocity"] - dvel
        ctrl.theta_hat[:] = theta
        out = ctrl.act(s)[0]
        ctrl.theta_hat[:] = theta
        return out

    dE = np.empty((n, n))
    dEd = np.empty((n, n))
    for j in range(n):
        e = np.zeros((1, n))
        e[0, j] = h
        dE[:, j] = (T(e, 0 * e) - T(-e, 0 * e)) / (2 * h)
        dEd[:, j] = (T(0 * e, e) - T(0 * e, -e)) / (2 * h)
    return dE, dEd


@pytest.mark.parametrize(
    "plant, spec",
    [
        ("hsm2", "adaptive-ccc"),
        ("hsm2", "adaptive-ccc:c=1e5/4e5"),
        ("hsm2", "adaptive-ccc:kv_rho=2.3e4/1.7e5"),
        ("hsm2", "adaptive-ccc:kv_rho=2e4/3e4:c=5e4/0"),
        ("friction-table", "adaptive-ccc:c=3e3/0"),
        ("jee-triaxial", "adaptive-ccc:c=0.02/0.03/0.01"),
    ],
)
def test_loop_gains_are_the_exact_linearisation_of_act(plant, spec):
    rng = np.random.default_rng(0)
    ctrl = make_controller(spec).configure_for(Plant(plant))
    n = ctrl.n_axes
    for curvature, torsion, feed in [(0.0, 0.0, 0.3), (10.0, 0.0, 0.4), (-16.7, 2.0, 0.2)]:
        if n == 2:
            torsion = 0.0
        sig = _signals(n, rng, curvature=curvature, torsion=torsion, feedrate=feed)
        A0, A1, A2 = ctrl.loop_gains(sig["frame"][0], curvature, torsion, feed)
        dE, dEd = _jacobians(ctrl, sig)
        np.testing.assert_allclose(dE, A0, rtol=1e-6, atol=1e-6 * np.abs(A0).max())
        np.testing.assert_allclose(dEd, A1, rtol=1e-6, atol=1e-6 * np.abs(A1).max())
        np.testing.assert_array_equal(A2, 0.0)


def test_coupling_parameters_set_lees_kv_over_rho_on_a_circle():
    plant = Plant("hsm2")
    rho, v = 0.1, 0.4
    t = np.array([0.6, 0.8])
    frame = np.column_stack([t, [-t[1], t[0]]])
    J = np.array([[0.0, 1.0], [-1.0, 0.0]])
    default = make_controller("adaptive-ccc").configure_for(plant)
    np.testing.assert_array_equal(default.coupling, default.k)  # today's behaviour
    for spec, kv_rho in [
        ("adaptive-ccc", default.k * v / rho),
        ("adaptive-ccc:c=1e5/4e5", np.array([1e5, 4e5]) * v / rho),
        ("adaptive-ccc:kv_rho=422/1359", np.array([422.0, 1359.0])),  # Lee's eq. 39 form
    ]:
        c = make_controller(spec).configure_for(plant)
        A0, K, _ = c.loop_gains(frame, 1 / rho, 0.0, v)
        # eq. 39: diag((kv/ρ)_1, (kv/ρ)_2) [x_d2 − x_2, −(x_d1 − x_1)]
        np.testing.assert_allclose(A0 - c.alpha * K - np.eye(2), kv_rho[:, None] * J, rtol=1e-12)
        # clockwise: the sign turns; a straight line: no coupling
        A0cw, _, _ = c.loop_gains(frame, -1 / rho, 0.0, v)
        np.testing.assert_allclose(A0cw - c.alpha * K - np.eye(2), -kv_rho[:, None] * J)
        A0line, _, _ = c.loop_gains(frame, 0.0, 0.0, v)
        np.testing.assert_allclose(A0line, c.alpha * K + np.eye(2))
    # Lee's constant form does not scale with the feed
    lee = make_controller("adaptive-ccc:kv_rho=422/1359").configure_for(plant)
    np.testing.assert_array_equal(lee.coupling, 0.0)
    a, _, _ = lee.loop_gains(frame, 1 / rho, 0.0, v)
    b, _, _ = lee.loop_gains(frame, 1 / rho, 0.0, 2 * v)
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="2-axis"):
        make_controller("adaptive-ccc:kv_rho=1").configure_for(Plant("jee-triaxial"))


def test_gamma_rule_and_its_parameters():
    plant = Plant("hsm2")
    c = make_controller("adaptive-ccc").configure_for(plant)
    a2, v2 = tuning_excitation(*TUNING_CIRCLE["hsm2"])
    R, v = TUNING_CIRCLE["hsm2"]
    assert a2 == pytest.approx((v**2 / R) ** 2 / 2) and v2 == pytest.approx(v**2 / 2)
    n = c.n_axes
    # θ = [m, b, f_c] from the nominal model (f_c = 0: the paper gives none for hsm2)
    assert c.friction
    nom = c.nominal
    np.testing.assert_array_equal(c.theta0, [*nom.mass_kg, *nom.viscous_Ns_m, 0.0, 0.0])
    np.testing.assert_allclose(c.Gamma[:n], c.k / (DEFAULT_TAU_A_S * a2))
    np.testing.assert_allclose(c.Gamma[n : 2 * n], c.k / (DEFAULT_TAU_A_S * v2))
    np.testing.assert_allclose(c.Gamma[2 * n :], c.k / DEFAULT_TAU_A_S)  # ⟨sgn²⟩ = 1
    slow = make_controller("adaptive-ccc:tau_a=2").configure_for(plant)
    np.testing.assert_allclose(slow.Gamma, c.Gamma * DEFAULT_TAU_A_S / 2)
    only_b = make_controller("adaptive-ccc:gamma_m=0").configure_for(plant)
    np.testing.assert_array_equal(only_b.Gamma[:n], 0.0)
    np.testing.assert_allclose(only_b.Gamma[n:], c.Gamma[n:])
    off = make_controller("adaptive-ccc:gamma=0").configure_for(plant)
    assert off.gamma == (0.0, 0.0)
    np.testing.assert_array_equal(off.Gamma, 0.0)
    # the nominal Coulomb friction is θ̂_c(0) where the model has it; friction=0: Lee's θ
    ft = make_controller("adaptive-ccc").configure_for(Plant("friction-table"))
    np.testing.assert_array_equal(ft.theta0[-2:], ft.nominal.coulomb_N)
    lee = make_controller("adaptive-ccc:friction=0").configure_for(Plant("friction-table"))
    assert not lee.friction and lee.theta0.size == 2 * lee.n_axes and lee.Gamma.size == 4
    off_ft = make_controller("adaptive-ccc:gamma=0").configure_for(Plant("friction-table"))
    np.testing.assert_array_equal(off_ft.Gamma, 0.0)


def _synthetic_decay(spec, column, scale=1.0, periods=3):
    """Drive act() with the quasi-static closed loop F r = Y_d θ̃ / k of one parameter on the
    hsm2 tuning circle's per-axis motion (amplitude × ``scale``); θ̃(t) / θ̃(0) per axis."""
    c = make_controller(spec).configure_for(Plant("hsm2"))
    n = c.n_axes
    R, v = TUNING_CIRCLE["hsm2"]
    w = v / R
    dt = c.servo_period_s
    steps = int(round(periods * 2 * math.pi / w / dt))
    theta_true = c.theta0 * 1.3
    theta_true[2 * n :] = 30.0  # Coulomb friction, N (the nominal f_c of hsm2 is 0)
    out = np.empty((steps + 1, n))
    idx = slice(column * n, (column + 1) * n)
    out[0] = 1.0
    for i in range(steps):
        t = i * dt
        x_acc = -scale * R * w**2 * math.sin(w * t) * np.ones(n)
        x_vel = scale * R * w * math.cos(w * t) * np.ones(n)
        tilde = np.zeros_like(theta_true)
        tilde[idx] = (theta_true - c.theta_hat[0])[idx]  # the other parameters are right
        phi = [x_acc, x_vel, np.sign(x_vel)][: c.n_columns]
        y_theta = sum(tilde[j * n : (j + 1) * n] * phi[j] for j in range(c.n_columns))
        sig = {
            "reference_position": np.zeros((1, n)),
            "measured_position": np.zeros((1, n)),
            "reference_velocity": x_vel[None],
            # F r = Y_d θ̃ / k (the law compares with ẋ_d − ẍ_d T/2: backward difference)
            "measured_velocity": (x_vel - 0.5 * dt * x_acc - y_theta / c.k)[None],
            "reference_acceleration": x_acc[None],
            "frame": np.eye(n)[None],
            "curvature": np.zeros(1),
            "torsion": np.zeros(1),
            "feedrate": np.zeros(1),
        }
        c.act(sig)
        out[i + 1] = (theta_true - c.theta_hat[0])[idx] / (theta_true - c.theta0)[idx]
    return out, dt, w, c


@pytest.mark.parametrize("column", [0, 1, 2])
def test_gamma_rule_gives_tau_a_on_a_synthetic_regression(column):
    # one parameter wrong (the others right): θ̃ = θ̃₀ exp(−∫ Γ φ² / k dt), and with
    # Γ = k / (τ_a ⟨φ²⟩): exp(−(t ∓ sin(2ωt)/(2ω)) / τ_a) for m (ẍ_d ∝ sin) and b (ẋ_d ∝ cos),
    # exp(−t/τ_a) for f_c (sgn² = 1); the default law, normalisation included (ψ² = 3 here)
    spec = "adaptive-ccc:gamma_b=0" if column == 0 else "adaptive-ccc:gamma_m=0"
    tau = DEFAULT_TAU_A_S
    ratio, dt, w, _ = _synthetic_decay(spec, column)
    t = np.arange(ratio.shape[0]) * dt
    sign = (-1.0, 1.0, 0.0)[column]
    expected = np.exp(-(t + sign * np.sin(2 * w * t) / (2 * w)) / tau)
    for ax in range(ratio.shape[1]):
        np.testing.assert_allclose(ratio[:, ax], expected, atol=5e-3)
    # over whole periods: exactly exp(−t/τ_a)
    period = int(round(2 * math.pi / w / dt))
    assert ratio[period, 0] == pytest.approx(math.exp(-period * dt / tau), rel=1e-2)


def test_normalisation_keeps_tau_a_on_stronger_excitation():
    # Lee's θ = [m, b], 5× the tuning amplitude at the same frequency: unnormalised the rate
    # is 25× (τ_a/25); normalised (n² = ψ²/2 = 25) it stays 1/τ_a
    spec = "adaptive-ccc:friction=0:gamma_b=0"
    ratio, dt, w, _ = _synthetic_decay(spec, 0, scale=5.0, periods=1)
    period = ratio.shape[0] - 1
    assert ratio[period, 0] == pytest.approx(math.exp(-period * dt / DEFAULT_TAU_A_S), rel=2e-2)
    raw, dt, w, _ = _synthetic_decay(spec + ":norm=0", 0, scale=5.0, periods=1)
    assert raw[period // 8, 0] < 0.05  # 25× faster: gone in an eighth of a period


def _tuning_circle_mass_errors(spec):
    """Relative mass-estimate errors over 3 revolutions of hsm2's tuning circle (not a named
    case) on the ideal plant carrying 1.2× its mass."""
    R, v = TUNING_CIRCLE["hsm2"]
    true = Plant("hsm2", ideal=True, true_scale={"mass_kg": 1.2}).params
    path = circle((0, 0, 0), R, normal=(0, 0, 1), start_angle=0.0, sweep=6 * math.pi)
    env = gym.make(ENV_ID, plant="hsm2", path=path, feedrate_m_s=v, ideal=True, plant_params=[true])
    c = make_controller(spec).bind(env)
    trace = []
    act = c.act

    def traced(signals):
        out = act(signals)
        trace.append(c.theta_hat[0, :2].copy())
        return out

    c.act = traced
    run_episode(env, c)
    err = (1.2 * c.theta0[:2] - np.array(trace)) / (0.2 * c.theta0[:2])
    return err, np.arange(len(trace)) * c.servo_period_s


def test_rule_holds_on_the_tuning_circle_closed_loop():
    # the real closed loop, the mass adapting alone: its errors decay with τ_a (± 20 %)
    err, t = _tuning_circle_mass_errors("adaptive-ccc:gamma_b=0")
    sel = (t > 0.4) & (t < 2.4)
    for ax in range(2):
        tau = -1 / np.polyfit(t[sel], np.log(np.abs(err[sel, ax])), 1)[0]
        assert 0.8 * DEFAULT_TAU_A_S < tau < 1.2 * DEFAULT_TAU_A_S, (ax, tau)
    # the default (m, b, f_c adapting together): within 1 % of the mass from 2 s on
    err, t = _tuning_circle_mass_errors("adaptive-ccc")
    assert np.all(np.abs(err[t >= 2.0]) < 0.05)


def test_payload_case_is_a_case_of_every_env_and_the_cli(capsys):
    env = gym.make(ENV_ID, case="hsm2-payload")
    plant = env.unwrapped.plant
    np.testing.assert_allclose(plant.params.mass_kg / plant.nominal.mass_kg, PAYLOAD)
    ref = gym.make(ENV_ID, case="hsm2-circle-II").unwrapped
    # case II's path and feed; every other realistic effect kept
    np.testing.assert_array_equal(
        env.unwrapped.setup.reference.position, ref.setup.reference.position
    )
    for field in ("viscous_Ns_m", "coulomb_N", "static_N", "ripple_amplitude_N"):
        np.testing.assert_array_equal(
            getattr(plant.params, field), getattr(ref.plant.params, field)
        )
    assert plant.params.computation_delay
    venv = gym.make_vec(
        ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", case="hsm2-payload"
    )
    core = venv.core if hasattr(venv, "core") else venv.unwrapped.core
    np.testing.assert_allclose(core.setup.plant.params.mass_kg, plant.params.mass_kg)
    sm = gym.make(ENV_ID, case="hsm2-payload", structural_mode=True).unwrapped.plant.params
    np.testing.assert_allclose(sm.mass_kg, plant.params.mass_kg)
    assert sm.has_structural_mode
    # the payload belongs to the case's plant: another plant on the same path has none
    other = gym.make(ENV_ID, case="hsm2-payload", plant="friction-table").unwrapped.plant
    assert not np.allclose(other.params.mass_kg / other.nominal.mass_kg, PAYLOAD)
    assert main(["cases", "-v"]) == 0
    out = capsys.readouterr().out
    assert "hsm2-payload" in out and "not in the paper" in out


def _run(spec, **env_kw):
    env = gym.make(ENV_ID, **env_kw)
    c = make_controller(spec).bind(env)
    m = score(run_episode(env, c))
    return m, c


def test_theta_converges_toward_the_payload_and_gamma_zero_keeps_it_fixed():
    _, c = _run("adaptive-ccc", case="hsm2-payload")
    n = c.n_axes
    ratio = c.theta_hat[0, :n] / c.theta0[:n]
    assert np.all(ratio > 1.2) and np.all(ratio < PAYLOAD + 0.05), ratio
    _, off = _run("adaptive-ccc:gamma=0", case="hsm2-payload")
    np.testing.assert_array_equal(off.theta_hat[0], off.theta0)


def test_payload_acceptance_adaptation_cuts_rms_at_equal_effort():
    # issue 13: Γ from the rule (τ_a, tuning circle), not tuned on this case
    res = compare(["adaptive-ccc", "adaptive-ccc:gamma=0"], case="hsm2-payload")["results"]
    by = {r["controller"]: r for r in res}
    on, off = by["adaptive-ccc"], by["adaptive-ccc:gamma=0"]
    assert on["stable"] and off["stable"]
    assert on["rms_contour_error_um"] <= 0.7 * off["rms_contour_error_um"]
    ratio = np.asarray(on["rms_effort"]) / np.asarray(off["rms_effort"])
    assert np.all(np.abs(ratio - 1) <= 0.10), ratio


@pytest.mark.parametrize(
    "case", ["hsm2-circle-I", "hsm2-circle-III", "hsm2-payload", "sharp-corner"]
)
def test_default_adaptation_is_bounded_with_the_structural_mode(case):
    m, c = _run("adaptive-ccc", case=case, structural_mode=True)
    assert m["completed"], m["termination_reason"]
    assert m["max_contour_error_um"] < 200
    assert m["saturation_fraction"] == 0.0
    th = c.theta_hat[0]
    assert np.all(np.isfinite(th))
    n = c.n_axes
    assert np.all(th[:n] < 4 * c.theta0[:n])
    off, _ = _run("adaptive-ccc:gamma=0", case=case, structural_mode=True)
    assert m["rms_contour_error_um"] <= off["rms_contour_error_um"]
