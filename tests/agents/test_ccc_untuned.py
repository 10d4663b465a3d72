"""CCC on a plant it has no tuned coupling gains for (a plant file, custom parameters): it adds
no coupling — the same commands as PD — and says so with a warning naming the way out; given
gains, no warning and the coupling acts."""

from __future__ import annotations

import json
import warnings

import gymnasium as gym
import numpy as np
import pytest

from agents import make_controller
from agents.ccc import UntunedGainsWarning
from contour_env import ENV_ID
from contour_env.circular_test import circular_path
from contour_env.evaluation import run_episode
from contour_env.metrics import score

CUSTOM = {
    "name": "my-mill",
    "axes": ["x", "y"],
    "mass": [300.0, 200.0],
    "viscous": [400.0, 300.0],
    "coulomb": [20.0, 15.0],
    "static": [30.0, 20.0],
    "force_limit": [3000.0, 2000.0],
    "servo_period": 0.001,
}


@pytest.fixture
def plant_file(tmp_path):
    path = tmp_path / "my-mill.json"
    path.write_text(json.dumps(CUSTOM))
    return str(path)


def _env(plant):
    return gym.make(ENV_ID, plant=plant, path=circular_path(0.02, "ccw", 10.0), feedrate_m_s=0.1)


def _rms(env, spec):
    return score(run_episode(env, make_controller(spec, env=env), seed=0))["rms_contour_error_um"]


def test_untuned_ccc_warns_and_equals_pd(plant_file):
    env = _env(plant_file)
    match = "no tuned cross-coupling gains for plant 'my-mill'"
    with pytest.warns(UntunedGainsWarning, match=match):
        make_controller("ccc", env=env).bind(env)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UntunedGainsWarning)
        assert _rms(env, "ccc") == _rms(env, "pd")


def test_given_gains_no_warning_and_coupling_acts(plant_file):
    env = _env(plant_file)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UntunedGainsWarning)
        make_controller("ccc:wp=3e3:wi=3e5", env=env).bind(env)
        make_controller("ccc", env=_env("hsm2")).bind(_env("hsm2"))  # tuned: silent
        ccc = _rms(env, "ccc:wp=3e3:wi=3e5")
    pd = _rms(env, "pd")
    assert np.isfinite(ccc) and ccc < 0.5 * pd
