"""Our default controllers on Lee 2012's three circles beside the paper's Tables 2 and 3.

Prints a markdown table (the README's is this output): max / RMS contour error (µm), the RMS
ratio to PD, and RMS effort (x torque in N m through the lead ℓ, y force in N) for ``pd``,
``ccc`` (our PID cross-coupling), ``ccc:wi=0`` (the proportional form Lee benchmarks) and
``adaptive-ccc``, next to the published figures (``contour_env/app/benchmark/published.py``). The
papers' numbers come from the real HSM2; what should carry over is the ordering and a similar
ratio between controllers. The runs are the ``nominal`` runs of ``contour-env benchmark
--suite readme``, rendered by :func:`contour_env.app.benchmark.readme_tables.lee2012_table`.

Usage: ``python scripts/lee2012_table.py [--cases hsm2-circle-I,...]``.
"""

from __future__ import annotations

import argparse
import sys

from contour_env.app.benchmark.readme_tables import lee2012_table, run_records
from contour_env.app.benchmark.suite import LEE2012_CASES, PAPER_NOMINAL, nominal

CONTROLLERS = PAPER_NOMINAL[LEE2012_CASES[0]]  # pd, ccc:wi=0, ccc, adaptive-ccc


def table(cases, workers: int = 1) -> list[str]:
    """The table's lines (header first) for ``cases`` (of Lee's three circles)."""
    bad = [c for c in cases if c not in LEE2012_CASES]
    if bad:
        raise ValueError(f"--cases: not a Lee 2012 circle: {', '.join(bad)}")
    specs = [nominal(case, c) for case in cases for c in PAPER_NOMINAL[case]]
    return lee2012_table(run_records(specs, workers), cases).splitlines()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=",".join(LEE2012_CASES))
    parser.add_argument("--workers", type=int, default=1, help="local processes (default 1)")
    args = parser.parse_args(argv)
    try:
        lines = table([c.strip() for c in args.cases.split(",")], args.workers)
    except ValueError as exc:
        parser.error(str(exc))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
