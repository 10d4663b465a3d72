"""Train a residual agent with stable-baselines3 (SAC, TD3, PPO) and write a model DIR.

``train(config, out_dir, resume=False)`` writes, in ``out_dir``:

- ``config.json``: the exact :class:`~agents.rl.config.TrainConfig`;
- ``agent.json``: what :class:`agents.residual.ResidualAgent` needs (algo, plant, axes,
  observation size, base, scale, action repeat) and the budget and cases;
- ``model.zip``: the kept sb3 model: the one with the lowest validation RMS contour error
  (keep-best, :mod:`agents.rl.validation`), or the final one with ``validation_paths`` 0;
- ``vecnormalize.pkl``, ``normalization.json``: its observation statistics (sb3's pickle, for
  resuming; plain JSON, what the agent reads);
- ``final/``: the final model (``model.zip``, ``vecnormalize.pkl``, ``normalization.json``,
  ``agent.json``), whichever model is kept;
- ``best/step_*``: the best model by validation so far (a verified checkpoint directory);
- ``validation_curve.json``, ``validation_curve.png``: the validation paths, the base's and
  the policy's mean RMS contour error (µm) on them at every evaluation, and the best point;
- ``learning_curve.json``, ``learning_curve.png``: RMS contour error (µm) on the training
  cases / G-code files vs timesteps, the base's level as a horizontal line (runs with cases
  or G-code files only); the JSON is rewritten at every evaluation (``"complete": false``
  until the run ends), so a long run can be read while it runs;
- ``checkpoints/step_*``: periodic checkpoints (:mod:`agents.rl.checkpoint`);
- ``tb/``: TensorBoard logs, only when ``tensorboard`` is installed (it is not a dependency).

Timesteps count agent steps (one agent step = ``action_repeat`` servo periods) summed over the
envs, as in sb3. Seeding: ``seed`` seeds Python, NumPy and PyTorch (sb3's ``set_random_seed``),
the task sampler (``seed``) and the env resets (``seed + 1``); a run is reproducible on the same
machine and thread count, a resumed run continues from the checkpoint's weights, statistics and
replay buffer but not from the exact random-generator states.

Evaluation: every ``eval_every()`` timesteps (and once at the end) the current policy (with
the current statistics, deterministic) is scored by :func:`contour_env.evaluation.evaluate`

- on the validation paths (generated, never trained on; :mod:`agents.rl.validation`): the
  validation curve, and the model kept;
- on each training case / G-code file without randomisation, seed 0: the learning curve (the
  mean RMS contour error over them), a record of the fit to the training tasks that does not
  choose the model.
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from contour_env import ENV_ID
from contour_env.evaluation import evaluate
from contour_env.io import atomic_save, atomic_write_json, check_output_dir
from contour_env.plants.from_file import is_plant_file

from ..registry import make_controller
from ..residual import MODEL_FORMAT, ResidualAgent
from .checkpoint import (
    algo_class,
    latest_checkpoint,
    load_model,
    normalizer_of,
    write_checkpoint,
)
from .config import TrainConfig, load_config
from .progress import EXPECT_AFTER_S, TargetWatch, budget_ends_first, expected_time_line
from .schedule import AnnealedRate
from .tasks import TaskSampler
from .validation import BestKeeper, Validator, curve_point, validation_record
from .vec import ResidualTrainVecEnv

CLIP_OBS = 10.0
# the model files of a model DIR besides agent.json (the kept model, final/)
MODEL_FILES = ("model.zip", "vecnormalize.pkl", "normalization.json")


def tensorboard_available() -> bool:
    return importlib.util.find_spec("tensorboard") is not None


def _model_kwargs(cfg: TrainConfig, n_actions: int) -> dict:
    kw = {
        "learning_rate": cfg.learning_rate,
        "gamma": cfg.gamma,
        "policy_kwargs": {"net_arch": list(cfg.net_arch)},
    }
    if not cfg.on_policy:  # sac, td3, sbx-sac (sbx's SAC takes sb3's keywords)
        kw.update(
            buffer_size=cfg.buffer_size,
            learning_starts=cfg.learning_starts,
            batch_size=cfg.batch_size or 256,
        )
        if cfg.train_freq is not None:
            kw["train_freq"] = cfg.train_freq
        if cfg.gradient_steps is not None:
            kw["gradient_steps"] = cfg.gradient_steps
        if cfg.algo == "sac" and cfg.teacher != "none":
            from .pretrain import TEACHER_ENT_COEF_INIT

            kw["ent_coef"] = TEACHER_ENT_COEF_INIT
        if cfg.algo == "td3":
            from stable_baselines3.common.noise import NormalActionNoise

            kw["action_noise"] = NormalActionNoise(np.zeros(n_actions), 0.1 * np.ones(n_actions))
    else:
        kw.update(
            n_steps=cfg.ppo_n_steps, batch_size=cfg.batch_size or 64, n_epochs=cfg.ppo_n_epochs
        )
    return kw


class Evaluator:
    """Scores the current policy on the nominal tasks (mean RMS contour error, µm)."""

    def __init__(self, sampler: TaskSampler, cfg: TrainConfig):
        self.tasks = sampler.nominal_tasks()
        self.cfg = cfg
        self.base_rms = float(
            np.mean([self._score(task, make_controller(cfg.base)) for task in self.tasks])
        )

    def _score(self, task, policy) -> float:
        env = gym.make(ENV_ID, **task)
        m = evaluate(env, policy, seed=0)
        rms = m["rms_contour_error_um"]
        return float("inf") if rms is None or not m["completed"] else float(rms)

    def __call__(self, meta: dict, model, normalizer) -> float:
        agent = ResidualAgent.from_parts(meta, model, normalizer)
        return float(np.mean([self._score(task, agent) for task in self.tasks]))


def _metadata(cfg: TrainConfig, venv: ResidualTrainVecEnv, timesteps: int) -> dict:
    g = venv.groups[0]
    return {
        "format": MODEL_FORMAT,
        "algo": cfg.algo,
        # the env's plant name (a plant file's "name", e.g. "identified"); the file it came
        # from in "plant_file"
        "plant": g.core.setup.plant.name,
        **(
            {"plant_file": os.path.basename(cfg.plant_name)}
            if is_plant_file(cfg.plant_name)
            else {}
        ),
        "n_axes": int(g.n_axes),
        "obs_dim": int(g.single_observation_space.shape[0]),
        "base": cfg.base,
        "base_kwargs": {},
        "scale": cfg.scale,
        "observe_base_command": cfg.observe_base_command,
        "observation": cfg.observation,
        "residual_axes": cfg.residual_axes,
        "residual_frame": cfg.residual_frame,
        "gate": cfg.gate,
        "observe_axes": cfg.observe_axes,
        "fade_at_rest": cfg.fade_at_rest,
        "action_repeat": int(g.action_repeat),
        "servo_period_s": float(g.core.T),
        "cases": list(cfg.cases),
        "gcode": [os.path.basename(f) for f in cfg.gcode],
        "timesteps": int(timesteps),
        "seed": cfg.seed,
        "teacher": cfg.teacher,
        "envelope": (
            venv.envelope.to_dict() if cfg.envelope and venv.envelope is not None else None
        ),
    }


def plot_learning_curve(
    curve: list[dict], base_rms: float, base: str, title: str, out, best=None
) -> None:
    """RMS contour error vs timesteps with the base's level; ``best``: (timesteps, µm) of the
    kept model, marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from contour_env.io import atomic_save_figure

    fig, ax = plt.subplots(figsize=(7, 4.5))
    x = [p["timesteps"] for p in curve]
    y = [p["rms_contour_error_um"] for p in curve]
    ax.plot(x, y, "o-", ms=3, label="residual agent (deterministic)")
    ok = [(p["timesteps"], p["rms_contour_error_um"]) for p in curve if p.get("eligible")]
    if any("eligible" in p for p in curve):
        # keep-best's candidates: no validation part worse than the base, enough mean gain;
        # the kept one is the eligible point with the lowest mean *ratio*, not the lowest RMS
        ax.plot(
            [t for t, _ in ok], [v for _, v in ok], "o", mfc="none", mec="g", ms=9,
            label=f"eligible ({len(ok)} of {len(curve)}): no part worse than the base",
        )  # fmt: skip
    if np.isfinite(base_rms):  # ∞: the base did not complete a path
        ax.axhline(base_rms, color="k", ls="--", lw=1, label=f"base {base}: {base_rms:.3g} µm")
    if best is not None and best[0] is not None and np.isfinite(best[1]):
        ax.plot([best[0]], [best[1]], "r*", ms=12, label=f"kept: {best[1]:.3g} µm")
    ax.set_xlabel("timesteps (agent steps)")
    ax.set_ylabel("RMS contour error (µm)")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    atomic_save_figure(fig, out, dpi=110)
    plt.close(fig)


