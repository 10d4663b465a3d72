"""Tiny end-to-end training runs, model DIRs, checkpoints, resume and mismatch errors."""

import json
import shutil
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from agents.residual import ResidualAgent, ResidualWrapper, residual_controller
from agents.rl import TrainConfig, train
from agents.rl.checkpoint import checkpoint_dirs, load_model, load_normalization
from agents.rl.models import format_models, list_models, shipped_model_for
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
    teacher="none",
    envelope=False,
)


@pytest.fixture(scope="module")
def sac_run(tmp_path_factory, gcode):
    out = tmp_path_factory.mktemp("runs") / "sac"
    cfg = TrainConfig(gcode=(gcode,), algo="sac", **TINY)
    res = train(cfg, out, progress=False, log=lambda s: None)
    return out, cfg, res


@pytest.mark.parametrize("algo", ["td3", "ppo"])
def test_tiny_training_writes_a_usable_model_dir(tmp_path, gcode, algo):
    n_envs = 2 if algo == "ppo" else None
    cfg = TrainConfig(gcode=(gcode,), algo=algo, n_envs=n_envs, **TINY)
    res = train(cfg, tmp_path / algo, progress=False, log=lambda s: None)
    _check_run(tmp_path / algo, res, algo)


def test_tiny_sac_training_writes_a_usable_model_dir(sac_run):
    out, _, res = sac_run
    _check_run(out, res, "sac")


def _check_run(out, res, algo):
    for name in (
        "model.zip",
        "agent.json",
        "config.json",
        "normalization.json",
        "vecnormalize.pkl",
        "learning_curve.json",
        "learning_curve.png",
    ):
        assert (out / name).is_file(), name
    assert res["timesteps"] >= 300
    meta = json.loads((out / "agent.json").read_text())
    assert (meta["algo"], meta["plant"], meta["n_axes"]) == (algo, "friction-table", 2)
    curve = json.loads((out / "learning_curve.json").read_text())
    assert [p["timesteps"] for p in curve["curve"]][-1] == res["timesteps"]
    assert curve["base_rms_contour_error_um"] > 0
    assert checkpoint_dirs(out / "checkpoints")
    m = evaluate(gym.make(ENV_ID, plant="friction-table", path=SHORT), ResidualAgent(out))
    assert m["completed"] and m["rms_contour_error_um"] > 0


def test_save_load_gives_identical_actions(sac_run):
    out, _, _ = sac_run
    newest = checkpoint_dirs(out / "checkpoints")[-1]  # a second, independent save
    # the final model (out/ itself holds the best by validation, maybe an earlier one)
    a1 = ResidualAgent(out / "final")
    model2 = load_model(newest / "model.zip", "sac")
    a2 = ResidualAgent.from_parts(
        a1.meta, model2, load_normalization(newest / "normalization.json")
    )
    r1 = run_episode(gym.make(ENV_ID, plant="friction-table", path=SHORT), a1)
    r2 = run_episode(gym.make(ENV_ID, plant="friction-table", path=SHORT), a2)
    np.testing.assert_array_equal(r1.force, r2.force)
    np.testing.assert_array_equal(r1.contour_error, r2.contour_error)


def _wrapper_of(agent):
    """The training wrapper of ``agent`` (its base, scale, action repeat and observation),
    built independently of ResidualAgent from the agent's metadata."""
    return ResidualWrapper(
        gym.make(ENV_ID, plant="friction-table", path=SHORT),
        agent.meta["base"],
        scale=agent.meta["scale"],
        action_repeat=agent.meta["action_repeat"],
        observation=agent.meta.get("observation", "full"),
        residual_axes=agent.meta["residual_axes"],
        residual_frame=agent.meta["residual_frame"],
        gate=agent.meta["gate"],
        observe_axes=agent.meta["observe_axes"],
        fade_at_rest=agent.meta["fade_at_rest"],
    )


