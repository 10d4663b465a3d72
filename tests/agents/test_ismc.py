"""Chen, Khong & Hsieh (2022) five-axis laws in closed loop on the nominal plant: the
equivalent-error ISMC (eqs. 8–12, Table 2) against the joint-space PD, tool-tip contour and
orientation errors (paper §4: line PD 330.7 µm / 145.3″, ISMC 2.9 µm / 4.8″; circle PD
668.4 µm / 649.5″, ISMC 17.9 µm / 2.8″)."""

from __future__ import annotations

import numpy as np
import pytest

from agents.ismc import PAPER_ISMC_GAINS, PAPER_PD_GAINS, EquivalentErrorISMC, JointPD
from contour_env.paths.builders import line
from contour_env.paths.five_axis import FIVE_AXIS_PATHS, five_axis_path
from contour_env.plants.five_axis import FiveAxisPlant, forward, gravity
from contour_env.tool_errors import tool_errors


@pytest.fixture(scope="module")
def plant():
    return FiveAxisPlant("nxv560a", ideal=True)


@pytest.fixture(scope="module")
def paths():
    return {name: five_axis_path(name) for name in FIVE_AXIS_PATHS}


def _run(path, law, plant):
    ref = path.reference
    state = plant.initial_state(ref.joints[0])
    law.reset()
    q = np.empty((ref.n_steps, 5))
    for k in range(ref.n_steps):
        q[k] = state.q[0]
        u = law.command(plant.measure(state)[0], state.qd[0], k)
        state, _ = plant.step(state, u[None, :], k * ref.servo_period_s)
    return q


def _rms(path, q):
    tip, tool = forward(q, path.geometry)
    err = tool_errors(tip, tool, path.tip_path, path.tool_at)
    rms = lambda x: float(np.sqrt(np.mean(x**2)))  # noqa: E731
    return rms(err.contour_error_m) * 1e6, rms(err.orientation_error_arcsec)


@pytest.fixture(scope="module")
def figures(plant, paths):
    """RMS (µm, arcsec) per (path, law) on the nominal plant."""
    inertia = plant.nominal.inertia
    out = {}
    for name, path in paths.items():
        out[(name, "pd")] = _rms(path, _run(path, JointPD(path, inertia), plant))
        out[(name, "ismc")] = _rms(path, _run(path, EquivalentErrorISMC(path, inertia), plant))
    return out


@pytest.mark.parametrize("name", FIVE_AXIS_PATHS)
def test_ismc_tracks_with_small_errors_and_beats_pd_tenfold(figures, name):
    pd_um, pd_arcsec = figures[(name, "pd")]
    ismc_um, ismc_arcsec = figures[(name, "ismc")]
    # nominal model, 1 ms zero-order hold: what is left is the sampling of the law
    assert ismc_um < 1.0 and ismc_arcsec < 1.0
    # the PD lags (no feed-forward): tens to hundreds of µm, as in the paper
    assert pd_um > 10.0 and pd_arcsec > 3.0
    assert ismc_um <= 0.1 * pd_um and ismc_arcsec <= 0.1 * pd_arcsec


def test_paper_gains_are_table_2(paths, plant):
    inertia = plant.nominal.inertia
    law = EquivalentErrorISMC(paths["five-axis-circle"], inertia)
    assert (law.b1, law.b2, law.rho, law.mu) == (283.0, 800.0, 150.0, 0.8)
    assert PAPER_ISMC_GAINS["five-axis-line"] == (57.0, 800.0, 50.0, 0.05)
    pd = JointPD(paths["five-axis-circle"], inertia)
    assert pd.kp.tolist() == [800.0] * 5 and pd.kd.tolist() == [310.0] * 5
    assert PAPER_PD_GAINS["five-axis-line"] == (800.0, 60.0)
    law = EquivalentErrorISMC(paths["five-axis-line"], inertia, b1=30.0)
    assert (law.b1, law.b2) == (30.0, 800.0)


def test_integral_state_and_reset(paths, plant):
    path = paths["five-axis-line"]
    law = EquivalentErrorISMC(path, plant.nominal.inertia)
    ref = path.reference
    k = 500
    q = ref.joints[k] + np.array([1e-5, -2e-5, 1e-5, 1e-5, -1e-5])
    law.command(q, ref.joint_rate[k], k)
    eta, _ = path.equivalent_errors(q, ref.joint_rate[k], k, law.tangent_floor_m_s)
    np.testing.assert_allclose(law.integral, ref.servo_period_s * eta)
    law.reset()
    assert np.all(law.integral == 0)