def plot_validation(record: dict, algo: str, plant: str, out) -> None:
    """``validation_curve.png`` from the content of ``validation_curve.json`` (``record``, see
    :func:`agents.rl.validation.validation_record`): mean validation RMS (µm) per checkpoint,
    keep-best's eligible checkpoints circled, the kept one starred (none when the base is
    kept); a model DIR's plot can be redrawn from its JSON alone."""
    points = [
        {
            "timesteps": p["timesteps"],
            "rms_contour_error_um": p["rms_contour_error_um"],
            "eligible": bool(p.get("eligible")),
        }
        for p in record["curve"]
        if p["rms_contour_error_um"] is not None
    ]
    best = record["best"]
    kept_base = best["kept"] == "base"
    base_rms = record["base_rms_contour_error_um"]
    where = "the base kept" if kept_base else f"kept: {best['timesteps']} timesteps"
    plot_learning_curve(
        points,
        math.inf if base_rms is None else base_rms,
        record["base"],
        f"{algo} + {record['base']}, {plant}: validation ({len(record['paths'])} generated "
        f"paths), {where}",
        out,
        best=None if kept_base else (best["timesteps"], best["validation_rms_contour_error_um"]),
    )


def train(config: TrainConfig, out_dir, *, resume: bool = False, progress: bool = True, log=print):
    """Train (or, with ``resume``, continue) and write ``out_dir``; returns a summary dict."""
    import torch
    from stable_baselines3.common.utils import set_random_seed

    cfg = config
    run_t0 = time.perf_counter()  # the run's wall clock (the evaluation share's denominator)
    check_output_dir(out_dir)  # a folder under a file, no permission: say so before training
    out = Path(out_dir)
    ckpt, curve, val_curve = _open_run_dir(cfg, out, resume)

    torch.set_num_threads(cfg.torch_threads)
    set_random_seed(cfg.seed)
    sampler = TaskSampler(cfg, cfg.seed)
    raw, venv = _build_envs(cfg, sampler, ckpt)
    model = _build_model(cfg, out, raw, venv, ckpt, log)
    raw.track_envelope = cfg.envelope
    teach = None
    if ckpt is None and cfg.teacher != "none":
        teach = _teach(cfg, out, raw, venv, model, log, progress)
    elif ckpt is not None:
        _resume_envelope(raw, ckpt)
    rate = _anneal_learning_rate(cfg, model)
    t_scoring = time.perf_counter()
    evaluator = Evaluator(sampler, cfg) if sampler.nominal_tasks() else None
    validator = Validator(cfg) if cfg.validation_paths else None
    base_scoring_s = time.perf_counter() - t_scoring  # the base on every scored part
    best = BestKeeper(out) if validator is not None else None
    _log_start(log, cfg, raw, evaluator, validator)
    run = _Run(
        cfg, out, log, run_t0, raw, venv, model, curve, val_curve, evaluator, validator, best
    )

    if teach is not None:
        # the teacher and the pretraining are training time (the time budget covers them)
        run.clock["prior"] += teach["seconds"]
        if validator is not None:
            t_val = time.perf_counter()
            run.validate(run.train_s())  # the pretrained student: keep-best's first candidate
            run.val_curve[-1]["wall_s"] = run.wall_s()
            run.clock["eval"] += time.perf_counter() - t_val
    hooks = _Hooks(run, rate, progress)
    log(expected_time_line(cfg, None, run.train_s(), model.num_timesteps, measured=False))
    t0 = time.perf_counter()
    remaining = cfg.timesteps - model.num_timesteps
    if cfg.fine_tune and (cfg.time_budget_s is None or run.train_s() < cfg.time_budget_s):
        model.learn(
            total_timesteps=remaining,
            callback=hooks,
            reset_num_timesteps=ckpt is None,
            tb_log_name=cfg.algo,
            progress_bar=False,
        )
    wall = time.perf_counter() - t0
    ts = run.train_s()
    final_rms, final_eval_s = run.score_final(ts)
    final_dir = run.save_final()

    # this session's wall time and the part of it spent scoring (the base at the start, the
    # periodic and final evaluations and validations)
    run_wall = time.perf_counter() - run_t0
    eval_s = base_scoring_s + run.clock["eval"] + final_eval_s
    summary = {
        "out": str(out),
        "timesteps": int(model.num_timesteps),
        "wall_s": wall,
        "train_s": ts,
        "run_wall_s": run_wall,
        "eval_s": eval_s,
        "eval_share": eval_s / run_wall if run_wall > 0 else 0.0,
        "time_to_target": run.watch.record(),
        "base_rms_contour_error_um": evaluator.base_rms if evaluator is not None else None,
        "final_rms_contour_error_um": final_rms,
        "curve": curve,
        "teacher": teach["record"] if teach is not None else None,
    }
    summary.update(_write_kept_model(out, cfg, final_dir, best, validator, val_curve, summary))
    if evaluator is not None:
        run.write_curve(complete=True)
        title = f"{cfg.algo} + {cfg.base} on {', '.join(cfg.cases or summary['gcode'])}"
        plot_learning_curve(curve, evaluator.base_rms, cfg.base, title, out / "learning_curve.png")
    _remove_partial_folders(out)
    summary.pop("gcode")
    log(
        f"wall time {run_wall:.1f} s, of which evaluations {eval_s:.1f} s "
        f"({summary['eval_share']:.1%}: the base scored at the start {base_scoring_s:.1f} s, "
        f"periodic {run.clock['eval']:.1f} s, final {final_eval_s:.1f} s)"
    )
    return summary


