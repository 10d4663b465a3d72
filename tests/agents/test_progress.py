"""What training tells while it runs: the time to target (first evaluation at each target, in
wall time), the expected time, the evaluation share of the run's wall time, and the presets."""

import argparse
import json
import math

import pytest

import contour_env  # noqa: F401
from agents.rl import TrainConfig, train
from agents.rl.config import PRESETS
from agents.rl.progress import (
    REFERENCE_STEPS_PER_S,
    TARGET_RATIO,
    TargetWatch,
    expected_time_line,
    reference_rate,
)
from contour_env.app import cli_rl

TINY = dict(
    plant="friction-table",
    timesteps=300,
    seed=0,
    learning_starts=50,
    buffer_size=2000,
    batch_size=32,
    eval_freq=100,
    checkpoint_freq=150,
    net_arch=(16, 16),
    validation_paths=1,
    teacher="none",
)


def _pt(t, rms=None, score=None, eligible=False, wall=None, ratios=None):
    p = {"timesteps": t, "train_s": t / 100.0, "wall_s": wall if wall is not None else t / 50.0}
    if rms is not None:
        p["rms_contour_error_um"] = rms
    if score is not None:
        p["score"], p["eligible"] = score, eligible
        p["ratio_to_base"] = ratios if ratios is not None else [score, score]
    return p


def test_target_watch_stamps_the_first_evaluation_at_each_target():
    curve, val = [], []
    w = TargetWatch(2.0, curve, val)
    assert w.postfix() == {f"to_{TARGET_RATIO:.2f}x": "—"}
    curve.append(_pt(100, rms=1.5))
    val.append(_pt(100, score=1.02))
    assert w.update() == []
    # the base itself (a closed gate: every ratio 1), or better on average but worse on a
    # part: not the base's level yet
    val.append(_pt(120, score=1.0))
    val.append(_pt(150, score=0.9, ratios=[0.7, 1.1]))
    assert w.update() == []
    curve.append(_pt(200, rms=1.39))  # 0.695 x 2.0 <= 0.70 x 2.0
    val.append(_pt(200, score=0.99))
    msgs = w.update()
    assert len(msgs) == 2 and all(m.startswith("time to target:") for m in msgs)
    curve.append(_pt(300, rms=1.0))
    val.append(_pt(300, score=0.8, eligible=True))
    msgs = w.update()
    assert len(msgs) == 1 and "eligible" in msgs[0]  # the others were reached already
    rec = w.record()
    assert rec["target_ratio"] == TARGET_RATIO
    assert rec["training_tasks_target"] == {"wall_s": 4.0, "train_s": 2.0, "timesteps": 200}
    assert rec["validation_base_level"]["timesteps"] == 200
    assert rec["validation_eligible"]["timesteps"] == 300
    assert w.postfix() == {"to_base": "0.1m", "to_keep": "0.1m", f"to_{TARGET_RATIO:.2f}x": "0.1m"}
    # json-serialisable, as it goes into agent.json
    json.dumps(rec)


def test_target_watch_reads_a_resumed_runs_points_without_logging_them():
    curve = [_pt(100, rms=0.5)]
    w = TargetWatch(1.0, curve, [])
    assert w.reached["training_tasks_target"]["timesteps"] == 100
    assert w.update() == []
    # no base on training tasks (a run on generated paths only): no such target
    assert "to_0.70x" not in TargetWatch(None, [], [_pt(1, score=1.5)]).postfix()