def test_ismc_on_the_reference_commands_the_inverse_dynamics(paths, plant):
    # on the reference with η = η̇ = ∫η = 0: u = Γ⁻¹(−Ω) = M ξ̈_d + C ξ̇_d + g
    from contour_env.plants.five_axis import coriolis_matrix, mass_matrix

    path = paths["five-axis-circle"]
    inertia = plant.nominal.inertia
    ref = path.reference
    k = 1000
    q, qd, qdd = ref.joints[k], ref.joint_rate[k], ref.joint_accel[k]
    u = EquivalentErrorISMC(path, inertia).command(q, qd, k)
    expected = mass_matrix(q, inertia) @ qdd + coriolis_matrix(q, qd, inertia) @ qd
    expected += gravity(q, inertia)
    np.testing.assert_allclose(u, expected, rtol=1e-7, atol=1e-6)


def test_papers_tangential_weight_is_singular_at_rest(paths, plant):
    path = paths["five-axis-line"]
    law = EquivalentErrorISMC(path, plant.nominal.inertia, tangent_floor_m_s=0.0)
    with pytest.raises(ValueError, match="singular"):
        law.command(path.reference.joints[0], np.zeros(5), 0)
    law.command(path.reference.joints[1000], path.reference.joint_rate[1000], 1000)


def test_ismc_needs_an_algebraic_path(plant):
    with pytest.raises(ValueError, match="algebraic path"):
        EquivalentErrorISMC(line((0, 0, 0), (0.1, 0, 0)), plant.nominal.inertia)


def test_bad_gains_are_refused(paths, plant):
    with pytest.raises(ValueError, match="mu"):
        EquivalentErrorISMC(paths["five-axis-line"], plant.nominal.inertia, mu=0.0)
    with pytest.raises(ValueError, match="kp"):
        JointPD(paths["five-axis-line"], plant.nominal.inertia, kp=-1.0)


def test_plain_pd_holds_the_gravity_load_on_the_reference(paths, plant):
    path = paths["five-axis-line"]
    inertia = plant.nominal.inertia
    ref = path.reference
    pd = JointPD(path, inertia, kp=1e6, kd=1e4, inverse_dynamics=False)
    u = pd.command(ref.joints[700], ref.joint_rate[700], 700)
    np.testing.assert_allclose(u, gravity(ref.joints[700], inertia))


def test_delay_prediction_follows_the_nominal_model(paths, plant):
    # on the reference, with the inverse-dynamics commands in the delay line, the state
    # predicted one period ahead is the reference's next sample (to the Taylor step's O(T³))
    from contour_env.plants.five_axis import coriolis_matrix, mass_matrix

    path = paths["five-axis-circle"]
    inertia = plant.nominal.inertia
    ref = path.reference
    k = 1000

    def u_ref(i):
        q, qd = ref.joints[i], ref.joint_rate[i]
        h = coriolis_matrix(q, qd, inertia) @ qd + gravity(q, inertia)
        return mass_matrix(q, inertia) @ ref.joint_accel[i] + h

    law = EquivalentErrorISMC(path, inertia, computation_delay_steps=1)
    law._in_flight = [u_ref(k - 1), u_ref(k)]
    # the measured rate is a backward difference: the mid-point rate of the last period
    qd_meas = (ref.joints[k] - ref.joints[k - 1]) / ref.servo_period_s
    q1, qd1 = law.predict(ref.joints[k], qd_meas)
    np.testing.assert_allclose(q1, ref.joints[k + 1], atol=1e-9)
    np.testing.assert_allclose(qd1, ref.joint_rate[k + 1], atol=2e-5)
    # without a delay the law acts on the measurement itself
    law0 = EquivalentErrorISMC(path, inertia)
    q0, qd0 = law0.predict(ref.joints[k], qd_meas)
    assert np.array_equal(q0, ref.joints[k]) and np.array_equal(qd0, qd_meas)
    # the commands issued are kept (clipped to the drive limits), and reset() forgets them
    lim = np.array([8000.0, 10000.0, 12000.0, 1500.0, 600.0])
    law = EquivalentErrorISMC(path, inertia, computation_delay_steps=1, drive_limit=lim)
    u = law.command(ref.joints[k], ref.joint_rate[k], k)
    np.testing.assert_allclose(law._in_flight[-1], np.clip(u, -lim, lim))
    law.reset()
    assert law._in_flight == [] and np.all(law.integral == 0)
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="computation_delay_steps"):
            EquivalentErrorISMC(path, inertia, computation_delay_steps=bad)


def test_default_tangential_weight_stays_within_one_to_two_peak_feeds(paths, plant):
    # w = dξ_d/ds (ṡ + v₀) with v₀ = F (the peak feed): defined at rest, within F … 2F
    for path in paths.values():
        law = EquivalentErrorISMC(path, plant.nominal.inertia)
        peak = float(np.max(path.reference.feedrate_m_s))
        assert law.tangent_floor_m_s == pytest.approx(peak)
        scale = path.reference.feedrate_m_s + law.tangent_floor_m_s
        assert scale.min() >= peak * (1 - 1e-12) and scale.max() <= 2 * peak * (1 + 1e-12)
        law.command(path.reference.joints[0], np.zeros(5), 0)  # Γ invertible at rest
