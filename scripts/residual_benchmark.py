"""Residual agents against their base controllers: the figures of issue 5's acceptance.

    python scripts/residual_benchmark.py [--models DIR[,DIR...]] [--json OUT] [--markdown]

For every model DIR (default: the shipped agents, ``contour-env models``) and every test
contour of its plant, the agent and its base are scored with the project's one scoring
function (:func:`contour_env.evaluation.evaluate`, seed 0) and the ratios printed:
RMS contour error agent / base, and RMS effort agent / base per axis (the effort budget is
+10 %). Test contours (:func:`contour_env.app.benchmark.residual.test_targets`):

- the agent's training cases (``agent.json``), and for ``hsm2`` all three Lee 2012 circles;
- ``polygon``: the 40 mm square with four sharp 90° corners (``contour_env/data/
  square_corners.nc``, exact stop at each corner), at the plant's case feedrate;
- ``spline``: an open C² spline through five fixed points (``SPLINE_POINTS``, scaled
  to the plant's workspace), at the plant's case feedrate.

Neither the polygon nor the spline is a training path of the shipped agents (they are trained
on circles), so these rows measure generalisation. The scoring is
:mod:`contour_env.app.benchmark.residual`, the ``residual`` runs of ``contour-env benchmark
--suite readme``, from whose report the README's table is rendered the same way
(:func:`format_markdown`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import contour_env  # noqa: F401  (registers the env)
from contour_env.app.benchmark.readme_tables import residual_markdown as format_markdown
from contour_env.app.benchmark.residual import (  # noqa: F401  (this script's API)
    EFFORT_FLOOR_N,
    SPLINE_POINTS,
    SPLINE_SIZE_M,
    benchmark_model,
    test_targets,
)
from contour_env.io import atomic_write_json


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


def main(argv=None) -> int:
    # the --models option as residual_scorecard.py's (a script beside this one)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from residual_scorecard import add_models_option, model_dirs

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_models_option(ap)
    ap.add_argument("--json", help="write the rows as JSON to this file")
    ap.add_argument(
        "--markdown", action="store_true", help="also print the rows as the README's table"
    )
    args = ap.parse_args(argv)
    dirs = model_dirs(args.models)
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
