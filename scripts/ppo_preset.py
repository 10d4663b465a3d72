"""The measurement behind the ``ppo-256`` preset (agents/rl/config.py, issue 34): PPO on 256
envs of the compiled vector env on ``lm-circle3d`` over CCC, short runs that differ in one
hyperparameter each from a reference setting (rollout length, minibatch, epochs, learning
rate), scored as ``scripts/time_to_target.py`` scores (same trainer, evaluations every
``--eval-every`` s of training, 16 validation parts; wall time).

    python scripts/ppo_preset.py [--budget 150] [--out out/ppo_preset]

Writes ``OUT/ppo_preset.json`` (after every variant) and ``OUT/ppo_preset.md``; prints the table.
Run it alone on a quiet machine: agent steps/s is one of its figures.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from time_to_target import base_score, run_config  # noqa: E402

from agents.rl.progress import TARGET_RATIO  # noqa: E402
from contour_env.io import atomic_write_json, atomic_write_text  # noqa: E402

REFERENCE = dict(
    algo="ppo", n_envs=256, ppo_n_steps=64, batch_size=4096, ppo_n_epochs=5, learning_rate=3e-4
)
# variant name -> the keys that differ from REFERENCE
VARIANTS = {
    "reference": {},
    "rollout-32": dict(ppo_n_steps=32, batch_size=2048),
    "rollout-128": dict(ppo_n_steps=128, batch_size=8192),
    "epochs-10": dict(ppo_n_epochs=10),
    "minibatch-1024": dict(batch_size=1024),
    "lr-1e-3": dict(learning_rate=1e-3),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=float, default=150.0, help="training seconds per variant")
    ap.add_argument("--eval-every", type=float, default=30.0, help="training s between evaluations")
    ap.add_argument("--variants", default=",".join(VARIANTS), help="comma-separated")
    ap.add_argument("--validation-paths", type=int, default=16)
    ap.add_argument("--out", default="out/ppo_preset", help="output folder")
    args = ap.parse_args(argv)
    names = [v.strip() for v in args.variants.split(",") if v.strip()]
    bad = [v for v in names if v not in VARIANTS]
    if bad or not names:
        print(f"error: --variants: unknown {bad}; known: {', '.join(VARIANTS)}", file=sys.stderr)
        return 2
    if args.validation_paths < 1 or not (args.budget > 0 and args.eval_every > 0):
        print(
            "error: --validation-paths: >= 1; --budget, --eval-every: seconds > 0",
            file=sys.stderr,
        )
        return 2
    out = Path(args.out)
    base_rms = base_score()
    target = TARGET_RATIO * base_rms
    rows = []
    for name in names:
        kw = {**REFERENCE, **VARIANTS[name]}
        r = run_config(
            name, args.budget, args.eval_every, out, keywords=kw,
            validation_paths=args.validation_paths,
        )  # fmt: skip
        rows.append(r)
        t = r["time_to_target"]["training_tasks_target"]
        print(
            f"{name}: {r['agent_steps_per_s']:,.0f} agent steps/s, best {r['best_rms_um']:.3f} µm "
            f"({r['best_rms_um'] / base_rms:.2f}x CCC), validation {r['validation_score']}, "
            f"target at {'—' if t is None else round(t['wall_s'] / 60, 1)} min",
            flush=True,
        )
        atomic_write_json(
            out / "ppo_preset.json",
            {"base_rms_um": base_rms, "target_rms_um": target, "budget_s": args.budget,
             "reference": REFERENCE, "runs": rows},
        )  # fmt: skip
    lines = [
        f"PPO, 256 envs, lm-circle3d over CCC ({base_rms:.3f} µm), {args.budget:.0f} s of "
        f"training each; target {target:.3f} µm",
        "",
        "| variant | changed | agent steps/s | best RMS (µm) | best / CCC | kept validation "
        "score | min to target (wall) |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        t = r["time_to_target"]["training_tasks_target"]
        when = "—" if t is None else f"{t['wall_s'] / 60:.1f}"
        changed = ", ".join(f"{k} {v}" for k, v in VARIANTS[r["config"]].items()) or "—"
        lines.append(
            f"| {r['config']} | {changed} | {r['agent_steps_per_s']:,.0f} | "
            f"{r['best_rms_um']:.3f} | {r['best_rms_um'] / base_rms:.2f} | "
            f"{r['validation_score']:.3f} | {when} |"
        )
    md = "\n".join(lines) + "\n"
    atomic_write_text(out / "ppo_preset.md", md)
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