class _ModelPolicy:
    """The agent's sb3 model acting on the wrapper's observation, as during training."""

    def __init__(self, agent):
        self.agent = agent

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        # the agent's deterministic actor (agents.rl.actor), as every scoring path uses it
        return self.agent._actor(self.agent.norm(obs[None]))[0], state


def test_agent_through_evaluate_equals_the_wrapper_it_was_trained_in(sac_run):
    out, _, _ = sac_run
    agent = ResidualAgent(out / "final")  # a trained network (the kept model may be the base)
    assert agent.residual_frame == "path" and agent.observe_axes  # the defaults
    m_agent = evaluate(gym.make(ENV_ID, plant="friction-table", path=SHORT), agent)
    w = _wrapper_of(agent)

    assert evaluate(w, _ModelPolicy(agent)) == m_agent


def test_agent_for_another_plant_or_axis_count_is_refused(sac_run):
    out, _, _ = sac_run
    with pytest.raises(ValueError, match="trained for plant 'friction-table'.*'hsm2'"):
        evaluate(gym.make(ENV_ID, case="hsm2-circle-III"), ResidualAgent(out))
    with pytest.raises(ValueError, match="2-axis plant"):
        residual_controller(out).bind(gym.make(ENV_ID, case="jee-circle3d"))


def test_corrupt_checkpoint_is_a_clear_error_and_the_previous_is_kept(sac_run, tmp_path):
    out0, cfg, _ = sac_run
    out = tmp_path / "run"
    shutil.copytree(out0, out)
    dirs = checkpoint_dirs(out / "checkpoints")
    assert len(dirs) == 2
    prev_bytes = (dirs[0] / "model.zip").read_bytes()
    data = bytearray((dirs[-1] / "model.zip").read_bytes())
    data[len(data) // 2] ^= 0xFF
    (dirs[-1] / "model.zip").write_bytes(bytes(data))
    cfg2 = TrainConfig(**{**cfg.to_dict_args(), "timesteps": 450})
    with pytest.raises(ValueError, match=r"corrupt.*previous checkpoint .*step_.* is kept"):
        train(cfg2, out, resume=True, progress=False, log=lambda s: None)
    assert (dirs[0] / "model.zip").read_bytes() == prev_bytes
    # half-written: a checkpoint directory without its manifest
    (dirs[-1] / "manifest.json").unlink()
    with pytest.raises(ValueError, match="half-written"):
        train(cfg2, out, resume=True, progress=False, log=lambda s: None)


def test_resume_with_a_changed_configuration_names_the_key(sac_run):
    out, cfg, _ = sac_run
    changed = TrainConfig(**{**cfg.to_dict_args(), "scale": 0.1, "timesteps": 450})
    with pytest.raises(ValueError, match=r"differs.*scale: 0\.05 \(checkpoint\) vs 0\.1"):
        train(changed, out, resume=True, progress=False, log=lambda s: None)


def test_resume_continues_to_the_new_budget(sac_run, tmp_path):
    out0, cfg, _ = sac_run
    out = tmp_path / "run"
    shutil.copytree(out0, out)
    cfg2 = TrainConfig(**{**cfg.to_dict_args(), "timesteps": 400})
    res = train(cfg2, out, resume=True, progress=False, log=lambda s: None)
    assert res["timesteps"] >= 400
    assert res["curve"][0]["timesteps"] == 150  # the curve goes on from the checkpoint's


def test_new_run_into_an_existing_out_dir_is_refused(sac_run):
    out, cfg, _ = sac_run
    with pytest.raises(ValueError, match="--resume"):
        train(cfg, out, progress=False, log=lambda s: None)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"algo": "dqn"}, r"algo: must be one of sac, td3, ppo"),
        ({"base": "nope"}, r"base: unknown controller 'nope'"),
        ({"cases": ("sharp-corner", "hsm2-circle-I"), "plant": None, "gcode": ()}, "one plant"),
        ({"path_variety": ("squares",)}, r"path_variety: unknown \['squares'\]"),
        ({"randomize_plant": 1.5}, "randomize_plant"),
        ({"timesteps": 0}, "timesteps"),
        ({"learning_rate_final": 1e-3}, r"learning_rate_final: must be > 0.0 and <= 0.0003"),
        ({"learning_rate_final": 0.0}, "learning_rate_final"),
    ],
)
def test_bad_configuration_is_a_clear_error(gcode, kwargs, match):
    kw = {**TINY, "gcode": (gcode,), **kwargs}
    with pytest.raises(ValueError, match=match):
        TrainConfig(**kw)


