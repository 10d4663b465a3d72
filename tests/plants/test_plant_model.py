"""Plant integration against independent references: scipy.integrate.solve_ivp (rtol 1e-10),
Jee 2007 eq. (9), and physical sanity of the stick–slip treatment."""

import numpy as np
import pytest
from scipy import signal
from scipy.integrate import solve_ivp

from contour_env.plants import Plant, params_from_mapping


def _simulate(plant, u, start=None):
    state = plant.initial_state(np.zeros((1, plant.n_axes)) if start is None else start)
    out = np.empty_like(u)
    T = plant.servo_period_s
    for k in range(u.shape[0]):
        state, _ = plant.step(state, u[k][None, :], k * T)
        out[k] = state.position[0]
    return out


def _ode_reference(plant, u, *, lag=False, delay=False):
    """Piecewise-constant input, continuous ODE integrated per servo period (no friction)."""
    p = plant.params
    T = p.servo_period_s
    out = np.empty_like(u)
    for i in range(plant.n_axes):
        m, b, tau = p.mass_kg[i], p.viscous_Ns_m[i], p.current_loop_time_constant_s[i]
        y = np.zeros(3)  # x, v, f
        for k in range(u.shape[0]):
            uk = u[k - 1, i] if delay else u[k, i]
            if delay and k == 0:
                uk = 0.0

            def rhs(t, y, uk=uk):
                f = y[2] if lag else uk
                return [y[1], (f - b * y[1]) / m, (uk - y[2]) / tau if lag else 0.0]

            y = solve_ivp(rhs, (k * T, (k + 1) * T), y, method="DOP853", rtol=1e-10, atol=1e-16).y[
                :, -1
            ]
            out[k, i] = y[0]
    return out


@pytest.mark.parametrize("name", ["hsm2", "jee-triaxial"])
def test_linear_plants_match_solve_ivp_within_1nm_over_1s(name):
    plant = Plant(name, ideal=True)
    rng = np.random.default_rng(1)
    n = int(round(1.0 / plant.servo_period_s))
    u = rng.uniform(-0.3, 0.3, (n, plant.n_axes)) * plant.params.force_limit_N
    err = np.max(np.abs(_simulate(plant, u) - _ode_reference(plant, u)))
    assert err < 1e-9


def test_current_loop_lag_and_computation_delay_match_solve_ivp():
    realistic = Plant("hsm2").params
    params = realistic.replace(coulomb_N=0.0, static_N=0.0, ripple_amplitude_N=0.0)
    plant = Plant(params)
    assert params.computation_delay and np.all(params.current_loop_time_constant_s > 0)
    rng = np.random.default_rng(2)
    u = rng.uniform(-2000, 2000, (1000, 2))
    err = np.max(np.abs(_simulate(plant, u) - _ode_reference(plant, u, lag=True, delay=True)))
    assert err < 1e-9


def test_two_mass_mode_matches_its_ode():
    params = Plant("hsm2", structural_mode=True).params.replace(
        coulomb_N=0.0,
        static_N=0.0,
        ripple_amplitude_N=0.0,
        computation_delay=False,
        current_loop_time_constant_s=0.0,
    )
    plant = Plant(params)
    rng = np.random.default_rng(3)
    u = rng.uniform(-1000, 1000, (300, 2))
    sim = _simulate(plant, u)
    T = params.servo_period_s
    for i in range(2):
        m, b = params.mass_kg[i], params.viscous_Ns_m[i]
        k, c = params.structural_stiffness_N_m[i], params.structural_damping_Ns_m[i]
        ml = params.load_mass_fraction[i] * m
        mm = m - ml
        y = np.zeros(4)  # x_load, v_load, x_motor, v_motor
        for j in range(u.shape[0]):

            def rhs(t, y, f=u[j, i]):
                spring = k * (y[2] - y[0]) + c * (y[3] - y[1])
                return [y[1], (spring - b * y[1]) / ml, y[3], (f - spring) / mm]

            y = solve_ivp(rhs, (j * T, (j + 1) * T), y, method="DOP853", rtol=1e-10, atol=1e-16).y[
                :, -1
            ]
            assert abs(y[0] - sim[j, i]) < 1e-9


