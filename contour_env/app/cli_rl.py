"""``contour-env train``, ``evaluate`` and ``models``: residual RL agents on the command line.

``add_rl_commands(subparsers)`` registers the three subcommands on the main parser
(:func:`contour_env.app.cli.build_parser`). Errors are ``ValueError``/``FileNotFoundError`` with the
parameter named; ``contour_env.app.cli.main`` prints them and exits with status 2.
"""

from __future__ import annotations

import argparse

# a module without imports: the CLI starts without the RL stack
from agents.algos import ALGOS, JAX_ALGOS

from .cli_common import (
    add_json_option,
    add_target_args,
    gcode_file,
    print_metrics,
    target_kwargs,
)

# the names of agents.rl.config.PRESETS (the keywords are read from there when one is used)
PRESET_NAMES = ("sac-4", "ppo-256")
# what contour-env train runs when neither --preset nor another --algo than sac is given: the
# fastest configuration of the time-to-target table (README, "Time to target"); --preset none
# for TrainConfig's own defaults (one env, one gradient step per transition)
DEFAULT_PRESET = "sac-4"
DEFAULT_TIMESTEPS = 20_000
# --timesteps when only --time-budget is given: the budget ends the run
BUDGET_TIMESTEPS = 100_000_000


# the residual law's options of contour-env train (the dest: add_argument's keywords), all
# default None: TrainConfig's defaults unless given
RESIDUAL_LAW_OPTIONS = {
    "residual_frame": dict(
        choices=("path", "axes"),
        help="the frame the agent acts in: the path's tangent/normal/binormal (path, default) "
        "or the machine axes (axes)",
    ),
    "gate": dict(
        action=argparse.BooleanOptionalAction,
        help="a learned gate g in [0, 1] on the residual, starting closed (default on: the "
        "README's ablation)",
    ),
    "observe_axes": dict(
        action=argparse.BooleanOptionalAction,
        help="give the agent each axis' reference velocity and acceleration (default on)",
    ),
    "reward_scale": dict(
        choices=("base", "fixed"),
        help="the reward's error scale per part: the base's RMS contour error on it (base, "
        "default: every part weighs the same) or the env's 10 um (fixed)",
    ),
    "fade_at_rest": dict(
        action=argparse.BooleanOptionalAction,
        help="no residual while the reference stands still, faded in over the first 5 %% of "
        "the feed (default on)",
    ),
}


def _floats(text: str, name: str, n: int | None = None) -> tuple:
    try:
        vals = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise ValueError(f"{name}: expected comma-separated numbers, got {text!r}") from None
    if n is not None and len(vals) != n:
        raise ValueError(f"{name}: expected {n} comma-separated numbers, got {text!r}")
    return vals