def _teach(cfg: TrainConfig, out: Path, raw, venv, model, log, progress: bool) -> dict:
    """The teacher's lessons on the training parts, the student's actor fitted to them, the
    critic warmed and the replay buffer filled (:mod:`agents.rl.teacher_data`,
    :mod:`agents.rl.pretrain`); writes ``teacher.json``; returns {"seconds", "record"}."""
    from .pretrain import (
        attach_teacher_regularizer,
        fill_replay_buffer,
        pretrain_actor,
        set_statistics,
        warm_critic,
    )
    from .teacher_data import collect

    t0 = time.perf_counter()
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=cfg.teacher_parts, unit="part", desc=f"teacher ({cfg.teacher})")

    def tick(entry):
        if bar is not None:
            bar.update(1)
            if entry.get("completed") and entry.get("base_rms_um"):
                bar.set_postfix(rms_ratio=f"{entry['rms_um'] / entry['base_rms_um']:.2f}")

    try:
        data = collect(cfg, cfg.teacher_parts, progress=tick, log=None)
    finally:
        if bar is not None:
            bar.close()
    summary = data.summary()
    log(
        f"teacher ({cfg.teacher}): {summary['completed']} of {summary['parts']} parts, "
        f"{summary['trials']} trials, {summary['samples']} samples in {summary['seconds']:.0f} s;"
        f" its RMS / max contour error {summary['mean_rms_ratio']:.3f} / "
        f"{summary['mean_max_ratio']:.3f}x the base's on average"
    )
    if cfg.envelope and data.envelope is not None:
        raw.envelope = data.envelope.copy()
    set_statistics(venv, data.obs)
    g = raw.groups[0]
    # the regression's share of a time budget: at most a sixth of it (its best epoch comes
    # early: 2–10 of 60 on the plants' training families)
    seconds = None if cfg.time_budget_s is None else cfg.time_budget_s / 6
    fit = pretrain_actor(
        model, venv, data, n_axes=int(g.n_axes), gate=cfg.gate,
        path_frame=cfg.residual_frame == "path", seed=cfg.seed, seconds=seconds, log=log,
    )  # fmt: skip
    stored = fill_replay_buffer(model, data)
    critic = warm_critic(model, venv, log=log) if stored else {"critic_steps": 0}
    regularized = attach_teacher_regularizer(
        model, venv, data, n_axes=int(g.n_axes), gate=cfg.gate,
        path_frame=cfg.residual_frame == "path", alpha=cfg.teacher_regularization, seed=cfg.seed,
    )  # fmt: skip
    record = {
        "teacher": cfg.teacher,
        **summary,
        "replay_buffer_rows": stored,
        "teacher_regularization": cfg.teacher_regularization if regularized else 0.0,
        "actor": fit,
        "critic": critic,
        "lessons": data.lessons,
    }
    atomic_write_json(out / "teacher.json", record)
    return {"seconds": time.perf_counter() - t0, "record": {k: v for k, v in record.items()
                                                             if k != "lessons"}}  # fmt: skip


