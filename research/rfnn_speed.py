"""Question: Does rfnn cost more than 2× PD's wall time on a compiled lm-circle3d episode (issue
17)?

Answer: No: rfnn takes 1.57× PD's time (min of 21 alternating runs; median 1.63×), about 0.25 µs
more per step.

Cited by: docs/RFNN.md (the speed table).

Wall time of a compiled lm-circle3d episode (159k servo periods) with rfnn, fnn and ccc
against pd — issue 17: rfnn must not take more than 2× PD's time.

Each controller runs once to load (or compile) the fused loop, then ``--repeats`` times in
alternation on the same env (so that a busy machine slows every controller alike); the
minimum and the median of each are reported, and their ratio to PD. The law alone (the
compiled per-step law called in a loop on the case's reference, without the plant) is timed
too: it is less sensitive to what else the machine runs. So is the CPU time of the episode
(``time.thread_time``: the time the thread ran, not the time it waited for a core), reported
next to the wall-time ratios as ``cpu min/pd`` and ``cpu med/pd``::

    python research/rfnn_speed.py [--repeats 15] [--json out/rfnn_speed.json]
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
import numpy as np
from numba import njit

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller
from agents.compiled import laws
from agents.compiled.forms import compiled_form
from contour_env import ENV_ID
from contour_env.evaluation import run_episode
from contour_env.io import atomic_write_json

CASE = "lm-circle3d"
SPECS = ("pd", "rfnn", "fnn", "ccc")


@njit
def _law_loop(kind, n, ax, ref_pav, frame, scal, fp, st, u, work):
    A = ax.shape[2]
    acc = 0.0
    for k in range(n):
        kk = k % ref_pav.shape[0]
        ax[2, 0, 0] = 1e-6 * (k % 7)  # a varying measured position (kernel.AX_MEAS)
        laws.law(kind, A, 0, kk, 1e-4, ax, ref_pav, frame, scal, fp, st, u, work)
        acc += u[0]
    return acc


def law_us_per_step(env, spec: str, n: int, repeats: int = 5) -> float:
    """µs per call of the compiled law of ``spec`` alone (best of ``repeats`` loops of n)."""
    core = env.unwrapped.core
    c = make_controller(spec).bind(env)
    env.reset(seed=0)
    c.reset()
    form = compiled_form(c)
    u, work, ax = np.zeros(core.dim), np.zeros(64), core.ax.copy()
    args = (core.ref_pav, core.frame, core.scal, form.fp, form.st, u, work)
    _law_loop(form.kind, 10, ax, *args)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        _law_loop(form.kind, n, ax, *args)
        best = min(best, time.perf_counter() - t0)
    return best / n * 1e6


def measure(repeats: int, specs=SPECS) -> dict:
    env = gym.make(ENV_ID, case=CASE)
    n_steps = env.unwrapped.core.n_steps - 1
    controllers = {s: make_controller(s).bind(env) for s in specs}
    for c in controllers.values():  # load / compile the loop
        run_episode(env, c)
    times: dict[str, list[float]] = {s: [] for s in specs}
    cpu: dict[str, list[float]] = {s: [] for s in specs}
    for _ in range(repeats):
        for s, c in controllers.items():
            t0, c0 = time.perf_counter(), time.thread_time()
            run_episode(env, c)
            times[s].append(time.perf_counter() - t0)
            cpu[s].append(time.thread_time() - c0)
    pd_min, pd_med = min(times["pd"]), statistics.median(times["pd"])
    pd_cpu_min, pd_cpu_med = min(cpu["pd"]), statistics.median(cpu["pd"])
    rows = {
        s: {
            "min_s": min(t),
            "median_s": statistics.median(t),
            "min_ratio_to_pd": min(t) / pd_min,
            "median_ratio_to_pd": statistics.median(t) / pd_med,
            "cpu_min_ratio_to_pd": min(cpu[s]) / pd_cpu_min,
            "cpu_median_ratio_to_pd": statistics.median(cpu[s]) / pd_cpu_med,
            "us_per_step_min": min(t) / n_steps * 1e6,
            "law_alone_us_per_step": law_us_per_step(env, s, n_steps),
        }
        for s, t in times.items()
    }
    return {"case": CASE, "n_steps": n_steps, "repeats": repeats, "controllers": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15, help="timed runs per controller")
    ap.add_argument("--json", help="write the figures as JSON to this file")
    args = ap.parse_args()
    result = measure(args.repeats)
    print(f"{result['case']}: {result['n_steps']} steps, {result['repeats']} runs each")
    print(
        f"{'controller':12s}{'min s':>9s}{'median s':>10s}{'min/pd':>8s}{'med/pd':>8s}"
        f"{'µs/step':>9s}{'law µs':>8s}{'cpu min/pd':>12s}{'cpu med/pd':>12s}"
    )
    for s, r in result["controllers"].items():
        print(
            f"{s:12s}{r['min_s']:9.3f}{r['median_s']:10.3f}{r['min_ratio_to_pd']:8.2f}"
            f"{r['median_ratio_to_pd']:8.2f}{r['us_per_step_min']:9.3f}"
            f"{r['law_alone_us_per_step']:8.3f}{r['cpu_min_ratio_to_pd']:12.2f}"
            f"{r['cpu_median_ratio_to_pd']:12.2f}"
        )
    if args.json:
        atomic_write_json(args.json, result)
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