def config_from_args(args):
    """The :class:`agents.rl.TrainConfig` of ``contour-env train``'s arguments."""
    from agents.rl import PATH_VARIETY, TrainConfig

    cases = []
    if args.case:
        cases.append(args.case)
    if args.cases:
        cases += [c.strip() for c in args.cases.split(",") if c.strip()]
    cases = list(dict.fromkeys(cases))
    gcode = list(args.gcode or [])
    if gcode and not args.plant:
        raise ValueError(
            "--gcode: needs --plant (hsm2, jee-triaxial, linear-motor, friction-table)"
        )
    gcode = [gcode_file(f) for f in gcode]  # files, always
    variety = tuple(v.strip() for v in (args.paths or "").split(",") if v.strip())
    bad = [v for v in variety if v not in PATH_VARIETY]
    if bad:
        raise ValueError(f"--paths: unknown {bad}; allowed: {', '.join(PATH_VARIETY)}")
    if args.plant and not cases and not gcode and not variety:
        variety = ("families",)  # --plant alone: the plant's training path families
    if not cases and not gcode and not (args.plant and variety):
        raise ValueError(
            "--case/--cases: give at least one training case (or --plant with --gcode, or "
            "--plant with --paths, e.g. --paths families)"
        )
    families = tuple(v.strip() for v in (args.families or "").split(",") if v.strip())
    kw = dict(
        cases=tuple(cases),
        plant=args.plant,
        gcode=tuple(gcode),
        base=args.base,
        algo=args.algo,
        timesteps=args.timesteps,
        seed=args.seed,
        n_envs=args.n_envs,
        train_freq=args.train_freq,
        time_budget_s=args.time_budget,
        eval_every_s=args.eval_every_s,
        gradient_steps=args.gradient_steps,
        scale=args.scale,
        observe_base_command=args.observe_base_command,
        action_repeat=args.action_repeat,
        residual_penalty=args.residual_penalty,
        residual_axes=args.residual_axes,
        randomize_plant=args.randomize_plant,
        randomize_feedrate=args.randomize_feedrate,
        path_variety=variety,
        families=families,
        eval_freq=args.eval_freq,
        checkpoint_freq=args.checkpoint_freq,
        torch_threads=args.threads,
    )
    if args.validation_paths is not None:
        kw["validation_paths"] = args.validation_paths
    if args.keep_min_gain is not None:
        kw["keep_min_gain"] = args.keep_min_gain
    for key in ("teacher", "teacher_parts", "teacher_trials", "fine_tune", "envelope",
                "keep_max_ratio", "max_penalty", "teacher_regularization",
                "observation"):  # fmt: skip
        value = getattr(args, key, None)
        if value is not None:
            kw[key] = value
    if args.learning_rate is not None:
        kw["learning_rate"] = args.learning_rate
    if args.learning_rate_final is not None:
        kw["learning_rate_final"] = args.learning_rate_final
    # the residual law's options: TrainConfig's defaults unless given
    for key in RESIDUAL_LAW_OPTIONS:
        value = getattr(args, key, None)
        if value is not None:
            kw[key] = value
    if args.net_arch:
        try:
            kw["net_arch"] = tuple(int(v) for v in args.net_arch.split(","))
        except ValueError:
            raise ValueError(
                f"--net-arch: comma-separated layer sizes, got {args.net_arch!r}"
            ) from None
    if args.circle_radius:
        kw["circle_radius_m"] = _floats(args.circle_radius, "--circle-radius", 2)
    # a preset fills what was not given; then the defaults of the options without one
    preset = getattr(args, "preset", None)
    if preset is None and kw.get("algo") in (None, "sac"):
        preset = DEFAULT_PRESET
    if preset is not None and preset != "none":
        from agents.rl.config import PRESETS

        if preset not in PRESETS:
            raise ValueError(f"--preset: unknown {preset!r}; known: {', '.join(PRESETS)}, none")
        for key, value in PRESETS[preset].items():
            if kw.get(key) is None:
                kw[key] = value
    if kw.get("algo") is None:
        kw["algo"] = "sac"
    if kw.get("timesteps") is None:
        # a time budget alone ends the run by time, not by the default step count
        kw["timesteps"] = BUDGET_TIMESTEPS if kw.get("time_budget_s") else DEFAULT_TIMESTEPS
    return TrainConfig(**kw)


def apply_train_defaults(args) -> None:
    """The defaults ``contour-env train`` fills in after parsing (the residual penalty; the
    scale is the plant's default in the configuration when not given)."""
    if args.residual_penalty is None:
        from agents.rl.config import TrainConfig

        args.residual_penalty = TrainConfig.__dataclass_fields__["residual_penalty"].default


def train_from_args(args, log=print):
    """``contour-env train``'s training: ``(config, summary)`` of :func:`agents.rl.train` on the
    parsed arguments (also each trial of ``contour-env train --sweep``)."""
    from agents.rl import train

    if not args.out:
        raise ValueError("--out: give the output DIR (model, config, curve, checkpoints)")
    apply_train_defaults(args)
    cfg = config_from_args(args)
    if cfg.algo in JAX_ALGOS:
        # without the [jax] extra: the error before the output DIR is created
        from agents.rl.checkpoint import sbx_module

        sbx_module()
    res = train(cfg, args.out, resume=args.resume, progress=not args.no_progress, log=log)
    return cfg, res


def cmd_train(args) -> int:
    cfg, res = train_from_args(args)
    print(f"trained {res['timesteps']} timesteps in {res['wall_s']:.1f} s")
    if res["final_rms_contour_error_um"] is not None:
        print(
            f"training tasks: final RMS contour error {res['final_rms_contour_error_um']:.4g} µm "
            f"(base {cfg.base}: {res['base_rms_contour_error_um']:.4g} µm)"
        )
    if res["kept"] == "best-validation":
        val, base = (
            res["validation_rms_contour_error_um"],
            res["validation_base_rms_contour_error_um"],
        )
        print(
            f"validation ({cfg.validation_paths} generated paths): kept the model of "
            f"{res['kept_timesteps']} timesteps, RMS contour error {_um(val)} (base {cfg.base}: "
            f"{_um(base)}), {res['validation_score']:.3f}x the base on average, no path worse"
        )
    elif res["kept"] == "base":
        print(
            f"validation ({cfg.validation_paths} generated paths): no checkpoint beat the base "
            f"{cfg.base} on every path; kept the base (the agent is its base: zero residual)"
        )
    else:
        print("no validation: kept the final model")
    print(f"wrote {args.out} (model.zip, agent.json, config.json, validation_curve.png, …)")
    return 0


