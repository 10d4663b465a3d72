"""Tune the five-axis ``pid`` baseline (docs/FIVE_AXIS.md, "The tuned baseline").

1. Margins: for each integral share ω_i / ω, the largest ω on a 5 rad/s grid whose joint loops
   keep ≥ 6 dB / ≥ 30° on the realistic plant over the ±20 % inertia corners and the poses
   (``agents.five_axis_margins``: the same computation as ``contour-env margins --plant
   five-axis --controller pid:w=W:wi=WI``).
2. Tracking, on the tuning program only (``contour_env/data/five_axis_tuning.nc``: five
   joint-space blocks with A and C reversals, not a named case; the named cases
   five-axis-line and five-axis-circle are never run here): each share's largest ω, then at
   the chosen gains the ablations of the feedforward terms (the friction feedforward off or
   at half and 1.5 × the identified levels, the acceleration feedforward off, its preview
   ``lead`` 0, 2, 3 samples against the default 1).

    python scripts/five_axis_tune.py [--shares 0,0.125,0.25,0.5,0.75] [--json OUT]

Prints the tables the docs quote; the defaults in agents/five_axis_controllers.py
(PID_BANDWIDTH_RAD_S, PID_INTEGRAL_SHARE, PID_FRICTION_DEFAULT) are what it selects.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

TUNING_PROGRAM = ROOT / "contour_env" / "data" / "five_axis_tuning.nc"
OMEGA_GRID = tuple(range(30, 201, 5))


def margins(spec: str) -> dict:
    from agents.five_axis_margins import five_axis_loop_margins

    return five_axis_loop_margins(spec)


def meets(rep: dict) -> bool:
    from agents.margins import meets_requirement

    return meets_requirement(rep)


def largest_omega(share: float) -> tuple[float, dict]:
    """Bisection over OMEGA_GRID (the margins fall as ω rises) for the largest ω meeting the
    requirement at this integral share."""
    lo, hi = 0, len(OMEGA_GRID) - 1
    best = None
    while lo <= hi:
        mid = (lo + hi) // 2
        w = OMEGA_GRID[mid]
        rep = margins(f"pid:w={w}:wi={share * w:g}")
        if meets(rep):
            best = (w, rep)
            lo = mid + 1
        else:
            hi = mid - 1
    if best is None:
        raise SystemExit(f"no ω of the grid meets the requirement at share {share}")
    return best


def track(spec: str) -> dict:
    import gymnasium as gym

    from agents import make_controller
    from contour_env import ENV_ID
    from contour_env.evaluation import evaluate

    env = gym.make(ENV_ID, plant="five-axis", path=str(TUNING_PROGRAM))
    m = evaluate(env, make_controller(spec, env=env))
    keys = (
        "max_contour_error_um",
        "rms_contour_error_um",
        "max_orientation_error_arcsec",
        "rms_orientation_error_arcsec",
        "completed",
    )
    return {k: m.get(k) for k in keys}


def _row(spec: str, m: dict, extra: str = "") -> str:
    return (
        f"| `{spec}` | {extra}{m['max_contour_error_um']:.2f} / {m['rms_contour_error_um']:.2f} | "
        f"{m['max_orientation_error_arcsec']:.2f} / {m['rms_orientation_error_arcsec']:.2f} | "
        f"{m['completed']} |"
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--shares", default="0,0.125,0.25,0.5,0.75", help="integral shares ω_i / ω")
    ap.add_argument("--json", help="write every figure here")
    a = ap.parse_args(argv)
    shares = [float(s) for s in a.shares.split(",")]
    out: dict = {"program": str(TUNING_PROGRAM.relative_to(ROOT)), "margins": [], "runs": {}}
    t0 = time.perf_counter()
    print("## 1. margins: the largest ω per integral share (realistic plant, ±20 % inertia)\n")
    print("| ω_i / ω | largest ω rad/s | min GM dB | min PM ° | worst PM loop (pose) |")
    print("|---|---|---|---|---|")
    chosen = {}
    for share in shares:
        w, rep = largest_omega(share)
        worst = min(rep["loops"], key=lambda r: r["phase_margin_deg"])
        at = worst["phase_margin_at"]
        print(
            f"| {share:g} | {w} | {rep['min_gain_margin_db']:.2f} | "
            f"{rep['min_phase_margin_deg']:.1f} | {worst['loop']} ({at['pose']}) |"
        )
        chosen[share] = w
        out["margins"].append(
            {
                "share": share,
                "omega": w,
                "min_gain_margin_db": rep["min_gain_margin_db"],
                "min_phase_margin_deg": rep["min_phase_margin_deg"],
            }
        )
    print(f"\n## 2. tracking on {TUNING_PROGRAM.name} (realistic plant)\n")
    print("| controller | max / RMS ε µm | max / RMS θ ″ | completed |")
    print("|---|---|---|---|")
    specs = ["pd"] + [f"pid:w={w}:wi={share * w:g}" for share, w in chosen.items()]
    for spec in specs:
        m = track(spec)
        out["runs"][spec] = m
        print(_row(spec, m))
    best_share = min(
        chosen,
        key=lambda s: out["runs"][f"pid:w={chosen[s]}:wi={s * chosen[s]:g}"][
            "rms_contour_error_um"
        ],
    )
    w = chosen[best_share]
    base = f"pid:w={w}:wi={best_share * w:g}"
    print(f"\nlowest RMS ε: {base}; ablations of the feedforward terms at those gains:\n")
    print("| controller | max / RMS ε µm | max / RMS θ ″ | completed |")
    print("|---|---|---|---|")
    for suffix in (
        "", ":friction=0", ":friction=0.5", ":friction=1.5", ":ff=0", ":lead=0", ":lead=2",
        ":lead=3",
    ):  # fmt: skip
        spec = base + suffix
        m = out["runs"].get(spec) or track(spec)
        out["runs"][spec] = m
        print(_row(spec, m))
    out["selected"] = {"omega": w, "integral_share": best_share}
    print(f"\n({time.perf_counter() - t0:.0f} s)")
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))
        print(f"wrote {a.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
