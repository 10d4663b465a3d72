"""The defaults a first session meets: gym.make without arguments, the case notes' numbers,
``contour-env bench --quick``."""

import math

import gymnasium as gym
import numpy as np
import pytest

import contour_env
from contour_env.cases import CASES, build_setup, case_facts


def test_gym_make_without_arguments_is_the_default_case_the_cli_uses():
    from contour_env.app import cli

    assert contour_env.DEFAULT_CASE == "hsm2-circle-II"
    assert cli.DEFAULT_CASE is contour_env.DEFAULT_CASE
    env = gym.make(contour_env.ENV_ID)
    assert env.unwrapped.setup.name == contour_env.DEFAULT_CASE
    named = gym.make(contour_env.ENV_ID, case=contour_env.DEFAULT_CASE)
    obs, _ = env.reset(seed=0)
    obs2, _ = named.reset(seed=0)
    np.testing.assert_array_equal(obs, obs2)
    assert env.unwrapped.core.n_steps == named.unwrapped.core.n_steps
    venv = gym.make_vec(contour_env.ENV_ID, num_envs=2, vectorization_mode="vector_entry_point")
    assert venv.unwrapped.setup.name == contour_env.DEFAULT_CASE
    # a plant without a path is still an error, not the default case
    with pytest.raises(ValueError, match="give a named case"):
        build_setup(plant="hsm2")


@pytest.mark.parametrize("name", list(CASES))
def test_case_notes_numbers_are_the_case_setups(name):
    spec = CASES[name]
    notes = spec.notes
    assert "{" not in notes and "}" not in notes
    setup = build_setup(name)
    facts = case_facts(spec)
    T = setup.plant.servo_period_s
    episode_steps = setup.reference.n_steps - 1
    assert facts["steps"].replace(" ", "") == str(episode_steps)
    assert float(facts["episode_s"]) == pytest.approx(episode_steps * T, abs=0.05 + T)
    assert float(facts["feed"]) == pytest.approx(spec.feedrate_m_s, rel=1e-5)
    if "a ≤" in notes:
        assert f"a ≤ {spec.max_accel_m_s2:g} m/s²" in notes
        assert f"jerk ≤ {spec.max_jerk_m_s3:g} m/s³" in notes
        assert f"settle {spec.settle_time_s:g} s" in notes
    else:  # "the same cosine S-curve and settle as hsm2-circle-II"
        base = CASES["hsm2-circle-II"]
        assert "the same cosine S-curve and settle as hsm2-circle-II" in notes
        for key in ("max_accel_m_s2", "max_jerk_m_s3", "settle_time_s", "feedrate_m_s", "path"):
            assert getattr(spec, key) == getattr(base, key)
    if spec.path["kind"] == "circle":
        r, v = spec.path["radius"], spec.feedrate_m_s
        assert float(facts["centripetal"]) == pytest.approx(v**2 / r, abs=0.005)


def test_the_linear_motor_note_gives_the_episode_it_runs():
    notes = CASES["lm-circle3d"].notes
    setup = build_setup("lm-circle3d")
    T = setup.plant.servo_period_s
    seconds = (setup.reference.n_steps - 1) * T
    assert seconds == pytest.approx(15.9, abs=0.05)  # not the 7.9 s once typed
    assert f"{seconds:.1f} s" in notes and "7.9 s" not in notes
    assert f"{setup.reference.n_steps - 1:,}".replace(",", " ") + " steps" in notes
    full = 2 * math.pi * 0.5 / 0.05
    assert f"takes {full:.0f} s ({round(full / T):,} steps)".replace(",", " ") in notes
    assert "from −45° to +45°" in notes and "reversal at 0°" in notes and "inclined 30°" in notes


def test_the_other_notes_keep_their_wording_with_computed_numbers():
    assert "(1.60 m/s² centripetal)" in CASES["hsm2-circle-II"].notes
    assert "(2.67 m/s² centripetal)" in CASES["hsm2-circle-III"].notes
    payload = CASES["hsm2-payload"].notes
    for text in ("1.3× the nominal", "mismatch 1.08/0.94", "30 % short", "60/45 Hz"):
        assert text in payload
    assert "radius 50 mm at 10 m/min" in CASES["jee-circle3d"].notes
    assert "normal to (1, 1, 1)" in CASES["jee-circle3d"].notes
    corner = CASES["sharp-corner"].notes
    assert "two 30 mm straight segments meeting at a 90° corner, 20 mm/s (1.2 m/min)" in corner
    assert CASES["hsm2-payload"].true_scale == {"mass_kg": (1.3, 1.3)}


def test_bench_quick_is_one_short_window_without_4096_envs():
    from contour_env.app.speed import QUICK_EXTRA_ENVS, QUICK_SIZES, format_bench, run_bench

    # the exploration and contended rows at 64 envs here (1024 in the real --quick)
    res = run_bench("hsm2-circle-III", quick=True, sizes=(1,), extra_envs=64, controllers=False)
    assert res["quick"] and res["repeats"] == 1 and res["seconds"] == 0.3
    assert len(res["single_env_steps_per_s_runs"]) == 1
    assert [r["num_envs"] for r in res["vector"]] == [1]
    assert res["single_env_steps_per_s"] > 0
    assert [r["amplitude"] for r in res["exploration"]] == [1.0, 0.01]
    assert all(len(r["env_steps_per_s_runs"]) == 1 for r in res["exploration"])
    for r in res["exploration"]:
        # each exploration window paired with a tracking window timed just before it
        (run,), (tracked,) = r["env_steps_per_s_runs"], r["tracking_env_steps_per_s_runs"]
        assert r["ratio_to_tracking"] == run / tracked
    assert res["contended"]["num_envs"] == 64 and res["contended"]["ratio_to_quiet"] > 0
    assert len(res["contended"]["env_steps_per_s_runs"]) == 1
    text = format_bench(res)
    assert "uniform random actions" in text and "contended 64 envs" in text

    assert 4096 not in QUICK_SIZES and QUICK_EXTRA_ENVS < 4096