def _um(x) -> str:
    return "not completed" if x is None else f"{x:.4g} µm"


def cmd_evaluate(args) -> int:
    import gymnasium as gym

    from agents import make_controller
    from agents.residual import ResidualAgent

    from .. import ENV_ID
    from ..evaluation import evaluate
    from ..io import atomic_write_json

    if not args.case and not args.gcode:
        raise ValueError("evaluate: give --case X, or --plant P with --gcode FILE")
    agent = ResidualAgent(args.model)
    if agent.is_base:
        print(
            f"the agent in {args.model} is its base {agent.base_name}: {agent.base_reason()}; "
            "its rows equal the base's"
        )
    kw = target_kwargs(args)
    env = gym.make(ENV_ID, **kw)
    setup = env.unwrapped.setup
    m_agent = evaluate(env, agent, seed=args.seed)
    m_base = evaluate(gym.make(ENV_ID, **kw), make_controller(agent.base_name), seed=args.seed)
    print_metrics(f"residual ({agent.meta['algo']} on {agent.base_name})", m_agent)
    print_metrics(f"base {agent.base_name}", m_base)
    ratio = max_ratio = None
    if m_agent["rms_contour_error_um"] and m_base["rms_contour_error_um"]:
        ratio = m_agent["rms_contour_error_um"] / m_base["rms_contour_error_um"]
        max_ratio = m_agent["max_contour_error_um"] / m_base["max_contour_error_um"]
        print(f"contour error agent/base: RMS {ratio:.3f}, max {max_ratio:.3f}")
    outside = m_agent.get("outside_envelope_fraction")
    if outside is not None:
        print(
            f"outside the agent's envelope (gate faded, the base alone beyond it): "
            f"{outside:.1%} of its decisions"
        )
    if args.json:
        atomic_write_json(
            args.json,
            {
                "case": setup.name,
                "plant": setup.plant.name,
                "model": str(args.model),
                "base": agent.base_name,
                "seed": args.seed,
                "ideal": bool(kw["ideal"]),
                "agent": m_agent,
                "base_metrics": m_base,
                "rms_ratio_agent_to_base": ratio,
                "max_ratio_agent_to_base": max_ratio,
                "outside_envelope_fraction": outside,
            },
        )
        print(f"wrote {args.json}")
    return 0


def cmd_models(args) -> int:
    from agents.rl.models import format_models, list_models

    print(format_models(list_models(args.dir)))
    return 0


def add_rl_commands(sub) -> None:
    """Register ``train``, ``evaluate`` and ``models`` on the main parser's subparsers."""
    p = sub.add_parser("train", help="train a residual RL agent on top of a classical controller")
    _add_task_options(p)
    _add_run_options(p)
    _add_residual_options(p)
    _add_variety_options(p)
    _add_learning_options(p)
    _add_teacher_options(p)
    _add_monitoring_options(p)
    _add_sweep_options(p)
    p.set_defaults(func=train_entry)

    p = sub.add_parser("evaluate", help="score a trained residual agent against its base")
    add_target_args(p)
    p.add_argument("--model", required=True, help="trained model DIR (from `contour-env train`)")
    add_json_option(p, "the metrics")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("models", help="list the shipped residual agents")
    p.add_argument("--dir", default=None, help="list the model DIRs in this folder instead")
    p.set_defaults(func=cmd_models)


def _add_task_options(p: argparse.ArgumentParser) -> None:
    # train: what to train on, and the controller the residual is added to
    p.add_argument("--case", help="training case (see `contour-env cases`)")
    p.add_argument("--cases", help="comma-separated training cases (one plant)")
    p.add_argument("--plant", help="plant, with --gcode training programs")
    p.add_argument(
        "--gcode", action="append", help="G-code training program (repeatable), with --plant"
    )
    p.add_argument("--base", default="pd", help="base controller (default pd)")


