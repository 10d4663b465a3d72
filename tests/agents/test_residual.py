"""Residual wrappers: a zero residual is the base controller exactly; bounded residual."""

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from agents import controller_names, make_controller
from agents.residual import ResidualVectorWrapper, ResidualWrapper, default_action_repeat
from contour_env import ENV_ID
from contour_env.evaluation import evaluate
from contour_env.plants.randomize import randomized

SHORT = "G21 G90 G17 G61\nG01 X2 F1200\nG01 Y2\n"


def _plant_for(name):
    return "jee-triaxial" if name == "jee-ccc" else "friction-table"


class Zero:
    def __init__(self, n):
        self.n = n

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return np.zeros(self.n, dtype=np.float32), state


@pytest.mark.parametrize("name", controller_names())
def test_zero_residual_reproduces_every_controller_exactly(name):
    plant = _plant_for(name)
    m_base = evaluate(gym.make(ENV_ID, plant=plant, path=SHORT), make_controller(name))
    w = ResidualWrapper(gym.make(ENV_ID, plant=plant, path=SHORT), name, action_repeat=1)
    m_res = evaluate(w, Zero(w.n_axes))
    assert m_res == m_base


def test_zero_residual_gives_identical_info_every_step_with_action_repeat():
    """k servo periods per wrapper step: the wrapper's info after each step equals the base
    policy's info after the same number of periods."""
    env = gym.make(ENV_ID, case="sharp-corner")
    base = make_controller("adaptive-ccc").bind(env)
    obs, _ = env.reset(seed=3)
    start, infos = np.ones(1, dtype=bool), []
    while True:
        a, _ = base.predict(obs, episode_start=start)
        start = np.zeros(1, dtype=bool)
        obs, _, term, trunc, info = env.step(a)
        infos.append(info)
        if term or trunc:
            break
    w = ResidualWrapper(gym.make(ENV_ID, case="sharp-corner"), "adaptive-ccc", action_repeat=4)
    w.reset(seed=3)
    k = 0
    while True:
        _, _, term, trunc, info = w.step(np.zeros(2))
        k += info["servo_steps"]
        ref = infos[k - 1]
        for key in ("position", "force", "reference"):
            np.testing.assert_array_equal(info[key], ref[key])
        assert info["contour_error"] == ref["contour_error"]
        if term or trunc:
            break
    assert k == len(infos)


def test_vector_wrapper_zero_residual_equals_base_on_the_vector_env():
    n = 3
    params = randomized(gym.make(ENV_ID, case="sharp-corner").unwrapped.plant.params, 0.2, n, 1)
    kw = dict(num_envs=n, vectorization_mode="vector_entry_point", plant_params=params)
    venv = gym.make_vec(ENV_ID, case="sharp-corner", **kw)
    base = make_controller("ccc").bind(venv)
    obs, _ = venv.reset(seed=5)
    w = ResidualVectorWrapper(gym.make_vec(ENV_ID, case="sharp-corner", **kw), "ccc")
    w.reset(seed=5)
    start = np.ones(n, dtype=bool)
    for _ in range(venv.unwrapped.core.n_steps - 1):
        a, _ = base.predict(obs, episode_start=start)
        start[:] = False
        obs, r1, t1, tr1, i1 = venv.step(a)
        _, r2, t2, tr2, i2 = w.step(np.zeros((n, 2)))
        np.testing.assert_array_equal(i1["position"], i2["position"])
        np.testing.assert_array_equal(i1["force"], i2["force"])
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(t1 | tr1, t2 | tr2)
    assert tr1.all()


