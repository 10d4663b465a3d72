"""The README's generated tables, rendered from the records of a benchmark report.

``contour-env benchmark --suite readme --out DIR`` runs exactly what the tables need
(:data:`.suite.README_TABLES`); :func:`render` turns ``DIR/results.json``'s records into each
table's markdown, and :func:`report_stamp` gives the date and commit the report was made at.
``scripts/readme_figures.py`` writes them into the README; the scripts that print one table
(``scripts/controller_table.py`` ...) run that table's runs and render it the same way.

Every table looks its runs up by spec (kind, case, controller, variant, seed): a run the
report lacks, or one that failed, is a ``ValueError`` naming the table and the run.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from .suite import (
    CORNER_BLEND,
    CORNER_BLEND_SEEDS,
    ILC,
    LEE2012_CASES,
    PAPER_NOMINAL,
    README_TABLES,
    RunSpec,
    nominal,
)


class Records:
    """The records of a report (``results.json``'s ``records``), looked up by spec."""

    def __init__(self, records: Iterable[dict], table: str = "table"):
        self.table = table
        self.by_key = {
            (r["kind"], r["case"], r["controller"], r["variant"], r["seed"]): r for r in records
        }

    def record(self, spec: RunSpec) -> dict:
        r = self.by_key.get(spec.key())
        what = f"{spec.kind} {spec.case} {spec.controller} ({spec.variant}, seed {spec.seed})"
        if r is None:
            raise ValueError(
                f"{self.table}: the report has no run {what}; run contour-env benchmark "
                "--suite readme"
            )
        if r.get("error"):
            raise ValueError(f"{self.table}: the run {what} failed: {r['error']}")
        return r

    def metrics(self, spec: RunSpec) -> dict:
        return self.record(spec)["metrics"]

    def of(self, table: str) -> Records:
        """The same records, errors naming ``table``."""
        out = Records((), table)
        out.by_key = self.by_key
        return out


def _records(records, table: str) -> Records:
    return records.of(table) if isinstance(records, Records) else Records(records, table)


# --- controller_table ---------------------------------------------------------------------


def controller_table(records) -> str:
    """Default gains and loop margins of every (plant, controller) of the design runs."""
    from .design import margins_text

    recs = _records(records, "controller_table")
    out = [
        "| plant | controller | default gains | margins, realistic ±20 % "
        "| margins, structural mode |",
        "|---|---|---|---|---|",
    ]
    for spec in README_TABLES["controller_table"]():
        m = recs.metrics(spec)
        out.append(
            f"| `{spec.case}` | `{spec.controller}` | {m['gains']} | "
            f"{margins_text(m['margins'])} | {margins_text(m['structural_mode_margins'])} |"
        )
    return "\n".join(out)


# --- lee2012_table ------------------------------------------------------------------------


def lee2012_table(records, cases=LEE2012_CASES) -> str:
    """Our pd, ccc:wi=0, ccc and adaptive-ccc on Lee 2012's circles beside Tables 2–3 (the
    paper's figures are the records' ``published``, :mod:`.published`)."""
    from agents.compare import significant

    recs = _records(records, "lee2012_table")
    out = [
        "| case | controller | max / RMS ε µm | RMS/PD | RMS x torque N m, y force N "
        "| Lee 2012: max / RMS ε µm | RMS/PD | x N m, y N |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for case in cases:
        rows = {c: recs.record(nominal(case, c)) for c in PAPER_NOMINAL[case]}
        pd_rms = rows["pd"]["metrics"]["rms_contour_error_um"]
        lee_pd = rows["pd"]["published"]
        for name, r in rows.items():
            m, lee = r["metrics"], r["published"]
            ours = (
                f"{m['max_contour_error_um']:.1f} / {m['rms_contour_error_um']:.2f} | "
                f"{m['rms_contour_error_um'] / pd_rms:.3f} | "
                f"{m['rms_x_torque_Nm']:.2f}, {m['rms_y_force_N']:.0f}"
            )
            if not lee:
                theirs = "— | — | —"
            else:
                mx, rms = lee["max_contour_error_um"]["value"], lee["rms_contour_error_um"]["value"]
                ratio = rms / lee_pd["rms_contour_error_um"]["value"]
                tx, fy = lee["rms_x_torque_Nm"]["value"], lee["rms_y_force_N"]["value"]
                theirs = f"{mx:g} / {rms:g} | {ratio:.3f} | {significant(tx, 3)}, {fy:g}"
            out.append(f"| {case} | `{name}` | {ours} | {theirs} |")
    return "\n".join(out)


# --- residual_table -----------------------------------------------------------------------


def residual_markdown(rows: list[dict]) -> str:
    """Rows of :func:`.residual.score_target` as the README's markdown table."""
    lines = [
        "| agent (base) | contour | base RMS / max µm | agent RMS / max µm | RMS ratio "
        "| max ratio | effort ratio per axis |",
        "|---|---|---|---|---|---|---|",
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
            f"{r['agent_max_contour_error_um']:.2f} | {r['rms_ratio']:.3f} | "
            f"{r['agent_max_contour_error_um'] / r['base_max_contour_error_um']:.3f} | {eff} |"
        )
    return "\n".join(lines)


def residual_table(records) -> str:
    """The shipped residual agents against their bases on their test contours."""
    recs = _records(records, "residual_table")
    return residual_markdown([recs.metrics(s) for s in README_TABLES["residual_table"]()])


# --- ilc_table ----------------------------------------------------------------------------


def _md_um(x, resolution_um=None) -> str:
    """A table figure: 4 significant digits, at most 3 decimals (98.63, 2.713, 0.803),
    ``≤R (enc)`` below one encoder count, ``failed`` for a trial without metrics."""
    from contour_env.metrics import format_um

    if x is None:
        return "failed"
    decimals = min(3, max(0, 3 - math.floor(math.log10(abs(x))))) if x else 3
    return format_um(x, resolution_um, f".{decimals}f")


def ilc_markdown(rows: list[dict], iterations: int) -> str:
    """Rows of ``scripts/ilc_benchmark.py`` (case, condition, controller,
    encoder_resolution_um, first_max_um, first_rms_um, last_max_um, last_rms_um) as the
    README's markdown table (case and condition written once per group)."""
    lines = [
        f"| case | condition | law | trial 1 max / RMS | trial {iterations} max / RMS |",
        "|---|---|---|---|---|",
    ]
    last = None
    for r in rows:
        group = (r["case"], r["condition"])
        case, cond = ("", "") if group == last else group
        last = group
        res = r["encoder_resolution_um"]
        cells = [
            case,
            cond,
            r["controller"],
            f"{_md_um(r['first_max_um'], res)} / {_md_um(r['first_rms_um'], res)}",
            f"{_md_um(r['last_max_um'], res)} / {_md_um(r['last_rms_um'], res)}",
        ]
        lines.append("|" + "|".join(f" {c} " if c else " " for c in cells) + "|")
    return "\n".join(lines)


def ilc_row(spec: RunSpec, metrics: dict) -> dict:
    """An ilc record's figures as a row of ``scripts/ilc_benchmark.py``."""
    return {
        "case": spec.case,
        "condition": spec.variant,
        "controller": spec.controller,
        "encoder_resolution_um": metrics.get("encoder_resolution_um"),
        "first_max_um": metrics["first_max_contour_error_um"],
        "first_rms_um": metrics["first_rms_contour_error_um"],
        "last_max_um": metrics["max_contour_error_um"],
        "last_rms_um": metrics["rms_contour_error_um"],
    }


def ilc_table(records) -> str:
    """The repeated-batch ILC benchmark: trial 1 and trial N of every learning law."""
    recs = _records(records, "ilc_table")
    specs = README_TABLES["ilc_table"]()
    assert all(s.kind == ILC for s in specs)
    n = specs[0].settings["iterations"]
    return ilc_markdown([ilc_row(s, recs.metrics(s)) for s in specs], n)


# --- corner_blend_table -------------------------------------------------------------------


def summarize_seeds(controller: str, runs: list[dict]) -> dict:
    """One controller's row over its episodes' metrics (one per seed): mean max and RMS
    contour error, the RMS range, the mean RMS effort per axis, whether all completed."""
    import numpy as np

    rms = np.array([m["rms_contour_error_um"] for m in runs], dtype=float)
    mx = np.array([m["max_contour_error_um"] for m in runs], dtype=float)
    effort = np.mean([m["rms_effort"] for m in runs], axis=0)
    return dict(
        controller=controller,
        max_um=float(mx.mean()),
        rms_um=float(rms.mean()),
        rms_min_um=float(rms.min()),
        rms_max_um=float(rms.max()),
        effort=[float(e) for e in effort],
        completed=all(m["completed"] for m in runs),
    )


def corner_blend_markdown(rows, n_seeds: int) -> str:
    out = [
        f"| controller | max ε µm (mean of {n_seeds}) | RMS ε µm (mean) | RMS range | "
        "RMS effort x, y N | completed |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        effort = ", ".join(f"{e:.4g}" for e in r["effort"])
        out.append(
            f"| `{r['controller']}` | {r['max_um']:.1f} | {r['rms_um']:.2f} | "
            f"{r['rms_min_um']:.2f}–{r['rms_max_um']:.2f} | {effort} | {r['completed']} |"
        )
    return "\n".join(out)


def corner_blend_rows(records, controllers=CORNER_BLEND, n_seeds: int = CORNER_BLEND_SEEDS):
    recs = _records(records, "corner_blend_table")
    return [
        summarize_seeds(c, [recs.metrics(nominal("corner-blend", c, s)) for s in range(n_seeds)])
        for c in controllers
    ]


def corner_blend_table(records, controllers=CORNER_BLEND, n_seeds: int = CORNER_BLEND_SEEDS):
    """pd, ccc and adaptive-ccc on corner-blend over seeds 0..N−1."""
    return corner_blend_markdown(corner_blend_rows(records, controllers, n_seeds), n_seeds)


# --- all ----------------------------------------------------------------------------------

RENDER = {
    "controller_table": controller_table,
    "lee2012_table": lee2012_table,
    "residual_table": residual_table,
    "ilc_table": ilc_table,
    "corner_blend_table": corner_blend_table,
}
assert set(RENDER) == set(README_TABLES)


def render(name: str, records) -> str:
    """The README table ``name`` from a report's records."""
    if name not in RENDER:
        raise ValueError(f"unknown README table {name!r}; known: {', '.join(RENDER)}")
    return RENDER[name](records)


def short_commit(commit: str | None) -> str:
    """``abcdef0123...-dirty`` → ``abcdef0-dirty``; None → ``unknown``."""
    if not commit:
        return "unknown"
    head, sep, rest = commit.partition("-")
    return head[:7] + sep + rest


def report_stamp(data: dict) -> tuple[str, str]:
    """(date, short commit) of a results.json ``{"meta", "records"}``: the meta's timestamp
    and code version, else the first record's."""
    meta = data.get("meta") or {}
    first = (data.get("records") or [{}])[0]
    timestamp = meta.get("timestamp") or first.get("timestamp") or ""
    version = meta.get("code_version") or first.get("code_version") or {}
    return timestamp[:10] or "unknown", short_commit(version.get("commit"))


def run_records(specs, workers: int = 1) -> list[dict]:
    """The records of ``specs`` run here (no report files): for the one-table scripts."""
    from .report import build_records
    from .runner import run_all

    return build_records(run_all(list(specs), workers=workers), {"suite": None})