def _add_run_options(p: argparse.ArgumentParser) -> None:
    # train: the algorithm, its budget and envs, the output folder
    p.add_argument(
        "--algo",
        choices=ALGOS,
        default=None,
        help="sb3 algorithm (default sac); sbx-sac, sbx-ppo: the JAX implementation sbx-rl "
        '(pip install -e ".[jax]")',
    )
    p.add_argument(
        "--preset",
        choices=(*PRESET_NAMES, "none"),
        default=None,
        help="a named configuration; options given explicitly override its keys. sac-4 (the "
        "default with SAC): 4 envs, 2 gradient steps per update of 4 transitions, the fastest "
        "to target in the README's time-to-target table; ppo-256: PPO on 256 envs of the "
        "compiled vector env (rollout, batch, epochs and learning rate chosen by measurement; "
        "docs/RESIDUAL_TRAINING.md); none: TrainConfig's defaults (1 env)",
    )
    p.add_argument(
        "--timesteps",
        type=int,
        default=None,
        help=f"agent steps in total (default {DEFAULT_TIMESTEPS}, or the preset's)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of every generator (default 0)")
    p.add_argument(
        "--out",
        help="output DIR (model, config, curve, checkpoints); required, except with --sweep "
        "(its out: key)",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue the run in --out from its newest checkpoint (same configuration)",
    )
    p.add_argument(
        "--n-envs",
        type=int,
        default=None,
        help="envs (default 4 SAC: the sac-4 preset; 1 TD3, 8 PPO)",
    )
    p.add_argument(
        "--time-budget",
        type=float,
        default=None,
        metavar="SECONDS",
        help="stop after this much training time (evaluations not counted), whatever "
        "--timesteps says (default: none)",
    )
    p.add_argument(
        "--train-freq",
        type=int,
        default=None,
        help="SAC/TD3: update every N steps of each env (default 1)",
    )
    p.add_argument(
        "--gradient-steps",
        type=int,
        default=None,
        help="SAC/TD3: gradient steps per update (default 1; -1: one per transition collected)",
    )


def _add_residual_options(p: argparse.ArgumentParser) -> None:
    # train: the residual agent, what it sees and how it acts (RESIDUAL_LAW_OPTIONS last)
    p.add_argument(
        "--scale",
        type=float,
        default=None,
        help="residual authority, fraction of the force limit (default 0.10 on linear-motor, "
        "0.05 on the other plants)",
    )
    p.add_argument(
        "--observe-base-command",
        action="store_true",
        help="append the base command to the agent's observation",
    )
    p.add_argument(
        "--observation",
        choices=("full", "state", "errors"),
        default=None,
        help="what the agent sees: the env's observation without the previous action (state, "
        "default), the whole of it (full) or only the task-frame position and velocity errors "
        "(errors)",
    )
    p.add_argument(
        "--action-repeat",
        type=int,
        default=None,
        help="servo periods per agent action (default: one action per ms)",
    )
    p.add_argument(
        "--residual-penalty",
        type=float,
        default=None,
        help="reward weight on the squared agent action (default 1.0)",
    )
    p.add_argument(
        "--residual-axes",
        choices=("path", "all"),
        default="path",
        help="axes that take a residual: those the path uses (path, default) or all",
    )
    for dest, keywords in RESIDUAL_LAW_OPTIONS.items():
        p.add_argument("--" + dest.replace("_", "-"), default=None, **keywords)


def _add_variety_options(p: argparse.ArgumentParser) -> None:
    # train: the variety of the training episodes and the validation set
    p.add_argument(
        "--randomize-plant",
        type=float,
        default=0.0,
        metavar="FRACTION",
        help="true-plant parameters ×U[1-F, 1+F] per episode (default 0)",
    )
    p.add_argument(
        "--randomize-feedrate",
        type=float,
        default=0.0,
        metavar="FRACTION",
        help="feedrate ×U[1-F, 1+F] per episode (default 0)",
    )
    p.add_argument(
        "--paths",
        help="random path variety, comma-separated: circles, splines, families (the training "
        "path families of docs/RESIDUAL_TRAINING.md; with --plant, no case needed) "
        "(default none)",
    )
    p.add_argument(
        "--families",
        help="families drawn with --paths families and for the validation set, comma-"
        "separated: polylines, arcs, circles, splines, helices (3-axis plants) (default: every "
        "family the plant takes)",
    )
    p.add_argument(
        "--validation-paths",
        type=int,
        default=None,
        metavar="N",
        help="generated validation paths; the checkpoint no worse than the base on any of them "
        "with the lowest mean ratio to the base is kept, else the base (default 16; 0: no "
        "validation, the final model is kept)",
    )
    p.add_argument(
        "--circle-radius", help="random circle radius range MIN,MAX in m (default 0.005,0.05)"
    )