def test_randomised_tasks_train_with_circles_splines_and_plant_variants(tmp_path, gcode):
    cfg = TrainConfig(
        gcode=(gcode,),
        algo="ppo",
        n_envs=2,
        path_variety=("circles", "splines"),
        circle_radius_m=(0.002, 0.004),
        spline_size_m=0.004,
        randomize_plant=0.2,
        randomize_feedrate=0.2,
        **{**TINY, "timesteps": 200},
    )
    assert cfg.randomized
    res = train(cfg, tmp_path / "rand", progress=False, log=lambda s: None)
    assert res["timesteps"] >= 200


def test_cli_train_evaluate_and_models(tmp_path, gcode, capsys, sac_run):
    out = tmp_path / "cli"
    rc = main(
        [
            "train", "--plant", "friction-table", "--gcode", gcode, "--base", "pd",
            "--algo", "ppo", "--timesteps", "64", "--seed", "1", "--out", str(out),
            "--n-envs", "2", "--net-arch", "16,16", "--no-progress", "--validation-paths", "1",
            "--teacher-parts", "2", "--teacher-trials", "2",
        ]
    )  # fmt: skip
    assert rc == 0
    assert json.loads((out / "config.json").read_text())["seed"] == 1
    js = tmp_path / "ev.json"
    rc = main(
        ["evaluate", "--model", str(out), "--plant", "friction-table", "--gcode", gcode,
         "--json", str(js)]
    )  # fmt: skip
    assert rc == 0
    data = json.loads(js.read_text())
    assert data["plant"] == "friction-table" and data["agent"]["completed"]
    assert main(["evaluate", "--model", str(out), "--case", "hsm2-circle-I"]) == 2
    assert "trained for plant 'friction-table'" in capsys.readouterr().err
    # models: the shipped folder (possibly empty) and any folder of model DIRs
    assert main(["models"]) == 0
    rows = list_models(out.parent)
    assert {r["name"] for r in rows} == {"cli"}
    assert "friction-table" in format_models(rows)
    shipped = format_models(list_models())
    assert "kept" in shipped.splitlines()[0]
    lines = shipped.splitlines()
    assert any(line.startswith("hsm2") and "the base itself" in line for line in lines)
    with pytest.raises(ValueError, match="no shipped residual agent for plant 'hsm2'"):
        shipped_model_for("hsm2", root=out.parent)
    assert shipped_model_for("friction-table", root=out.parent) == out


def test_compare_puts_the_agent_in_the_same_table(sac_run, tmp_path, gcode, capsys):
    out, _, _ = sac_run
    js = tmp_path / "cmp.json"
    rc = main(
        ["compare", "--plant", "friction-table", "--gcode", gcode, "--controllers",
         "pd,residual", "--model", str(out), "--json", str(js)]
    )  # fmt: skip
    assert rc == 0
    rows = {r["controller"]: r for r in json.loads(js.read_text())["results"]}
    assert set(rows) == {"pd", "residual"}
    # the residual row is the project's one scoring function applied to the agent
    m = evaluate(gym.make(ENV_ID, plant="friction-table", path=gcode), ResidualAgent(out))
    assert rows["residual"]["rms_contour_error_um"] == m["rms_contour_error_um"]
    assert rows["residual"]["rms_effort"] == m["rms_effort"]
    # robustness over plant variations runs the agent on the vectorised env
    from agents.compare import robustness

    rob = robustness(["residual"], 0.2, 3, model=out, plant="friction-table", path=gcode)
    assert rob[0]["controller"] == "residual" and np.isfinite(rob[0]["mean_rms_contour_error_um"])