def test_jee_step_response_equals_paper_eq_9():
    plant = Plant("jee-triaxial", ideal=True)
    T = 1e-3
    K = np.array([121.0, 118.0, 83.0])
    tau = np.array([0.025, 0.03, 0.01])
    n = 400
    u = np.full((n, 3), 1e-4)
    sim = _simulate(plant, u)
    for i in range(3):
        r = np.exp(-T / tau[i])
        H1 = K[i] * (T - tau[i] + tau[i] * r)
        H0 = K[i] * (tau[i] - tau[i] * r - T * r)
        # G(z) = (H1 z + H0) / ((z − 1)(z − r)), eq. (9)
        sys = signal.dlti([H1, H0], np.polymul([1, -1], [1, -r]), dt=T)
        u_ext = np.concatenate([u[:, i], u[-1:, i]])
        _, y = signal.dlsim(sys, u_ext, t=np.arange(n + 1) * T)[:2]
        # dlsim's y[k] is the position at sample k; ours after step k is at sample k + 1
        np.testing.assert_allclose(sim[:, i], y[1:, 0], rtol=1e-10, atol=1e-18)


def _friction_reference(plant, u):
    """Event-based stick–slip reference (independent of the kernel's substep scheme)."""
    p = plant.params
    T = p.servo_period_s
    out = np.empty_like(u)
    for i in range(plant.n_axes):
        m, b = p.mass_kg[i], p.viscous_Ns_m[i]
        fc, fs, vs = p.coulomb_N[i], p.static_N[i], p.stribeck_velocity_m_s[i]
        A, P = p.ripple_amplitude_N[i], p.ripple_period_m[i]

        def ext(x):
            return A * np.sin(2 * np.pi * x / P)

        x, v, stuck = 0.0, 0.0, True
        for k in range(u.shape[0]):
            t, t_end, uk = k * T, (k + 1) * T, u[k, i]
            while t < t_end - 1e-15:
                if stuck:
                    if abs(uk - ext(x)) <= fs:
                        t = t_end
                        continue
                    stuck, d = False, np.sign(uk - ext(x))
                else:
                    d = np.sign(v) if v != 0 else np.sign(uk - ext(x))

                def rhs(tt, y, d=d, uk=uk):
                    mag = fc + (fs - fc) * np.exp(-((y[1] / vs) ** 2))
                    return [y[1], (uk - b * y[1] - d * mag - ext(y[0])) / m]

                def reversal(tt, y, d=d):
                    return y[1] * d

                reversal.terminal, reversal.direction = True, -1
                sol = solve_ivp(
                    rhs,
                    (t, t_end),
                    [x, v],
                    method="DOP853",
                    rtol=1e-10,
                    atol=1e-14,
                    events=reversal,
                )
                x, v, t = sol.y[0, -1], sol.y[1, -1], sol.t[-1]
                if sol.status == 1:
                    v = 0.0
                    stuck = abs(uk - ext(x)) <= fs
            out[k, i] = x
    return out


@pytest.mark.parametrize("name", ["linear-motor", "friction-table"])
def test_friction_plants_match_event_based_reference_within_1um(name):
    base = Plant(name, ideal=True).params
    plant = Plant(base.replace(disturbance_amplitude_N=0.0))
    n = int(round(0.5 / plant.servo_period_s))
    t = np.arange(n) * plant.servo_period_s
    # above the static friction, then below it: reversals, sliding through and sticking
    u = np.outer(
        np.sin(2 * np.pi * 4.0 * t) * np.where(t < 0.25, 1.0, 0.3), 3.0 * plant.params.static_N
    )
    err = np.max(np.abs(_simulate(plant, u) - _friction_reference(plant, u)))
    assert err < 1e-6


