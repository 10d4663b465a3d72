"""Repeated-batch ILC benchmark: the figures of issue 4's acceptance, measured.

    python scripts/ilc_benchmark.py [--iterations 10] [--cases sharp-corner,hsm2-circle-II]
        [--disturbance-phase fixed|random] [--seeds 1] [--json OUT]

For every case and learning controller (ilc-pd, ilc-contour, vilcfd): max/RMS contour error of
the first trial and of trial N, the ratio RMS_N / RMS_1, and vilcfd's max error at trial N
relative to ilc-pd's. With ``--disturbance-phase random`` the friction table's disturbance is
redrawn every trial (not learnable); ``--seeds`` averages over several batch seeds.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller
from agents.registry import LEARNING_CONTROLLERS
from agents.repeated_batch import run_batch
from contour_env.io import atomic_write_json


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--iterations", type=int, default=10)
    ap.add_argument("--cases", default="sharp-corner,hsm2-circle-II")
    ap.add_argument("--controllers", default=",".join(LEARNING_CONTROLLERS))
    ap.add_argument("--disturbance-phase", default="fixed", choices=("fixed", "random"))
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    n = args.iterations
    out = []
    for case in args.cases.split(","):
        rows = {}
        for name in args.controllers.split(","):
            per_seed = []
            for s in range(args.seeds):
                env = gym.make(
                    "contour_env/Contouring-v0", case=case, disturbance_phase=args.disturbance_phase
                )
                res = run_batch(env, make_controller(name), n, seed=1000 * s)
                it = res["iterations"]
                per_seed.append(
                    [
                        it[0]["max_contour_error_um"],
                        it[0]["rms_contour_error_um"],
                        it[-1]["max_contour_error_um"],
                        it[-1]["rms_contour_error_um"],
                        sum(r["error_growing"] for r in it),
                    ]
                )
            a = np.mean(np.array(per_seed, dtype=float), axis=0)
            row = {
                "case": case,
                "controller": name,
                "first_max_um": a[0],
                "first_rms_um": a[1],
                "last_max_um": a[2],
                "last_rms_um": a[3],
                "rms_ratio_last_to_first": a[3] / a[1],
                "iterations_error_growing": a[4],
            }
            rows[name] = row
            out.append(row)
            print(
                f"{case:16s} {name:12s} trial 1: {a[0]:8.3f} / {a[1]:8.3f} µm   trial {n}: "
                f"{a[2]:8.3f} / {a[3]:8.3f} µm (max / RMS)   RMS_{n}/RMS_1 = {a[3] / a[1]:.4f}",
                flush=True,
            )
        if "vilcfd" in rows and "ilc-pd" in rows:
            red = 1.0 - rows["vilcfd"]["last_max_um"] / rows["ilc-pd"]["last_max_um"]
            print(f"{case:16s} vilcfd max ε at trial {n} is {100 * red:.1f} % lower than ilc-pd's")
    if args.json:
        atomic_write_json(args.json, {"iterations": n, "rows": out})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
