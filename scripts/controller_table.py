"""Print the README's table of default gains and their loop margins (generated, not typed).

For every named plant and every controller that applies to it: the default gains as the
controller computes them for that plant, and the worst gain/phase margin of its loops on the
realistic plant over the ±20 % mass corners (agents.margins), and with the two-mass mode
where the plant has one. These are the ``design`` runs of ``contour-env benchmark --suite
readme`` (:mod:`contour_env.app.benchmark.design`), run here and rendered as the README renders
them (:func:`contour_env.app.benchmark.readme_tables.controller_table`).

Usage: ``python scripts/controller_table.py [--workers N]`` (markdown on stdout; about a
minute).
"""

from __future__ import annotations

import argparse
import sys

from contour_env.app.benchmark.readme_tables import controller_table, run_records
from contour_env.app.benchmark.suite import README_TABLES


def rows(workers: int = 1) -> list[str]:
    """The table's lines (header first)."""
    specs = README_TABLES["controller_table"]()
    return controller_table(run_records(specs, workers)).splitlines()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=1, help="local processes (default 1)")
    args = ap.parse_args(argv)
    print("\n".join(rows(args.workers)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
