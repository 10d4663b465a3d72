"""Issue 20 item 4 ("close the slips"): plant_params checked against the case, custom plant
parameters within documented ranges, no bool feed rates, no complex actions."""

import re

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from contour_env import ENV_ID
from contour_env.env.contouring_env import ContouringEnv
from contour_env.plants import nominal_params, params_from_mapping
from contour_env.plants.params import PARAM_RANGES, check_param_ranges
from contour_env.plants.randomize import randomized


def _vec(n, **kw):
    return gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kw)


# --- 1. plant_params must fit the case's plant -------------------------------------------------
def test_hsm2_params_on_a_three_axis_case_are_refused_single_and_vector():
    hsm2 = nominal_params("hsm2")[0]
    pattern = r"plant_params\[0\].*3 axes.*servo period 0\.0001 s.*got 'hsm2' with 2 axes"
    with pytest.raises(ValueError, match=pattern):
        ContouringEnv(case="lm-circle3d", plant_params=[hsm2])
    with pytest.raises(ValueError, match=pattern):
        _vec(2, case="lm-circle3d", plant_params=[hsm2, hsm2])


def test_linear_motor_params_on_an_hsm2_case_name_the_servo_period():
    lm = nominal_params("linear-motor")[0]
    # same number of axes would not save it: project the 3-axis set onto two axes
    per_axis = [k for k in PARAM_RANGES if k not in ("servo_period_s", "friction_substeps")]
    two = lm.replace(axis_names=("x", "y"), **{k: getattr(lm, k)[:2] for k in per_axis})
    with pytest.raises(ValueError, match=r"plant_params\[0\].*servo period 0\.001 s.*0\.0001 s"):
        ContouringEnv(case="hsm2-circle-II", plant_params=[two])
    with pytest.raises(ValueError, match=r"plant_params\[1\].*servo period"):
        true = ContouringEnv(case="hsm2-circle-II").plant.params
        _vec(2, case="hsm2-circle-II", plant_params=[true, two])


@pytest.mark.parametrize("bad", [None, "hsm2", 3.0])
def test_plant_params_that_are_not_a_list_of_params(bad):
    true = ContouringEnv(case="hsm2-circle-II").plant.params
    plant_params = [true, bad] if bad is not None else true
    with pytest.raises(ValueError, match="plant_params"):
        _vec(2, case="hsm2-circle-II", plant_params=plant_params)


def test_randomised_variants_of_the_case_plant_still_run():
    env = ContouringEnv(case="sharp-corner")
    variants = randomized(env.plant.params, 0.2, 3, seed=1)
    venv = _vec(3, case="sharp-corner", plant_params=variants)
    venv.reset(seed=0)
    obs, rew, *_ = venv.step(np.zeros((3, 2)))
    assert np.all(np.isfinite(obs)) and np.all(np.isfinite(rew))


# --- 2. extreme custom parameters: documented ranges ------------------------------------------
@pytest.mark.parametrize(
    "change, name",
    [
        ({"force_limit": 1e308}, "force_limit_N"),
        ({"mass": 1e-300}, "mass_kg"),
        ({"mass": 1e300}, "mass_kg"),
        ({"servo_period": 1e-12}, "servo_period_s"),
        ({"structural_stiffness": 1e30}, "structural_stiffness_N_m"),
    ],
)
def test_extreme_custom_parameters_name_the_parameter_and_range(change, name):
    base = dict(mass=10.0, force_limit=100.0, servo_period=1e-3)
    lo, hi = PARAM_RANGES[name]
    key = next(iter(change))
    with pytest.raises(
        ValueError, match=re.escape(f"plant: {key}: must be a number in [{lo:g}, {hi:g}]")
    ):
        params_from_mapping({**base, **change})
    # a PlantParams made directly, given as plant_params, is checked by the env
    hsm2 = ContouringEnv(case="hsm2-circle-II").plant.params
    field_change = {name: np.full(2, float(next(iter(change.values()))))}
    if name in ("servo_period_s", "structural_stiffness_N_m"):
        return  # refused as a servo period / state layout mismatch first
    bad = hsm2.replace(**field_change)
    with pytest.raises(ValueError, match=rf"plant_params\[0\]: {name} must be in"):
        ContouringEnv(case="hsm2-circle-II", plant_params=[bad])


def test_every_named_plant_lies_in_the_ranges():
    from contour_env.cases import CASES

    for case in CASES:
        check_param_ranges(ContouringEnv(case=case).plant.params)