def _resume_envelope(raw, ckpt: Path) -> None:
    """The envelope so far of a resumed run (the checkpoint's agent.json)."""
    from ..envelope import Envelope

    meta_path = ckpt / "agent.json"
    if not meta_path.is_file():
        return
    from ..model_files import read_agent_json

    meta = read_agent_json(meta_path)
    if meta.get("envelope"):
        raw.envelope = Envelope.from_dict(meta["envelope"], int(meta["n_axes"]))


def _open_run_dir(cfg: TrainConfig, out: Path, resume: bool):
    """Check ``out`` for a new run (empty of one) or a resumed one (the same configuration, a
    checkpoint short of ``cfg.timesteps``), create it and write ``config.json``; returns the
    checkpoint to resume from (None for a new run) and its learning and validation curves."""
    ckpt_root = out / "checkpoints"
    ckpt = None
    curve: list[dict] = []
    val_curve: list[dict] = []
    if resume:
        if not (out / "config.json").is_file():
            raise ValueError(f"--resume: {out} holds no training run (no config.json)")
        old = load_config(out / "config.json")
        diff = old.differences(cfg)
        if diff:
            raise ValueError(
                f"--resume: the configuration differs from the run in {out}: {'; '.join(diff)}"
                " (only timesteps may change; use a new --out for a new configuration)"
            )
        ckpt = latest_checkpoint(ckpt_root)
        if ckpt is None:
            raise ValueError(f"--resume: {ckpt_root} holds no checkpoint")
        state = json.loads((ckpt / "state.json").read_text())
        curve = list(state["curve"])
        val_curve = list(state.get("validation_curve", []))
        if state["timesteps"] >= cfg.timesteps:
            raise ValueError(
                f"timesteps: the checkpoint has {state['timesteps']} timesteps already; give "
                f"--timesteps > {state['timesteps']} to continue"
            )
    elif (out / "config.json").exists() or ckpt_root.exists():
        raise ValueError(
            f"--out: {out} already holds a training run; use --resume to continue it or "
            "another --out"
        )
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "config.json", cfg.to_dict())
    return ckpt, curve, val_curve


