"""The training configuration: one frozen record, validated, written as JSON and compared on
``--resume`` (every key but ``timesteps`` must match; ``timesteps`` may grow to extend a run).

Defaults (documented choices, not tuned by a hyperparameter search — see the README's
"Train your own residual agent" for what has been measured):

- network: two hidden layers of 64 units (actor and critic), tanh-free ReLU MLPs as in sb3.
  Small enough for fast CPU updates on 2 cores and a model file far below 5 MB.
- ``algo``: sb3's ``sac``, ``td3``, ``ppo``, or the JAX implementations ``sbx-sac`` and
  ``sbx-ppo`` (sbx-rl, ``pip install -e ".[jax]"``) with the same hyperparameters.
- ``n_envs``: 1 for SAC/TD3 (off-policy: one gradient step per env step; more envs add samples
  the updates cannot keep up with on 2 cores), 8 for PPO (on-policy: batches of
  n_envs × n_steps samples; with one fixed case the 8 envs are one compiled vectorised env).
- ``gamma`` 0.98: the contour error responds to a residual within a few tens of ms, a
  horizon of ~50 agent steps (1 ms each) is enough and keeps the value targets low-variance.
- reward: the env's default (−ε / 10 µm per servo period, mean over the agent step) minus
  ``residual_penalty`` · ‖a_agent‖² / n with ``residual_penalty`` 1.0: a residual at full
  authority costs as much as 10 µm of contour error. Measured on ``sharp-corner`` (SAC on PD,
  seed 0, one run each): with 0.01 and 20 000 steps the agent lowered RMS ε from 11.7 to
  3.6 µm but spent 2.5–4.7× PD's RMS effort; with 1.0 and 12 000 steps it reached 1.8 µm at
  RMS effort [22.9, 18.0] N against PD's [27.7, 15.9] N; a 100 000-step run
  reached 0.44 µm at 0.77× / 1.16× PD's effort (README, "Shipped agents and what they do").
- ``scale`` 0.05 of the force limit and one agent action per ms: see :mod:`agents.residual`.
- TD3 exploration noise σ = 0.1 (sb3's suggestion); SAC's default entropy tuning.
- ``validation_paths`` 16: the model kept is the checkpoint no worse than the base on any of
  16 generated parts (three or four per family) that training never draws, with the lowest
  mean ratio to the base, or the base itself (the friction-table agents of issue 33 were 1.0–1.3×
  the base on a few of 24 parts at checkpoints that were 0.6× on average: the more parts, the
  surer the "never worse")
  (:mod:`agents.rl.validation`); ``path_variety`` ``families`` trains on the path families of
  :mod:`agents.rl.families` (docs/RESIDUAL_TRAINING.md). G-code files of the held-out
  evaluation suite are refused (:mod:`agents.rl.heldout`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from agents.algos import ALGOS, JAX_ALGOS, ON_POLICY  # noqa: F401 (re-exported)
from agents.records import attributes
from agents.registry import controller_names
from agents.residual import OBSERVATIONS, RESIDUAL_AXES, default_scale
from agents.residual_law import RESIDUAL_FRAMES

from .families import check_families
from .heldout import refuse_heldout

PATH_VARIETY = ("circles", "splines", "families")
REWARD_SCALES = ("base", "fixed")
CONFIG_FORMAT = "contour_env.train_config/1"
# the least training time (s, at the reference rate) between two evaluations by default
EVAL_MIN_TRAIN_S = 30.0
# named configurations (``contour-env train --preset NAME``): TrainConfig keywords that an
# explicit option overrides. ppo-256: PPO on 256 envs of the compiled vector env, its rollout,
# batch, epochs and learning rate chosen by measurement on lm-circle3d over CCC (README, "Time
# to target"; docs/RESIDUAL_TRAINING.md), evaluated by training time (every 60 s: by steps,
# 65,536 of them took minutes)
PRESETS = {
    # SB3 SAC on 4 envs (one compiled vector env on a fixed task), 2 gradient steps per update
    # of 4 transitions: the fastest configuration of the time-to-target table to 0.70x CCC on
    # lm-circle3d (README, "Time to target"); contour-env train's default for SAC
    "sac-4": dict(algo="sac", n_envs=4, gradient_steps=2),
    "ppo-256": dict(
        algo="ppo",
        n_envs=256,
        ppo_n_steps=64,
        batch_size=4096,
        ppo_n_epochs=5,
        learning_rate=1e-3,
        eval_every_s=60.0,
    ),
}
# keys that may differ on --resume
RESUMABLE_KEYS = ("timesteps", "time_budget_s", "eval_every_s")


def _file_digest(path: str) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run (SI units)."""

    cases: tuple = ()
    plant: str | None = None
    gcode: tuple = ()
    gcode_sha256: tuple = ()
    base: str = "pd"
    algo: str = "sac"
    timesteps: int = 20_000
    seed: int = 0
    n_envs: int | None = None
    # residual law (agents.residual)
    # residual authority, fraction of the force limit (None: the plant's default,
    # agents.residual.default_scale: 0.10 on the linear motor, 0.05 elsewhere)
    scale: float | None = None
    observe_base_command: bool = False
    # what the agent sees (agents.residual.observation_fields): "state", every field of the
    # env's observation but the previous action (the default since issue 48: a student of the
    # teacher that sees its previous action copies it), "full", "errors"
    observation: str = "state"
    action_repeat: int | None = None
    residual_penalty: float = 1.0
    # which axes take a residual: "path" (the axes the path uses) or "all"
    residual_axes: str = "path"
    # the frame the agent acts in ("path": t, n, b; "axes": machine axes), a learned gate on
    # the residual, the per-axis reference velocity and acceleration in the observation
    # (agents.residual_law; the defaults are the README ablation's choice)
    residual_frame: str = "path"
    gate: bool = True
    observe_axes: bool = True
    # no residual while the reference stands still (agents.residual_law, "At rest")
    fade_at_rest: bool = True
    # the reward pays max_penalty per unit of the reward's scale by which the contour error
    # exceeds the base's max on the part (issue 48: RL on the error alone traded a higher max
    # for a lower RMS on friction-table validation parts — 1.2–1.7x the base's max on two of
    # 24 at every checkpoint; 10 disrupted the learning (worse than the base on 22 of 24 parts
    # after 18k steps), 1 left the max 1.1–1.8x, 3 gave checkpoints no worse in max; 0 in
    # configurations before it)
    max_penalty: float = 3.0
    # the reward's error scale per task: "base" (the base's RMS contour error on the part:
    # r = -eps / eps_base, every part weighs the same) or "fixed" (the env's 10 um)
    reward_scale: str = "base"
    # env reward weights (ContouringEnv)
    w_contour: float = 1.0
    w_lag: float = 0.0
    w_effort: float = 0.0
    # domain randomisation
    randomize_plant: float = 0.0
    randomize_feedrate: float = 0.0
    path_variety: tuple = ()
    circle_radius_m: tuple = (0.005, 0.05)
    spline_size_m: float = 0.03
    # training path families (agents.rl.families) drawn with path_variety "families", and the
    # families of the validation set; () = every family the plant takes
    families: tuple = ()
    # generated validation paths scored at each evaluation; the model kept is the one with the
    # lowest mean RMS contour error on them (0: no validation, the final model is kept)
    validation_paths: int = 16
    # a checkpoint is eligible only if its mean ratio to the base on the validation parts is at
    # most 1 − keep_min_gain (and no part is worse): a checkpoint barely better on average has
    # no margin on parts it never saw (agents/rl/validation.py)
    keep_min_gain: float = 0.10
    # ... and no validation part's max contour error may exceed keep_max_ratio × the base's: a
    # tolerance is a max, and an agent that lowers the RMS while raising the max has not helped
    # (issue 48; None: no max rule, as in configurations written before it)
    keep_max_ratio: float | None = 1.0
    # learner
    net_arch: tuple = (64, 64)
    learning_rate: float = 3e-4
    # anneal the learning rate geometrically from learning_rate to this over the run (over
    # time_budget_s of training time when set, else over timesteps); None: constant
    learning_rate_final: float | None = None
    gamma: float = 0.98
    batch_size: int | None = None
    buffer_size: int = 200_000
    learning_starts: int = 1_000
    # SAC/TD3: update every train_freq steps of each env with gradient_steps gradient steps
    # (None: sb3's defaults, 1 and 1; gradient_steps -1: as many as transitions collected)
    train_freq: int | None = None
    gradient_steps: int | None = None
    # stop training once this much training time (s, evaluations not counted) has passed,
    # whatever timesteps says (None: no limit); the run then ends as at its last timestep
    time_budget_s: float | None = None
    ppo_n_steps: int = 256
    # PPO: passes over each rollout (sb3's n_epochs)
    ppo_n_epochs: int = 10
    # bookkeeping
    eval_freq: int | None = None
    # also evaluate whenever this much more training time (s) has passed (None: by timesteps
    # only): what a time-to-target run needs, whatever the algorithm's steps per second
    eval_every_s: float | None = None
    checkpoint_freq: int | None = None
    keep_checkpoints: int = 2
    torch_threads: int = 1
    # the teacher (agents/teacher.py, issue 48): "ilc-contour" learns a correction per training
    # part by ILC on top of the base in the agent's action space; the actor is pretrained on it
    # by regression, the critic warmed and the replay buffer filled with its transitions, then
    # RL fine-tunes (fine_tune); "none": RL from scratch (the recipe before issue 48)
    # (None: "ilc-contour" for sb3's algorithms, "none" for the JAX ones, which it does not
    # pretrain)
    teacher: str | None = None
    teacher_parts: int = 60
    teacher_trials: int = 30
    # RL after the teacher's pretraining (False: the pretrained student is the candidate)
    fine_tune: bool = True
    # SAC/TD3 fine-tuning keeps the actor near the teacher: TD3+BC's alpha, the weight of the
    # critic's value against the regression loss in each actor update (agents.rl.pretrain.
    # attach_teacher_regularizer; 0: off)
    teacher_regularization: float = 0.0
    # the agent fades its gate outside the ranges it was trained on (agents/envelope.py)
    envelope: bool = True
    extra: dict = field(default_factory=dict)

    def __post_init__(self):
        """Sequences as tuples, then every field checked (``ValueError`` naming the field; a
        missing G-code file ``FileNotFoundError``), the G-code files' digests filled in."""
        for key in (
            "cases",
            "gcode",
            "gcode_sha256",
            "path_variety",
            "families",
            "net_arch",
            "circle_radius_m",
        ):
            object.__setattr__(self, key, tuple(getattr(self, key)))
        self._check_choices()
        self._check_gcode_and_plant()
        if self.scale is None:
            object.__setattr__(self, "scale", default_scale(self.plant_name))
        self._check_counts()
        self._check_numbers()
        self._check_paths()

    def _check_choices(self) -> None:
        """The named choices (observation, algorithm, base, frame, ...), the switches, and a
        task to train on."""
        if self.observation not in OBSERVATIONS:
            raise ValueError(
                f"observation: must be one of {', '.join(OBSERVATIONS)}, got {self.observation!r}"
            )
        if self.algo not in ALGOS:
            raise ValueError(f"algo: must be one of {', '.join(ALGOS)}, got {self.algo!r}")
        if self.base not in controller_names():
            raise ValueError(
                f"base: unknown controller {self.base!r}; known: {', '.join(controller_names())}"
            )
        if not self.cases and not self.gcode and not (self.plant and self.path_variety):
            raise ValueError(
                "cases: give at least one case (--case/--cases), or --plant with --gcode or "
                "with --paths (e.g. --paths families)"
            )
        if self.residual_axes not in RESIDUAL_AXES:
            raise ValueError(
                f"residual_axes: must be one of {', '.join(RESIDUAL_AXES)}, got "
                f"{self.residual_axes!r}"
            )
        if self.residual_frame not in RESIDUAL_FRAMES:
            raise ValueError(
                f"residual_frame: must be one of {', '.join(RESIDUAL_FRAMES)}, got "
                f"{self.residual_frame!r}"
            )
        if self.reward_scale not in REWARD_SCALES:
            raise ValueError(
                f"reward_scale: must be one of {', '.join(REWARD_SCALES)}, got "
                f"{self.reward_scale!r}"
            )
        from agents.teacher import check_teacher

        if self.teacher is None:
            default = "none" if str(self.algo).startswith("sbx") else "ilc-contour"
            object.__setattr__(self, "teacher", default)
        check_teacher(self.teacher)
        if self.teacher != "none" and self.algo.startswith("sbx"):
            raise ValueError(
                f"teacher: {self.teacher!r} pretrains sb3's sac, td3 or ppo, not {self.algo} "
                "(use --teacher none with the JAX algorithms)"
            )
        for key in ("gate", "observe_axes", "fade_at_rest", "fine_tune", "envelope"):
            if not isinstance(getattr(self, key), bool):
                raise ValueError(f"{key}: expected true or false, got {getattr(self, key)!r}")

    def _check_gcode_and_plant(self) -> None:
        """G-code files (a plant given, none held out, each read for its digest) and one plant
        for every task."""
        if self.gcode and not self.plant:
            raise ValueError("plant: G-code training paths need --plant")
        for f in self.gcode:
            # before the file is opened (digest below)
            refuse_heldout(f, "gcode")
        if self.gcode and not self.gcode_sha256:
            for f in self.gcode:
                if not Path(f).is_file():
                    raise FileNotFoundError(f"gcode: no such file {f!r}")
            object.__setattr__(self, "gcode_sha256", tuple(_file_digest(f) for f in self.gcode))
        from contour_env.cases import get_case

        plants = {get_case(c).plant for c in self.cases}
        if self.plant:
            plants.add(self.plant)
        if len(plants) != 1:
            raise ValueError(
                f"cases: an agent is trained for one plant; these cases use {sorted(plants)}"
            )

    def _check_counts(self) -> None:
        """The integer settings, the time budget and evaluation period (s), and the
        off-policy update options."""
        _int(self, "timesteps", 1)
        _int(self, "seed", 0)
        _int(self, "buffer_size", 1)
        _int(self, "learning_starts", 0)
        _int(self, "ppo_n_steps", 2)
        _int(self, "ppo_n_epochs", 1)
        _int(self, "keep_checkpoints", 1)
        _int(self, "validation_paths", 0)
        _int(self, "torch_threads", 1)
        _int(self, "teacher_parts", 1)
        _int(self, "teacher_trials", 1)
        _seconds_or_none(self, "time_budget_s")
        _seconds_or_none(self, "eval_every_s")
        gs = self.gradient_steps
        if gs is not None and (
            isinstance(gs, bool) or not isinstance(gs, int) or (gs < 1 and gs != -1)
        ):
            raise ValueError(f"gradient_steps: an integer >= 1 or -1, got {gs!r}")
        if self.algo in ON_POLICY and (
            self.train_freq is not None or self.gradient_steps is not None
        ):
            raise ValueError(
                "train_freq, gradient_steps: options of the off-policy algorithms (sac, td3, "
                f"sbx-sac), not {self.algo}"
            )
        for key in (
            "n_envs", "batch_size", "action_repeat", "eval_freq", "checkpoint_freq", "train_freq",
        ):  # fmt: skip
            if getattr(self, key) is not None:
                _int(self, key, 1)

    def _check_numbers(self) -> None:
        """The real-valued settings in their ranges (stored as floats)."""
        for key, lo, hi in (
            ("scale", 0.0, 2.0),
            ("randomize_plant", 0.0, 0.99),
            ("randomize_feedrate", 0.0, 0.99),
            ("gamma", 0.0, 1.0),
            ("keep_min_gain", 0.0, 0.99),
        ):
            _num(self, key, lo, hi, open_low=(key in ("scale",)))
        for key in (
            "residual_penalty", "w_contour", "w_lag", "w_effort", "max_penalty",
            "teacher_regularization",
        ):  # fmt: skip
            _num(self, key, 0.0, math.inf)
        _num(self, "learning_rate", 0.0, 1.0, open_low=True)
        v = self.keep_max_ratio
        if v is not None:
            if (
                isinstance(v, bool)
                or not isinstance(v, (int, float))
                or not (math.isfinite(v) and v >= 1.0)
            ):
                raise ValueError(
                    f"keep_max_ratio: must be a finite number >= 1 (or None: no max rule), "
                    f"got {v!r}"
                )
            object.__setattr__(self, "keep_max_ratio", float(v))
        if self.learning_rate_final is not None:
            _num(self, "learning_rate_final", 0.0, self.learning_rate, open_low=True)
        _num(self, "spline_size_m", 0.0, 10.0, open_low=True)

    def _check_paths(self) -> None:
        """The path variety, the families, the circle radii and the network's layers."""
        bad = [v for v in self.path_variety if v not in PATH_VARIETY]
        if bad:
            raise ValueError(
                f"path_variety: unknown {bad}; allowed: {', '.join(PATH_VARIETY)} (G-code files "
                "with --gcode)"
            )
        if self.families or "families" in self.path_variety or self.validation_paths:
            check_families(self.families, self.plant_name)
        r = self.circle_radius_m
        if len(r) != 2 or not (0 < float(r[0]) <= float(r[1])):
            raise ValueError(f"circle_radius_m: (min, max) with 0 < min <= max (m), got {r!r}")
        if not self.net_arch or any(
            not isinstance(h, int) or isinstance(h, bool) or h < 1 for h in self.net_arch
        ):
            raise ValueError(f"net_arch: hidden layer sizes, integers >= 1, got {self.net_arch!r}")

    # --- derived ---------------------------------------------------------------------------
    @property
    def plant_name(self) -> str:
        if self.plant:
            return self.plant
        from contour_env.cases import get_case

        return get_case(self.cases[0]).plant

    @property
    def num_envs(self) -> int:
        return self.n_envs or (8 if self.on_policy else 1)

    @property
    def on_policy(self) -> bool:
        """PPO (sb3's or sbx's): rollouts and epochs, no replay buffer."""
        return self.algo in ON_POLICY

    @property
    def randomized(self) -> bool:
        """Whether episodes differ in plant, feed or path (then each env is rebuilt per
        episode instead of one compiled vectorised env)."""
        return bool(
            self.randomize_plant
            or self.randomize_feedrate
            or self.path_variety
            or len(self.cases) + len(self.gcode) > 1
        )

    @property
    def training_families(self) -> tuple:
        """The families drawn for training and validation (all the plant takes when
        ``families`` is empty)."""
        return check_families(self.families, self.plant_name)

    def eval_every(self) -> int:
        """Agent steps between evaluations: ``eval_freq``, or a tenth of the run (of the steps
        the time budget allows at the reference rate, when it ends the run first) but at least
        :data:`EVAL_MIN_TRAIN_S` seconds of training at the algorithm's reference rate on this
        machine kind (:data:`agents.rl.progress.REFERENCE_STEPS_PER_S`): an evaluation (the
        validation parts and the training cases, ~3–4 s on lm-circle3d's plant) then takes at
        most ~10–15 % of the run's wall time. By steps, not by the clock, so that the same
        configuration evaluates — and keeps — the same checkpoints on any machine."""
        if self.eval_freq:
            return self.eval_freq
        from .progress import reference_rate

        rate = reference_rate(self.algo, self.num_envs) or 0.0
        run = self.timesteps
        if self.time_budget_s is not None and rate > 0:
            # the steps the time budget is expected to allow, when it ends the run first
            run = min(run, int(self.time_budget_s * rate))
        return max(1000, run // 10, int(EVAL_MIN_TRAIN_S * rate))

    def checkpoint_every(self) -> int:
        return self.checkpoint_freq or max(1000, self.timesteps // 5)

    def teacher_kwargs(self) -> dict:
        """Keyword arguments of :class:`agents.teacher.ResidualTeacher`."""
        return {"max_trials": self.teacher_trials}

    def env_config(self) -> dict:
        """Reward keywords of the env."""
        return {"w_contour": self.w_contour, "w_lag": self.w_lag, "w_effort": self.w_effort}

    def wrapper_kwargs(self) -> dict:
        """Keyword arguments of the residual wrappers (:mod:`agents.residual`)."""
        return attributes(
            self, "base", "scale", "observe_base_command", "observation", "action_repeat",
            "residual_penalty", "residual_axes", "residual_frame", "gate", "observe_axes",
            "fade_at_rest",
        )  # fmt: skip

    # --- JSON ------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        for key, value in d.items():
            if isinstance(value, tuple):
                d[key] = list(value)
        return {"format": CONFIG_FORMAT, **d}

    def to_dict_args(self) -> dict:
        """The constructor's keyword arguments (``TrainConfig(**cfg.to_dict_args())`` is
        ``cfg``); handy for a changed copy."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, data: dict) -> TrainConfig:
        data = dict(data)
        fmt = data.pop("format", None)
        if fmt != CONFIG_FORMAT:
            raise ValueError(f"config: format {fmt!r}, expected {CONFIG_FORMAT!r}")
        # a run configured before residual_axes existed had a residual on every axis
        data.setdefault("residual_axes", "all")
        # ... and before the path frame, the gate and the axis observation: the axes frame
        data.setdefault("residual_frame", "axes")
        data.setdefault("gate", False)
        data.setdefault("observe_axes", False)
        data.setdefault("fade_at_rest", False)
        data.setdefault("reward_scale", "fixed")
        # ... and before the minimum gain of keep-best: any eligible checkpoint better on average
        data.setdefault("keep_min_gain", 0.0)
        # ... and before the teacher and the envelope (issue 48): RL from scratch, no envelope
        data.setdefault("teacher", "none")
        data.setdefault("keep_max_ratio", None)
        data.setdefault("max_penalty", 0.0)
        data.setdefault("envelope", False)
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"config: unknown keys {unknown}")
        return cls(**data)

    def differences(self, other: TrainConfig) -> list[str]:
        """Keys whose values differ (``RESUMABLE_KEYS`` excluded), as 'key: a -> b'."""
        a, b = self.to_dict(), other.to_dict()
        return [
            f"{k}: {a[k]!r} (checkpoint) vs {b[k]!r} (now)"
            for k in a
            if k not in RESUMABLE_KEYS and a.get(k) != b.get(k)
        ]


def _int(cfg, key, lo):
    v = getattr(cfg, key)
    if isinstance(v, bool) or not isinstance(v, int) or v < lo:
        raise ValueError(f"{key}: expected an integer >= {lo}, got {v!r}")


def _seconds_or_none(cfg, key):
    v = getattr(cfg, key)
    if v is not None and (
        isinstance(v, bool) or not isinstance(v, (int, float)) or not (0 < v < math.inf)
    ):
        raise ValueError(f"{key}: a finite number of seconds > 0 or None, got {v!r}")


def _num(cfg, key, lo, hi, open_low=False):
    v = getattr(cfg, key)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"{key}: expected a number, got {v!r}")
    ok = math.isfinite(v) and (v > lo if open_low else v >= lo) and v <= hi
    if not ok:
        lo_s = f"> {lo}" if open_low else f">= {lo}"
        raise ValueError(f"{key}: must be {lo_s} and <= {hi}, got {v!r}")
    object.__setattr__(cfg, key, float(v))


def load_config(path) -> TrainConfig:
    try:
        data = json.loads(Path(path).read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"config: {path} is not valid JSON ({exc})") from None
    return TrainConfig.from_dict(data)