@pytest.mark.parametrize(
    "change", [{"force_limit_N": 1e7}, {"mass_kg": 1e-6}, {"mass_kg": 1e-6, "force_limit_N": 1e7}]
)
def test_extremes_inside_the_ranges_end_with_a_finite_reward(change):
    true = ContouringEnv(case="hsm2-circle-II").plant.params
    extreme = true.replace(**{k: np.full(2, v) for k, v in change.items()})
    env = ContouringEnv(case="hsm2-circle-II", plant_params=[extreme])
    env.reset(seed=0)
    for _ in range(50):
        obs, r, term, trunc, info = env.step(np.ones(2))
        assert np.isfinite(r) and np.all(np.isfinite(obs))
        if term:
            assert info["termination_reason"] in (
                "non_finite_state",
                "contour_error_limit",
                "tracking_error_limit",
            )
            assert r == -env.config.guard_penalty * (env.core.n_steps - info["step"])
            break
    assert term


def test_a_guard_penalty_that_overflows_is_refused():
    with pytest.raises(ValueError, match="guard penalty"):
        ContouringEnv(case="hsm2-circle-II", w_contour=1e300, contour_error_scale_m=1e-300)


# --- 6. bools are not numbers, complex actions are not commands ---------------------------------
@pytest.mark.parametrize(
    "kw", ["feedrate_m_s", "max_accel_m_s2", "max_jerk_m_s3", "settle_time_s", "rapid_feed_m_s"]
)
def test_bool_numbers_are_refused(kw):
    with pytest.raises(ValueError, match=rf"{kw}: must be a finite number"):
        ContouringEnv(case="hsm2-circle-II", **{kw: True})


def test_bool_feedrate_is_not_1_m_s_and_complex_feedrate_refused():
    with pytest.raises(ValueError, match="feedrate_m_s"):
        ContouringEnv(case="hsm2-circle-II", feedrate_m_s=1 + 0j)
    with pytest.raises(ValueError, match="ideal: must be True or False"):
        ContouringEnv(case="hsm2-circle-II", ideal="no")


@pytest.mark.parametrize(
    "action",
    [np.array([0.1 + 0.5j, 0.0]), [0.1j, 0.2], np.array([True, False]), ["a", "b"], [None, 1]],
)
def test_non_real_actions_are_refused_single(action):
    env = ContouringEnv(case="hsm2-circle-II")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action: expected real numbers, got dtype"):
        env.step(action)


def test_complex_actions_are_refused_vector():
    venv = _vec(2, case="hsm2-circle-II")
    venv.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions: expected real numbers, got dtype complex"):
        venv.step(np.zeros((2, 2), dtype=complex))
    obs, *_ = venv.step(np.zeros((2, 2), dtype=np.float32))  # float32 and ints still work
    venv.step(np.zeros((2, 2), dtype=np.int64))
    assert obs.shape[0] == 2


# --- per-env parameters without static friction on a plant that has it --------------------------
# Found by this project's own benchmarking (2026-12-03): the initial stuck flag came from the
# case's plant (static friction > 0), so with frictionless per-env parameters the first period
# went down the stick–slip path, whose tests are fractions of f_s = 0, and never left it (the
# step hung). The run is in a subprocess with a time limit, so that a regression fails here
# instead of stalling the suite.
_FRICTIONLESS_RUN = """
import numpy as np, gymnasium as gym
import contour_env
from contour_env import ENV_ID
from contour_env.env.contouring_env import ContouringEnv
true = ContouringEnv(case="hsm2-circle-II").plant.params
zero = np.zeros(true.n_axes)
p = true.replace(static_N=zero, coulomb_N=zero)
acts = np.random.default_rng(0).uniform(-1, 1, (40, 3, 2)).astype(np.float32)
runs = []
for kw in (dict(case="hsm2-circle-II", plant_params=[p] * 3),
           dict(case="hsm2-circle-II", plant=p.to_dict())):
    venv = gym.make_vec(ENV_ID, num_envs=3, vectorization_mode="vector_entry_point", **kw)
    obs, _ = venv.reset(seed=0)
    rows = [obs]
    for a in acts:
        obs, r, te, tr, info = venv.step(a)
        rows.append(np.c_[obs, r, info["position"].reshape(3, -1)])
    runs.append(np.concatenate([x.reshape(3, -1) for x in rows], axis=1))
assert np.all(np.isfinite(runs[0]))
assert np.array_equal(runs[0], runs[1]), "per-env parameters differ from the same custom plant"
print("ok")
"""


def test_frictionless_per_env_params_on_a_plant_with_stiction_do_not_hang():
    import subprocess
    import sys

    res = subprocess.run(
        [sys.executable, "-c", _FRICTIONLESS_RUN], capture_output=True, text=True, timeout=600
    )
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip().endswith("ok")
