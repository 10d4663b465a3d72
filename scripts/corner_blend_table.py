"""The classical controllers on the ``corner-blend`` case over several disturbance phases.

    python scripts/corner_blend_table.py [--seeds 5] [--controllers pd,ccc,adaptive-ccc]

``corner-blend`` draws its disturbance phase at random each episode and adds 50 nm encoder
noise (the case's env defaults), so one seed is one draw: the table gives, per controller, the
mean over seeds 0..N−1 of the max and RMS contour error (µm), the range of the RMS, and the RMS
effort per axis (N). Each episode is `contour_env.evaluation.evaluate` with that seed, the same
scoring as ``contour-env compare --case corner-blend --seed N``.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

CASE = "corner-blend"


def measure(controllers, n_seeds: int) -> list[dict]:
    import contour_env  # noqa: F401  (registers the env)
    from agents import make_controller
    from contour_env import ENV_ID
    from contour_env.evaluation import evaluate

    rows = []
    for name in controllers:
        runs = []
        for seed in range(n_seeds):
            env = gym.make(ENV_ID, case=CASE)
            runs.append(evaluate(env, make_controller(name), seed=seed))
        rms = np.array([m["rms_contour_error_um"] for m in runs], dtype=float)
        mx = np.array([m["max_contour_error_um"] for m in runs], dtype=float)
        effort = np.mean([m["rms_effort"] for m in runs], axis=0)
        rows.append(
            dict(
                controller=name,
                max_um=float(mx.mean()),
                rms_um=float(rms.mean()),
                rms_min_um=float(rms.min()),
                rms_max_um=float(rms.max()),
                effort=[float(e) for e in effort],
                completed=all(m["completed"] for m in runs),
            )
        )
    return rows


def format_markdown(rows, n_seeds: int) -> str:
    out = [
        f"| controller | max ε µm (mean of {n_seeds}) | RMS ε µm (mean) | RMS range | "
        "RMS effort x, y N | completed |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        effort = ", ".join(f"{e:.4g}" for e in r["effort"])
        out.append(
            f"| `{r['controller']}` | {r['max_um']:.1f} | {r['rms_um']:.2f} | "
            f"{r['rms_min_um']:.2f}–{r['rms_max_um']:.2f} | {effort} | {r['completed']} |"
        )
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seeds", type=int, default=5, help="seeds 0..N-1 (default 5)")
    p.add_argument("--controllers", default="pd,ccc,adaptive-ccc")
    args = p.parse_args(argv)
    if args.seeds < 1:
        p.error(f"--seeds: must be >= 1, got {args.seeds}")
    names = [c for c in args.controllers.split(",") if c]
    print(format_markdown(measure(names, args.seeds), args.seeds))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
