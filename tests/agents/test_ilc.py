"""Iterative learning controllers (ilc-pd, ilc-contour, vilcfd) in repeated-batch runs."""

import json

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from agents import make_controller
from agents.ilc import read_state
from agents.registry import LEARNING_CONTROLLERS
from agents.repeated_batch import run_batch, run_trial
from contour_env.evaluation import evaluate
from contour_env.plants.randomize import randomized

ENV_ID = "contour_env/Contouring-v0"
# a short sharp corner on the friction table: 3 mm + 3 mm at 20 mm/s (about 0.6 s per trial)
SHORT_CORNER = "G21 G90 G17\nG01 X3 F1200\nG01 Y3\n"


def short_env(**kw):
    return gym.make(ENV_ID, plant="friction-table", path=SHORT_CORNER, **kw)


def rms_list(result):
    return [r["rms_contour_error_um"] for r in result["iterations"]]


def test_first_trial_of_pd_based_ilc_is_the_pd_episode():
    env = gym.make(ENV_ID, case="sharp-corner")
    pd = evaluate(env, make_controller("pd"), seed=0)
    for name in ("ilc-pd", "ilc-contour"):
        row = run_batch(gym.make(ENV_ID, case="sharp-corner"), make_controller(name), 1)[
            "iterations"
        ][0]
        for key in ("max_contour_error_um", "rms_contour_error_um", "rms_effort"):
            assert row[key] == pd[key]


@pytest.mark.parametrize("name", LEARNING_CONTROLLERS)
def test_no_divergence_over_50_iterations_on_a_short_sharp_corner(name):
    res = run_batch(short_env(), make_controller(name), 50)
    rows = res["iterations"]
    assert not res["diverged"]
    assert all(r["completed"] for r in rows)
    rms = rms_list(res)
    assert all(np.isfinite(rms))
    # converged and stays converged: every late trial far below the first
    assert max(rms[10:]) <= 0.2 * rms[0]
    json.dumps([dict(r) for r in rows], allow_nan=False)


def test_ilc_contour_on_hsm2_circle_II_reaches_20_percent_in_10_iterations():
    res = run_batch(gym.make(ENV_ID, case="hsm2-circle-II"), make_controller("ilc-contour"), 10)
    rms = rms_list(res)
    assert rms[-1] <= 0.2 * rms[0]


def test_vilcfd_on_sharp_corner_reaches_20_percent_in_10_iterations():
    res = run_batch(gym.make(ENV_ID, case="sharp-corner"), make_controller("vilcfd"), 10)
    rms = rms_list(res)
    assert rms[-1] <= 0.2 * rms[0]


def test_learning_converges_under_20_percent_mismatch_quantisation_and_noise():
    """±20 % true-plant variations (the controllers keep the nominal model), the encoder's
    0.1 µm quantisation and 0.05 µm measurement noise, new in every trial."""
    probe = short_env()
    variants = randomized(probe.unwrapped.plant.params, 0.2, 4, seed=7)
    for name in LEARNING_CONTROLLERS:
        venv = gym.make_vec(
            ENV_ID,
            num_envs=4,
            vectorization_mode="vector_entry_point",
            plant="friction-table",
            path=SHORT_CORNER,
            plant_params=variants,
            measurement_noise_std_m=5e-8,
        )
        res = run_batch(venv, make_controller(name), 12, seed=3, keep_trials=(1, -1))
        first, last = res["trials"][1], res["trials"][12]
        for b in range(4):
            r1 = np.sqrt(np.mean(first.contour_error[b] ** 2))
            r12 = np.sqrt(np.mean(last.contour_error[b] ** 2))
            assert r12 < 0.35 * r1, (name, b, r1, r12)
        assert res["iterations"][-1]["batch"]["failures"] == 0


def test_vector_env_batches_learn_like_single_envs():
    single = run_batch(short_env(), make_controller("ilc-contour"), 4)
    venv = gym.make_vec(
        ENV_ID,
        num_envs=3,
        vectorization_mode="vector_entry_point",
        plant="friction-table",
        path=SHORT_CORNER,
    )
    batch = run_batch(venv, make_controller("ilc-contour"), 4)
    for a, b in zip(single["iterations"], batch["iterations"], strict=True):
        assert a["rms_contour_error_um"] == pytest.approx(b["rms_contour_error_um"], rel=1e-9)
    assert batch["iterations"][-1]["batch"]["n_envs"] == 3


