"""The classical controllers on the ``corner-blend`` case over several disturbance phases.

    python scripts/corner_blend_table.py [--seeds 5] [--controllers pd,ccc,adaptive-ccc]
        [--workers N]

``corner-blend`` draws its disturbance phase at random each episode and adds 50 nm encoder
noise (the case's env defaults), so one seed is one draw: the table gives, per controller, the
mean over seeds 0..N−1 of the max and RMS contour error (µm), the range of the RMS, and the RMS
effort per axis (N). Each episode is a ``nominal`` run of ``contour-env benchmark`` with that
seed (the ``readme`` suite has these runs), the same scoring as ``contour-env compare --case
corner-blend --seed N``; the table is
:func:`contour_env.app.benchmark.readme_tables.corner_blend_table`, as in the README.
"""

from __future__ import annotations

import argparse

from contour_env.app.benchmark.readme_tables import (
    corner_blend_markdown,
    corner_blend_rows,
    run_records,
)
from contour_env.app.benchmark.suite import nominal

CASE = "corner-blend"


def measure(controllers, n_seeds: int, workers: int = 1) -> list[dict]:
    """One row per controller over seeds 0..n_seeds−1."""
    specs = [nominal(CASE, c, seed) for c in controllers for seed in range(n_seeds)]
    return corner_blend_rows(run_records(specs, workers), controllers, n_seeds)


format_markdown = corner_blend_markdown


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seeds", type=int, default=5, help="seeds 0..N-1 (default 5)")
    p.add_argument("--controllers", default="pd,ccc,adaptive-ccc")
    p.add_argument("--workers", type=int, default=1, help="local processes (default 1)")
    args = p.parse_args(argv)
    if args.seeds < 1:
        p.error(f"--seeds: must be >= 1, got {args.seeds}")
    names = [c for c in args.controllers.split(",") if c]
    print(format_markdown(measure(names, args.seeds, args.workers), args.seeds))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