def test_compare_residual_errors(sac_run, gcode, capsys):
    out, _, _ = sac_run
    # an agent of another plant
    assert main(["compare", "--case", "hsm2-circle-I", "--controllers", "pd,residual",
                 "--model", str(out)]) == 2  # fmt: skip
    assert "trained for plant 'friction-table'" in capsys.readouterr().err
    # --model without a residual row
    assert main(["compare", "--case", "sharp-corner", "--controllers", "pd",
                 "--model", str(out)]) == 2  # fmt: skip
    assert "add residual to --controllers" in capsys.readouterr().err
    # a plant without a shipped agent
    from agents.compare import bound_controller
    from agents.rl.models import list_models

    shipped = {r["plant"] for r in list_models() if "error" not in r}
    env = gym.make(ENV_ID, case="jee-circle3d")
    if "jee-triaxial" not in shipped:
        with pytest.raises(ValueError, match="no shipped residual agent for plant 'jee-triaxial'"):
            bound_controller("residual", env)


def test_errors_observation_agent_is_scored_as_it_was_trained(tmp_path, gcode):
    cfg = TrainConfig(gcode=(gcode,), algo="sac", observation="errors", **TINY)
    out = tmp_path / "errors"
    train(cfg, out, progress=False, log=lambda s: None)
    agent = ResidualAgent(out / "final")  # a trained network (the kept model may be the base)
    # the 2 n task-frame errors and, by default, the 2 n axis reference fields
    assert agent.meta["observation"] == "errors" and agent.meta["obs_dim"] == 8
    m_agent = evaluate(gym.make(ENV_ID, plant="friction-table", path=SHORT), agent)
    w = _wrapper_of(agent)
    assert w.observation == "errors"

    assert evaluate(w, _ModelPolicy(agent)) == m_agent
    with pytest.raises(ValueError, match="observation: must be one of full, state, errors"):
        TrainConfig(gcode=(gcode,), observation="everything", **TINY)


def test_gradient_steps_and_train_freq_reach_sb3_and_curves_carry_training_time(tmp_path, gcode):
    cfg = TrainConfig(
        gcode=(gcode,), algo="sac", n_envs=2, train_freq=2, gradient_steps=3,
        **{**TINY, "timesteps": 240, "eval_freq": 80},
    )  # fmt: skip
    summary = train(cfg, tmp_path / "gs", progress=False, log=lambda *a: None)

    model = load_model(tmp_path / "gs" / "final" / "model.zip", "sac")
    assert model.gradient_steps == 3 and model.train_freq.frequency == 2
    # every curve point carries the training time without evaluations, increasing, and no
    # more than the run's wall time
    last = {}
    for name in ("learning_curve.json", "validation_curve.json"):
        pts = json.loads((tmp_path / "gs" / name).read_text())["curve"]
        ts = [p["train_s"] for p in pts]
        assert len(ts) >= 3 and all(b >= a for a, b in zip(ts, ts[1:], strict=False))
        assert 0 < ts[-1] <= summary["train_s"] <= summary["wall_s"]
        last[name] = ts[-1]
    # the final model's point (learning curve) is scored at the end of training
    assert summary["train_s"] == last["learning_curve.json"]


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(algo="ppo", gradient_steps=2), "off-policy"),
        (dict(gradient_steps=0), "gradient_steps: an integer >= 1 or -1"),
        (dict(gradient_steps=True), "gradient_steps"),
        (dict(train_freq=0), "train_freq: expected an integer >= 1"),
    ],
)
def test_update_schedule_options_are_checked(gcode, kwargs, match):
    with pytest.raises(ValueError, match=match):
        TrainConfig(gcode=(gcode,), **{**TINY, **kwargs})


