"""The student's training data: the teacher's lessons (:mod:`agents.teacher`) on training parts,
replayed through the agent's own wrapper.

For each part the teacher learns a table of agent actions; tables of its trials are then
replayed by :class:`agents.residual.ResidualWrapper` on the same part, seed and reward settings
as an RL episode of the run (the reward scaled by the base's error on the part, the residual
penalty), so each agent step gives what an RL transition holds: the agent's observation, the
action taken, the reward, the next observation and whether the episode ended — and the label,
the kept table's action at that agent step. Three trials are replayed per part: the base's
(an all-zero table), one half-way and the kept one, all labelled with the kept table, so the
student sees the states a policy meets on its way from the base to the teacher (errors from
the base's down to the teacher's) with the one correction to make there, and does not learn
that the correction follows from errors as small as the teacher leaves. The student's actor
regresses the labels (:mod:`agents.rl.pretrain`), its critic is warmed on the transitions, and
the replay buffer starts with them.

Parts: drawn from the run's own task sampler (the path families with training seeds, the
training cases and G-code files; never a validation or held-out part), from a generator
seeded apart from the RL episodes' (``seed + TEACHER_SEED_OFFSET``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import gymnasium as gym
import numpy as np

from contour_env import ENV_ID

from ..envelope import Envelope
from ..teacher import ResidualTeacher

TEACHER_SEED_OFFSET = 7919
# the teacher's parts per run by default
DEFAULT_TEACHER_PARTS = 60


@dataclass
class TeacherData:
    """Transitions of the replayed lessons (one row per agent step), the lessons' summaries
    and the envelope of the parts."""

    obs: np.ndarray
    # the action taken in the replay (what the replay buffer holds)
    actions: np.ndarray
    # the teacher's kept action at the same agent step (what the actor regresses)
    labels: np.ndarray
    rewards: np.ndarray
    next_obs: np.ndarray
    dones: np.ndarray
    # 1 where the agent's residual acts (the reference moves in the agent step), else 0
    weight: np.ndarray
    part: np.ndarray
    lessons: list = field(default_factory=list)
    # the parts (indices) that are the run's own training cases and G-code files: the
    # student's regression gives them NOMINAL_SHARE of its weight (agents.rl.pretrain)
    nominal_parts: tuple = ()
    envelope: Envelope | None = None
    seconds: float = 0.0

    def __len__(self) -> int:
        return int(self.obs.shape[0])

    def summary(self) -> dict:
        done = [x for x in self.lessons if x["completed"]]
        ratio_rms = [x["rms_um"] / x["base_rms_um"] for x in done if x["base_rms_um"] > 0]
        ratio_max = [x["max_um"] / x["base_max_um"] for x in done if x["base_max_um"] > 0]
        return {
            "parts": len(self.lessons),
            "completed": len(done),
            "samples": len(self),
            "seconds": self.seconds,
            "mean_rms_ratio": float(np.mean(ratio_rms)) if ratio_rms else None,
            "mean_max_ratio": float(np.mean(ratio_max)) if ratio_max else None,
            "trials": int(sum(x["trials"] for x in self.lessons)),
        }


def reference_features(core) -> np.ndarray:
    """(2 + 2n,) the largest feed, |curvature|, |axis velocity| and |axis acceleration| of the
    reference of ``core``."""
    A = core.dim
    scal, ref = core.scal, core.ref_pav
    return np.concatenate(
        [
            [np.max(np.abs(scal[:, 0])), np.max(np.abs(scal[:, 2]))],
            np.max(np.abs(ref[:, 1, :A]), axis=0),
            np.max(np.abs(ref[:, 2, :A]), axis=0),
        ]
    )


def teacher_parts(cfg, n_parts: int) -> list[tuple[dict, int]]:
    """(env kwargs, episode seed) of the teacher's parts: the run's training cases and G-code
    files each once, then parts of its task sampler up to ``n_parts`` — or, when the run's
    tasks are fixed (one case or program, nothing randomised: every sample would be the same
    part), generated parts of the plant's path families with training seeds, so that the
    student learns what generalises to the validation parts that choose the model."""
    from .families import VALIDATION_SEED_BASE, generate_path
    from .tasks import TaskSampler

    sampler = TaskSampler(cfg, cfg.seed + TEACHER_SEED_OFFSET)
    rng = np.random.default_rng(cfg.seed + TEACHER_SEED_OFFSET)
    parts = [(dict(t), 0) for t in sampler.nominal_tasks()]
    families = cfg.training_families
    k = 0
    while len(parts) < n_parts:
        seed = int(rng.integers(0, 2**31))
        if sampler.fixed:
            family = families[k % len(families)]
            part = generate_path(
                family, cfg.plant_name, int(rng.integers(0, VALIDATION_SEED_BASE)),
                plant_variation=cfg.randomize_plant,
            )  # fmt: skip
            parts.append(({**cfg.env_config(), **part.env_kwargs()}, part.reset_seed))
            k += 1
        else:
            parts.append((sampler.sample(), seed))
    return parts[: max(n_parts, len(sampler.nominal_tasks()))]


def _reward_kwargs(task: dict, cfg) -> tuple[dict, float]:
    """The env keywords of the task as an RL episode of the run has them (the reward's scale)
    and the max penalty's cap (m; ∞ without one)."""
    from .vec import base_error_figures

    kw = dict(task)
    cap = np.inf
    if cfg.reward_scale == "base" or cfg.max_penalty > 0:
        scale, cap = base_error_figures(task, cfg.base)
        if cfg.reward_scale == "base":
            kw["contour_error_scale_m"] = scale
    params = kw.get("plant_params")
    if params is not None:
        kw["plant_params"] = params[:1]
    return kw, cap if cfg.max_penalty > 0 else np.inf


def _wrapper(task: dict, cfg):
    """The single-env wrapper of an RL episode of the run on ``task`` and its max cap."""
    from ..residual import ResidualWrapper

    law = cfg.wrapper_kwargs()
    base = law.pop("base")
    kw, cap = _reward_kwargs(task, cfg)
    return ResidualWrapper(gym.make(ENV_ID, **kw), base, **law), cap


def replay(task: dict, cfg, actions: np.ndarray, seed: int, labels=None) -> dict:
    """A table of agent actions replayed as RL transitions on ``task`` (module docstring),
    each row labelled with ``labels`` (default the actions themselves): the compiled loop
    (:func:`agents.compiled.residual_runner.replay_residual_table`), the same transitions as
    :func:`replay_python` steps the wrapper through (tested)."""
    from contour_env.env.layout import EpisodeTrace
    from contour_env.env.rollout import empty_record

    from ..compiled import compiled_form
    from ..compiled.residual_runner import replay_residual_table

    w, cap = _wrapper(task, cfg)
    core = w.core
    w.env.reset(seed=seed)
    w.base.reset(np.ones(1, dtype=bool))
    form = compiled_form(w.base)
    if form is None:
        return replay_python(task, cfg, actions, seed, labels)
    view = w._view
    fields = np.arange(core.obs_dim) if view.fields is None else np.asarray(view.fields)
    size = w.observation_space.shape[0]
    if view.observe_base_command:
        return replay_python(task, cfg, actions, seed, labels)
    M = actions.shape[0]
    obs = np.zeros((M + 1, size), dtype=np.float32)
    rewards = np.zeros(M)
    moving = np.zeros(M, dtype=np.bool_)
    rec = empty_record(core)
    trace = EpisodeTrace(
        rec["time"], rec["contour_error"], rec["position"], rec["reference"], rec["force"]
    )
    weights = w._weights if w._weights is not None else np.ones(core.dim)
    view_args = (
        np.ascontiguousarray(fields, dtype=np.int64), bool(view.rotate_prev),
        bool(view.observe_axes), float(view.feed), float(view.acc), float(view.clip),
    )  # fmt: skip
    m, bad, term = replay_residual_table(
        *form._core_args(core), trace, np.ascontiguousarray(actions, dtype=np.float64), w.scale,
        np.ascontiguousarray(w._axis_mask(), dtype=np.float64),
        np.ascontiguousarray(weights, dtype=np.float64), w.residual_frame == "path", w.gate,
        w._v_rest, w.action_repeat, w.residual_penalty, view_args, obs, rewards, moving,
    )  # fmt: skip
    form.store()
    if bad:
        raise ValueError("teacher: the base's action went non-finite in the replay")
    n = int(core.k[0])
    eps = rec["contour_error"][:n]
    if np.isfinite(cap):
        # the max penalty per period, meaned over each agent step's periods as the wrapper
        # does (ResidualWrapper.set_error_cap)
        over = np.minimum(np.maximum(np.nan_to_num(eps, nan=np.inf) - cap, 0.0), 1.0)
        cost = cfg.max_penalty * over / float(core.config.contour_error_scale_m)
        step = np.arange(n) // w.action_repeat
        total = np.bincount(step, weights=cost, minlength=m)[:m]
        count = np.bincount(step, minlength=m)[:m]
        rewards[:m] -= total / np.maximum(count, 1)
    dones = np.zeros(m, dtype=bool)
    dones[-1] = bool(term)
    lab = actions if labels is None else labels
    return {
        "obs": obs[:m],
        "actions": np.asarray(actions[:m], dtype=np.float32),
        "rewards": rewards[:m],
        "next_obs": obs[1 : m + 1],
        "dones": dones,
        "weight": moving[:m].astype(np.float64) if w.fade_at_rest else np.ones(m),
        "labels": np.asarray(lab[:m], dtype=np.float32),
        "rms_um": float(np.sqrt(np.mean(eps * eps)) * 1e6),
    }


def replay_python(task: dict, cfg, actions: np.ndarray, seed: int, labels=None) -> dict:
    """:func:`replay` through :class:`agents.residual.ResidualWrapper`'s ``step`` (the
    reference the compiled replay is tested against; a base without a compiled form)."""
    w, cap = _wrapper(task, cfg)
    if np.isfinite(cap):
        w.set_error_cap(cap, cfg.max_penalty)
    obs, _ = w.reset(seed=seed)
    rows = {"obs": [], "actions": [], "rewards": [], "next_obs": [], "dones": [], "weight": []}
    eps = []
    core = w.core
    for a in actions:
        moving = float(core.scal[min(int(core.k[0]), core.n_steps - 1), 0] > 0)
        nxt, r, term, trunc, info = w.step(a)
        rows["obs"].append(obs)
        rows["actions"].append(np.asarray(a, dtype=np.float32))
        rows["rewards"].append(r)
        rows["next_obs"].append(nxt)
        rows["dones"].append(bool(term))
        rows["weight"].append(moving if w.fade_at_rest else 1.0)
        eps.append(info["contour_error"])
        obs = nxt
        if term or trunc:
            break
    out = {k: np.asarray(v) for k, v in rows.items()}
    lab = actions if labels is None else labels
    out["labels"] = np.asarray(lab[: len(out["rewards"])], dtype=np.float32)
    e = np.asarray(eps)
    out["rms_um"] = float(np.sqrt(np.mean(e * e)) * 1e6)
    return out


def collect(cfg, n_parts: int = DEFAULT_TEACHER_PARTS, *, progress=None, log=None) -> TeacherData:
    """Teach ``n_parts`` parts (:func:`teacher_parts`) and replay every lesson."""
    t0 = time.perf_counter()
    law = cfg.wrapper_kwargs()
    base = law.pop("base")
    teacher = ResidualTeacher(base, law, **cfg.teacher_kwargs())
    parts = teacher_parts(cfg, n_parts)
    from .tasks import TaskSampler

    n_nominal = len(TaskSampler(cfg, cfg.seed).nominal_tasks())
    chunks, lessons = [], []
    n_axes = None
    envelope = None
    for i, (task, seed) in enumerate(parts):
        lesson = teacher.teach(task, seed=seed)
        entry = {"part": i, "completed": bool(lesson.completed), "trials": lesson.trials}
        if lesson.completed:
            entry.update(lesson.summary())
            # the states of the base's trial, one half-way and the kept one, each labelled
            # with the kept table: the student learns the correction whatever the error it
            # meets on the way there (and the buffer holds each replay's own actions)
            for table, trial_seed in lesson.coverage:
                data = replay(task, cfg, table, trial_seed, labels=lesson.actions)
                rms = data.pop("rms_um")
                if table is lesson.actions:
                    entry["replay_rms_um"] = rms
                data["part"] = np.full(len(data["rewards"]), i)
                chunks.append(data)
            core = gym.make(ENV_ID, **task).unwrapped.core
            if envelope is None:
                n_axes = core.dim
                envelope = Envelope(n_axes)
            envelope.update(np.concatenate([reference_features(core), lesson.error_max_m])[None])
            envelope.update_feed(core.setup.feedrate_m_s)
        lessons.append(entry)
        if progress is not None:
            progress(entry)
    if not chunks:
        raise ValueError("teacher: the base completed none of the teacher's parts")
    data = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}
    out = TeacherData(
        obs=data["obs"].astype(np.float32),
        actions=data["actions"].astype(np.float32),
        labels=data["labels"].astype(np.float32),
        rewards=data["rewards"].astype(np.float32),
        next_obs=data["next_obs"].astype(np.float32),
        dones=data["dones"].astype(bool),
        weight=data["weight"].astype(np.float32),
        part=data["part"].astype(np.int64),
        lessons=lessons,
        nominal_parts=tuple(range(n_nominal)),
        envelope=envelope,
        seconds=time.perf_counter() - t0,
    )
    if log is not None:
        s = out.summary()
        log(
            f"teacher: {s['completed']} of {s['parts']} parts, {s['trials']} trials, "
            f"{s['samples']} samples in {s['seconds']:.0f} s; the teacher's RMS / max "
            f"contour error {s['mean_rms_ratio']:.3f} / {s['mean_max_ratio']:.3f}x the base "
            "on average"
        )
    return out


__all__ = ["DEFAULT_TEACHER_PARTS", "TeacherData", "collect", "replay", "teacher_parts"]
