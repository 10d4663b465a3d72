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
