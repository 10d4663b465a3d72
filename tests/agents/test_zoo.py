"""RL Baselines3 Zoo as a client: the shipped hyperparameter files train plain and residual
agents through ``python -m rl_zoo3.train`` and the runs are scored by the project's scoring.

Skipped unless ``rl_zoo3`` is installed (``pip install -e ".[zoo]"``)."""

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from agents.residual import ResidualAgent, ResidualWrapper
from agents.rl.actor import numpy_actor
from agents.zoo import (
    ALGOS,
    RESIDUAL_ENV_ID,
    ZooAgent,
    ZooRun,
    conf_file,
    export_agent,
    load_agent,
    residual_wrapper,
)
from contour_env import ENV_ID
from contour_env.evaluation import evaluate, run_episode

STEPS = 300


def _zoo_train(log_folder, env_id, case, algo="sac"):
    """``python -m rl_zoo3.train`` for STEPS steps, one torch thread; the run folder."""
    cmd = [
        sys.executable, "-m", "rl_zoo3.train",
        "--algo", algo, "--env", env_id,
        "--gym-packages", "agents.zoo",
        "--conf-file", str(conf_file(algo)),
        "--env-kwargs", f"case:'{case}'",
        "--num-threads", "1", "-n", str(STEPS), "--seed", "0",
        "--eval-freq", "-1", "--verbose", "0",
        "-f", str(log_folder),
        # start learning within the budget
        "-params", "learning_starts:100",
    ]  # fmt: skip
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    name = env_id.replace("/", "-")
    run = log_folder / algo / f"{name}_1"
    assert (run / f"{name}.zip").stat().st_size > 0
    assert (run / name / "config.yml").is_file()
    assert (run / name / "vecnormalize.pkl").is_file()
    return run


@pytest.fixture(scope="module")
def zoo():
    pytest.importorskip("rl_zoo3")


@pytest.fixture(scope="module")
def plain_run(zoo, tmp_path_factory):
    return _zoo_train(tmp_path_factory.mktemp("zoo"), ENV_ID, "hsm2-circle-I")


@pytest.fixture(scope="module")
def residual_run(zoo, tmp_path_factory):
    return _zoo_train(tmp_path_factory.mktemp("zoo"), RESIDUAL_ENV_ID, "sharp-corner")


def test_shipped_files_have_plain_and_residual_entries(zoo):
    import yaml

    for algo in ALGOS:
        data = yaml.safe_load(conf_file(algo).read_text())
        assert set(data) == {ENV_ID, RESIDUAL_ENV_ID}
        plain, res = data[ENV_ID], data[RESIDUAL_ENV_ID]
        assert "env_wrapper" not in plain
        assert plain["gamma"] == 0.98 and "net_arch=[64, 64]" in plain["policy_kwargs"]
        ((name, kwargs),) = res["env_wrapper"][0].items()
        assert name == "agents.zoo.residual_wrapper"
        env = gym.make(ENV_ID, case="sharp-corner")
        assert isinstance(residual_wrapper(env, **kwargs), ResidualWrapper)


def test_zoo_trains_plain_sac_and_the_project_scores_it(plain_run):
    run = ZooRun(plain_run)
    assert (run.algo, run.env_id, run.residual) == ("sac", ENV_ID, False)
    assert run.env_kwargs == {"case": "hsm2-circle-I"}
    agent = load_agent(plain_run)
    assert isinstance(agent, ZooAgent)
    m = evaluate(gym.make(ENV_ID, case="hsm2-circle-I"), agent)
    assert m["n_steps"] > 0 and m["rms_contour_error_um"] > 0
    with pytest.raises(ValueError, match="plain run"):
        export_agent(plain_run, plain_run.parent / "export")


def test_zoo_trains_a_residual_agent_scored_as_it_was_trained(residual_run, tmp_path):
    run = ZooRun(residual_run)
    assert run.residual and run.wrapper_kwargs["base"] == "ccc"
    agent = load_agent(residual_run)
    assert isinstance(agent, ResidualAgent)
    assert (agent.base_name, agent.scale, agent.action_repeat) == ("ccc", 0.05, 1)
    rec = run_episode(gym.make(ENV_ID, case="sharp-corner"), agent)

    # the same episode through the zoo's own env stack: the residual wrapper of the run's
    # config.yml on the env, the model on the saved statistics
    model, norm = run.load_model(), run.normalizer()
    actor = numpy_actor(model)  # the agent's deterministic actor (agents.rl.actor)
    env = residual_wrapper(gym.make(ENV_ID, case="sharp-corner"), **run.wrapper_kwargs)
    obs, _ = env.reset(seed=0)
    eps = []
    done = False
    while not done:
        obs, _, term, trunc, info = env.step(actor(norm(obs[None]))[0])
        eps.append(info["contour_error"])
        done = term or trunc
    np.testing.assert_allclose(rec.contour_error, eps, rtol=0, atol=1e-12)

    # exported as a model DIR, the project's CLI row and ResidualAgent read it
    out = export_agent(residual_run, tmp_path / "agent")
    again = evaluate(gym.make(ENV_ID, case="sharp-corner"), ResidualAgent(out))
    rms_um = float(np.sqrt(np.mean(np.square(eps)))) * 1e6
    assert again["rms_contour_error_um"] == pytest.approx(rms_um, rel=1e-9)


def test_residual_wrapper_names_bad_keywords():
    env = gym.make(ENV_ID, case="sharp-corner")
    with pytest.raises(ValueError, match="unknown keyword.*scael"):
        residual_wrapper(env, scael=0.1)
    with pytest.raises(ValueError, match="base must be one of"):
        residual_wrapper(env, base="pid")
    with pytest.raises(ValueError, match="scale"):
        residual_wrapper(env, scale=0)
    with pytest.raises(ValueError, match="observe_base_command"):
        residual_wrapper(env, observe_base_command="no")
    with pytest.raises(ValueError, match="observation must be"):
        residual_wrapper(env, observation="errs")
    w = residual_wrapper(env, base="pd", scale=0.1, residual_penalty=0)
    assert (w.scale, w.residual_penalty, w.base.name) == (0.1, 0.0, "pd")


def test_a_plain_zoo_agent_refuses_another_plant(plain_run):
    agent = load_agent(plain_run)
    with pytest.raises(ValueError, match="observation size"):
        agent.bind(gym.make(ENV_ID, case="lm-circle3d"))