def _add_learning_options(p: argparse.ArgumentParser) -> None:
    # train: the networks, the learning rate and the rule that keeps a checkpoint
    p.add_argument("--net-arch", help="hidden layer sizes, e.g. 64,64 (default)")
    p.add_argument(
        "--keep-min-gain",
        type=float,
        default=None,
        metavar="G",
        help="keep a checkpoint only if its mean ratio to the base on the validation parts is "
        "<= 1 - G, and no part is worse (default 0.10)",
    )
    p.add_argument("--learning-rate", type=float, default=None, metavar="LR", help="default 3e-4")
    p.add_argument(
        "--learning-rate-final",
        type=float,
        default=None,
        metavar="LR",
        help="anneal the learning rate geometrically to LR over the run (over --time-budget "
        "when given, else over --timesteps); default: constant",
    )


def _add_teacher_options(p: argparse.ArgumentParser) -> None:
    # train: the teacher, the student's fine-tuning, the envelope and the max rule (issue 48)
    p.add_argument(
        "--teacher",
        choices=("ilc-contour", "none"),
        default=None,
        help="ilc-contour (default): ILC on top of the base in the agent's action space on "
        "--teacher-parts training parts, the actor pretrained on what it learned, the critic "
        "warmed, then RL; none: RL from scratch (the recipe before the teacher)",
    )
    p.add_argument(
        "--teacher-parts", type=int, default=None, metavar="N",
        help="training parts the teacher learns on (default 60)",
    )  # fmt: skip
    p.add_argument(
        "--teacher-trials", type=int, default=None, metavar="N",
        help="ILC trials per part at most (default 30)",
    )  # fmt: skip
    p.add_argument(
        "--fine-tune",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="RL after the teacher's pretraining (default on; --no-fine-tune: the pretrained "
        "student is keep-best's only candidate)",
    )
    p.add_argument(
        "--envelope",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the agent fades its gate outside the ranges it was trained on (default on)",
    )
    p.add_argument(
        "--max-penalty",
        type=float,
        default=None,
        metavar="W",
        help="the reward pays W per unit of its error scale by which the contour error exceeds "
        "the base's max on the part (default 3; 0: off)",
    )
    p.add_argument(
        "--teacher-regularization",
        type=float,
        default=None,
        metavar="ALPHA",
        help="keep the fine-tuned actor near the teacher, TD3+BC's alpha (default 0: off)",
    )
    p.add_argument(
        "--keep-max-ratio",
        type=float,
        default=None,
        metavar="R",
        help="keep a checkpoint only if no validation part's max contour error exceeds R x "
        "the base's (default 1.0)",
    )


def _add_monitoring_options(p: argparse.ArgumentParser) -> None:
    # train: evaluations, checkpoints, threads and the progress bar
    p.add_argument("--eval-freq", type=int, default=None, help="timesteps between evaluations")
    p.add_argument(
        "--eval-every-s",
        type=float,
        default=None,
        metavar="SECONDS",
        help="also evaluate after every SECONDS of training time (time-to-target runs)",
    )
    p.add_argument(
        "--checkpoint-freq", type=int, default=None, help="timesteps between checkpoints"
    )
    p.add_argument("--threads", type=int, default=1, help="torch threads (default 1)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def _add_sweep_options(p: argparse.ArgumentParser) -> None:
    # train --sweep FILE (contour_env.app.sweep), with --ray its trials on Ray Tune
    p.add_argument(
        "--sweep",
        metavar="FILE",
        help="train a grid of runs (cases × seeds × algorithms, …) described by this YAML file "
        "into one folder, with --out DIR or its out: key (docs/SWEEP.md); the other train "
        "options go in the file",
    )
    p.add_argument(
        "--ray",
        default=None,
        metavar="auto|ADDRESS",
        help="with --sweep: run the trials with Ray Tune, auto (a running cluster, else a local "
        'instance) or a cluster ADDRESS; needs pip install -e ".[ray]" (default: one after '
        "another in this process)",
    )


def train_entry(args: argparse.Namespace) -> int:
    """``contour-env train`` without ``--sweep`` (the command line's entry,
    :func:`contour_env.app.sweep.train_or_sweep`, runs a sweep when it is given)."""
    if args.sweep is not None:
        raise ValueError("--sweep: sweeps run from the contour-env command line")
    if args.ray is not None:
        raise ValueError("--ray: runs the trials of --sweep FILE; give --sweep too")
    return cmd_train(args)


def train_parser() -> argparse.ArgumentParser:
    """The parser of ``contour-env train`` (the same arguments, defaults and checks)."""
    sub = argparse.ArgumentParser(prog="contour-env").add_subparsers()
    add_rl_commands(sub)
    return sub.choices["train"]