def _build_envs(cfg: TrainConfig, sampler: TaskSampler, ckpt):
    """The training envs: the raw residual vector env and the monitored, normalised one the
    model trains on (the normalisation statistics of the checkpoint ``ckpt`` when resuming)."""
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    raw = ResidualTrainVecEnv(
        sampler, cfg.num_envs, cfg.wrapper_kwargs(), seed=cfg.seed + 1,
        reward_scale=cfg.reward_scale, max_penalty=cfg.max_penalty,
    )  # fmt: skip
    monitored = VecMonitor(raw)
    if ckpt is not None:
        venv = VecNormalize.load(str(ckpt / "vecnormalize.pkl"), monitored)
        venv.training = True
    else:
        venv = VecNormalize(
            monitored, norm_obs=True, norm_reward=False, clip_obs=CLIP_OBS, gamma=cfg.gamma
        )
    return raw, venv


def _build_model(cfg: TrainConfig, out: Path, raw, venv, ckpt, log):
    """A new sb3 model on ``venv``, or the checkpoint's (with its replay buffer) when
    resuming; TensorBoard logs in ``out/tb`` when tensorboard is installed."""
    tb = str(out / "tb") if tensorboard_available() else None
    if tb is None:
        log("TensorBoard logs off: tensorboard is not installed (pip install tensorboard)")
    n_actions = raw.action_space.shape[0]
    if ckpt is not None:
        model = load_model(ckpt / "model.zip", cfg.algo, env=venv)
        model.tensorboard_log = tb
        if (ckpt / "replay_buffer.pkl").is_file():
            model.load_replay_buffer(ckpt / "replay_buffer.pkl")
        log(f"resuming from {ckpt} at {model.num_timesteps} timesteps")
    else:
        model = algo_class(cfg.algo)(
            "MlpPolicy",
            venv,
            seed=cfg.seed,
            device="cpu",
            verbose=0,
            tensorboard_log=tb,
            **_model_kwargs(cfg, n_actions),
        )
    return model


def _anneal_learning_rate(cfg: TrainConfig, model):
    """The annealed learning rate set on ``model`` (None: a constant one)."""
    rate = None
    if cfg.learning_rate_final is not None:
        rate = AnnealedRate(cfg.learning_rate, cfg.learning_rate_final)
        model.learning_rate = rate
        model.lr_schedule = rate
    return rate


def _remove_partial_folders(out: Path) -> None:
    """Folders a checkpoint or best model left half-written (``.tmp-*``)."""
    for root in (out / "checkpoints", out / "best"):
        for tmp in root.glob(".tmp-*"):
            shutil.rmtree(tmp, ignore_errors=True)


