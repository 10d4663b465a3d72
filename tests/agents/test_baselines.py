"""The default gain sets as a servo engineer would try them: bounded with the structural mode
on every named case, and cross-coupling that holds on a corner that is not axis-aligned."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from agents import make_controller
from contour_env import ENV_ID
from contour_env.cases import CASES
from contour_env.evaluation import run_episode
from contour_env.metrics import score
from contour_env.plants.catalog import nominal_params

DATA = Path(__file__).resolve().parents[1] / "data"
ROTATED_CORNER = DATA / "corner_rotated_30.nc"


def _run(name: str, **env_kwargs) -> dict:
    env = gym.make(ENV_ID, **env_kwargs)
    return score(run_episode(env, make_controller(name).bind(env)))


def _no_limit_cycle(m: dict, reference: dict) -> None:
    """Bounded and quiet: completed, (almost) never at the force limit, and no axis working
    much harder than the reference run — a limit cycle at the force limit fails all three."""
    assert m["completed"], m["termination_reason"]
    assert m["saturation_fraction"] < 0.01
    assert np.all(np.asarray(m["rms_effort"]) <= 1.5 * np.asarray(reference["rms_effort"]))


def _deflection_allowance_um(case: str) -> float:
    """The quasi-static deflection of the load against the drive side under the case's largest
    reference acceleration, 2 a / (2π f)² (two equal halves, the lowest mode f): the encoder on
    the drive side cannot see it, so it adds to the contour error without any instability."""
    env = gym.make(ENV_ID, case=case)
    acc = env.unwrapped.core.ref_pav[:, 2, :]
    a_max = float(np.max(np.linalg.norm(acc, axis=1)))
    f = min(nominal_params(CASES[case].plant)[1].structural_mode_hz)
    return 2.0 * a_max / (2.0 * np.pi * f) ** 2 * 1e6


def _cases_with_a_mode():
    return [
        name
        for name, spec in CASES.items()
        if nominal_params(spec.plant)[1].structural_mode_hz and spec.plant != "linear-motor"
    ]


@pytest.mark.parametrize("case", _cases_with_a_mode())
@pytest.mark.parametrize("name", ["pd", "ccc", "adaptive-ccc"])
def test_default_controllers_are_bounded_with_the_structural_mode(case, name):
    """With the axial two-mass mode every default controller completes the case without a
    limit cycle (effort and contour error stay near the run without the mode)."""
    plain = _run(name, case=case)
    modal = _run(name, case=case, structural_mode=True)
    _no_limit_cycle(modal, plain)
    bound = 3.0 * plain["max_contour_error_um"] + _deflection_allowance_um(case) + 5.0
    assert modal["max_contour_error_um"] <= bound


@pytest.fixture(scope="module")
def lm_pd_plain():
    return _run("pd", case="lm-circle3d")


@pytest.mark.parametrize("name", ["pd", "ccc", "adaptive-ccc"])
def test_linear_motor_defaults_are_bounded_with_the_structural_mode(name, lm_pd_plain):
    """lm-circle3d (160 k steps at 0.1 ms) with the 400 Hz mode. One reference run (PD without
    the mode) for the three, to keep the suite short: every law here needs about the same
    force on this arc (friction and inertia), and PD's contour error is the largest."""
    modal = _run(name, case="lm-circle3d", structural_mode=True)
    _no_limit_cycle(modal, lm_pd_plain)
    allowance = _deflection_allowance_um("lm-circle3d")
    assert modal["max_contour_error_um"] <= 3.0 * lm_pd_plain["max_contour_error_um"] + allowance


@pytest.mark.parametrize("plant", ["friction-table", "hsm2"])
def test_ccc_holds_a_corner_rotated_by_30_degrees(plant):
    """The sharp corner rotated by 30° (both axes move on both legs; a G-code file): CCC's RMS
    contour error is at most PD's, with no limit cycle."""
    pd = _run("pd", plant=plant, path=str(ROTATED_CORNER))
    ccc = _run("ccc", plant=plant, path=str(ROTATED_CORNER))
    _no_limit_cycle(ccc, pd)
    assert ccc["rms_contour_error_um"] <= pd["rms_contour_error_um"]


def _corner_signals(frame, reference, measured):
    z = np.zeros((1, 2))
    return {
        "measured_position": np.asarray([measured], dtype=float),
        "measured_velocity": z,
        "reference_position": np.asarray([reference], dtype=float),
        "reference_velocity": z,
        "reference_acceleration": z,
        "frame": np.asarray(frame, dtype=float)[None],
        "curvature": np.zeros(1),
        "torsion": np.zeros(1),
        "feedrate": np.zeros(1),
        "step": np.zeros(1, dtype=int),
    }


def test_ccc_holds_its_coupling_until_the_tool_passes_an_exact_stop_corner():
    """At an exact-stop corner the reference frame jumps; a tool still on the first leg is
    not off the path, so the coupling (its integral above all) holds until the tool passes
    the corner's bisector, and the integral restarts there."""
    from contour_env.plants import Plant

    plant = Plant("friction-table")
    ccc = make_controller("ccc:wp=1e3:wi=1e5").configure_for(plant)
    pd = make_controller("pd").configure_for(plant)
    leg1 = [[1.0, 0.0], [0.0, 1.0]]  # t along +x, n along +y
    leg2 = [[0.0, -1.0], [1.0, 0.0]]  # a left turn by 90°: t along +y
    behind = (-1e-4, 2e-5)  # 100 µm short of the corner, 20 µm off the first leg
    # on the first leg the coupling acts on the 20 µm normal error
    s = _corner_signals(leg1, (0.0, 0.0), behind)
    assert not np.allclose(ccc.act(s), pd.act(s))
    # the frame jumps, the tool is still on the first leg: PD's command exactly
    for _ in range(5):
        s = _corner_signals(leg2, (0.0, 1e-5), behind)
        np.testing.assert_array_equal(ccc.act(s), pd.act(s))
    # past the bisector (x − c)·(t1 + t2) ≥ 0: the coupling is back, its integral restarted
    past = (1e-5, 3e-5)
    s = _corner_signals(leg2, (0.0, 4e-5), past)
    eps_n = -(np.array(leg2)[:, 1] @ (np.array([0.0, 4e-5]) - np.array(past)))
    expected = (
        pd.act(s)
        - ccc.mass
        * (ccc.W_p * eps_n + ccc.W_i * eps_n * ccc.servo_period_s)
        * (np.array(leg2)[:, 1])
    )
    np.testing.assert_allclose(ccc.act(s), expected, rtol=1e-12)