def test_mass_comes_to_rest_and_sticks_without_energy_gain():
    params = Plant("friction-table", ideal=True).params.replace(disturbance_amplitude_N=0.0)
    plant = Plant(params)
    state = plant.initial_state(np.zeros((1, 2)))
    state.z[0, :, 1] = [0.05, -0.03]
    state.stuck[:] = 0.0
    energy = [0.5 * np.sum(params.mass_kg * state.velocity[0] ** 2)]
    for k in range(400):
        state, _ = plant.step(state, np.zeros((1, 2)), k * 1e-3)
        energy.append(0.5 * np.sum(params.mass_kg * state.velocity[0] ** 2))
    assert np.all(np.diff(energy) <= 1e-15)
    assert np.all(state.velocity == 0.0) and np.all(state.stuck == 1.0)
    x_rest = state.position.copy()
    for k in range(100):
        state, _ = plant.step(state, np.zeros((1, 2)), (400 + k) * 1e-3)
    np.testing.assert_array_equal(state.position, x_rest)


def test_force_below_static_friction_does_not_move_the_mass():
    params = Plant("friction-table", ideal=True).params.replace(disturbance_amplitude_N=0.0)
    plant = Plant(params)
    below = 0.99 * params.static_N
    x = _simulate(plant, np.tile(below, (200, 1)))
    np.testing.assert_array_equal(x, 0.0)
    above = 1.05 * params.static_N
    assert np.all(_simulate(plant, np.tile(above, (200, 1)))[-1] > 0)


def test_saturation_clips_at_the_force_limit():
    plant = Plant("hsm2", ideal=True)
    state = plant.initial_state(np.zeros((1, 2)))
    _, applied = plant.step(state, np.array([[1e9, -1e9]]), 0.0)
    np.testing.assert_allclose(
        applied[0], [plant.params.force_limit_N[0], -plant.params.force_limit_N[1]]
    )


def test_realistic_and_ideal_effects():
    real = Plant("hsm2")
    assert real.params.computation_delay
    assert np.all(real.params.current_loop_time_constant_s > 0)
    assert np.all(real.params.static_N > 0)
    assert not np.allclose(real.params.mass_kg, real.nominal.mass_kg)
    ideal = Plant("hsm2", ideal=True)
    assert not ideal.params.computation_delay
    np.testing.assert_array_equal(ideal.params.mass_kg, ideal.nominal.mass_kg)
    # HSM2 x axis through the documented lead: m = J / ℓ²
    assert ideal.nominal.mass_kg[0] == pytest.approx(0.05916 / 4.4e-3**2)


@pytest.mark.parametrize(
    "change, match",
    [
        ({"mass": [0.0, 1.0]}, "plant: mass: "),
        ({"servo_period": 0.0}, "plant: servo_period: "),
        ({"viscous": -1.0}, "plant: viscous: "),
        ({"coulomb": 5.0, "static": 1.0}, "static_N"),
        ({"mass": [1.0, 2.0, 3.0]}, "plant: mass: "),
        ({"colour": 1}, 'plant: unknown key "colour"'),
    ],
)
def test_custom_parameter_errors_name_the_parameter(change, match):
    base = {"mass": [10.0, 12.0], "force_limit": 100.0, "servo_period": 1e-3}
    with pytest.raises(ValueError, match=match):
        params_from_mapping({**base, **change})


def test_missing_required_and_unknown_plant():
    with pytest.raises(ValueError, match="force_limit"):
        params_from_mapping({"mass": 1.0, "servo_period": 1e-3})
    with pytest.raises(ValueError, match=r"unknown plant 'nope'.*friction-table"):
        Plant("nope")


def test_nan_command_is_rejected():
    plant = Plant("hsm2")
    with pytest.raises(ValueError, match="command"):
        plant.step(plant.initial_state(np.zeros((1, 2))), np.array([[np.nan, 0.0]]), 0.0)