@dataclass(eq=False)
class _Run:
    """One training session: the model and its envs, the learning and validation curves,
    the clocks, and what scores the model and writes its files.

    ``run_t0``: the session's start (``time.perf_counter``); ``curve``, ``val_curve``: the
    learning and validation curves so far (a resumed run's); ``evaluator`` (training tasks),
    ``validator`` and ``best`` (validation paths, keep-best): None when not used. The
    training clock starts when the run is made."""

    cfg: TrainConfig
    out: Path
    log: Callable
    run_t0: float
    raw: ResidualTrainVecEnv
    venv: object  # sb3's VecNormalize
    model: object  # the sb3 model
    curve: list
    val_curve: list
    evaluator: Evaluator | None
    validator: Validator | None
    best: BestKeeper | None

    def __post_init__(self):
        self.ckpt_root = self.out / "checkpoints"
        curve, val_curve = self.curve, self.val_curve
        # training wall time (s) without the evaluations and validations, carried over a
        # resume: the curves' "train_s", what time-to-target figures read
        self.clock = {
            "start": time.perf_counter(),
            "eval": 0.0,
            "prior": max((pt.get("train_s", 0.0) for pt in curve + val_curve), default=0.0),
            # wall time (s) of the run so far, evaluations included, carried over a resume:
            # the curves' "wall_s", what the time-to-target table reads
            # (scripts/time_to_target.py)
            "prior_wall": max((pt.get("wall_s", 0.0) for pt in curve + val_curve), default=0.0),
        }
        self.watch = TargetWatch(
            self.evaluator.base_rms if self.evaluator is not None else None, curve, val_curve
        )

    def meta_now(self) -> dict:
        return _metadata(self.cfg, self.raw, self.model.num_timesteps)

    def wall_s(self) -> float:
        return self.clock["prior_wall"] + (time.perf_counter() - self.run_t0)

    def train_s(self) -> float:
        clock = self.clock
        return clock["prior"] + (time.perf_counter() - clock["start"] - clock["eval"])

    def write_files(self, folder: Path, with_buffer: bool) -> None:
        model, venv = self.model, self.venv
        model.save(folder / "model.zip")
        venv.save(str(folder / "vecnormalize.pkl"))
        atomic_write_json(folder / "normalization.json", normalizer_of(venv).to_dict())
        atomic_write_json(folder / "agent.json", self.meta_now())
        if with_buffer and not self.cfg.on_policy:
            model.save_replay_buffer(folder / "replay_buffer.pkl")
        atomic_write_json(
            folder / "state.json",
            {
                "timesteps": int(model.num_timesteps),
                "curve": self.curve,
                "validation_curve": self.val_curve,
            },
        )

    def checkpoint(self, timesteps: int) -> None:
        """A periodic checkpoint (with the replay buffer) at ``timesteps``."""
        write_checkpoint(
            self.ckpt_root,
            timesteps,
            lambda d: self.write_files(d, True),
            self.cfg.keep_checkpoints,
        )

    def write_curve(self, complete: bool) -> None:
        atomic_write_json(
            self.out / "learning_curve.json",
            {
                "base": self.cfg.base,
                "base_rms_contour_error_um": self.evaluator.base_rms,
                "curve": self.curve,
                "complete": complete,
            },
        )

    def evaluate(self, ts: float) -> float:
        """Score the policy on the training tasks (``ts``: the training time so far) and add
        the point to the learning curve; returns the mean RMS contour error (µm)."""
        rms = self.evaluator(self.meta_now(), self.model, normalizer_of(self.venv))
        point = {"timesteps": int(self.model.num_timesteps), "rms_contour_error_um": rms}
        self.curve.append({**point, "train_s": ts})
        return rms

    def validate(self, ts: float) -> None:
        """Score the policy on the validation paths (``ts``: the training time so far); keep
        it if it is the best so far."""
        validator, best = self.validator, self.best
        t = int(self.model.num_timesteps)
        validator.last_max = None
        rms, per_path = validator(self.meta_now(), self.model, normalizer_of(self.venv))
        per_max = validator.last_max
        point = curve_point(t, rms, per_path, validator, per_max)
        point["train_s"] = ts
        self.val_curve.append(point)
        score, eligible = validator.judge(per_path, per_max)
        if best.offer(t, rms, score, eligible, lambda d: self.write_files(d, False)):
            self.log(
                f"validation: new best {rms:.4g} µm, {score:.3f}x the base on average, at {t} "
                "timesteps"
            )
        # the curve so far, readable while the run goes on (rewritten at the end)
        atomic_write_json(
            self.out / "validation_curve.json",
            validation_record(validator, self.cfg.base, self.val_curve, best),
        )

    def score_final(self, ts: float):
        """Score the final model (the last periodic evaluation may precede the last gradient
        steps) at ``ts`` s of training; returns its RMS contour error on the training tasks
        (None without them) and the seconds the scoring took."""
        t_final = time.perf_counter()
        curve, val_curve, num_timesteps = self.curve, self.val_curve, self.model.num_timesteps
        final_rms = None
        if self.evaluator is not None:
            if curve and curve[-1]["timesteps"] == num_timesteps:
                curve.pop()
            final_rms = self.evaluate(ts)
        if self.validator is not None and (
            not val_curve or val_curve[-1]["timesteps"] < num_timesteps
        ):
            # the final model, unless a periodic validation saw these timesteps (each point of
            # the curve is the score of the model kept for it)
            self.validate(ts)
        final_eval_s = time.perf_counter() - t_final
        if self.evaluator is not None:
            curve[-1]["wall_s"] = self.wall_s()
        if self.validator is not None and val_curve and "wall_s" not in val_curve[-1]:
            val_curve[-1]["wall_s"] = self.wall_s()
        for msg in self.watch.update():
            self.log(msg)
        return final_rms, final_eval_s

    def save_final(self) -> Path:
        """The last checkpoint and ``final/`` (the final model, its statistics and metadata);
        closes the envs; returns ``final/``."""
        model, venv = self.model, self.venv
        self.checkpoint(model.num_timesteps)
        final_dir = self.out / "final"
        for name, save in (
            ("model.zip", lambda p: model.save(p)),
            ("vecnormalize.pkl", lambda p: venv.save(p)),
        ):
            atomic_save(final_dir / name, save)
        atomic_write_json(final_dir / "normalization.json", normalizer_of(venv).to_dict())
        atomic_write_json(final_dir / "agent.json", self.meta_now())
        venv.close()
        return final_dir


