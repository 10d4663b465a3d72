"""CCC on a plant it has no tuned coupling gains for (a plant file, custom parameters): it adds
no coupling — the same commands as PD — and says so with a warning naming the way out (PD's
fallback ω too); given gains (on the command line or as the plant's ``controller_gains``), no
warning and the coupling acts."""

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
    with pytest.warns(UntunedGainsWarning) as record:
        make_controller("ccc", env=env).bind(env)
    assert len(record) == 1  # one warning naming both fallbacks and the way out
    text = str(record[0].message)
    assert "no tuned gains for plant 'my-mill'" in text
    assert "ω = 100 rad/s" in text and "W_p = W_i = W_d = 0" in text
    assert "contour-env tune --plant" in text
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UntunedGainsWarning)
        assert _rms(env, "ccc") == _rms(env, "pd")


def test_given_gains_no_warning_and_coupling_acts(plant_file):
    env = _env(plant_file)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UntunedGainsWarning)
        make_controller("ccc:w=100:wp=3e3:wi=3e5", env=env).bind(env)
        make_controller("ccc", env=_env("hsm2")).bind(_env("hsm2"))  # tuned: silent
        ccc = _rms(env, "ccc:w=100:wp=3e3:wi=3e5")
    pd = _rms(env, "pd:w=100")
    assert np.isfinite(ccc) and ccc < 0.5 * pd


def test_untuned_pd_warns_once_and_given_omega_is_silent(plant_file):
    env = _env(plant_file)
    with pytest.warns(UntunedGainsWarning, match=r"pd: no tuned gains .*ω = 100 rad/s"):
        make_controller("pd", env=env).bind(env)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UntunedGainsWarning)
        make_controller("pd:w=90", env=env).bind(env)
        make_controller("pd:p=3e6:d=6e4", env=env).bind(env)  # both gains given: no ω used


def test_controller_gains_in_the_plant_are_the_defaults(tmp_path):
    gains = {"pd": {"bandwidth_rad_s": 90.0}, "ccc": {"W_p": 1e3, "W_i": 1e5}}
    path = tmp_path / "tuned.json"
    path.write_text(json.dumps({**CUSTOM, "controller_gains": gains}))
    env = _env(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("error", UntunedGainsWarning)
        pd = make_controller("pd", env=env).bind(env)
        ccc = make_controller("ccc", env=env).bind(env)
        acc = make_controller("adaptive-ccc", env=env).bind(env)
        ilc = make_controller("ilc-pd", env=env).bind(env)
        given = make_controller("ccc:w=70:wi=0", env=env).bind(env)
    m = np.array(CUSTOM["mass"])
    np.testing.assert_allclose(pd.P, m * 90.0**2)  # P = m ω² (Lee §4)
    np.testing.assert_allclose(pd.D, 2 * m * 90.0 - np.array(CUSTOM["viscous"]))
    assert (ccc.omega, ccc.W_p, ccc.W_i, ccc.W_d) == (90.0, 1e3, 1e5, 0.0)  # W_d not given: 0
    np.testing.assert_allclose(acc.alpha * acc.k + 1.0, m * 90.0**2)  # the same P action
    assert ilc.feedback.omega == 90.0
    assert (given.omega, given.W_p, given.W_i) == (70.0, 1e3, 0.0)  # explicit wins
