"""The JAX implementations (sbx-rl, the optional extra ``pip install -e ".[jax]"``): a tiny
end-to-end training of ``sbx-sac`` (and ``sbx-ppo``), the model DIR read back as a residual
agent, the NumPy actor against sbx's ``predict``, and the error without the extra. The module
is skipped when sbx or JAX is not installed (except the missing-extra tests, which hide it)."""

import json
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import contour_env  # noqa: F401
from agents.residual import ResidualAgent
from agents.rl import TrainConfig, train
from agents.rl.actor import numpy_actor
from agents.rl.checkpoint import algo_class, checkpoint_dirs, load_model, load_normalization
from contour_env import ENV_ID
from contour_env.app.cli import main
from contour_env.evaluation import evaluate, run_episode

SHORT = "G21 G90 G17 G61\nG01 X2 F1200\nG01 Y2\n"
TINY = dict(
    plant="friction-table",
    timesteps=300,
    seed=0,
    learning_starts=50,
    buffer_size=2000,
    batch_size=32,
    eval_freq=150,
    checkpoint_freq=150,
    ppo_n_steps=32,
    net_arch=(16, 16),
    validation_paths=1,
)


def _jax():
    """sbx and JAX, or skip the test."""
    pytest.importorskip("jax")
    return pytest.importorskip("sbx")


@pytest.fixture(scope="module")
def sbx_sac_run(tmp_path_factory, gcode):
    _jax()
    out = tmp_path_factory.mktemp("runs") / "sbx-sac"
    cfg = TrainConfig(gcode=(gcode,), algo="sbx-sac", **TINY)
    res = train(cfg, out, progress=False, log=lambda s: None)
    return out, cfg, res


class _Env(gym.Env):
    """The spaces a model needs to be built (never stepped)."""

    observation_space = spaces.Box(-10, 10, (7,), dtype=np.float32)
    action_space = spaces.Box(-1, 1, (3,), dtype=np.float32)

    def reset(self, *, seed=None, options=None):
        return np.zeros(7, dtype=np.float32), {}

    def step(self, action):
        return np.zeros(7, dtype=np.float32), 0.0, False, False, {}


# --- the NumPy actor -------------------------------------------------------------------------


@pytest.mark.parametrize("algo", ["sbx-sac", "sbx-ppo"])
@pytest.mark.parametrize("net_arch", [[16], [64, 64]])
def test_numpy_actor_matches_sbx_predict(algo, net_arch):
    _jax()
    import jax

    kw = {"n_steps": 32, "batch_size": 16} if algo == "sbx-ppo" else {}
    model = algo_class(algo)(
        "MlpPolicy", _Env(), seed=0, device="cpu", policy_kwargs={"net_arch": net_arch}, **kw
    )
    # weights large enough that the squash (SAC) and the clip (PPO) are exercised
    st = model.policy.actor_state
    model.policy.actor_state = st.replace(
        params=jax.tree_util.tree_map(lambda p: p * 4.0, st.params)
    )
    rng = np.random.default_rng(1)
    x = rng.normal(size=(256, 7)).astype(np.float32) * 3
    want, _ = model.predict(x, deterministic=True)
    got = numpy_actor(model)(x)
    assert got.shape == (256, 3) and got.dtype == np.float64
    assert np.all(np.abs(got) <= 1.0)
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5)
    assert np.mean(np.abs(got) > 0.99) > 0.05  # saturated actions are in the sample


def test_an_unsupported_sbx_actor_is_refused():
    sbx = _jax()
    model = sbx.SAC("SimbaPolicy", _Env(), seed=0, device="cpu")
    with pytest.raises(ValueError, match="not supported"):
        numpy_actor(model)


# --- training end to end ---------------------------------------------------------------------


def test_tiny_sbx_sac_training_writes_a_model_dir_the_package_reads(sbx_sac_run):
    sbx = _jax()
    out, _, res = sbx_sac_run
    assert res["timesteps"] >= 300
    for name in ("model.zip", "agent.json", "config.json", "normalization.json"):
        assert (out / name).is_file(), name
    meta = json.loads((out / "agent.json").read_text())
    assert (meta["algo"], meta["plant"], meta["n_axes"]) == ("sbx-sac", "friction-table", 2)
    newest = checkpoint_dirs(out / "checkpoints")[-1]
    assert (newest / "replay_buffer.pkl").is_file()  # off-policy: resumable with its buffer
    model = load_model(out / "final" / "model.zip", "sbx-sac")
    assert isinstance(model, sbx.SAC)
    # the model DIR as a residual agent, scored by the project's one scoring function
    env = gym.make(ENV_ID, plant="friction-table", path=SHORT)
    m = evaluate(env, ResidualAgent(out))
    assert m["completed"] and m["rms_contour_error_um"] > 0
    # the final model: its NumPy actor is sbx's deterministic predict on the agent's inputs
    agent = ResidualAgent(out / "final")
    assert isinstance(agent.model, sbx.SAC)
    x = np.random.default_rng(0).normal(size=(64, meta["obs_dim"])).astype(np.float32)
    want, _ = agent.model.predict(x, deterministic=True)
    np.testing.assert_allclose(agent._actor(x), want, rtol=0, atol=2e-5)
    # a second, independent save (the newest checkpoint) acts the same, bit for bit
    a2 = ResidualAgent.from_parts(
        agent.meta,
        load_model(newest / "model.zip", "sbx-sac"),
        load_normalization(newest / "normalization.json"),
    )
    r1 = run_episode(gym.make(ENV_ID, plant="friction-table", path=SHORT), agent)
    r2 = run_episode(gym.make(ENV_ID, plant="friction-table", path=SHORT), a2)
    np.testing.assert_array_equal(r1.force, r2.force)
    # the stochastic agent goes through sbx's predict (the same protocol as sb3's)
    m = evaluate(
        gym.make(ENV_ID, plant="friction-table", path=SHORT),
        ResidualAgent(out / "final", deterministic=False),
    )
    assert m["completed"]


