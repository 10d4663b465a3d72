"""Linear plant integration against independent references.

- the continuous ODE integrated with ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10) period by
  period with the same held input (ideal plants, current-loop lag + computation delay, the
  two-mass structural mode), written here from the equations, not from the package's matrices;
- Jee & Lee 2007 eq. (9), G(z) = (H1 z + H0) / ((z − 1)(z − r)), as a difference equation
  (``scipy.signal.lfilter``) and as ``scipy.signal.dstep``;
- actuator saturation.
"""

import numpy as np
import pytest
from scipy import signal
from scipy.integrate import solve_ivp

from contour_env.plants import Plant

RTOL, ATOL = 1e-10, 1e-15
ONE_NM = 1e-9


def simulate(plant, u, state=None, t0=0.0):
    """Step ``plant`` through the held commands u (n, A); positions and applied commands after
    each step, (n, A) each."""
    if state is None:
        state = plant.initial_state(np.zeros((1, plant.n_axes)))
    T = plant.servo_period_s
    pos = np.empty_like(u)
    applied = np.empty_like(u)
    for k in range(u.shape[0]):
        state, a = plant.step(state, u[k][None, :], t0 + k * T)
        pos[k] = state.position[0]
        applied[k] = a[0]
    return pos, applied


def held_inputs(u, delay):
    """The input each period actually sees: u[k], or u[k − 1] (0 in the first period)."""
    if not delay:
        return u
    return np.vstack([np.zeros((1, u.shape[1])), u[:-1]])


def rigid_reference(params, u, *, lag, delay):
    """m ẍ + b ẋ = f with f = u (no lag) or τ ḟ = u − f (lag); all axes at once, solve_ivp
    period by period."""
    m, b = params.mass_kg, params.viscous_Ns_m
    tau = params.current_loop_time_constant_s
    n_axes = m.size
    T = params.servo_period_s
    uh = held_inputs(u, delay)
    y = np.zeros(3 * n_axes)  # [x (A), v (A), f (A)]
    out = np.empty_like(u)
    for k in range(u.shape[0]):

        def rhs(t, y, uk=uh[k]):
            v, f = y[n_axes : 2 * n_axes], y[2 * n_axes :]
            force = f if lag else uk
            fdot = (uk - f) / tau if lag else np.zeros(n_axes)
            return np.concatenate([v, (force - b * v) / m, fdot])

        sol = solve_ivp(rhs, (k * T, (k + 1) * T), y, method="DOP853", rtol=RTOL, atol=ATOL)
        assert sol.success
        y = sol.y[:, -1]
        out[k] = y[:n_axes]
    return out


def two_mass_reference(params, u, *, lag, delay):
    """Load (table) and motor joined by a spring k and damper c; guideway viscous b on the load,
    the (lagged) drive force on the motor:

        m_l ẍ_l = k (x_m − x_l) + c (ẋ_m − ẋ_l) − b ẋ_l
        m_m ẍ_m = f − k (x_m − x_l) − c (ẋ_m − ẋ_l)
    """
    m = params.mass_kg
    ml = params.load_mass_fraction * m
    mm = m - ml
    b = params.viscous_Ns_m
    k_s, c_s = params.structural_stiffness_N_m, params.structural_damping_Ns_m
    tau = params.current_loop_time_constant_s
    n = m.size
    T = params.servo_period_s
    uh = held_inputs(u, delay)
    y = np.zeros(5 * n)  # [x_l, v_l, x_m, v_m, f] per axis, blocks of n
    out = np.empty_like(u)
    for j in range(u.shape[0]):

        def rhs(t, y, uk=uh[j]):
            xl, vl, xm, vm, f = (y[i * n : (i + 1) * n] for i in range(5))
            spring = k_s * (xm - xl) + c_s * (vm - vl)
            drive = f if lag else uk
            fdot = (uk - f) / tau if lag else np.zeros(n)
            return np.concatenate([vl, (spring - b * vl) / ml, vm, (drive - spring) / mm, fdot])

        sol = solve_ivp(rhs, (j * T, (j + 1) * T), y, method="DOP853", rtol=RTOL, atol=ATOL)
        assert sol.success
        y = sol.y[:, -1]
        out[j] = y[:n]
    return out


def random_commands(plant, seed, seconds=1.0, fraction=0.8):
    rng = np.random.default_rng(seed)
    n = int(round(seconds / plant.servo_period_s))
    return rng.uniform(-fraction, fraction, (n, plant.n_axes)) * plant.params.force_limit_N


