"""``contour-env benchmark``: a suite's runs, ``results.json``, ``report.md``, ``report.html``.

    contour-env benchmark [--suite quick|paper|full|readme] --out DIR [--workers N]
                          [--ray auto|ADDRESS]

:func:`add_benchmark_command` registers it on the ``contour-env`` parser; :func:`main` runs it
standalone (``python -m contour_env.app.cli_benchmark ...``).
"""

from __future__ import annotations

import argparse
import sys
import time


def add_benchmark_command(subparsers) -> argparse.ArgumentParser:
    from .benchmark.suite import SUITES

    p = subparsers.add_parser(
        "benchmark",
        help="the whole benchmark: every case × controller, robustness, ILC, circular tests; a "
        "report beside the papers' tables",
    )
    p.add_argument(
        "--suite",
        default="quick",
        help=f"which runs: {', '.join(SUITES)} (default quick: under 2 min; paper: the seed "
        "papers' published comparisons; full: paper + robustness + ILC + residual agents + "
        "circular tests; "
        "readme: the runs behind the README's tables, readme:NAME[,NAME] some of them)",
    )
    p.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="folder for results.json, report.md, report.html and the figures",
    )
    p.add_argument(
        "--workers",
        default="1",
        metavar="N",
        help="run the independent runs on N local processes (default 1: in this process); "
        "the figures are identical",
    )
    p.add_argument(
        "--ray",
        default=None,
        metavar="auto|ADDRESS",
        help="run them as Ray tasks: auto (a running cluster, else a local instance) or a "
        'cluster ADDRESS; needs pip install -e ".[ray]"',
    )
    p.set_defaults(func=cmd_benchmark)
    return p


def cmd_benchmark(args) -> int:
    from tqdm.auto import tqdm

    from ..io import check_output_dir
    from .benchmark.report import code_version, write_report
    from .benchmark.runner import check_ray, check_workers, run_all
    from .benchmark.suite import get_suite

    # every value checked before anything runs
    workers = check_workers(args.workers)
    address = check_ray(args.ray)
    if address is not None and workers != 1:
        raise ValueError("--workers: give --workers N or --ray ADDRESS, not both")
    out = check_output_dir(args.out)
    suite = get_suite(args.suite)
    specs = list(suite.runs)
    executor = (
        f"Ray ({address})" if address else f"{workers} processes" if workers > 1 else "serial"
    )
    print(f"benchmark {suite.name}: {len(specs)} runs ({executor}) → {out}", flush=True)
    bar = tqdm(total=len(specs), desc=f"benchmark {suite.name}", unit="run", disable=None)

    def tick(res):
        s = res["spec"]
        bar.set_postfix_str(f"{s['case']} {s['controller']}", refresh=False)
        bar.update(1)

    t0 = time.perf_counter()
    try:
        results = run_all(specs, workers=workers, ray=address, progress=tick)
    finally:
        bar.close()
    meta = {
        "suite": suite.name,
        "description": suite.description,
        "n_runs": len(specs),
        "executor": executor,
        "workers": workers,
        "ray": address,
        "wall_s": time.perf_counter() - t0,
        "timestamp": _utc_now(),
        "code_version": code_version(),
    }
    written = write_report(out, results, meta)
    for name in ("results.json", "report.md", "report.html"):
        print(f"wrote {out / name}")
    n_png = sum(1 for f in written["files"] if str(f).endswith(".png"))
    print(f"wrote {n_png} figures in {out}")
    failed = [r for r in results if r.get("error")]
    for r in failed:
        s = r["spec"]
        print(
            f"error: run {s['kind']} {s['case']} {s['controller']}: {r['error']}", file=sys.stderr
        )
    return 1 if failed else 0


def _utc_now() -> str:
    import datetime as dt

    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


def main(argv=None) -> int:
    """Standalone entry point (the same command as ``contour-env benchmark``)."""
    from ..io import OutputPathError

    parser = argparse.ArgumentParser(prog="contour-env")
    sub = parser.add_subparsers(dest="command", required=True)
    add_benchmark_command(sub)
    args = parser.parse_args(["benchmark", *(sys.argv[1:] if argv is None else argv)])
    try:
        return args.func(args)
    except OutputPathError as exc:
        print(f"error: --out: {exc}", file=sys.stderr)
        return 2
    except (ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