def test_vector_wrapper_matches_single_wrapper_with_actions_and_repeat():
    rng = np.random.default_rng(0)
    kw = dict(plant="friction-table", path=SHORT)
    single = ResidualWrapper(gym.make(ENV_ID, **kw), "pd", action_repeat=3, residual_penalty=0.1)
    vec = ResidualVectorWrapper(
        gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", **kw),
        "pd",
        action_repeat=3,
        residual_penalty=0.1,
    )
    o1, _ = single.reset(seed=7)
    o2, _ = vec.reset(seed=7)
    np.testing.assert_array_equal(o1, o2[0])
    while True:
        a = rng.uniform(-1, 1, size=(2, 2)).astype(np.float32)
        o1, r1, t1, tr1, _ = single.step(a[0])
        o2, r2, t2, tr2, _ = vec.step(a)
        np.testing.assert_array_equal(o1, o2[0])
        assert r1 == pytest.approx(r2[0], rel=1e-12, abs=0)
        assert (t1, tr1) == (t2[0], tr2[0])
        if t1 or tr1:
            break


def test_residual_is_bounded_by_scale():
    w = ResidualWrapper(gym.make(ENV_ID, plant="friction-table", path=SHORT), "pd", scale=0.03)
    w.reset(seed=0)
    rng = np.random.default_rng(1)
    for _ in range(50):
        _, _, _, _, info = w.step(rng.uniform(-5, 5, 2))
        assert np.all(np.abs(info["residual_action"]) <= 0.03 + 1e-12)


def test_observe_base_command_appends_the_next_base_action():
    w = ResidualWrapper(
        gym.make(ENV_ID, plant="friction-table", path=SHORT), "pd", observe_base_command=True
    )
    obs, _ = w.reset(seed=0)
    assert obs.shape == (w.core.obs_dim + 2,) and w.observation_space.contains(obs)
    for _ in range(20):
        nxt, _, _, _, info = w.step(np.full(2, 0.5))
        np.testing.assert_array_equal(obs[-2:], info["base_action"].astype(np.float32))
        obs = nxt


def test_same_step_autoreset_returns_next_episode_and_final_obs():
    venv = gym.make_vec(
        ENV_ID,
        num_envs=2,
        vectorization_mode="vector_entry_point",
        plant="friction-table",
        path=SHORT,
    )
    w = ResidualVectorWrapper(venv, "pd", autoreset_mode="same_step")
    obs0, _ = w.reset(seed=0)
    while True:
        obs, _, term, trunc, info = w.step(np.zeros((2, 2)))
        if (term | trunc).any():
            break
    assert info["_final_obs"].all()
    np.testing.assert_array_equal(obs[0], obs0[0])  # the named path restarts at rest
    assert not np.array_equal(info["final_obs"][0], obs0[0])
    assert (w.core.k == 0).all()


def test_default_action_repeat_is_one_agent_action_per_ms():
    assert default_action_repeat(1e-3) == 1
    assert default_action_repeat(1e-4) == 10


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"scale": 0.0}, "scale"),
        ({"scale": float("nan")}, "scale"),
        ({"action_repeat": 0}, "action_repeat"),
        ({"residual_penalty": -1}, "residual_penalty"),
        ({"base": "nope"}, r"base: unknown controller 'nope'.*pd"),
        ({"observation": "all"}, r"observation: must be one of full, state, errors"),
    ],
)
def test_bad_arguments_are_clear_errors(kwargs, match):
    kw = {"base": "pd", **kwargs}
    with pytest.raises(ValueError, match=match):
        ResidualWrapper(gym.make(ENV_ID, plant="friction-table", path=SHORT), **kw)


def test_non_finite_agent_action_is_an_error():
    w = ResidualWrapper(gym.make(ENV_ID, plant="friction-table", path=SHORT))
    w.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        w.step(np.array([np.nan, 0.0]))
    with pytest.raises(ValueError, match="shape"):
        w.step(np.zeros(3))


def test_single_and_vector_wrappers_refuse_the_other_kind():
    venv = gym.make_vec(
        ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", case="sharp-corner"
    )
    with pytest.raises(ValueError, match="ResidualVectorWrapper"):
        ResidualWrapper(venv)
    with pytest.raises(ValueError, match="ResidualWrapper"):
        ResidualVectorWrapper(gym.make(ENV_ID, case="sharp-corner"))


