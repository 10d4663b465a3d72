"""The five-axis tables of the README and docs/FIVE_AXIS.md, from the benchmark's own runs.

    python scripts/five_axis_table.py [--out DIR] [--ablations] [--ideal]

Default: the benchmark's nominal runs of the two five-axis cases (every controller of
``contour_env.app.benchmark.suite.FIVE_AXIS``: ``pd`` with the paper's gains, the tuned
``pid``, ``ismc``; the realistic plant, seed 0), the same runs ``contour-env benchmark``
makes, printed as a markdown table of max / RMS contour error ε and orientation error θ;
``--out DIR`` also writes their benchmark report there (results.json, report.md, report.html).
``--ablations``: ISMC's two additions to the paper, each switched or scaled, and pid's
feedforward terms, on both cases (``agents.compare.compare``, the computation of ``contour-env
compare``): ``ismc:predict=0``, ``ismc:v0=`` shares of the path's peak feed F, and
``pid:friction=0``. ``--ideal``: the same rows on the paper's model (``contour-env compare
--ideal``).
"""

from __future__ import annotations

import argparse
import datetime
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CASES = ("five-axis-line", "five-axis-circle")
# v0 of ismc:v0= as shares of the path's peak feed F (default 1: v0 = F)
V0_SHARES = (0.01, 0.1, 0.5, 2.0, 10.0)
LABELS = {"pd": "`pd` (the paper's gains)", "pid": "`pid` (tuned)", "ismc": "`ismc`"}


def _fmt(v) -> str:
    return "—" if v is None else f"{v:.3g}" if v < 10 else f"{v:.1f}"


def _row(case: str, spec: str, m: dict) -> str:
    status = "ok" if m.get("completed") else (m.get("incomplete_reason") or "incomplete")
    return (
        f"| {case} | {LABELS.get(spec, f'`{spec}`')} | {_fmt(m['max_contour_error_um'])} / "
        f"{_fmt(m['rms_contour_error_um'])} | {_fmt(m['max_orientation_error_arcsec'])} / "
        f"{_fmt(m['rms_orientation_error_arcsec'])} | {status} |"
    )


HEADER = "| case | controller | max / RMS ε µm | max / RMS θ ″ | status |\n|---|---|---|---|---|"


def benchmark_rows(out: str | None) -> None:
    from contour_env.app.benchmark import suite as S
    from contour_env.app.benchmark.runner import run_all

    specs = [S.nominal(case, c) for case in CASES for c in S.FIVE_AXIS]
    t0 = time.perf_counter()
    results = run_all(specs)
    wall = time.perf_counter() - t0
    print(HEADER)
    for res in results:
        s = res["spec"]
        if res.get("error"):
            print(f"| {s['case']} | `{s['controller']}` | — | — | error: {res['error']} |")
            continue
        print(_row(s["case"], s["controller"], res["metrics"]))
    if out:
        from contour_env.app.benchmark.report import code_version, write_report

        meta = {
            "suite": "five-axis rows (scripts/five_axis_table.py)",
            "description": "the five-axis cases' nominal runs of the benchmark",
            "n_runs": len(specs),
            "executor": "serial",
            "workers": 1,
            "ray": None,
            "wall_s": wall,
            "timestamp": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "code_version": code_version(),
        }
        write_report(Path(out), results, meta)
        print(f"wrote {out}/report.md")


def _peak_feed(case: str) -> float:
    import gymnasium as gym

    from contour_env import ENV_ID

    return float(gym.make(ENV_ID, case=case).unwrapped.setup.feedrate_m_s)


def compare_rows(specs_of, ideal: bool) -> None:
    from agents.compare import compare

    print(HEADER)
    for case in CASES:
        specs = specs_of(case)
        result = compare(specs, case=case, ideal=ideal)
        for row in result["results"]:
            print(_row(case, row["controller"], row))


def ablation_specs(case: str) -> list[str]:
    feed = _peak_feed(case)
    v0 = [f"ismc:v0={share * feed:.4g}" for share in V0_SHARES]
    return ["ismc", "ismc:predict=0", *v0, "pid", "pid:friction=0"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", help="also write the benchmark report of the runs here")
    ap.add_argument("--ablations", action="store_true", help="ISMC's and pid's ablation rows")
    ap.add_argument("--ideal", action="store_true", help="on the paper's model (--ideal)")
    a = ap.parse_args(argv)
    if a.ablations:
        for case in CASES:
            print(f"{case}: peak feed F = {_peak_feed(case):.5g} m/s")
        compare_rows(ablation_specs, a.ideal)
    elif a.ideal:
        compare_rows(lambda case: ["pd", "pid", "pid:friction=0", "ismc"], True)
    else:
        benchmark_rows(a.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
