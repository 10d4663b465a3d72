"""Time to target of the residual trainers on ``lm-circle3d`` (issue 18, "minutes, not tens").

The target: an RMS contour error 50 % below the best classical controller on ``lm-circle3d``
(pd, ccc, adaptive-ccc, fnn and rfnn, the papers' fixed laws, scored here with
:func:`contour_env.evaluation.evaluate`, seed 0; rfnn is the best, 1.18 µm). Each
configuration trains a residual agent on top of that best controller with
``contour-env train``'s trainer (:func:`agents.rl.train`), seed 0, one torch thread, for
``--budget`` seconds of training time (evaluations not counted: the curves' ``train_s``),
scoring the deterministic policy on ``lm-circle3d`` every ``eval_freq`` agent steps. It
reports, per configuration: agent steps per second of training time, the best RMS reached,
and the training time of the first evaluation at or below the target (None: not reached in
the budget).

The named case is both what is trained on and what is scored here: this script compares the
*algorithms' speed* on the issue's yardstick, it does not make an agent to ship (shipped
agents train on generated parts, docs/RESIDUAL_TRAINING.md).

    python scripts/time_to_target.py [--budget 600] [--configs sac-1,sac-4-utd2,ppo-256]
        [--out out/time_to_target]

Writes ``OUT/time_to_target.json`` and ``OUT/time_to_target.md`` (atomically) and prints the
table.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import gymnasium as gym

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller
from agents.rl import TrainConfig, train
from contour_env import ENV_ID
from contour_env.evaluation import evaluate
from contour_env.io import atomic_write_json, atomic_write_text

CASE = "lm-circle3d"
CLASSICAL = ("pd", "ccc", "adaptive-ccc", "fnn", "rfnn")
TARGET_FRACTION = 0.5
# configuration name -> TrainConfig keywords (besides case, base, seed, budget)
CONFIGS = {
    # SB3 SAC on one env, one gradient step per agent step (the trainer's default)
    "sac-1": dict(algo="sac", n_envs=1, eval_freq=4_000),
    # SB3 TD3 on one env
    "td3-1": dict(algo="td3", n_envs=1, eval_freq=4_000),
    # SB3 SAC on 4 envs (one compiled vector env), 2 gradient steps per transition collected
    "sac-4-utd2": dict(algo="sac", n_envs=4, gradient_steps=8, eval_freq=8_000),
    # SB3 SAC on 16 envs, one gradient step per transition
    "sac-16-utd1": dict(algo="sac", n_envs=16, gradient_steps=16, eval_freq=16_000),
    # SB3 PPO on 256 envs of the compiled vector env: 64-step rollouts, minibatches of 1024
    # (evaluated by training time, every minute: by steps, 65 536 of them took minutes)
    "ppo-256": dict(
        algo="ppo", n_envs=256, ppo_n_steps=64, batch_size=1024, eval_freq=10**9, eval_every_s=60.0
    ),
}


def classical_scores() -> dict:
    env = gym.make(ENV_ID, case=CASE)
    return {
        name: evaluate(env, make_controller(name), seed=0)["rms_contour_error_um"]
        for name in CLASSICAL
    }


def run_config(name: str, base: str, budget_s: float, out: Path) -> dict:
    kw = dict(CONFIGS[name])
    cfg = TrainConfig(
        cases=(CASE,),
        base=base,
        seed=0,
        timesteps=10**8,
        time_budget_s=budget_s,
        validation_paths=0,
        checkpoint_freq=10**8,
        torch_threads=1,
        **kw,
    )
    t0 = time.perf_counter()
    summary = train(cfg, out / name, progress=False, log=lambda *a: None)
    return {
        "config": name,
        "algo": cfg.algo,
        "n_envs": cfg.num_envs,
        "gradient_steps": cfg.gradient_steps,
        "timesteps": summary["timesteps"],
        "train_s": summary["train_s"],
        "wall_s": time.perf_counter() - t0,
        "agent_steps_per_s": summary["timesteps"] / summary["train_s"],
        "curve": summary["curve"],
    }


def reached(curve: list, target: float):
    for p in curve:
        if p["rms_contour_error_um"] <= target:
            return p["train_s"]
    return None


def table(rows: list, target: float, best_name: str, best_rms: float) -> str:
    lines = [
        f"Target on {CASE}: RMS contour error ≤ {target:.3f} µm ({TARGET_FRACTION:.0%} of the "
        f"best classical controller, {best_name} {best_rms:.3f} µm); training time excludes "
        "evaluations.",
        "",
        "| configuration | algorithm | envs | gradient steps | agent steps/s | best RMS (µm) "
        "| best / base | minutes to target |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        best = min(p["rms_contour_error_um"] for p in r["curve"])
        t = r["time_to_target_s"]
        when = f"{t / 60:.1f}" if t is not None else f"not in {r['train_s'] / 60:.0f}"
        gs = r["gradient_steps"] if r["gradient_steps"] is not None else "—"
        lines.append(
            f"| {r['config']} | {r['algo']} | {r['n_envs']} | {gs} | "
            f"{r['agent_steps_per_s']:,.0f} | {best:.3f} | {best / best_rms:.2f} | {when} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=float, default=600.0, help="training seconds per config")
    ap.add_argument(
        "--configs",
        default="sac-1,sac-4-utd2,ppo-256",
        help=f"comma-separated, from {', '.join(CONFIGS)}",
    )
    ap.add_argument("--out", default="out/time_to_target", help="output folder")
    args = ap.parse_args(argv)
    names = [c.strip() for c in args.configs.split(",") if c.strip()]
    bad = [c for c in names if c not in CONFIGS]
    if bad or not names:
        print(f"error: --configs: unknown {bad}; known: {', '.join(CONFIGS)}", file=sys.stderr)
        return 2
    if not (math.isfinite(args.budget) and args.budget > 0):
        print(f"error: --budget: seconds > 0, got {args.budget}", file=sys.stderr)
        return 2
    out = Path(args.out)
    scores = classical_scores()
    best_name = min(scores, key=scores.get)
    best_rms = scores[best_name]
    target = TARGET_FRACTION * best_rms
    print(f"classical on {CASE}: " + ", ".join(f"{k} {v:.3f} µm" for k, v in scores.items()))
    print(f"target {target:.3f} µm; base {best_name}; budget {args.budget:.0f} s per config")
    rows = []
    for name in names:
        r = run_config(name, best_name, args.budget, out)
        r["time_to_target_s"] = reached(r["curve"], target)
        rows.append(r)
        print(
            f"{name}: {r['timesteps']} agent steps in {r['train_s']:.0f} s of training "
            f"({r['agent_steps_per_s']:.0f}/s), best "
            f"{min(p['rms_contour_error_um'] for p in r['curve']):.3f} µm, target at "
            f"{r['time_to_target_s']} s",
            flush=True,
        )
        record = {
            "case": CASE,
            "classical_rms_um": scores,
            "base": best_name,
            "target_rms_um": target,
            "budget_s": args.budget,
            "runs": rows,
        }
        atomic_write_json(out / "time_to_target.json", record)  # after every config
    md = table(rows, target, best_name, best_rms)
    atomic_write_text(out / "time_to_target.md", md)
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