def test_save_and_load_round_trip_exactly(tmp_path):
    env = short_env()
    a = make_controller("vilcfd")
    run_batch(env, a, 3)
    f = tmp_path / "state.npz"
    a.save(f)
    b = make_controller("vilcfd").load_state(f)
    b.bind(short_env())
    np.testing.assert_array_equal(a.u_ff, b.u_ff)
    assert b.iteration == a.iteration == 3
    # continuing either gives the same next trial, bit for bit
    ta = run_trial(env, a)
    env_b = b._core and short_env()
    b.bind(env_b)
    tb = run_trial(env_b, b)
    np.testing.assert_array_equal(ta.contour_error, tb.contour_error)
    meta, u = read_state(f)
    assert meta["controller"] == "vilcfd" and meta["fingerprint"]["case"] == a.fingerprint["case"]


def test_trial_of_another_contour_is_rejected_and_state_untouched():
    env = short_env()
    c = make_controller("ilc-pd")
    run_batch(env, c, 2)
    before = c.u_ff.copy()
    other = gym.make(ENV_ID, plant="friction-table", path="G21 G90\nG01 X4 F1200\nG01 Y3\n")
    foreign = run_trial(other, make_controller("ilc-pd").bind(other))
    with pytest.raises(ValueError, match="does not match the learning state"):
        c.learn(foreign)
    np.testing.assert_array_equal(c.u_ff, before)
    with pytest.raises(ValueError, match="n_samples"):
        c.bind(other)
    np.testing.assert_array_equal(c.u_ff, before)


def test_loading_a_state_of_another_case_or_controller_fails_cleanly(tmp_path):
    c = make_controller("ilc-contour")
    run_batch(short_env(), c, 1)
    f = tmp_path / "s.npz"
    c.save(f)
    d = make_controller("ilc-contour").bind(gym.make(ENV_ID, case="sharp-corner"))
    before = d.u_ff.copy()
    with pytest.raises(ValueError, match="does not match the learning state"):
        d.load_state(f)
    np.testing.assert_array_equal(d.u_ff, before)
    with pytest.raises(ValueError, match="not of 'ilc-pd'"):
        make_controller("ilc-pd").load_state(f)


def test_corrupt_or_missing_state_file_is_a_clear_error(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip at all")
    with pytest.raises(ValueError, match="unreadable or not a contour_env learning state"):
        make_controller("ilc-pd").load_state(bad)
    with pytest.raises(ValueError, match="no such file"):
        make_controller("ilc-pd").load_state(tmp_path / "missing.npz")
    c = make_controller("ilc-pd")
    run_batch(short_env(), c, 1)
    good = tmp_path / "good.npz"
    c.save(good)
    half = tmp_path / "half.npz"
    half.write_bytes(good.read_bytes()[: len(good.read_bytes()) // 2])
    with pytest.raises(ValueError, match="unreadable"):
        make_controller("ilc-pd").load_state(half)


def test_divergence_is_reported_per_iteration_never_nan():
    """An over-aggressive law (γ = 2, no Q-filter, no lead) grows; every row stays finite."""
    c = make_controller("ilc-pd", learning_gain=2.0, lead_steps=0, q_cutoff_hz=1e4)
    res = run_batch(short_env(), c, 15)
    rows = res["iterations"]
    json.dumps(rows, allow_nan=False)
    assert res["diverged"]
    assert any(r["error_growing"] for r in rows)
    assert all(np.all(np.isfinite(c.u_ff)) for _ in [0])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(learning_gain=0.0), "learning_gain: must be in"),
        (dict(learning_gain=3.0), "learning_gain: must be in"),
        (dict(lead_steps=-1), "lead_steps: must be an integer"),
        (dict(q_cutoff_hz=-5.0), "q_cutoff_hz: must be > 0"),
        (dict(q_order=0), "q_order: must be an integer"),
    ],
)
def test_bad_learning_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        make_controller("ilc-pd", **kwargs).bind(short_env())


def test_bad_iterations_and_unbound_learn():
    with pytest.raises(ValueError, match="iterations: must be an integer >= 1"):
        run_batch(short_env(), make_controller("ilc-pd"), 0)
    with pytest.raises(ValueError, match="bind the controller"):
        make_controller("ilc-pd").learn(None)


def test_learning_controllers_work_on_every_named_case_for_two_trials():
    for case in ("hsm2-circle-III", "jee-circle3d", "sharp-corner"):
        for name in LEARNING_CONTROLLERS:
            res = run_batch(gym.make(ENV_ID, case=case), make_controller(name), 2)
            rms = rms_list(res)
            assert all(r["completed"] for r in res["iterations"]), (case, name)
            assert rms[1] < rms[0], (case, name, rms)
