"""Compare a ``contour-env bench`` run with the speed figures recorded in the repository.

    python scripts/check_speed_regression.py [BENCH_JSON] [--reference docs/bench_reference.json]
        [--tolerance 0.2] [--absolute] [--update [--force]] [--quick] [--repeats N]

BENCH_JSON is what ``contour-env bench --json FILE`` wrote; without it the script runs
``contour-env bench --json`` itself (a minute or more, as the bench does; ``--quick`` and
``--repeats`` are passed on to it). The figures compared
are ratios measured within one run — contour_env to CartPole-v1 (the windows alternate, so a
slow spell of the machine hits both), exploration to tracking, contended to quiet, a controller
in the loop to the env's own rate — so a run on another machine, or in a slow spell, compares
with the reference; the absolute rates are printed beside them and judged only with
``--absolute`` (the same machine). Every ratio that fell by more than ``--tolerance`` (20 %)
below the reference is listed and the exit status is 1; 0 when none did, 2 when the two
cannot be compared (another case, no figure in common, an unreadable file).

A release step, not a timed unit test: run it on a quiet machine (``uptime``: load below 0.3).
``--update`` writes the run's figures as the new reference (atomically), with the date, the
commit and the machine; it refuses a run that started on a busy machine (1-minute load above
0.3 at its start), a ``--quick`` run, or one without its load recorded, unless ``--force``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "docs" / "bench_reference.json"
TOLERANCE = 0.20
MAX_LOAD = 0.3  # the 1-minute load average above which a run is no reference


class Incomparable(ValueError):
    """The run and the reference cannot be compared."""


def _pair_ratio(row: dict, key: str, ours: str, theirs: str) -> float | None:
    # the stored ratio; for a report written before the ratios were stored, the median of the
    # window pairs' ratios, or the ratio of the medians
    if row.get(key) is not None:
        return float(row[key])
    a, b = row.get(f"{ours}_runs"), row.get(f"{theirs}_runs")
    if a and b and len(a) == len(b):
        return statistics.median(x / y for x, y in zip(a, b, strict=True))
    if row.get(ours) and row.get(theirs):
        return row[ours] / row[theirs]
    return None


def figures(bench: dict) -> tuple[dict, dict]:
    """(ratios, rates) of a bench report, each {figure name: value}."""
    ratios: dict[str, float] = {}
    rates: dict[str, float] = {}
    r = _pair_ratio(
        bench, "single_ratio_to_cartpole", "single_env_steps_per_s", "cartpole_single_steps_per_s"
    )
    if r is not None:
        ratios["single env / CartPole"] = r
    if bench.get("single_env_steps_per_s") is not None:
        rates["single env, steps/s"] = bench["single_env_steps_per_s"]
    if bench.get("cartpole_single_steps_per_s") is not None:
        rates["CartPole single env, steps/s"] = bench["cartpole_single_steps_per_s"]
    for row in bench.get("vector", []):
        n = row["num_envs"]
        r = _pair_ratio(row, "ratio_to_cartpole", "env_steps_per_s", "cartpole_env_steps_per_s")
        if r is not None:
            ratios[f"{n} envs / CartPole"] = r
        rates[f"{n} envs, env-steps/s"] = row["env_steps_per_s"]
        rates[f"CartPole {n} envs, env-steps/s"] = row["cartpole_env_steps_per_s"]
    for row in bench.get("exploration", []):
        name = f"{row['label']}, {row['num_envs']} envs"
        ratios[f"{name} / tracking"] = row["ratio_to_tracking"]
        rates[f"{name}, env-steps/s"] = row["env_steps_per_s"]
    row = bench.get("contended")
    if row:
        n = row["num_envs"]
        ratios[f"contended {n} envs / quiet"] = row["ratio_to_quiet"]
        r = _pair_ratio(row, "ratio_to_cartpole", "env_steps_per_s", "cartpole_env_steps_per_s")
        if r is not None:
            ratios[f"contended {n} envs / CartPole"] = r
        rates[f"contended {n} envs, env-steps/s"] = row["env_steps_per_s"]
    for row in bench.get("controllers", []):
        # the bench's names end in their unit ("..., steps/s", "..., env-steps/s")
        name = row["name"]
        base = name.rsplit(", ", 1)[0] if name.endswith("steps/s") else name
        ratios[f"{base} / env single"] = row["ratio_to_env"]
        rates[name if base != name else f"{name}, steps/s"] = row["steps_per_s"]
    return ratios, rates


def compare(run: dict, reference: dict, tolerance: float = TOLERANCE, absolute=False) -> dict:
    """Compare a bench report ``run`` with a ``reference`` (the recorded file's content).

    Returns {"rows": [(kind, figure, reference, run, change, dropped)], "dropped": [...],
    "missing": [figures of the reference the run lacks], "new": [figures of the run the
    reference lacks], "notes": [...]}; change is
    run / reference − 1, dropped when it is below −tolerance (rates only with ``absolute``).
    Raises :class:`Incomparable` for another case or no figure in common."""
    if not 0.0 < tolerance < 1.0:
        raise ValueError(f"tolerance: must be in (0, 1), got {tolerance!r}")
    if run.get("case") != reference.get("case"):
        raise Incomparable(
            f"the run is of case {run.get('case')!r}, the reference of {reference.get('case')!r}"
        )
    ratios, rates = figures(run)
    notes = []
    if bool(run.get("quick")) != bool(reference.get("quick")):
        notes.append(
            f"the run is {'a --quick' if run.get('quick') else 'a full'} bench, the reference "
            f"{'a --quick' if reference.get('quick') else 'a full'} one: shorter windows are "
            "noisier"
        )
    load = (run.get("load_average_at_start") or [None])[0]
    if load is not None and load > MAX_LOAD:
        notes.append(
            f"the run started on a busy machine (load {load:.2f}): a drop may be the machine's"
        )
    rows, dropped, missing, new = [], [], [], []
    for kind, mine, judged in (
        ("ratio", ratios, True),
        ("rate", rates, absolute),
    ):
        new += [name for name in mine if name not in reference.get(f"{kind}s", {})]
        for name, ref in reference.get(f"{kind}s", {}).items():
            if name not in mine:
                missing.append(name)
                continue
            value = mine[name]
            change = value / ref - 1.0 if ref else float("nan")
            drop = judged and ref > 0 and value < (1.0 - tolerance) * ref
            rows.append((kind, name, ref, value, change, drop))
            if drop:
                dropped.append(rows[-1])
    if not any(r[0] == "ratio" for r in rows):
        raise Incomparable("the run and the reference have no ratio in common")
    return {"rows": rows, "dropped": dropped, "missing": missing, "new": new, "notes": notes}


def format_comparison(result: dict, tolerance: float = TOLERANCE) -> str:
    def num(kind, v):
        return f"{v:12.3f}" if kind == "ratio" else f"{v:12,.0f}"

    names = [r[1] for r in result["rows"]] + result["missing"] + result.get("new", [])
    width = max([len(n) for n in names] + [20]) + 2
    lines = [
        f"{'figure':{width}s}{'reference':>12s}{'this run':>12s}{'change':>9s}",
    ]
    kind = None
    for k, name, ref, value, change, drop in result["rows"]:
        if k != kind:
            kind = k
            lines.append(
                "ratios (judged)" if k == "ratio" else "absolute rates (machine-dependent)"
            )
        mark = f"  DROPPED > {tolerance:.0%}" if drop else ""
        lines.append(f"{name:{width}s}{num(k, ref)}{num(k, value)}{change:+9.1%}{mark}")
    for name in result["missing"]:
        lines.append(f"{name:{width}s}  not in this run")
    for name in result.get("new", []):
        lines.append(f"{name:{width}s}  not in the reference")
    for note in result["notes"]:
        lines.append(f"note: {note}")
    if result["dropped"]:
        lines.append(f"{len(result['dropped'])} figure(s) dropped by more than {tolerance:.0%}:")
        for _, name, ref, value, change, _ in result["dropped"]:
            lines.append(f"  {name}: {ref:.4g} -> {value:.4g} ({change:+.1%})")
    else:
        lines.append(f"no figure dropped by more than {tolerance:.0%}")
    return "\n".join(lines)


def reference_from(run: dict) -> dict:
    """The reference file's content for a bench report: the ratios, the absolute rates, the
    date, the commit and the machine."""
    ratios, rates = figures(run)
    return {
        "about": "contour-env bench figures of record; compared by "
        "scripts/check_speed_regression.py (ratios judged, rates shown)",
        "command": "contour-env bench --json FILE",
        "date": run.get("started"),
        "commit": (run.get("code") or {}).get("commit"),
        "machine": run.get("machine") or {"cpu_count": run.get("cpu_count")},
        "load_average_at_start": run.get("load_average_at_start"),
        "case": run.get("case"),
        "quick": bool(run.get("quick")),
        "statistic": run.get("statistic"),
        "ratios": ratios,
        "rates": rates,
    }


def update_refusal(run: dict) -> str | None:
    """Why ``run`` must not become the reference without ``--force`` (None: it may)."""
    if run.get("quick"):
        return "a --quick run (one short window per figure, no 4096-env rows)"
    load = run.get("load_average_at_start")
    if not load:
        return "the run has no load average recorded at its start"
    if load[0] > MAX_LOAD:
        return f"the run started on a busy machine (1-minute load {load[0]:.2f} > {MAX_LOAD})"
    return None


def run_bench_json(extra: list[str]) -> dict:
    """Run ``contour-env bench --json`` in a child process and read its report."""
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "bench.json"
        cmd = [sys.executable, "-m", "contour_env.app.cli", "bench", "--json", str(out), *extra]
        print("running:", " ".join(cmd[2:]), flush=True)
        subprocess.run(cmd, check=True, cwd=ROOT)
        return json.loads(out.read_text(encoding="utf-8"))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("bench_json", nargs="?", help="a contour-env bench --json report")
    p.add_argument("--reference", default=str(REFERENCE), help="the recorded figures")
    p.add_argument("--tolerance", type=float, default=TOLERANCE, help="allowed drop (0.2)")
    p.add_argument("--absolute", action="store_true", help="judge the absolute rates too")
    p.add_argument("--update", action="store_true", help="write the run as the new reference")
    p.add_argument("--force", action="store_true", help="--update even from a busy/quick run")
    p.add_argument("--quick", action="store_true", help="without BENCH_JSON: bench --quick")
    p.add_argument("--repeats", type=int, help="without BENCH_JSON: bench --repeats N")
    args = p.parse_args(argv)
    try:
        if args.bench_json:
            run = json.loads(Path(args.bench_json).read_text(encoding="utf-8"))
        else:
            extra = ["--quick"] if args.quick else []
            extra += ["--repeats", str(args.repeats)] if args.repeats else []
            run = run_bench_json(extra)
    except (OSError, ValueError, subprocess.CalledProcessError) as e:
        print(f"error: cannot read the bench report: {e}", file=sys.stderr)
        return 2
    ref_path = Path(args.reference)
    reference = None
    if ref_path.exists():
        try:
            reference = json.loads(ref_path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as e:
            print(f"error: cannot read {ref_path}: {e}", file=sys.stderr)
            return 2
    status = 0
    if reference is not None:
        print(
            f"reference: {ref_path} ({reference.get('date')}, commit {reference.get('commit')}, "
            f"{(reference.get('machine') or {}).get('cpu')})"
        )
        try:
            result = compare(run, reference, args.tolerance, args.absolute)
        except Incomparable as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        print(format_comparison(result, args.tolerance))
        status = 1 if result["dropped"] else 0
    elif not args.update:
        print(f"error: no reference at {ref_path} (--update writes one)", file=sys.stderr)
        return 2
    if args.update:
        why = update_refusal(run)
        if why and not args.force:
            print(f"not updating {ref_path}: {why} (--force to write it anyway)", file=sys.stderr)
            return 2
        from contour_env.io import atomic_write_json

        atomic_write_json(ref_path, reference_from(run))
        print(f"wrote {ref_path}")
        status = 0
    return status


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    raise SystemExit(main())
