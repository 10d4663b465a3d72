"""Residual agents against their base controllers: the figures of issue 5's acceptance.

    python scripts/residual_benchmark.py [--models DIR[,DIR...]] [--json OUT] [--markdown]

For every model DIR (default: the shipped agents, ``contour-env models``) and every test
contour of its plant, the agent and its base are scored with the project's one scoring
function (:func:`contour_env.evaluation.evaluate`, seed 0) and the ratios printed:
RMS contour error agent / base, and RMS effort agent / base per axis (the effort budget is
+10 %). Test contours:

- the agent's training cases (``agent.json``), and for ``hsm2`` all three Lee 2012 circles;
- ``polygon``: the 40 mm square with four sharp 90° corners (``contour_env/data/
  square_corners.nc``, exact stop at each corner), at the plant's case feedrate;
- ``spline``: an open C² spline through five fixed points (:data:`SPLINE_POINTS`, scaled
  to the plant's workspace), at the plant's case feedrate.

Neither the polygon nor the spline is a training path of the shipped agents (they are trained
on circles), so these rows measure generalisation.
"""

from __future__ import annotations

import argparse
from importlib.resources import files
from pathlib import Path

import gymnasium as gym
import numpy as np

import contour_env  # noqa: F401  (registers the env)
from agents.registry import make_controller
from agents.residual import ResidualAgent, read_model_metadata
from agents.rl.models import list_models
from contour_env import ENV_ID
from contour_env.cases import case_names, get_case
from contour_env.evaluation import evaluate
from contour_env.io import atomic_write_json
from contour_env.paths import spline

# unit-square points of the test spline (scaled by SPLINE_SIZE_M of the plant); not a circle
SPLINE_POINTS = np.array(
    [[0.0, 0.0, 0.0], [0.35, 0.6, 0.0], [0.7, 0.15, 0.0], [1.0, 0.8, 0.0], [0.55, 1.0, 0.0]]
)
# workspace scale of the test spline per plant, m
# RMS effort below which an axis counts as idle for the effort ratio, N
EFFORT_FLOOR_N = 1e-6
SPLINE_SIZE_M = {"hsm2": 0.15, "jee-triaxial": 0.08, "linear-motor": 0.08, "friction-table": 0.04}


def _plant_feed(plant: str) -> float:
    """The feedrate of the plant's first named case, m/s."""
    for c in case_names():
        spec = get_case(c)
        if spec.plant == plant:
            return spec.feedrate_m_s
    raise ValueError(f"plant: no named case uses {plant!r}")


def test_targets(meta: dict) -> list[tuple[str, dict]]:
    """(label, env kwargs) of every test contour for the agent described by ``meta``."""
    plant = meta["plant"]
    cases = list(meta.get("cases") or [])
    if plant == "hsm2":
        cases = sorted(set(cases) | {"hsm2-circle-I", "hsm2-circle-II", "hsm2-circle-III"})
    targets = [(c, {"case": c}) for c in cases]
    feed = _plant_feed(plant)
    polygon = str(files("contour_env") / "data" / "square_corners.nc")
    targets.append(("polygon", {"plant": plant, "path": polygon, "feedrate_m_s": feed}))
    pts = SPLINE_POINTS * SPLINE_SIZE_M[plant]
    targets.append(("spline", {"plant": plant, "path": spline(pts), "feedrate_m_s": feed}))
    return targets


def benchmark_model(model_dir) -> list[dict]:
    meta = read_model_metadata(model_dir)
    rows = []
    for label, kw in test_targets(meta):
        base = evaluate(gym.make(ENV_ID, **kw), make_controller(meta["base"]))
        agent = evaluate(gym.make(ENV_ID, **kw), ResidualAgent(model_dir))
        # ratio per axis; None where the base does not use the axis (e.g. z on a planar path)
        effort = [
            a / b if b > EFFORT_FLOOR_N else None
            for a, b in zip(agent["rms_effort"], base["rms_effort"], strict=True)
        ]
        rows.append(
            {
                "model": str(model_dir),
                "plant": meta["plant"],
                "base": meta["base"],
                "target": label,
                "base_rms_contour_error_um": base["rms_contour_error_um"],
                "agent_rms_contour_error_um": agent["rms_contour_error_um"],
                "base_max_contour_error_um": base["max_contour_error_um"],
                "agent_max_contour_error_um": agent["max_contour_error_um"],
                "rms_ratio": agent["rms_contour_error_um"] / base["rms_contour_error_um"],
                "base_rms_effort": base["rms_effort"],
                "agent_rms_effort": agent["rms_effort"],
                "effort_ratio": effort,
                "agent_completed": bool(agent["completed"]),
            }
        )
    return rows


def format_rows(rows: list[dict]) -> str:
    lines = [
        f"{'plant':15s}{'base':13s}{'target':17s}{'RMS ε base':>11s}{'agent':>9s}{'ratio':>7s}"
        f"{'max ε base':>12s}{'agent':>8s}  effort agent/base",
    ]
    for r in rows:
        eff = ", ".join(
            f"{e:.3f}" if e is not None else f"{a:.2g} N (base idle)"
            for e, a in zip(r["effort_ratio"], r["agent_rms_effort"], strict=True)
        )
        lines.append(
            f"{r['plant']:15s}{r['base']:13s}{r['target']:17s}"
            f"{r['base_rms_contour_error_um']:11.3f}{r['agent_rms_contour_error_um']:9.3f}"
            f"{r['rms_ratio']:7.3f}{r['base_max_contour_error_um']:12.2f}"
            f"{r['agent_max_contour_error_um']:8.2f}  [{eff}]"
            + ("" if r["agent_completed"] else "  (agent stopped by the crash guard)")
        )
    return "\n".join(lines)


def format_markdown(rows: list[dict]) -> str:
    """The rows as the README's markdown table."""
    lines = [
        "| agent (base) | contour | base RMS / max µm | agent RMS / max µm | RMS ratio "
        "| effort ratio per axis |",
        "|---|---|---|---|---|---|",
    ]
    last = None
    for r in rows:
        label = "" if r["model"] == last else f"`{r['plant']}` ({r['base']})"
        last = r["model"]
        eff = ", ".join(
            f"{e:.3f}" if e is not None else "(idle in base)" for e in r["effort_ratio"]
        )
        lines.append(
            f"| {label} | {r['target']} | {r['base_rms_contour_error_um']:.3f} / "
            f"{r['base_max_contour_error_um']:.2f} | {r['agent_rms_contour_error_um']:.3f} / "
            f"{r['agent_max_contour_error_um']:.2f} | {r['rms_ratio']:.3f} | {eff} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", help="comma-separated model DIRs (default: the shipped agents)")
    ap.add_argument("--json", help="write the rows as JSON to this file")
    ap.add_argument(
        "--markdown", action="store_true", help="also print the rows as the README's table"
    )
    args = ap.parse_args(argv)
    if args.models:
        dirs = [Path(d) for d in args.models.split(",") if d]
    else:
        dirs = [Path(r["path"]) for r in list_models() if "error" not in r]
    if not dirs:
        raise SystemExit("no model DIRs: pass --models or ship agents (scripts/train_agents.py)")
    rows = []
    for d in dirs:
        new = benchmark_model(d)
        rows += new
        print(format_rows(new), flush=True)
    print()
    print(format_rows(rows))
    if args.markdown:
        print()
        print(format_markdown(rows))
    if args.json:
        atomic_write_json(args.json, {"rows": rows})
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