@pytest.mark.parametrize("name, seed", [("hsm2", 11), ("jee-triaxial", 12)])
def test_ideal_linear_plant_matches_solve_ivp_within_1nm_over_1s(name, seed):
    plant = Plant(name, ideal=True)
    p = plant.params
    assert not p.has_friction and not p.computation_delay
    assert np.all(p.current_loop_time_constant_s == 0)
    u = random_commands(plant, seed)
    sim, applied = simulate(plant, u)
    np.testing.assert_array_equal(applied, u)  # within the limit: applied as commanded
    ref = rigid_reference(p, u, lag=False, delay=False)
    err = np.max(np.abs(sim - ref))
    # measured: 3.1e-16 m (hsm2), 1.6e-16 m (jee-triaxial); the motion itself is cm
    assert err < ONE_NM, f"max position error {err:.3e} m"
    assert np.max(np.abs(ref)) > 1e-4  # the comparison is not vacuous


def test_current_loop_lag_and_computation_delay_match_solve_ivp_within_1nm():
    realistic = Plant("hsm2").params
    params = realistic.replace(coulomb_N=0.0, static_N=0.0, ripple_amplitude_N=0.0)
    plant = Plant(params)
    assert plant.params is params and plant.nominal is params
    assert params.computation_delay and not params.has_friction
    assert np.all(params.current_loop_time_constant_s > 0)
    u = random_commands(plant, 21)
    sim, applied = simulate(plant, u)
    # the command computed at sample k is applied over period k + 1
    np.testing.assert_array_equal(applied, held_inputs(u, True))
    ref = rigid_reference(params, u, lag=True, delay=True)
    err = np.max(np.abs(sim - ref))
    # measured: 6.6e-16 m
    assert err < ONE_NM, f"max position error {err:.3e} m"
    # and the lag and delay are visible: ignoring them is off by far more than 1 nm
    naive = rigid_reference(params, u, lag=False, delay=False)
    assert np.max(np.abs(sim - naive)) > 1e3 * ONE_NM


def test_two_mass_structural_mode_matches_its_ode_within_1nm():
    realistic = Plant("hsm2", structural_mode=True).params
    params = realistic.replace(coulomb_N=0.0, static_N=0.0, ripple_amplitude_N=0.0)
    assert params.has_structural_mode and params.computation_delay
    # the documented mode: 60 Hz (x) and 45 Hz (y) on the reduced mass m_l m_m / (m_l + m_m)
    ml = params.load_mass_fraction * params.mass_kg
    mm = params.mass_kg - ml
    f_mode = np.sqrt(params.structural_stiffness_N_m * (1 / ml + 1 / mm)) / (2 * np.pi)
    np.testing.assert_allclose(f_mode, [60.0, 45.0], rtol=1e-12)
    plant = Plant(params)
    u = random_commands(plant, 31)
    sim, _ = simulate(plant, u)
    assert plant.initial_state(np.zeros((1, 2))).z.shape[-1] == 5  # x_l, v_l, x_m, v_m, f
    ref = two_mass_reference(params, u, lag=True, delay=True)
    err = np.max(np.abs(sim - ref))
    # measured: 3.2e-14 m
    assert err < ONE_NM, f"max position error {err:.3e} m"
    # the load really differs from a rigid body driven the same way
    rigid = rigid_reference(params, u, lag=True, delay=True)
    assert np.max(np.abs(sim - rigid)) > 10 * ONE_NM


def test_two_mass_without_lag_or_delay_matches_its_ode():
    params = Plant("friction-table", structural_mode=True).params.replace(
        coulomb_N=0.0,
        static_N=0.0,
        disturbance_amplitude_N=0.0,
        computation_delay=False,
        current_loop_time_constant_s=0.0,
    )
    plant = Plant(params)
    assert plant.initial_state(np.zeros((1, 2))).z.shape[-1] == 4
    u = random_commands(plant, 32, seconds=0.3, fraction=0.05)
    sim, _ = simulate(plant, u)
    err = np.max(np.abs(sim - two_mass_reference(params, u, lag=False, delay=False)))
    # measured: 6.4e-15 m
    assert err < ONE_NM, f"max position error {err:.3e} m"


