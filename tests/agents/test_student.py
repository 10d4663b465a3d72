"""The student (agents.rl.pretrain) and a run with the teacher end to end (issue 48), with a
tiny budget: the teacher's data, the actor fitted to it, the critic warmed, keep-best's first
candidate at 0 timesteps, the envelope in agent.json."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from agents.residual import ResidualAgent
from agents.rl import TrainConfig, train
from agents.rl.pretrain import _deterministic, _effective, pretrain_actor, set_statistics
from agents.rl.teacher_data import TeacherData

TINY = dict(
    plant="friction-table",
    base="ccc",
    algo="sac",
    seed=0,
    families=("arcs",),
    learning_starts=50,
    buffer_size=20_000,
    batch_size=64,
    checkpoint_freq=100,
    net_arch=(16, 16),
    teacher="ilc-contour",
    teacher_parts=2,
    teacher_trials=3,
    validation_paths=1,
)


def test_the_actor_learns_a_residual_that_is_a_function_of_the_observation(tmp_path, gcode):
    """Synthetic labels p* = 0.5 (tanh x0, tanh x1) with the gate open: the fitted policy's g p̂
    is within 10 % of the labels' power on parts it was not fitted on."""
    cfg = TrainConfig(gcode=(gcode,), **{**TINY, "teacher": "none"})
    from agents.rl.tasks import TaskSampler
    from agents.rl.trainer import _build_envs, _build_model

    raw, venv = _build_envs(cfg, TaskSampler(cfg, 0), None)
    model = _build_model(cfg, tmp_path, raw, venv, None, lambda s: None)
    rng = np.random.default_rng(0)
    n, d = 6000, raw.observation_space.shape[0]
    obs = rng.normal(size=(n, d)).astype(np.float32)
    labels = np.zeros((n, 3), dtype=np.float32)
    labels[:, :2] = 0.5 * np.tanh(obs[:, :2])
    labels[:, 2] = 1.0
    data = TeacherData(
        obs=obs, actions=labels, labels=labels, rewards=np.zeros(n, np.float32),
        next_obs=obs, dones=np.zeros(n, bool), weight=np.ones(n, np.float32),
        part=np.arange(n) // 600,
    )  # fmt: skip
    set_statistics(venv, obs)
    fit = pretrain_actor(model, venv, data, n_axes=2, gate=True, path_frame=True, seed=0)
    assert fit["validation_loss"] < 0.1
    x = torch.as_tensor(np.asarray(venv.normalize_obs(obs[:500]), dtype=np.float32))
    with torch.no_grad():
        a, log_std = _deterministic(model, x)
        eff = _effective(a, 2, True, True).numpy()
    err = np.mean(np.sum((eff - labels[:500, :2]) ** 2, axis=1))
    assert err < 0.1 * np.mean(np.sum(labels[:500, :2] ** 2, axis=1))
    assert float(log_std.mean()) == pytest.approx(-2.5, abs=0.5)


@pytest.fixture(scope="module")
def teacher_run(tmp_path_factory, gcode):
    out = tmp_path_factory.mktemp("teacher") / "run"
    cfg = TrainConfig(gcode=(gcode,), timesteps=200, eval_freq=100, **TINY)
    res = train(cfg, out, progress=False, log=lambda s: None)
    return cfg, out, res


def test_a_teacher_run_writes_its_lessons_and_the_first_candidate_is_the_student(teacher_run):
    cfg, out, res = teacher_run
    rec = json.loads((out / "teacher.json").read_text())
    assert rec["teacher"] == "ilc-contour" and rec["parts"] == 2 and rec["completed"] == 2
    assert rec["samples"] > 0 and rec["replay_buffer_rows"] > 0
    assert rec["critic"]["critic_steps"] > 0 and rec["actor"]["epochs"] >= 1
    assert all(x["rms_um"] <= x["base_rms_um"] for x in rec["lessons"])
    curve = json.loads((out / "validation_curve.json").read_text())["curve"]
    assert curve[0]["timesteps"] == 0 and "per_path_max_um" in curve[0]
    assert [p["timesteps"] for p in curve] == sorted(p["timesteps"] for p in curve)
    assert res["teacher"]["parts"] == 2


def test_the_kept_agent_carries_its_envelope_and_the_teacher(teacher_run):
    cfg, out, res = teacher_run
    meta = json.loads((out / "agent.json").read_text())
    assert meta["teacher"] == "ilc-contour" and meta["observation"] == "state"
    env = meta["envelope"]
    bounds = env["upper_bounds"]
    # the training program's feed, 1200 mm/min, bounds the feed (validation parts not counted)
    assert bounds["feed_m_s"] >= 0.02 - 1e-9
    # the final model's envelope holds every state trained on since: at least as wide
    agent = ResidualAgent(out / "final")
    assert agent.use_envelope and np.all(agent.envelope.hi >= np.array(list(bounds.values())))


def test_no_fine_tune_keeps_the_student_or_the_base(tmp_path, gcode):
    cfg = TrainConfig(gcode=(gcode,), timesteps=200, fine_tune=False, **TINY)
    res = train(cfg, tmp_path / "nf", progress=False, log=lambda s: None)
    assert res["timesteps"] == 0
    assert res["kept"] in ("base", "best-validation") and res["kept_timesteps"] == 0