class _Hooks(BaseCallback):
    """sb3's callback of a training run: the progress bar, the time budget, the annealed
    learning rate, the periodic evaluations and checkpoints."""

    def __init__(self, run: _Run, rate, progress: bool):
        super().__init__()
        self.run = run
        self.rate = rate
        self.progress = progress
        cfg, points = run.cfg, run.curve + run.val_curve
        self.bar = None
        self.by_time = False
        last = max((pt["timesteps"] for pt in points), default=0)
        self.next_eval = last + cfg.eval_every()
        # by training time as well (eval_every_s), counted on from the last point
        last_s = max((pt.get("train_s", 0.0) for pt in points), default=0.0)
        self.next_eval_s = None if cfg.eval_every_s is None else last_s + cfg.eval_every_s
        self.next_ckpt = run.model.num_timesteps + cfg.checkpoint_every()
        self.ckpt_due = False
        # the expected time, said again at the first evaluation after EXPECT_AFTER_S s of
        # training, from this run's own rate and evaluation time
        self.expect_at = run.train_s() + EXPECT_AFTER_S
        self.start_steps = run.model.num_timesteps
        self.start_s = run.train_s()

    def say(self, msg: str) -> None:
        """``log`` without breaking the progress bar's line."""
        if self.bar is None:
            self.run.log(msg)
        else:
            from tqdm import tqdm

            with tqdm.external_write_mode():
                self.run.log(msg)

    def _on_training_start(self):
        if self.progress:
            from tqdm import tqdm

            cfg = self.run.cfg
            self.by_time = budget_ends_first(cfg)
            if self.by_time:  # the time budget ends the run: a bar of training seconds
                self.bar = tqdm(
                    total=round(cfg.time_budget_s),
                    initial=min(round(self.run.train_s()), round(cfg.time_budget_s)),
                    unit="s",
                    desc="train (s of training)",
                )
            else:
                self.bar = tqdm(
                    total=cfg.timesteps, initial=self.num_timesteps, unit="step", desc="train"
                )

    def _evaluate(self):
        run, cfg = self.run, self.run.cfg
        evaluator, validator, val_curve = run.evaluator, run.validator, run.val_curve
        shown = {}
        t_in = time.perf_counter()
        ts = run.train_s()
        if evaluator is not None:
            rms = run.evaluate(ts)
            self.logger.record("eval/rms_contour_error_um", rms)
            shown.update(rms_um=f"{rms:.3g}", base_um=f"{evaluator.base_rms:.3g}")
        if validator is not None:
            run.validate(ts)
            val = val_curve[-1]["rms_contour_error_um"]
            if val is not None:  # None: a validation path not completed
                self.logger.record("eval/validation_rms_contour_error_um", val)
            shown.update(
                val_ratio=f"{val_curve[-1]['score'] or float('inf'):.3g}",
                kept="base" if run.best.kept_base else f"{run.best.score:.3g}",
            )
        # the wall time at which this evaluation's verdict was known (evaluations included)
        now_wall = run.wall_s()
        if evaluator is not None:
            run.curve[-1]["wall_s"] = now_wall
        if validator is not None:
            val_curve[-1]["wall_s"] = now_wall
        for msg in run.watch.update():
            self.say(msg)
        shown.update(run.watch.postfix())
        if self.expect_at is not None and ts >= min(self.expect_at, cfg.time_budget_s or 1e300):
            self.expect_at = None
            rate_now = (self.num_timesteps - self.start_steps) / max(ts - self.start_s, 1e-9)
            self.say(
                expected_time_line(
                    cfg, rate_now, ts, self.num_timesteps, measured=True,
                    eval_s=time.perf_counter() - t_in,
                )
            )  # fmt: skip
        if self.bar is not None:
            self.bar.set_postfix(**shown)
        if evaluator is not None:
            # the curve so far, so that an interrupted or long run can be read while it runs
            # (rewritten with the final point at the end)
            run.write_curve(complete=False)
        run.clock["eval"] += time.perf_counter() - t_in

    def _on_step(self) -> bool:
        run, cfg = self.run, self.run.cfg
        if self.bar is not None:
            done = min(round(run.train_s()), self.bar.total) if self.by_time else self.num_timesteps
            if done > self.bar.n:
                self.bar.update(done - self.bar.n)
        now_s = run.train_s()
        if cfg.time_budget_s is not None and now_s >= cfg.time_budget_s:
            return False  # sb3 ends learn(); the run is finished as at its last step
        if self.rate is not None:
            self.rate.at(
                now_s / cfg.time_budget_s
                if cfg.time_budget_s is not None
                else self.num_timesteps / cfg.timesteps
            )
        by_time = self.next_eval_s is not None and now_s >= self.next_eval_s
        if self.num_timesteps >= self.next_eval or by_time:
            self._evaluate()
            while self.next_eval <= self.num_timesteps:
                self.next_eval += cfg.eval_every()
            if self.next_eval_s is not None:
                self.next_eval_s = run.train_s() + cfg.eval_every_s
        if self.num_timesteps >= self.next_ckpt:
            if cfg.on_policy:
                self._checkpoint()
            else:
                # sb3's off-policy loop calls on_step before it stores the step's
                # transition: a checkpoint written now would lack it (one transition lost
                # per resume). Written at the end of the rollout, after the store.
                self.ckpt_due = True
        return True

    def _on_rollout_end(self) -> None:
        if self.ckpt_due:
            self._checkpoint()

    def _checkpoint(self) -> None:
        self.run.checkpoint(self.num_timesteps)
        self.ckpt_due = False
        while self.next_ckpt <= self.num_timesteps:
            self.next_ckpt += self.run.cfg.checkpoint_every()

    def _on_training_end(self):
        if self.bar is not None:
            self.bar.close()


