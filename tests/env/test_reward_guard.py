"""Doing nothing must not score well: the tracking-error guard, the penalty of a termination
(the guard penalty for every step it skips) and ``completed`` in the metrics."""

import math

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from agents import make_controller
from contour_env import ENV_ID
from contour_env.cases import case_names
from contour_env.env.core import EnvConfig
from contour_env.evaluation import run_episode
from contour_env.metrics import score


def _run(env, policy):
    """(return, record, rewards, infos of the last step) of one episode from seed 0."""
    rewards = []
    last = {}
    step = env.step

    def recording_step(action):
        out = step(action)
        rewards.append(out[1])
        last["info"] = out[4]
        return out

    env.step = recording_step
    record = run_episode(env, policy, seed=0)
    return float(np.sum(rewards)), record, rewards, last["info"]


@pytest.mark.parametrize("case", case_names())
def test_zero_action_scores_below_pd_and_is_not_completed(case):
    env = gym.make(ENV_ID, case=case)
    zero_return, zero_record, zero_rewards, info = _run(env, None)
    m = score(zero_record)
    assert not m["completed"] and m["incomplete_reason"]
    assert m["termination_reason"] == "tracking_error_limit"
    # stopped once the reference is 10 mm away; the tool itself never left the path
    assert m["max_contour_error_um"] < 1.0
    core = env.unwrapped.core
    P = core.config.guard_penalty
    assert zero_rewards[-1] == pytest.approx(-P * (core.n_steps - info["step"]), rel=1e-12)

    pd_env = gym.make(ENV_ID, case=case)
    pd_return, pd_record, *_ = _run(pd_env, make_controller("pd"))
    assert pd_record.termination_reason is None and score(pd_record)["completed"]
    assert zero_return < pd_return < 0


@pytest.mark.parametrize(
    "case, controller",
    [
        (case, ctrl)
        for case in case_names()
        if case != "lm-circle3d"  # PD above covers it; CCC there takes half a minute
        for ctrl in ("ccc", "adaptive-ccc")
    ]
    + [("jee-circle3d", "jee-ccc")],
)
def test_classical_controllers_are_never_stopped_on_the_named_cases(case, controller):
    env = gym.make(ENV_ID, case=case)
    _, record, rewards, _ = _run(env, make_controller(controller))
    assert record.termination_reason is None
    assert score(record)["completed"], record.incomplete_reason
    # no guard penalty in the rewards: every step is the ε reward
    np.testing.assert_allclose(rewards, -record.contour_error / 1e-5, rtol=1e-12, atol=0)


def test_a_termination_charges_the_guard_penalty_for_every_skipped_step():
    # with every weight on: the lag and effort terms raise P so that no running step costs more
    kw = dict(
        case="hsm2-circle-I",
        w_contour=2.0,
        w_lag=0.5,
        w_effort=0.1,
        abort_contour_error_m=1e-3,
        abort_tracking_error_m=4e-3,
    )
    env = gym.make(ENV_ID, **kw)
    core = env.unwrapped.core
    P = core.config.guard_penalty
    assert P == pytest.approx((2.0 * 1e-3 + 0.5 * 4e-3) / 1e-5 + 0.1)
    env.reset(seed=0)
    a = np.array([0.02, 0.02], dtype=np.float32)
    rewards = []
    for _ in range(core.n_steps):
        _, r, term, trunc, info = env.step(a)
        rewards.append(r)
        if term or trunc:
            break
    assert term and info["termination_reason"] in ("contour_error_limit", "tracking_error_limit")
    k = info["step"]
    assert rewards[-1] == pytest.approx(-P * (core.n_steps - k), rel=1e-12)
    # each running step costs at most P, so the episode's n_steps − 1 terms are each ≥ −P
    assert min(rewards[:-1]) >= -P
    assert sum(rewards) <= -P * (core.n_steps - k)


def test_contour_guard_comes_before_the_tracking_guard():
    env = gym.make(ENV_ID, case="hsm2-circle-I", abort_contour_error_m=1e-4)
    env.reset(seed=0)
    for _ in range(2000):
        _, r, term, trunc, info = env.step(np.array([1.0, 1.0], dtype=np.float32))
        if term or trunc:
            break
    assert info["termination_reason"] == "contour_error_limit"
    core = env.unwrapped.core
    assert r == pytest.approx(-core.config.guard_penalty * (core.n_steps - info["step"]))


def test_a_larger_tracking_guard_lets_the_zero_action_run_on():
    env = gym.make(ENV_ID, case="hsm2-circle-III", abort_tracking_error_m=0.5)
    rec = run_episode(env, None)
    assert rec.termination_reason is None and len(rec.contour_error) == rec.n_steps_planned
    m = score(rec)
    # the score's own rule still sees that the tool never followed the reference
    assert not m["completed"] and "did not follow" in m["incomplete_reason"]


def test_vector_env_gives_the_single_envs_rewards_and_terminations():
    kw = dict(case="hsm2-circle-I")
    n, steps, seed = 3, 300, 4
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    singles = [gym.make(ENV_ID, **kw) for _ in range(n)]
    venv.reset(seed=seed)
    for i, e in enumerate(singles):
        e.reset(seed=seed + i)
    # env 0 stands still (stopped by the tracking guard near step 128), env 1 is driven off
    # the path (contour guard), env 2 follows with a PD controller
    pd = make_controller("pd").bind(singles[2])
    seen = set()
    single_done = [False] * n
    for _ in range(steps):
        actions = np.zeros((n, 2), dtype=np.float32)
        actions[1] = 0.3
        actions[2] = pd.predict(None)[0] if not single_done[2] else 0.0
        _, vr, vterm, vtrunc, vinfo = venv.step(actions)
        for i, e in enumerate(singles):
            if single_done[i]:
                # the vector env resets it at this step (reward 0, not done); skip the single
                assert vr[i] == 0.0 and not vterm[i]
                single_done[i] = False
                e.reset(seed=seed + i)  # (seeds only matter for noise; the case is noise-free)
                continue
            _, r, term, trunc, info = e.step(actions[i])
            assert vr[i] == r, (i, vr[i], r)
            assert vterm[i] == term and vtrunc[i] == trunc
            assert (vinfo["termination_reason"][i] or None) == info["termination_reason"]
            if term:
                seen.add(info["termination_reason"])
            single_done[i] = term or trunc
    assert seen == {"tracking_error_limit", "contour_error_limit"}


@pytest.mark.parametrize("bad", [0.0, -1e-3, math.nan, math.inf, "1", True, None])
def test_bad_tracking_guard_raises_naming_the_parameter(bad):
    with pytest.raises(ValueError, match="abort_tracking_error_m"):
        EnvConfig(abort_tracking_error_m=bad)
    with pytest.raises(ValueError, match="abort_tracking_error_m"):
        gym.make(ENV_ID, case="hsm2-circle-I", abort_tracking_error_m=bad)


def test_run_without_controller_prints_completed_false_with_a_reason(capsys):
    from contour_env.app.cli import main

    assert main(["run", "--case", "sharp-corner"]) == 0
    out = capsys.readouterr().out
    lines = {
        line.split()[0]: line.split(None, 1)[1]
        for line in out.splitlines()
        if line.startswith("  ") and len(line.split()) > 1
    }
    assert lines["completed"].strip() == "False"
    assert lines["max_contour_error_um"].strip() in ("0", "≤0.1 (enc)")
    assert "tracking_error_limit" in lines["termination_reason"]
    assert "tracking_error_limit" in lines["incomplete_reason"]