def jee_eq9_coefficients(K, tau, T):
    """H1, H0, r of Jee & Lee 2007 eq. (9); 1 − r via expm1 (H1 is a small difference)."""
    one_minus_r = -np.expm1(-T / tau)
    r = 1.0 - one_minus_r
    H1 = K * (T - tau * one_minus_r)  # K (T − τ + τ r)
    H0 = K * (tau * one_minus_r - T * r)  # K (τ − τ r − T r)
    return H1, H0, r


def test_jee_step_response_equals_eq_9():
    plant = Plant("jee-triaxial", ideal=True)
    assert not plant.params.computation_delay
    T = 1e-3
    K = np.array([121.0, 118.0, 83.0])  # Table 1
    tau = np.array([0.025, 0.03, 0.01])
    assert plant.servo_period_s == T
    # common form m = τ / K, b = 1 / K
    np.testing.assert_allclose(plant.params.mass_kg, tau / K, rtol=1e-15)
    np.testing.assert_allclose(plant.params.viscous_Ns_m, 1.0 / K, rtol=1e-15)
    u0 = 1e-4  # well inside the velocity-command limit: no saturation
    assert np.all(u0 < plant.params.force_limit_N)
    n = 600
    sim, applied = simulate(plant, np.full((n, 3), u0))
    np.testing.assert_array_equal(applied, u0)
    H1, H0, r = jee_eq9_coefficients(K, tau, T)
    t = np.arange(1, n + 1) * T  # the plant's position after step k is at sample k + 1
    for i in range(3):
        # eq. (9) as a cascade: q = (H1 z + H0) / (z − r) u, then the integrator 1 / (z − 1):
        # y[k] = y[k−1] + q[k−1], y[0] = 0 (y[k] is the position at sample k). The cascade keeps
        # the poles 1 and r exact; the expanded denominator z² − (1 + r) z + r rounds 1 + r and
        # the double recursion then drifts by 4e-13 relative over 600 samples.
        q = signal.lfilter([H1[i], H0[i]], [1.0, -r[i]], np.full(n, u0))
        y = np.cumsum(q)
        # measured max relative deviation: 1.3e-14
        np.testing.assert_allclose(sim[:, i], y, rtol=1e-12, atol=0)
        # the expanded form through scipy's LTI step response (unit step, scaled)
        sys = signal.dlti([H1[i], H0[i]], np.polymul([1.0, -1.0], [1.0, -r[i]]), dt=T)
        _, (ys,) = signal.dstep(sys, n=n + 1)
        # measured: 7.7e-13 (that drift of the expanded recursion)
        np.testing.assert_allclose(sim[:, i], u0 * ys[1:, 0], rtol=1e-11, atol=0)
        # exact: a held step samples the continuous response K u (t − τ (1 − e^{−t/τ}))
        exact = K[i] * u0 * (t + tau[i] * np.expm1(-t / tau[i]))
        # measured: 1.2e-14
        np.testing.assert_allclose(sim[:, i], exact, rtol=1e-12, atol=0)


def test_saturation_clips_commands_at_the_force_limit():
    plant = Plant("hsm2", ideal=True)
    lim = plant.params.force_limit_N
    state = plant.initial_state(np.zeros((3, 2)))
    cmd = np.array([[1e9, -1e9], [-2.0 * lim[0], 1.5 * lim[1]], [0.5 * lim[0], -0.5 * lim[1]]])
    new, applied = plant.step(state, cmd, 0.0)
    np.testing.assert_array_equal(applied[0], [lim[0], -lim[1]])
    np.testing.assert_array_equal(applied[1], [-lim[0], lim[1]])
    np.testing.assert_array_equal(applied[2], cmd[2])
    # the dynamics see the clipped force: identical to commanding exactly the limit
    exact, _ = plant.step(state, np.clip(cmd, -lim, lim), 0.0)
    np.testing.assert_array_equal(new.z, exact.z)


def test_saturation_applies_to_the_delayed_command():
    plant = Plant("hsm2")  # realistic: one-period computation delay
    lim = plant.params.force_limit_N
    state = plant.initial_state(np.zeros((1, 2)))
    state, applied = plant.step(state, np.array([[5 * lim[0], -5 * lim[1]]]), 0.0)
    np.testing.assert_array_equal(applied, 0.0)  # nothing computed before: zero
    _, applied = plant.step(state, np.zeros((1, 2)), plant.servo_period_s)
    np.testing.assert_array_equal(applied[0], [lim[0], -lim[1]])