def test_time_budget_ends_training_before_the_timesteps(tmp_path, gcode):
    cfg = TrainConfig(
        gcode=(gcode,),
        algo="sac",
        **{**TINY, "timesteps": 1_000_000, "time_budget_s": 1.0, "eval_freq": 10**6,
           "validation_paths": 0},
    )  # fmt: skip
    summary = train(cfg, tmp_path / "tb", progress=False, log=lambda *a: None)
    assert 0 < summary["timesteps"] < 1_000_000
    assert 1.0 <= summary["train_s"] < 30.0
    assert (tmp_path / "tb" / "model.zip").is_file() and (tmp_path / "tb" / "final").is_dir()
    pts = json.loads((tmp_path / "tb" / "learning_curve.json").read_text())["curve"]
    assert pts[-1]["timesteps"] == summary["timesteps"]
    with pytest.raises(ValueError, match="time_budget_s: a finite number of seconds > 0"):
        TrainConfig(gcode=(gcode,), **{**TINY, "time_budget_s": 0})


def test_eval_every_s_evaluates_by_training_time_and_the_curve_is_written_as_it_runs(
    tmp_path, gcode, monkeypatch
):
    import agents.rl.trainer as trainer_module

    out = tmp_path / "es"
    written = []  # every learning_curve.json the run writes, in order
    real_write = trainer_module.atomic_write_json

    def spy(path, payload, *a, **kw):
        if Path(path).name == "learning_curve.json":
            written.append(json.loads(json.dumps(payload)))
        return real_write(path, payload, *a, **kw)

    monkeypatch.setattr(trainer_module, "atomic_write_json", spy)

    cfg = TrainConfig(
        gcode=(gcode,),
        algo="sac",
        **{**TINY, "timesteps": 1_000_000, "time_budget_s": 2.0, "eval_freq": 10**6,
           "eval_every_s": 0.4, "validation_paths": 0},
    )  # fmt: skip
    summary = train(cfg, out, progress=False, log=lambda *a: None)
    final = json.loads((out / "learning_curve.json").read_text())
    assert final["complete"] is True and written[-1] == final
    # one partial curve per periodic evaluation, each one point longer
    partial = written[:-1]
    assert partial and all(w["complete"] is False for w in partial)
    assert [len(w["curve"]) for w in partial] == list(range(1, len(partial) + 1))
    # evaluations every 0.4 s of training time (eval_freq alone would give none before the end)
    ts = [p["train_s"] for p in final["curve"]]
    assert len(ts) >= 3 and ts[-1] == summary["train_s"]
    periodic = ts[:-1]  # the last point is the final model's, scored at the end
    assert all(b - a >= 0.4 for a, b in zip(periodic[:-1], periodic[1:], strict=True))
    with pytest.raises(ValueError, match="eval_every_s: a finite number of seconds > 0"):
        TrainConfig(gcode=(gcode,), **{**TINY, "eval_every_s": -1})


def test_cli_residual_law_options_reach_the_config_and_the_agent(tmp_path, gcode):
    out = tmp_path / "opts"
    rc = main(
        [
            "train", "--plant", "friction-table", "--gcode", gcode, "--base", "pd",
            "--algo", "sac", "--timesteps", "60", "--out", str(out), "--net-arch", "8",
            "--no-progress", "--validation-paths", "1", "--residual-frame", "axes", "--gate",
            "--no-observe-axes", "--teacher", "none",
        ]
    )  # fmt: skip
    assert rc == 0
    cfg = json.loads((out / "config.json").read_text())
    assert (cfg["residual_frame"], cfg["gate"], cfg["observe_axes"]) == ("axes", True, False)
    meta = json.loads((out / "final" / "agent.json").read_text())
    assert (meta["residual_frame"], meta["gate"], meta["observe_axes"]) == ("axes", True, False)
    agent = ResidualAgent(out / "final")
    assert agent.model.action_space.shape == (3,)  # two axes and the gate
    with pytest.raises(SystemExit):  # argparse names the option and the allowed values
        main(["train", "--plant", "friction-table", "--gcode", gcode, "--out",
              str(tmp_path / "bad"), "--residual-frame", "tool"])  # fmt: skip


