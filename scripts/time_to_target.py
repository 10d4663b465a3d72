"""Time to target of the residual trainers on ``lm-circle3d`` over CCC (issue 34).

Each configuration trains a residual agent on top of CCC with ``contour-env train``'s trainer
(:func:`agents.rl.train`) on ``lm-circle3d``, seed 0, one torch thread, for ``--budget``
seconds of training time, evaluating every ``--eval-every`` seconds of training time on

- the 16 generated validation parts of the plant (never trained on; what keep-best reads):
  (a) the first evaluation at which the mean ratio to CCC is at most 1, the base's level;
- ``lm-circle3d`` itself, seed 0: (b) the first evaluation at or below
  :data:`agents.rl.progress.TARGET_RATIO` (0.70) × CCC's RMS contour error (1.702 µm →
  1.191 µm).

Times are **wall time** from the start of the run (building the envs, scoring the base,
training and every evaluation included: the curves' ``wall_s``, stamped when an evaluation's
verdict is known), as a user waits for them; the evaluation share is the run's own figure
(``eval_share`` of the summary and of ``agent.json``). The named case is trained on and scored
here: the table compares the *configurations' speed* on the issue's yardstick; it does not
make an agent to ship (shipped agents train on generated parts, docs/RESIDUAL_TRAINING.md).

    python scripts/time_to_target.py [--budget 600] [--configs sac-1,sbx-sac-1,...]
        [--eval-every 30] [--out out/time_to_target]

Configurations whose algorithm needs the ``[jax]`` extra are skipped with a message when JAX
is absent. Writes ``OUT/time_to_target.json`` (after every configuration) and
``OUT/time_to_target.md`` atomically, and prints the table. Run one configuration at a time
on a quiet machine (the figures are speeds).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
import time
from pathlib import Path

import gymnasium as gym

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller
from agents.rl import TrainConfig, train
from agents.rl.config import JAX_ALGOS, PRESETS
from agents.rl.progress import TARGET_RATIO, TargetWatch
from contour_env import ENV_ID
from contour_env.evaluation import evaluate
from contour_env.io import atomic_write_json, atomic_write_text

CASE = "lm-circle3d"
BASE = "ccc"
# the trainer's settings of the runs the table records (issue 34, before the teacher, the
# envelope and the max rules of issue 48): RL from scratch on the full observation
BEFORE_TEACHER = dict(
    teacher="none", observation="full", envelope=False, max_penalty=0.0, keep_max_ratio=None
)
# configuration name -> TrainConfig keywords (besides case, base, seed, budget, evaluation)
CONFIGS = {
    # SB3 SAC on one env, one gradient step per agent step (sb3's default)
    "sac-1": dict(algo="sac"),
    # SB3 SAC on 4 envs (one compiled vector env), 2 gradient steps per 4 transitions: the
    # sac-4 preset, contour-env train's default
    "sac-4": dict(PRESETS["sac-4"]),
    # PPO on 256 envs of the compiled vector env: the ppo-256 preset (agents/rl/config.py)
    "ppo-256": dict(PRESETS["ppo-256"]),
    # sbx SAC (JAX) on one env, one gradient step per agent step
    "sbx-sac-1": dict(algo="sbx-sac"),
    # sbx SAC on 4 envs, one gradient step per transition collected
    "sbx-sac-4": dict(algo="sbx-sac", n_envs=4, gradient_steps=4),
}


def base_score() -> float:
    env = gym.make(ENV_ID, case=CASE)
    return float(evaluate(env, make_controller(BASE), seed=0)["rms_contour_error_um"])


def run_config(
    name: str,
    budget_s: float,
    eval_every_s: float,
    out: Path,
    keywords: dict | None = None,
    validation_paths: int = 16,
) -> dict:
    """Train configuration ``name`` (``keywords``: its TrainConfig keywords, default
    ``CONFIGS[name]``) for ``budget_s`` s of training; its row of the table."""
    keywords = dict(CONFIGS[name] if keywords is None else keywords)
    cfg = TrainConfig(
        cases=(CASE,),
        base=BASE,
        seed=0,
        timesteps=10**9,
        time_budget_s=budget_s,
        checkpoint_freq=10**9,
        torch_threads=1,
        **{
            **BEFORE_TEACHER,
            **keywords,
            "validation_paths": validation_paths,
            "eval_freq": 10**9,
            "eval_every_s": eval_every_s,
        },
    )
    s = train(cfg, out / name, progress=False, log=lambda *a: None)
    ttt = targets(out / name)
    curve = s["curve"]
    return {
        "config": name,
        "algo": cfg.algo,
        "n_envs": cfg.num_envs,
        "gradient_steps": cfg.gradient_steps,
        "keywords": keywords,
        "timesteps": s["timesteps"],
        "train_s": s["train_s"],
        "run_wall_s": s["run_wall_s"],
        "eval_s": s["eval_s"],
        "eval_share": s["eval_share"],
        "agent_steps_per_s": s["timesteps"] / s["train_s"],
        "best_rms_um": min(p["rms_contour_error_um"] for p in curve),
        "kept": s["kept"],
        "validation_score": s["validation_score"],
        "time_to_target": ttt,
        "curve": curve,
        "validation_curve": [
            {k: p.get(k) for k in ("timesteps", "train_s", "wall_s", "score", "eligible")}
            for p in s["validation_curve"]
        ],
    }


def targets(run_dir: Path) -> dict:
    """The time-to-target record of a finished run, from its curve files (the same rule as
    the run's own ``time_to_target``)."""
    lc = json.loads((run_dir / "learning_curve.json").read_text())
    vc = json.loads((run_dir / "validation_curve.json").read_text())
    return TargetWatch(lc["base_rms_contour_error_um"], lc["curve"], vc["curve"]).record()


def _minutes(stamp) -> str:
    return "—" if stamp is None else f"{stamp['wall_s'] / 60:.1f}"


def table(rows: list, base_rms: float, budget_s: float) -> str:
    target = TARGET_RATIO * base_rms
    lines = [
        f"Trained and scored on {CASE} over {BASE.upper()} ({base_rms:.3f} µm); target (b): "
        f"≤ {target:.3f} µm ({TARGET_RATIO:.2f}× {BASE.upper()}); (a): the base's level on the "
        f"validation parts (no part worse, better on average), (a'): a checkpoint eligible for "
        f"keep-best (no part worse, ≥ 10 % better on average). Minutes of wall time "
        "(evaluations included); "
        f"{budget_s / 60:.0f} min of training per configuration; — : not reached.",
        "",
        "| configuration | algorithm | envs | gradient steps | agent steps/s | evaluation share "
        "| best RMS (µm) | best / CCC | min to (a) | min to (a') | min to (b) | wall min |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        gs = r["gradient_steps"] if r["gradient_steps"] is not None else "—"
        t = r["time_to_target"]
        lines.append(
            f"| {r['config']} | {r['algo']} | {r['n_envs']} | {gs} | "
            f"{r['agent_steps_per_s']:,.0f} | {r['eval_share']:.1%} | {r['best_rms_um']:.3f} | "
            f"{r['best_rms_um'] / base_rms:.2f} | {_minutes(t['validation_base_level'])} | "
            f"{_minutes(t['validation_eligible'])} | {_minutes(t['training_tasks_target'])} | "
            f"{r['run_wall_s'] / 60:.1f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=float, default=600.0, help="training seconds per config")
    ap.add_argument(
        "--eval-every", type=float, default=30.0, help="seconds of training between evaluations"
    )
    ap.add_argument(
        "--configs", default=",".join(CONFIGS), help=f"comma-separated, from {', '.join(CONFIGS)}"
    )
    ap.add_argument("--out", default="out/time_to_target", help="output folder")
    ap.add_argument(
        "--validation-paths", type=int, default=16, help="validation parts (default 16)"
    )
    ap.add_argument(
        "--from-json",
        nargs="+",
        metavar="JSON",
        help="no training: the table of earlier runs' time_to_target.json files (targets "
        "re-read from each run's curve files)",
    )
    args = ap.parse_args(argv)
    if args.from_json:
        return _from_json(args.from_json, Path(args.out))
    if args.validation_paths < 1:
        print(f"error: --validation-paths: >= 1, got {args.validation_paths}", file=sys.stderr)
        return 2
    names = [c.strip() for c in args.configs.split(",") if c.strip()]
    bad = [c for c in names if c not in CONFIGS]
    if bad or not names:
        print(f"error: --configs: unknown {bad}; known: {', '.join(CONFIGS)}", file=sys.stderr)
        return 2
    for key in ("budget", "eval_every"):
        v = getattr(args, key)
        if not (math.isfinite(v) and v > 0):
            print(f"error: --{key.replace('_', '-')}: seconds > 0, got {v}", file=sys.stderr)
            return 2
    out = Path(args.out)
    base_rms = base_score()
    print(f"{BASE} on {CASE}: {base_rms:.3f} µm; target {TARGET_RATIO * base_rms:.3f} µm")
    path = out / "time_to_target.json"
    rows = []
    for name in names:
        if CONFIGS[name]["algo"] in JAX_ALGOS and importlib.util.find_spec("sbx") is None:
            print(f"{name}: skipped (needs the [jax] extra: pip install -e '.[jax]')")
            continue
        t0 = time.perf_counter()
        r = run_config(
            name, args.budget, args.eval_every, out, validation_paths=args.validation_paths
        )
        rows.append(r)
        t = r["time_to_target"]
        print(
            f"{name}: {r['timesteps']} agent steps, {r['agent_steps_per_s']:.0f}/s, evaluation "
            f"share {r['eval_share']:.1%}, best {r['best_rms_um']:.3f} µm, (a) at "
            f"{_minutes(t['validation_base_level'])} min, (b) at "
            f"{_minutes(t['training_tasks_target'])} min ({time.perf_counter() - t0:.0f} s)",
            flush=True,
        )
        atomic_write_json(
            path,
            {
                "case": CASE,
                "base": BASE,
                "base_rms_um": base_rms,
                "target_ratio": TARGET_RATIO,
                "budget_s": args.budget,
                "eval_every_s": args.eval_every,
                "runs": rows,
            },
        )
    md = table(rows, base_rms, args.budget)
    atomic_write_text(out / "time_to_target.md", md)
    print(md)
    return 0


def _from_json(files: list, out: Path) -> int:
    rows, base_rms, budget = [], None, None
    for f in files:
        rec = json.loads(Path(f).read_text())
        base_rms, budget = rec["base_rms_um"], rec["budget_s"]
        for r in rec["runs"]:
            r["time_to_target"] = targets(Path(f).parent / r["config"])
            rows.append(r)
    md = table(rows, base_rms, budget)
    atomic_write_json(
        out / "time_to_target.json",
        {"case": CASE, "base": BASE, "base_rms_um": base_rms, "target_ratio": TARGET_RATIO,
         "budget_s": budget, "from": [str(f) for f in files], "runs": rows},
    )  # fmt: skip
    atomic_write_text(out / "time_to_target.md", md)
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