def test_sbx_sac_training_repeats_itself_with_the_same_seed(sbx_sac_run, tmp_path):
    out, cfg, res = sbx_sac_run
    res2 = train(cfg, tmp_path / "again", progress=False, log=lambda s: None)
    assert res2["timesteps"] == res["timesteps"]
    a1 = numpy_actor(load_model(out / "final" / "model.zip", "sbx-sac"))
    a2 = numpy_actor(load_model(tmp_path / "again" / "final" / "model.zip", "sbx-sac"))
    for (k1, w1, b1), (k2, w2, b2) in zip(a1.layers, a2.layers, strict=True):
        assert k1 == k2
        if w1 is not None:
            np.testing.assert_array_equal(w1, w2)
            np.testing.assert_array_equal(b1, b2)


def test_sbx_sac_model_dir_on_the_command_line(sbx_sac_run, gcode, capsys):
    out, _, _ = sbx_sac_run
    common = ["--plant", "friction-table", "--gcode", gcode]
    assert main(["evaluate", "--model", str(out), *common]) == 0
    assert "sbx-sac" in capsys.readouterr().out
    rc = main(["compare", *common, "--controllers", "pd,residual", "--model", str(out)])
    assert rc == 0
    assert "residual" in capsys.readouterr().out


def test_sbx_sac_resume_continues_from_the_checkpoint(sbx_sac_run, tmp_path):
    import shutil

    src, cfg, res = sbx_sac_run
    out = tmp_path / "run"
    shutil.copytree(src, out)
    more = TrainConfig(**{**cfg.to_dict_args(), "timesteps": 450})
    res2 = train(more, out, resume=True, progress=False, log=lambda s: None)
    assert res2["timesteps"] >= 450 > res["timesteps"]
    assert json.loads((out / "final" / "agent.json").read_text())["timesteps"] >= 450


def test_tiny_sbx_ppo_training_and_annealed_rate(tmp_path, gcode):
    sbx = _jax()
    cfg = TrainConfig(
        gcode=(gcode,), algo="sbx-ppo", n_envs=2, learning_rate_final=1e-4,
        **{**TINY, "validation_paths": 0},
    )  # fmt: skip
    assert cfg.num_envs == 2 and cfg.on_policy
    res = train(cfg, tmp_path / "ppo", progress=False, log=lambda s: None)
    assert res["timesteps"] >= 300 and res["kept"] == "final"
    model = load_model(tmp_path / "ppo" / "model.zip", "sbx-ppo")
    assert isinstance(model, sbx.PPO)
    # the learning rate was annealed to its final value (sbx reads the trainer's schedule
    # sb3's way): the actor's and the critic's optimisers (saved with the model) ran at it
    for state in (model.policy.actor_state, model.policy.vf_state):
        opt = state.opt_state if isinstance(state.opt_state, tuple) else (state.opt_state,)
        rates = [float(s.hyperparams["learning_rate"]) for s in opt if hasattr(s, "hyperparams")]
        assert rates and np.allclose(rates, 1e-4, rtol=1e-3), rates
    assert not (
        checkpoint_dirs(tmp_path / "ppo" / "checkpoints")[-1] / "replay_buffer.pkl"
    ).exists()
    m = evaluate(
        gym.make(ENV_ID, plant="friction-table", path=SHORT), ResidualAgent(tmp_path / "ppo")
    )
    assert m["completed"]


def test_the_algorithm_lists_agree():
    from agents.rl import checkpoint, config
    from contour_env.app import cli_rl

    assert cli_rl.ALGOS == config.ALGOS == checkpoint.SB3_ALGOS + checkpoint.SBX_ALGOS
    assert cli_rl.JAX_ALGOS == config.JAX_ALGOS == checkpoint.SBX_ALGOS


def test_sbx_ppo_refuses_off_policy_options(gcode):
    with pytest.raises(ValueError, match="not sbx-ppo"):
        TrainConfig(gcode=(gcode,), algo="sbx-ppo", gradient_steps=2, **TINY)


# --- without the extra -----------------------------------------------------------------------


@pytest.fixture
def no_sbx(monkeypatch):
    """sbx not importable (as without the [jax] extra)."""
    monkeypatch.setitem(sys.modules, "sbx", None)


def test_without_the_extra_algo_class_says_what_to_install(no_sbx):
    for algo in ("sbx-sac", "sbx-ppo"):
        with pytest.raises(ValueError, match=r'--algo.*pip install -e "\.\[jax\]"'):
            algo_class(algo)
    algo_class("sac")  # sb3 is untouched


def test_without_the_extra_a_jax_model_dir_says_what_to_install(sbx_sac_run, monkeypatch):
    out, _, _ = sbx_sac_run
    monkeypatch.setitem(sys.modules, "sbx", None)
    with pytest.raises(ValueError, match=r'sbx-sac model.*pip install -e "\.\[jax\]"'):
        ResidualAgent(out)


def test_without_the_extra_train_fails_before_writing(no_sbx, tmp_path, gcode, capsys):
    out = tmp_path / "run"
    rc = main(
        [
            "train", "--plant", "friction-table", "--gcode", gcode, "--algo", "sbx-sac",
            "--timesteps", "100", "--out", str(out), "--no-progress",
        ]
    )  # fmt: skip
    assert rc == 2
    err = capsys.readouterr().err
    assert "--algo" in err and 'pip install -e ".[jax]"' in err
    assert not out.exists()