@pytest.mark.parametrize("observe_base_command", [False, True])
def test_errors_observation_is_the_task_frame_errors_in_single_and_vector_wrappers(
    observe_base_command,
):
    kw = dict(plant="friction-table", path=SHORT)
    wk = dict(observation="errors", observe_base_command=observe_base_command)
    full = ResidualWrapper(gym.make(ENV_ID, **kw), "pd", observe_base_command=observe_base_command)
    single = ResidualWrapper(gym.make(ENV_ID, **kw), "pd", **wk)
    vec = ResidualVectorWrapper(
        gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", **kw),
        "pd",
        autoreset_mode="same_step",
        **wk,
    )
    n = 2
    extra = n if observe_base_command else 0
    assert single.observation_space.shape == (2 * n + extra,)
    assert vec.single_observation_space.shape == (2 * n + extra,)
    of, _ = full.reset(seed=3)
    o1, _ = single.reset(seed=3)
    o2, _ = vec.reset(seed=3)
    rng = np.random.default_rng(2)
    while True:
        # the first 2 n fields of the env observation: task-frame position and velocity errors
        np.testing.assert_array_equal(o1[: 2 * n], of[: 2 * n])
        if observe_base_command:
            np.testing.assert_array_equal(o1[2 * n :], of[-n:])
        np.testing.assert_array_equal(o1, o2[0])
        assert single.observation_space.contains(o1)
        a = rng.uniform(-1, 1, size=(2, n)).astype(np.float32)
        of, _, _, _, _ = full.step(a[0])
        o1, _, t1, tr1, _ = single.step(a[0])
        o2, _, t2, tr2, info = vec.step(a)
        if t1 or tr1:
            # sb3's terminal observation has the agent's layout too (its base part is the last
            # applied base action: the base is not asked again at a terminal state)
            assert info["final_obs"].shape == (2, 2 * n + extra)
            np.testing.assert_array_equal(info["final_obs"][0, : 2 * n], o1[: 2 * n])
            break


# --- residual axes: only the axes the path uses (issue 18 item 2) ---------------------------

PLANAR = "G21 G90 G17 G64 P0.01\nG01 X3 Y1 F900\nG01 X1 Y4\nG01 X0 Y0\n"  # z never moves
SPATIAL = "G21 G90 G17 G61\nG01 X3 Y1 Z-1 F900\nG01 X1 Y4 Z0\n"


@pytest.mark.parametrize(
    "kwargs, expected",
    [
        (dict(case="lm-circle3d"), [1.0, 1.0, 1.0]),  # circle inclined 30° about x
        (dict(plant="linear-motor", path=PLANAR), [1.0, 1.0, 0.0]),
        (dict(plant="linear-motor", path=SPATIAL), [1.0, 1.0, 1.0]),
        (dict(plant="friction-table", path=PLANAR), [1.0, 1.0]),
        (dict(plant="friction-table", path="G21 G90 G61\nG01 X4 F600\n"), [1.0, 0.0]),
    ],
)
def test_path_axes_mask_marks_the_axes_the_reference_moves(kwargs, expected):
    from agents.residual import path_axes_mask

    env = gym.make(ENV_ID, **kwargs)
    env.reset(seed=0)
    np.testing.assert_array_equal(path_axes_mask(env.unwrapped.core), expected)


def _run_ones(w, steps=30):
    w.reset(seed=0)
    out = []
    for _ in range(steps):
        a = np.ones(w.action_space.shape, dtype=np.float32)
        _, _, term, trunc, info = w.step(a)
        out.append(info["residual_action"])
        if np.any(term) or np.any(trunc):
            break
    return np.array(out)