def test_expected_time_from_the_reference_rate_then_the_budget(gcode):
    cfg = TrainConfig(gcode=(gcode,), algo="sac", **{**TINY, "timesteps": 17_000})
    rate = REFERENCE_STEPS_PER_S[("sac", 1)]
    line = expected_time_line(cfg, None, 0.0, 0, measured=False, eval_s=2.0)
    assert f"{17_000 / rate / 60:.1f} min of training" in line
    assert "reference rate of sac with 1 env(s)" in line
    n_eval = 17_000 // cfg.eval_every() + 1
    assert f"for {n_eval} evaluations" in line
    assert f"about {n_eval * 2.0 / 60:.1f} min for" in line
    # before any evaluation: their time is not guessed
    assert "plus the evaluations (timed at the first one)" in expected_time_line(
        cfg, None, 0.0, 0, measured=False
    )
    # a time budget shorter than the steps: the budget says it
    cfg_b = TrainConfig(
        gcode=(gcode,), algo="sac", **{**TINY, "timesteps": 10**7}, time_budget_s=90
    )
    line = expected_time_line(cfg_b, 100.0, 30.0, 3000, measured=True)
    assert "1.0 min of training (the time budget ends it first)" in line
    # evaluations: over the steps the budget allows (60 s x 100/s), not the 10^7 timesteps
    line = expected_time_line(cfg_b, 100.0, 30.0, 3000, measured=True, eval_s=1.0)
    assert f"for {math.ceil(6000 / cfg_b.eval_every()) + 1} evaluations" in line
    assert "100 agent steps/s measured over this run's first 30 s" in line


def test_reference_rate_is_the_nearest_measured_envs_count():
    assert reference_rate("sac", 1) == REFERENCE_STEPS_PER_S[("sac", 1)]
    assert reference_rate("ppo", 200) == REFERENCE_STEPS_PER_S[("ppo", 256)]
    assert reference_rate("no-such-algo", 1) is None


def test_a_run_reports_its_wall_time_evaluation_share_and_time_to_target(tmp_path, gcode):
    lines = []
    cfg = TrainConfig(gcode=(gcode,), algo="sac", **TINY)
    s = train(cfg, tmp_path / "run", progress=False, log=lines.append)
    assert s["wall_s"] <= s["run_wall_s"]
    assert 0.0 < s["eval_s"] < s["run_wall_s"] and s["eval_share"] == pytest.approx(
        s["eval_s"] / s["run_wall_s"]
    )
    for curve in (s["curve"], s["validation_curve"]):
        walls = [p["wall_s"] for p in curve]
        assert len(walls) >= 3 and walls == sorted(walls)
        assert all(p["wall_s"] >= p["train_s"] for p in curve)
        assert walls[-1] <= s["run_wall_s"]
    assert set(s["time_to_target"]) == {
        "target_ratio", "validation_base_level", "validation_eligible", "training_tasks_target"
    }  # fmt: skip
    meta = json.loads((tmp_path / "run" / "agent.json").read_text())
    assert meta["eval_share"] == s["eval_share"] and meta["time_to_target"] == s["time_to_target"]
    assert any(x.startswith("expected time:") for x in lines)
    assert any(x.startswith("wall time ") and "of which evaluations" in x for x in lines)


def _args(**kw):
    ns = argparse.Namespace(
        case=None, cases=None, plant="friction-table", gcode=None, base="pd", algo=None,
        preset=None, timesteps=None, seed=0, n_envs=None, train_freq=None, time_budget=None,
        eval_every_s=None, gradient_steps=None, scale=0.05, observe_base_command=False,
        observation="full", action_repeat=None, residual_penalty=1.0, residual_axes="path",
        randomize_plant=0.0, randomize_feedrate=0.0, paths="families", families=None,
        eval_freq=None, checkpoint_freq=None, threads=1, validation_paths=None,
        keep_min_gain=None, learning_rate=None, learning_rate_final=None, net_arch=None,
        circle_radius=None,
    )  # fmt: skip
    for k, v in kw.items():
        setattr(ns, k, v)
    return ns


