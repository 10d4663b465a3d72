"""Repeated-batch ILC benchmark: vilcfd against both pure ILC laws, repeatable and not.

    python scripts/ilc_benchmark.py [--iterations 10] [--cases sharp-corner,hsm2-circle-II]
        [--controllers ilc-pd,ilc-contour,vilcfd] [--conditions repeatable,random]
        [--noise 5e-8] [--seeds 1] [--tuning] [--json OUT] [--markdown]

For every case, condition and learning controller: max/RMS contour error of the first trial
and of trial N (the project's one scoring function, :func:`contour_env.metrics.score`), and
``vilcfd``'s trial-N max and RMS against each pure ILC law's, phrased lower/higher from the
sign. Conditions:

- ``repeatable``: the plant's disturbance with its documented fixed phase, no encoder noise —
  every trial is the same, everything can be learned;
- ``random``: the disturbance phase drawn anew in every trial (``disturbance_phase="random"``)
  and Gaussian encoder noise of ``--noise`` m (default 50 nm) — what does not repeat, which
  iterative learning cannot learn and the in-trial observer/compensator of ``vilcfd`` is for.

Trial i of seed s runs with seed 1000 s + i − 1; ``--seeds`` averages over seeds (the random
condition differs per seed, the repeatable one does not). ``--tuning`` runs the two corners
the controllers' defaults were chosen on instead of ``--cases`` (:func:`tuning_paths`: never
the scored ``sharp-corner``). The JSON (written atomically) holds the rows and comparisons;
``--markdown`` also prints the README's table (:func:`format_markdown`, which renders the
README's ``ilc_table`` from the ``ilc`` runs of ``contour-env benchmark --suite readme`` too:
10 trials, seed 0, the defaults here).
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller
from agents.registry import LEARNING_CONTROLLERS
from agents.repeated_batch import run_batch
from contour_env.app.benchmark.readme_tables import ilc_markdown as format_markdown
from contour_env.cases import get_case
from contour_env.io import atomic_write_json
from contour_env.metrics import below_count, encoder_resolution_um, format_um
from contour_env.paths import polyline

ENV_ID = "contour_env/Contouring-v0"
CONDITIONS = ("repeatable", "random")
DEFAULT_NOISE_M = 5e-8
PURE_ILC = ("ilc-pd", "ilc-contour")


def tuning_paths() -> dict:
    """The corners ``vilcfd``'s and the Q-filter's defaults were chosen on, on the friction
    table with ``sharp-corner``'s feed profile (20 mm/s, 0.5 m/s², 10 m/s³, 0.1 s settle), each
    two 30 mm legs from the origin, the first at 30°:

    - ``corner-120``: a 120° corner whose second leg runs along +y, so the x axis stops at the
      corner and rests (a standstill after a corner, as on ``sharp-corner``);
    - ``corner-90-rot30``: a 90° corner rotated by 30°; at the corner x reverses and y stops
      and starts again.
    """
    L = 0.03
    c, s = np.cos(np.radians(30.0)), np.sin(np.radians(30.0))
    p1 = np.array([L * c, L * s])
    return {
        "corner-120": polyline([(0.0, 0.0), tuple(p1), tuple(p1 + [0.0, L])]),
        "corner-90-rot30": polyline([(0.0, 0.0), tuple(p1), tuple(p1 + L * np.array([-s, c]))]),
    }


def make_env(case: str, condition: str, noise_m: float = DEFAULT_NOISE_M):
    """The env of a named case, or of a tuning path (``tuning_paths``), under a condition."""
    if condition not in CONDITIONS:
        raise ValueError(f"condition: one of {', '.join(CONDITIONS)}, got {condition!r}")
    kw = {}
    if condition == "random":
        kw = dict(disturbance_phase="random", measurement_noise_std_m=noise_m)
    paths = tuning_paths()
    if case in paths:
        sc = get_case("sharp-corner")
        return gym.make(
            ENV_ID,
            plant="friction-table",
            path=paths[case],
            feedrate_m_s=sc.feedrate_m_s,
            max_accel_m_s2=sc.max_accel_m_s2,
            max_jerk_m_s3=sc.max_jerk_m_s3,
            settle_time_s=sc.settle_time_s,
            **kw,
        )
    return gym.make(ENV_ID, case=case, **kw)


def compare(a: float, b: float) -> str:
    """How a compares with b, in words: "12.3 % lower" / "4.5 % higher" / "equal"."""
    if a == b:
        return "equal"
    pct = 100.0 * abs(a - b) / b
    return f"{pct:.1f} % {'lower' if a < b else 'higher'}"


def run(case, condition, controller, iterations, seeds, noise_m) -> dict:
    per_seed = []
    for s in range(seeds):
        res = run_batch(
            make_env(case, condition, noise_m),
            make_controller(controller),
            iterations,
            seed=1000 * s,
        )
        it = res["iterations"]
        per_seed.append(
            [
                it[0]["max_contour_error_um"],
                it[0]["rms_contour_error_um"],
                it[-1]["max_contour_error_um"],
                it[-1]["rms_contour_error_um"],
                sum(r["error_growing"] for r in it),
                float(res["diverged"]),
            ]
        )
    # a failed trial has no metrics (None → NaN): the mean is then NaN, written as null
    a = np.mean(np.array(per_seed, dtype=float), axis=0)
    res_um = encoder_resolution_um(
        make_env(case, condition, noise_m).unwrapped.plant.params.encoder_resolution_m
    )
    return {
        "case": case,
        "condition": condition,
        "controller": controller,
        "encoder_resolution_um": res_um,
        "first_max_um": _num(a[0]),
        "first_rms_um": _num(a[1]),
        "last_max_um": _num(a[2]),
        "last_rms_um": _num(a[3]),
        "last_max_below_resolution": below_count(_num(a[2]), res_um),
        "last_rms_below_resolution": below_count(_num(a[3]), res_um),
        "rms_ratio_last_to_first": _num(a[3] / a[1]),
        "iterations_error_growing": _num(a[4]),
        "diverged_share": _num(a[5]),
    }


def _num(x) -> float | None:
    return float(x) if np.isfinite(x) else None


def _fmt(x, width: int, resolution_um=None) -> str:
    """A figure, ``≤R (enc)`` below one encoder count R, or ``failed``."""
    if x is None:
        return f"{'failed':>{width}s}"
    return f"{format_um(x, resolution_um, '.3f'):>{width}s}"


def run_benchmark(cases, conditions, names, n, seeds, noise_m, log=print):
    """Every (case, condition, controller) row and ``vilcfd``'s comparisons with each pure ILC
    law, printed through ``log`` as they come; returns ``(rows, comparisons)``."""
    rows, comparisons = [], []
    log(
        f"{'case':16s} {'condition':10s} {'controller':12s} {'trial 1 max':>11s} "
        f"{'RMS':>8s} {f'trial {n} max':>12s} {'RMS':>8s}   (contour error, µm)"
    )
    t0 = time.time()
    for case in cases:
        for cond in conditions:
            by_name = {}
            for name in names:
                r = run(case, cond, name, n, seeds, noise_m)
                by_name[name] = r
                rows.append(r)
                res_um = r["encoder_resolution_um"]
                log(
                    f"{case:16s} {cond:10s} {name:12s} {_fmt(r['first_max_um'], 11, res_um)} "
                    f"{_fmt(r['first_rms_um'], 8, res_um)} {_fmt(r['last_max_um'], 12, res_um)} "
                    f"{_fmt(r['last_rms_um'], 8, res_um)}"
                )
            v = by_name.get("vilcfd")
            for other in PURE_ILC:
                o = by_name.get(other)
                keys = ("last_max_um", "last_rms_um")
                if v is None or o is None or any(x[k] is None for x in (v, o) for k in keys):
                    continue
                comp = {
                    "case": case,
                    "condition": cond,
                    "against": other,
                    "max": compare(v["last_max_um"], o["last_max_um"]),
                    "rms": compare(v["last_rms_um"], o["last_rms_um"]),
                    "max_change_percent": 100.0 * (v["last_max_um"] / o["last_max_um"] - 1.0),
                    "rms_change_percent": 100.0 * (v["last_rms_um"] / o["last_rms_um"] - 1.0),
                }
                comparisons.append(comp)
                log(
                    f"{'':16s} {'':10s} vilcfd at trial {n} against {other}: max "
                    f"{v['last_max_um']:.3f} vs {o['last_max_um']:.3f} µm ({comp['max']}), "
                    f"RMS {v['last_rms_um']:.3f} vs {o['last_rms_um']:.3f} µm ({comp['rms']})"
                )
    log(f"({time.time() - t0:.0f} s)")
    return rows, comparisons


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--iterations", type=int, default=10)
    ap.add_argument("--cases", default="sharp-corner,hsm2-circle-II")
    ap.add_argument("--controllers", default=",".join(LEARNING_CONTROLLERS))
    ap.add_argument("--conditions", default=",".join(CONDITIONS))
    ap.add_argument("--noise", type=float, default=DEFAULT_NOISE_M, metavar="STD_M")
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--tuning", action="store_true", help="run the tuning corners instead")
    ap.add_argument("--json")
    ap.add_argument(
        "--markdown", action="store_true", help="also print the rows as the README's table"
    )
    args = ap.parse_args(argv)
    if args.iterations < 1 or args.seeds < 1:
        ap.error("--iterations and --seeds must be >= 1")
    n = args.iterations
    cases = list(tuning_paths()) if args.tuning else args.cases.split(",")
    conditions = args.conditions.split(",")
    for c in conditions:
        if c not in CONDITIONS:
            ap.error(f"--conditions: one of {', '.join(CONDITIONS)}, got {c!r}")
    names = args.controllers.split(",")
    rows, comparisons = run_benchmark(
        cases, conditions, names, n, args.seeds, args.noise, log=lambda s: print(s, flush=True)
    )
    if args.markdown:
        print()
        print(format_markdown(rows, n))
    if args.json:
        atomic_write_json(
            args.json,
            {
                "iterations": n,
                "seeds": args.seeds,
                "noise_std_m": args.noise,
                "tuning_paths": bool(args.tuning),
                "rows": rows,
                "comparisons": comparisons,
            },
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