def test_an_agent_kept_as_its_base_says_so_in_compare_and_evaluate(
    sac_run, tmp_path, gcode, capsys
):
    src, _, _ = sac_run
    out = tmp_path / "as-base"
    shutil.copytree(src, out)
    meta = json.loads((out / "agent.json").read_text())
    meta["kept"] = "base"
    (out / "agent.json").write_text(json.dumps(meta))
    js = tmp_path / "cmp.json"
    rc = main(
        ["compare", "--plant", "friction-table", "--gcode", gcode, "--controllers",
         "pd,residual", "--model", str(out), "--json", str(js)]
    )  # fmt: skip
    assert rc == 0
    assert "the agent is its base pd" in capsys.readouterr().out
    rows = {r["controller"]: r for r in json.loads(js.read_text())["results"]}
    assert rows["residual"]["agent_is_base"] is True
    assert rows["residual"]["rms_contour_error_um"] == rows["pd"]["rms_contour_error_um"]
    assert main(["evaluate", "--model", str(out), "--plant", "friction-table", "--gcode",
                 gcode]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    assert "is its base pd" in printed and "agent/base: RMS 1.000, max 1.000" in printed


def test_reward_scale_base_is_the_base_error_on_the_part(gcode):
    from agents.registry import make_controller
    from agents.rl.tasks import TaskSampler
    from agents.rl.vec import ResidualTrainVecEnv

    cfg = TrainConfig(gcode=(gcode,), algo="sac", **TINY)
    assert cfg.reward_scale == "base"
    venv = ResidualTrainVecEnv(
        TaskSampler(cfg, 0), 1, cfg.wrapper_kwargs(), seed=1, reward_scale="base"
    )
    core = venv.groups[0].core
    m = evaluate(gym.make(ENV_ID, plant="friction-table", path=gcode), make_controller(cfg.base))
    assert core.config.contour_error_scale_m == pytest.approx(m["rms_contour_error_um"] * 1e-6)
    # zero residual: the mean reward per servo period is -mean(eps) / eps_rms_base
    venv.reset()
    total, n = 0.0, 0
    while True:
        _, r, done, info = venv.step(np.zeros((1, venv.action_space.shape[0]), np.float32))
        total += float(r[0])
        n += 1
        if done[0]:
            break
    want = m["mean_abs_contour_error_um"] / m["rms_contour_error_um"]
    assert -total / n == pytest.approx(want, rel=1e-6)  # (sb3 rewards are float32)
    fixed = ResidualTrainVecEnv(TaskSampler(cfg, 0), 1, cfg.wrapper_kwargs(), seed=1)
    assert fixed.groups[0].core.config.contour_error_scale_m == 10e-6
    with pytest.raises(ValueError, match="reward_scale: must be one of base, fixed"):
        TrainConfig(gcode=(gcode,), reward_scale="median", **TINY)


def test_the_learning_rate_anneals_to_its_final_value(tmp_path, gcode):
    cfg = TrainConfig(gcode=(gcode,), algo="sac", learning_rate_final=3e-5, **TINY)
    train(cfg, tmp_path / "run", progress=False, log=lambda s: None)
    model = load_model(tmp_path / "run" / "final" / "model.zip", "sac")
    # the last gradient step ran at the end of the run: the final rate (the start rate if the
    # schedule were not applied)
    for opt in (model.actor.optimizer, model.critic.optimizer):
        assert opt.param_groups[0]["lr"] == pytest.approx(3e-5, rel=1e-9)