def _log_start(log, cfg: TrainConfig, raw, evaluator, validator) -> None:
    parts = []
    if evaluator is not None:
        parts.append(
            f"base {cfg.base}: RMS contour error {evaluator.base_rms:.4g} µm (mean over "
            f"{len(evaluator.tasks)} training task(s))"
        )
    if validator is not None:
        parts.append(
            f"validation: base {validator.base_rms:.4g} µm (mean over {len(validator.paths)} "
            f"generated path(s) of {', '.join(cfg.training_families)}); the best model by "
            "validation is kept"
        )
    else:
        parts.append("no validation (validation_paths 0): the final model is kept")
    parts.append(
        f"action repeat {raw.action_repeat}, {cfg.num_envs} env(s), "
        f"{'randomised' if cfg.randomized else 'fixed'} tasks"
    )
    log("; ".join(parts))


def _write_kept_model(out: Path, cfg, final_dir: Path, best, validator, val_curve, summary):
    """The kept model's files at the top of ``out`` (the best by validation, the final model
    without validation, or — when no checkpoint beat the base on the validation set — the
    final model's files marked ``"kept": "base"``, which :class:`ResidualAgent` runs as the
    base alone), its ``agent.json`` with the run's figures, and the validation curve; returns
    the summary's validation keys."""
    if best is None:
        source, kept = final_dir, "final"
    elif best.kept_base:
        source, kept = final_dir, "base"
    else:
        source, kept = best.folder, "best-validation"
    for name in MODEL_FILES:
        atomic_save(out / name, lambda p, src=source / name: shutil.copyfile(src, p))
    meta = json.loads((source / "agent.json").read_text())
    if kept == "base":
        meta["timesteps"] = 0  # the zero residual: no training step is in the kept model
    extra = {
        "kept": kept,
        "final_timesteps": summary["timesteps"],
        "train_wall_s": summary["wall_s"],
        "run_wall_s": summary["run_wall_s"],
        "eval_share": summary["eval_share"],
        "time_to_target": summary["time_to_target"],
        "base_rms_contour_error_um": summary["base_rms_contour_error_um"],
        "final_rms_contour_error_um": summary["final_rms_contour_error_um"],
        "validation_paths": cfg.validation_paths,
        "validation_rms_contour_error_um": None,
        "validation_base_rms_contour_error_um": None,
        "validation_score": None,
    }
    if validator is not None:
        record = validation_record(validator, cfg.base, val_curve, best)
        atomic_write_json(out / "validation_curve.json", record)
        extra["validation_rms_contour_error_um"] = record["best"]["validation_rms_contour_error_um"]
        extra["validation_base_rms_contour_error_um"] = record["base_rms_contour_error_um"]
        extra["validation_score"] = record["best"]["validation_score"]
        plot_validation(record, cfg.algo, cfg.plant_name, out / "validation_curve.png")
    meta.update(extra)
    atomic_write_json(out / "agent.json", meta)
    return {
        "kept": extra["kept"],
        "kept_timesteps": int(meta["timesteps"]),
        "validation_rms_contour_error_um": extra["validation_rms_contour_error_um"],
        "validation_base_rms_contour_error_um": extra["validation_base_rms_contour_error_um"],
        "validation_score": extra["validation_score"],
        "validation_curve": list(val_curve),
        "gcode": meta["gcode"],
    }
