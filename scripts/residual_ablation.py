"""The residual ablation: {axes, path} frame × {no gate, gate}, the same training budget, several
seeds, scored on the held-out suite and the plant's named cases.

    python scripts/residual_ablation.py [--plant friction-table] [--base ccc]
        [--timesteps 60000] [--seeds 0,1,2] [--parallel 2] [--work out/ablation]
        [--out docs/ablation_<plant>.json] [--markdown] [--train-args '...']

Each run is ``contour-env train --plant P --paths families --base B --timesteps N`` with one
variant's ``--residual-frame`` / ``--gate`` (everything else at the trainer's defaults; the
axis observation and the fade at rest on in every variant), run as its own process,
``--parallel`` at a time (each with one torch thread); a run that exists in ``--work`` with its
``agent.json`` is not trained again. Each kept agent is then scored by
:mod:`agents.rl.scorecard` (agent / base RMS contour error on every held-out program and named
case of the plant). Writes ``--out`` (atomically): per run its card, per variant the mean and
spread over the seeds of the held-out mean ratio, the held-out worst ratio and the worst ratio
over every target. ``--markdown`` prints the README's table.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
VARIANTS = {
    "axes": {"residual_frame": "axes", "gate": False},
    "axes+gate": {"residual_frame": "axes", "gate": True},
    "path": {"residual_frame": "path", "gate": False},
    "path+gate": {"residual_frame": "path", "gate": True},
}


def _command(plant, base, timesteps, seed, variant, out, extra=()) -> list[str]:
    v = VARIANTS[variant]
    cmd = [
        sys.executable, "-m", "contour_env.app.cli", "train", "--plant", plant, "--paths",
        "families", "--base", base, "--algo", "sac", "--timesteps", str(timesteps),
        "--eval-freq", str(max(1, timesteps // 8)),
        "--seed", str(seed), "--residual-frame", v["residual_frame"], "--observe-axes",
        "--fade-at-rest",
        "--gate" if v["gate"] else "--no-gate", "--out", str(out), "--no-progress",
        *extra,
    ]  # fmt: skip
    return cmd


def train_all(jobs, parallel: int) -> None:
    """Run the training commands ``jobs`` [(out, cmd)], ``parallel`` at a time."""
    waiting = [(out, cmd) for out, cmd in jobs if not (out / "agent.json").is_file()]
    running = []
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    while waiting or running:
        while waiting and len(running) < parallel:
            out, cmd = waiting.pop(0)
            if out.exists():  # an interrupted run: start again
                import shutil

                shutil.rmtree(out)
            out.parent.mkdir(parents=True, exist_ok=True)
            log = open(out.parent / f"{out.name}.log", "w")
            print(f"train {out.name}", flush=True)
            running.append((out, subprocess.Popen(cmd, cwd=ROOT, stdout=log, stderr=log, env=env)))
        time.sleep(2.0)
        for out, proc in list(running):
            if proc.poll() is not None:
                running.remove((out, proc))
                status = "done" if proc.returncode == 0 else f"FAILED ({proc.returncode})"
                print(f"  {out.name}: {status}", flush=True)


def _stats(values) -> dict:
    v = np.array([np.inf if x is None else x for x in values], dtype=float)
    return {
        "mean": float(np.mean(v)) if np.all(np.isfinite(v)) else None,
        "min": float(np.min(v)),
        "max": float(np.max(v)) if np.all(np.isfinite(v)) else None,
        "values": [None if not np.isfinite(x) else float(x) for x in v],
    }


def summarise(cards_by_variant: dict) -> dict:
    out = {}
    for variant, cards in cards_by_variant.items():
        out[variant] = {
            key: _stats([c[key] for c in cards])
            for key in ("heldout_mean_ratio", "heldout_worst_ratio", "worst_ratio")
        }
        out[variant]["kept_base"] = sum(c["kept"] == "base" for c in cards)
        out[variant]["seeds"] = len(cards)
    return out


def markdown(result: dict) -> str:
    """The README's table: per variant, the kept agent (keep-best with the base as a candidate)
    and the final policy (the end of training), mean (min–max) over the seeds."""

    def cell(s):
        if s["mean"] is None:
            return "not completed on every part"
        return f"{s['mean']:.2f} ({s['min']:.2f}–{s['max']:.2f})"

    lines = [
        "| variant | kept: held-out mean | kept: worst of all | kept as base | "
        "final policy: held-out mean | final policy: worst of all |",
        "|---|---|---|---|---|---|",
    ]
    finals = result.get("summary_final", {})
    for variant, s in result["summary"].items():
        f = finals.get(variant)
        fin = (
            f"{cell(f['heldout_mean_ratio'])} | {cell(f['worst_ratio'])}" if f else "– | –"
        )  # fmt: skip
        lines.append(
            f"| `{variant}` | {cell(s['heldout_mean_ratio'])} | {cell(s['worst_ratio'])} | "
            f"{s['kept_base']} of {s['seeds']} | {fin} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant", default="friction-table")
    ap.add_argument("--base", default="ccc")
    ap.add_argument(
        "--timesteps",
        type=int,
        default=60_000,
        help="agent steps per run (a budget in steps, not seconds: the variants get the same "
        "training whatever else the machine runs; 60k steps are about 4-5 min of SAC here)",
    )
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--parallel", type=int, default=2)
    ap.add_argument("--work", default="out/ablation")
    ap.add_argument("--out", default=None, help="JSON (default docs/ablation_<plant>.json)")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument(
        "--train-args",
        default="",
        help="more contour-env train options for every run, e.g. "
        "'--learning-rate-final 3e-5 --validation-paths 16' (the same for every variant)",
    )
    args = ap.parse_args(argv)
    from agents.rl.scorecard import scorecard
    from contour_env.io import atomic_write_json

    seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
    extra = shlex.split(args.train_args)
    variants = [v for v in args.variants.split(",") if v]
    bad = [v for v in variants if v not in VARIANTS]
    if bad:
        raise SystemExit(f"--variants: unknown {bad}; known: {', '.join(VARIANTS)}")
    work = Path(args.work) / args.plant
    runs = {
        (v, s): work / f"{v.replace('+', '-')}-s{s}" for v in variants for s in seeds
    }  # fmt: skip
    jobs = [
        (out, _command(args.plant, args.base, args.timesteps, s, v, out, extra))
        for (v, s), out in runs.items()
    ]
    t0 = time.perf_counter()
    train_all(jobs, args.parallel)
    cards_by_variant = {v: [] for v in variants}
    finals_by_variant = {v: [] for v in variants}
    for (v, s), out in runs.items():
        card = scorecard(out, workers=args.parallel)
        meta = json.loads((out / "agent.json").read_text())
        card.update(seed=s, variant=v, train_s=meta.get("train_wall_s"))
        cards_by_variant[v].append(card)
        # the policy at the end of training, whatever keep-best decided: what the variant learned
        final = scorecard(out / "final", workers=args.parallel)
        final.update(seed=s, variant=v, kept="final")
        finals_by_variant[v].append(final)
        print(
            f"{v:10s} seed {s}: kept ({card['kept']}) held-out mean "
            f"{card['heldout_mean_ratio']}, worst {card['worst_ratio']}; final policy held-out "
            f"mean {final['heldout_mean_ratio']}, worst {final['worst_ratio']}",
            flush=True,
        )
    result = {
        "plant": args.plant,
        "base": args.base,
        "timesteps": args.timesteps,
        "train_args": extra,
        "seeds": seeds,
        "wall_s": time.perf_counter() - t0,
        "summary": summarise(cards_by_variant),
        "summary_final": summarise(finals_by_variant),
        "cards": cards_by_variant,
        "final_cards": finals_by_variant,
    }
    out_json = args.out or str(ROOT / "docs" / f"ablation_{args.plant}.json")
    atomic_write_json(out_json, result)
    print(f"wrote {out_json}")
    print(markdown(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