def test_a_preset_fills_what_was_not_given_and_options_override_it():
    assert cli_rl.PRESET_NAMES == tuple(PRESETS)
    cfg = cli_rl.config_from_args(_args(preset="ppo-256"))
    for key, value in PRESETS["ppo-256"].items():
        assert getattr(cfg, key) == value, key
    cfg = cli_rl.config_from_args(_args(preset="ppo-256", n_envs=64, learning_rate=1e-3))
    assert cfg.n_envs == 64 and cfg.learning_rate == 1e-3 and cfg.algo == "ppo"
    # no preset, SAC or no --algo: the default preset, the table's fastest to target
    for algo in (None, "sac"):
        d = cli_rl.config_from_args(_args(algo=algo))
        assert (d.algo, d.n_envs, d.gradient_steps) == ("sac", 4, 2)
        assert d.timesteps == cli_rl.DEFAULT_TIMESTEPS
    assert PRESETS[cli_rl.DEFAULT_PRESET] == dict(algo="sac", n_envs=4, gradient_steps=2)
    # another algorithm, or --preset none: TrainConfig's own defaults
    assert cli_rl.config_from_args(_args(algo="td3")).n_envs is None
    plain = cli_rl.config_from_args(_args(preset="none"))
    assert (plain.algo, plain.n_envs, plain.gradient_steps) == ("sac", None, None)
    with pytest.raises(ValueError, match="--preset: unknown"):
        cli_rl.config_from_args(_args(preset="nope"))


def test_the_ppo_preset_trains_end_to_end(tmp_path, gcode):
    # the preset's 256 envs, PPO, batch and epochs over one rollout of 16 steps per env (its
    # 64 would only repeat the same path four times over)
    preset = {k: v for k, v in PRESETS["ppo-256"].items() if k != "timesteps"}
    preset["ppo_n_steps"] = 16
    kw = {**TINY, **preset, "timesteps": preset["n_envs"] * preset["ppo_n_steps"]}
    kw["batch_size"] = preset["batch_size"]
    cfg = TrainConfig(gcode=(gcode,), **kw)
    s = train(cfg, tmp_path / "ppo", progress=False, log=lambda *a: None)
    assert s["timesteps"] >= cfg.timesteps and (tmp_path / "ppo" / "model.zip").is_file()


def test_the_teacher_options_reach_the_configuration_and_a_budget_alone_ends_by_time():
    """contour-env train's issue-48 options; with --time-budget and no --timesteps the run is
    ended by the budget, not by the default 20 000 steps."""
    cfg = cli_rl.config_from_args(_args(time_budget=540.0, scale=None, observation=None))
    assert cfg.teacher == "ilc-contour" and cfg.envelope and cfg.fine_tune
    assert cfg.timesteps == cli_rl.BUDGET_TIMESTEPS and cfg.observation == "state"
    assert cfg.scale == 0.05 and cfg.max_penalty == 3.0 and cfg.keep_max_ratio == 1.0
    cfg = cli_rl.config_from_args(
        _args(teacher="none", envelope=False, fine_tune=False, max_penalty=0.0,
              keep_max_ratio=1.05, teacher_parts=7, teacher_trials=4,
              teacher_regularization=2.5, plant="linear-motor", scale=None)
    )  # fmt: skip
    assert (cfg.teacher, cfg.envelope, cfg.fine_tune) == ("none", False, False)
    assert (cfg.max_penalty, cfg.keep_max_ratio) == (0.0, 1.05)
    assert (cfg.teacher_parts, cfg.teacher_trials, cfg.teacher_regularization) == (7, 4, 2.5)
    assert cfg.scale == 0.10  # the linear motor's default authority
    assert cli_rl.config_from_args(_args()).timesteps == cli_rl.DEFAULT_TIMESTEPS


def test_the_reference_rates_are_the_measured_ones_of_their_record():
    """agents/rl/data/reference_rates.json against the runs it names (docs/
    time_to_target.json): each rate is its run's agent steps/s rounded (within 0.5 %)."""
    import json
    from pathlib import Path

    from agents.rl.progress import RATES_FILE

    data = json.loads(RATES_FILE.read_text())
    assert (
        data["measured_by"]
        and data["record"] == "docs/time_to_target.json (runs[].agent_steps_per_s)"
    )
    record = json.loads(
        (Path(__file__).resolve().parents[2] / "docs" / "time_to_target.json").read_text()
    )
    measured = {(r["algo"], r["n_envs"]): r["agent_steps_per_s"] for r in record["runs"]}
    for (algo, n), rate in REFERENCE_STEPS_PER_S.items():
        if (algo, n) in measured:
            assert rate == pytest.approx(measured[(algo, n)], rel=0.005), (algo, n)
    assert len([k for k in REFERENCE_STEPS_PER_S if k in measured]) == 5