def test_no_residual_on_an_axis_the_path_does_not_use_single_and_vector():
    w = ResidualWrapper(gym.make(ENV_ID, plant="linear-motor", path=PLANAR), "ccc")
    assert w.residual_axes == "path"
    res = _run_ones(w)
    assert np.all(res[:, 2] == 0.0) and np.all(np.abs(res[:, :2]) > 0.0)
    wa = ResidualWrapper(
        gym.make(ENV_ID, plant="linear-motor", path=PLANAR), "ccc", residual_axes="all"
    )
    assert np.all(np.abs(_run_ones(wa)[:, 2]) > 0.0)
    venv = gym.make_vec(
        ENV_ID, num_envs=3, vectorization_mode="vector_entry_point", plant="linear-motor",
        path=PLANAR,
    )  # fmt: skip
    vres = _run_ones(ResidualVectorWrapper(venv, "ccc"))
    assert np.all(vres[:, :, 2] == 0.0) and np.all(np.abs(vres[:, :, :2]) > 0.0)


def test_residual_axes_is_checked_and_old_agents_keep_every_axis(tmp_path):
    with pytest.raises(ValueError, match="residual_axes: must be one of path, all"):
        ResidualWrapper(gym.make(ENV_ID, case="sharp-corner"), "pd", residual_axes="xy")
    from agents.rl.config import TrainConfig

    old = TrainConfig(cases=("sharp-corner",)).to_dict()
    del old["residual_axes"]  # a config.json written before the option
    assert TrainConfig.from_dict(old).residual_axes == "all"
    with pytest.raises(ValueError, match="residual_axes"):
        TrainConfig(cases=("sharp-corner",), residual_axes="z")
    # an agent.json written before the option (the shipped agents of 2026-12-02 were such)
    import json
    import shutil

    from agents.residual import ResidualAgent
    from agents.rl.models import shipped_model_for

    old_dir = tmp_path / "old-agent"
    shutil.copytree(shipped_model_for("friction-table"), old_dir)
    meta = json.loads((old_dir / "agent.json").read_text())
    assert meta.pop("residual_axes") == "path"
    (old_dir / "agent.json").write_text(json.dumps(meta))
    agent = ResidualAgent(old_dir)
    assert "residual_axes" not in agent.meta and agent.residual_axes == "all"


def test_the_max_penalty_pays_for_the_error_above_the_cap_single_and_vector():
    """Issue 48: with an error cap c and penalty p, each period's reward is the env's minus
    p · (ε − c)⁺ / scale; the same episode, stepped with and without, differs by exactly that."""
    kw = {"plant": "friction-table", "path": SHORT, "contour_error_scale_m": 5e-6}
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.3, 0.3, size=(300, 2))
    plain = ResidualWrapper(gym.make(ENV_ID, **kw), "ccc", action_repeat=1)
    capped = ResidualWrapper(gym.make(ENV_ID, **kw), "ccc", action_repeat=1)
    capped.set_error_cap(20e-6, 3.0)
    vec = ResidualVectorWrapper(
        gym.make_vec(ENV_ID, num_envs=1, vectorization_mode="vector_entry_point", **kw), "ccc",
        action_repeat=1,
    )  # fmt: skip
    vec.set_error_cap(20e-6, 3.0)
    for w in (plain, capped, vec):
        w.reset(seed=1)
    paid = 0
    for a in actions:
        _, r0, *_, info = plain.step(a)
        _, r1, *_ = capped.step(a)
        _, rv, *_ = vec.step(a[None])
        eps = info["contour_error"]
        want = r0 - 3.0 * max(eps - 20e-6, 0.0) / 5e-6
        assert r1 == pytest.approx(want, rel=1e-12, abs=1e-12)
        assert rv[0] == pytest.approx(want, rel=1e-9, abs=1e-9)
        paid += eps > 20e-6
    assert paid > 0  # the test reaches the cap
    with pytest.raises(ValueError, match="error cap: cap >= 0 m and penalty >= 0"):
        plain.set_error_cap(1e-6, -1.0)
