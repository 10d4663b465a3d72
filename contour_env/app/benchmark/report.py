"""The benchmark's outputs: ``results.json`` (one record per run), ``report.md``,
``report.html`` (self-contained: the figures embedded, and written as PNGs beside it) and the
figures. Every table puts the paper's figure, where one exists, in the column next to ours,
with the ratios to PD side by side, and is followed by a reading generated from its numbers.
The circular-test section's tables, readings and polar plots come from :mod:`.circular`.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import subprocess
from pathlib import Path

import numpy as np

from . import circular
from .published import RELATIVE, published_for
from .suite import CIRCULAR, DESIGN, ILC, NOMINAL, RESIDUAL_RUN, ROBUSTNESS

HEADLINE = "rms_contour_error_um"
# published metrics shown beside ours, in this order, with their column label
COLUMNS = {
    "max_contour_error_um": "max ε µm",
    "rms_contour_error_um": "RMS ε µm",
    "max_orientation_error_arcsec": "max θ ″",
    "rms_orientation_error_arcsec": "RMS θ ″",
    "total_contour_error_um": "total ε mm",
    "max_tracking_error_um": "max tracking µm",
    "rms_x_torque_Nm": "RMS x torque N m",
    "rms_y_force_N": "RMS y force N",
}
# shown in the unit of the paper's table
SCALE = {"total_contour_error_um": 1e-3}


def code_version() -> dict:
    """The package version and, in a git checkout, the commit (``-dirty`` when tracked files
    are modified); ``commit`` is None outside one."""
    from contour_env import __version__

    root = Path(__file__).resolve().parents[2]
    commit = None
    try:

        def git(*args):
            return subprocess.run(
                ["git", *args], cwd=root, capture_output=True, text=True, check=True, timeout=30
            ).stdout.strip()

        commit = git("rev-parse", "HEAD")
        if git("status", "--porcelain", "--untracked-files=no"):
            commit += "-dirty"
    except (OSError, subprocess.SubprocessError):
        commit = None
    return {"package": "contour_env", "version": __version__, "commit": commit}


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def _value(metrics: dict, metric: str):
    v = metrics.get(metric)
    if isinstance(v, list):  # per-axis: the worst axis
        vals = [x for x in v if x is not None]
        return max(vals) if vals else None
    return v


def build_records(results: list[dict], settings: dict, version: dict | None = None) -> list[dict]:
    """One JSON record per run: what ran (kind, case, controller, plant, variant, seed,
    settings), its metrics, the paper's figures for that row, the headline figure (RMS contour
    error: ours, the paper's) and the ratios to PD (ours and the paper's), the code version
    and a timestamp."""
    version = version or code_version()
    stamp = _now()
    records = []
    for res in results:
        spec = res["spec"]
        pub = published_for(spec["case"], spec["controller"]) if spec["kind"] == NOMINAL else {}
        records.append(
            {
                "kind": spec["kind"],
                "case": spec["case"],
                "controller": spec["controller"],
                "plant": res["plant"],
                "variant": spec["variant"],
                "seed": spec["seed"],
                "settings": spec["settings"],
                "metrics": res["metrics"],
                "published": {
                    m: {
                        "value": p.value,
                        "kind": p.kind,
                        "source": p.source,
                        "table": p.table,
                        **({"note": p.note} if p.note else {}),
                    }
                    for m, p in pub.items()
                },
                "figure": {
                    "metric": _headline(spec["kind"]),
                    "ours": res["metrics"].get(_headline(spec["kind"])),
                    "paper": pub[HEADLINE].value if HEADLINE in pub else None,
                },
                "ratio_to_pd": None,
                "paper_ratio_to_pd": None,
                "error": res.get("error"),
                "code_version": version,
                "suite": settings.get("suite"),
                "timestamp": stamp,
                "wall_s": round(float(res.get("wall_s", 0.0)), 3),
            }
        )
    _ratios(records)
    return records


def _headline(kind: str) -> str:
    if kind == CIRCULAR:  # the circular deviation G of the worse direction
        return circular.HEADLINE
    return "mean_rms_contour_error_um" if kind == ROBUSTNESS else HEADLINE


def _ratios(records: list[dict]) -> None:
    pd = {
        (r["kind"], r["case"], r["variant"], r["seed"]): r
        for r in records
        if r["controller"] == "pd" and r["kind"] != ILC
    }
    for r in records:
        ref = pd.get((r["kind"], r["case"], r["variant"], r["seed"]))
        if ref is None:
            continue
        ours, base = r["figure"]["ours"], ref["figure"]["ours"]
        if ours is not None and base:
            r["ratio_to_pd"] = ours / base
        paper, paper_base = r["figure"]["paper"], ref["figure"]["paper"]
        if paper is not None and paper_base:
            r["paper_ratio_to_pd"] = paper / paper_base


# --- formatting ---------------------------------------------------------------------------


def _fmt(v, digits: int = 3) -> str:
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    from agents.compare import significant

    return significant(float(v), digits)


def _status(r: dict) -> str:
    m = r["metrics"]
    if r["kind"] == NOMINAL:
        if m.get("completed"):
            return "ok"
        return f"incomplete: {m.get('incomplete_reason') or m.get('termination_reason')}"
    if r["kind"] == ILC:
        return "diverged" if m.get("diverged") else "ok"
    return f"{m.get('failure_rate', 0):.0%} failed"


# table order of the controller names (a variant follows its base: ccc, ccc:wi=0)
ORDER = (
    "pd", "pid", "ccc", "adaptive-ccc", "jee-ccc", "ismc", "rfnn", "fnn",
    "ilc-pd", "ilc-contour", "vilcfd", "residual",
)  # fmt: skip


def _row_key(r: dict) -> tuple:
    name = r["controller"].split(":")[0]
    return (ORDER.index(name) if name in ORDER else len(ORDER), name, r["controller"])


def _by(records, kind):
    groups: dict = {}
    for r in records:
        if r["kind"] == kind and not r.get("error"):
            groups.setdefault((r["case"], r["variant"], r["seed"]), []).append(r)
    from contour_env.cases import all_case_names

    cases = all_case_names()

    def case_key(k):  # the named cases' order, then any other
        return (cases.index(k[0]) if k[0] in cases else len(cases), k[0])

    return {k: sorted(groups[k], key=_row_key) for k in sorted(groups, key=case_key)}


def nominal_tables(records: list[dict]) -> list[dict]:
    """Per case: {title, header, rows (text cells), reading, figure}."""
    tables = []
    for (case, variant, seed), rows in _by(records, NOMINAL).items():
        metrics = ["max_contour_error_um", "rms_contour_error_um"]
        extra = {m for r in rows for m in r["published"]}
        if any("rms_orientation_error_arcsec" in r["metrics"] for r in rows):
            extra |= {"max_orientation_error_arcsec", "rms_orientation_error_arcsec"}
        metrics += [m for m in COLUMNS if m in extra and m not in metrics]
        header = ["controller"]
        for m in metrics:
            header += [f"{COLUMNS[m]} (ours)", "paper"]
            if m == HEADLINE:
                header += ["RMS/PD (ours)", "RMS/PD (paper)"]
        header += ["status"]
        body = []
        for r in rows:
            cells = [_controller_label(r)]
            for m in metrics:
                scale = SCALE.get(m, 1.0)
                v = _value(r["metrics"], m)
                cells.append(_fmt(None if v is None else v * scale))
                p = r["published"].get(m)
                if p is None:
                    cells.append("—")
                else:
                    txt = _fmt(p["value"] * scale)
                    cells.append(f"≤ {txt} (goal)" if p["kind"] == "bound" else txt)
                if m == HEADLINE:
                    cells += [_fmt(r["ratio_to_pd"]), _fmt(r["paper_ratio_to_pd"])]
            cells.append(_status(r))
            body.append(cells)
        plant = rows[0]["plant"]
        sources = sorted(
            {f"{p['source']} {p['table']}" for r in rows for p in r["published"].values()}
        )
        tables.append(
            {
                "title": f"{case} (plant {plant}, {variant}, seed {seed})",
                "case": case,
                "sources": sources,
                "header": header,
                "rows": body,
                "reading": read_nominal(case, rows),
                "figure": f"contour_{case}.png",
            }
        )
    return tables


def _controller_label(r: dict) -> str:
    """The controller column: the spec, and on the five-axis plant ``pd`` marked as the
    paper's gains (Chen 2022 Table 2; the tuned baseline there is ``pid``)."""
    if r["controller"] == "pd" and r.get("plant") == "five-axis":
        return "pd (the paper's gains)"
    return r["controller"]


def _order(rows, key) -> list[str]:
    vals = [(key(r), r["controller"]) for r in rows if key(r) is not None]
    return [c for _, c in sorted(vals)]


def read_nominal(case: str, rows: list[dict]) -> str:
    """A paragraph on one case's table, from its numbers."""
    ok = [r for r in rows if r["metrics"].get("completed") and r["figure"]["ours"] is not None]
    bad = [r for r in rows if r not in ok]
    parts = []
    if ok:
        best = min(ok, key=lambda r: r["figure"]["ours"])
        worst = max(ok, key=lambda r: r["figure"]["ours"])
        text = (
            f"On {case}, {best['controller']} has the lowest RMS contour error "
            f"({_fmt(best['figure']['ours'])} µm"
        )
        if best["ratio_to_pd"] is not None and best["controller"] != "pd":
            text += f", {_fmt(best['ratio_to_pd'])}× PD's"
        text += ")"
        if worst is not best:
            text += f" and {worst['controller']} the highest ({_fmt(worst['figure']['ours'])} µm)"
        parts.append(text + " among the runs that followed the program.")
    # the paper comparison takes every row with both figures (an incomplete run is flagged)
    both = [r for r in rows if r["figure"]["ours"] is not None and r["figure"]["paper"] is not None]
    if len(both) >= 2:
        ours = _order(both, lambda r: r["figure"]["ours"])
        paper = _order(both, lambda r: r["figure"]["paper"])
        if ours == paper:
            parts.append(f"The paper's ordering by RMS ({' < '.join(paper)}) holds in ours.")
        else:
            parts.append(
                f"The paper's ordering by RMS ({' < '.join(paper)}) does not hold: ours is "
                f"{' < '.join(ours)}."
            )
        pairs = [
            (r["controller"], r["ratio_to_pd"], r["paper_ratio_to_pd"])
            for r in both
            if r["controller"] != "pd" and r["ratio_to_pd"] and r["paper_ratio_to_pd"]
        ]
        if pairs:
            lower = sum(o < p for _, o, p in pairs)
            parts.append(
                "Against PD, "
                + ", ".join(f"{c} keeps {_fmt(o)}× (paper {_fmt(p)}×)" for c, o, p in pairs)
                + (
                    "; our ratios are all lower than the paper's."
                    if lower == len(pairs)
                    else "; our ratios are all higher than the paper's."
                    if lower == 0
                    else f"; {lower} of {len(pairs)} of our ratios are lower than the paper's."
                )
            )
        absolute = [r["figure"]["ours"] / r["figure"]["paper"] for r in both]
        parts.append(
            f"Our RMS figures are {_fmt(min(absolute))}–{_fmt(max(absolute))}× the paper's."
        )
    for r in rows:
        for m, p in r["published"].items():
            if p["kind"] != "bound":
                continue
            v = _value(r["metrics"], m)
            met = v is not None and v <= p["value"]
            parts.append(
                f"{p['source']}'s design goal for {r['controller']}, {COLUMNS.get(m, m)} ≤ "
                f"{_fmt(p['value'])}, is {'met' if met else 'missed'} (ours {_fmt(v)})."
            )
    for r in bad:
        parts.append(f"{r['controller']} did not follow the program ({_status(r)}).")
    return " ".join(parts)


def robustness_tables(records: list[dict]) -> list[dict]:
    nominal = {
        (r["case"], r["controller"]): r for r in records if r["kind"] == NOMINAL and r["seed"] == 0
    }
    tables = []
    for (case, _variant, seed), rows in _by(records, ROBUSTNESS).items():
        header = [
            "controller",
            "nominal RMS ε µm",
            "mean RMS ε µm",
            "CVaR10 RMS ε µm",
            "worst max ε µm",
            "failures",
            "mean RMS/PD",
        ]
        body = []
        for r in rows:
            m = r["metrics"]
            nom = nominal.get((case, r["controller"]))
            body.append(
                [
                    r["controller"],
                    _fmt(nom["figure"]["ours"]) if nom else "—",
                    _fmt(m["mean_rms_contour_error_um"]),
                    _fmt(m["cvar10_rms_contour_error_um"]),
                    _fmt(m["worst_max_contour_error_um"]),
                    f"{m['failure_rate']:.0%}",
                    _fmt(r["ratio_to_pd"]),
                ]
            )
        tables.append(
            {
                "title": f"{case}: {rows[0]['metrics']['episodes']} plant variations, "
                f"±{rows[0]['metrics']['randomize'] * 100:g} % (seed {seed})",
                "case": case,
                "sources": [],
                "header": header,
                "rows": body,
                "reading": read_robustness(case, rows, nominal),
                "figure": f"robustness_{case}.png",
            }
        )
    return tables


def read_robustness(case: str, rows: list[dict], nominal: dict) -> str:
    m = {r["controller"]: r["metrics"] for r in rows}
    best = min(m, key=lambda c: m[c]["mean_rms_contour_error_um"])
    spread = {
        c: m[c]["cvar10_rms_contour_error_um"] / max(m[c]["mean_rms_contour_error_um"], 1e-12)
        for c in m
    }
    widest = max(spread, key=spread.get)
    parts = [
        f"Over {m[best]['episodes']} variations of the plant (±{m[best]['randomize'] * 100:g} % "
        f"on every randomised parameter), {best} keeps the lowest mean RMS contour error on "
        f"{case} ({_fmt(m[best]['mean_rms_contour_error_um'])} µm).",
        f"The worst 10 % of variations cost {widest} the most: its CVaR10 is "
        f"{_fmt(spread[widest])}× its mean.",
    ]
    shifts = []
    for c in m:
        nom = nominal.get((case, c))
        if nom and nom["figure"]["ours"]:
            shifts.append(f"{c} {_fmt(m[c]['mean_rms_contour_error_um'] / nom['figure']['ours'])}×")
    if shifts:
        parts.append("Mean over variations against the nominal plant: " + ", ".join(shifts) + ".")
    failed = [c for c in m if m[c]["failure_rate"] > 0]
    parts.append(
        "No variation was stopped by the crash guard."
        if not failed
        else "Stopped by the crash guard: "
        + ", ".join(f"{c} in {m[c]['failure_rate']:.0%} of variations" for c in failed)
        + "."
    )
    return " ".join(parts)


def ilc_tables(records: list[dict]) -> list[dict]:
    tables = []
    for (case, variant, seed), rows in _by(records, ILC).items():
        n = rows[0]["metrics"]["iterations"]
        header = [
            "law",
            "trial 1 max ε µm",
            "trial 1 RMS ε µm",
            f"trial {n} max ε µm",
            f"trial {n} RMS ε µm",
            f"RMS trial {n}/trial 1",
            "status",
        ]
        body = []
        for r in rows:
            m = r["metrics"]
            first, last = m["first_rms_contour_error_um"], m["rms_contour_error_um"]
            body.append(
                [
                    r["controller"],
                    _fmt(m["first_max_contour_error_um"]),
                    _fmt(first),
                    _fmt(m["max_contour_error_um"]),
                    _fmt(last),
                    _fmt(last / first if first and last is not None else None),
                    _status(r),
                ]
            )
        extra, reading_rel = _relative_rows(case, rows)
        tables.append(
            {
                "title": f"{case}, {variant} ({n} trials, seed {seed})",
                "case": case,
                "sources": sorted({f"{x.source} {x.table}" for x in RELATIVE if x.case == case})
                if extra
                else [],
                "header": header,
                "rows": body,
                "relative": extra,
                "reading": read_ilc(case, variant, rows) + reading_rel,
                "figure": f"ilc_{case}_{variant}.png",
            }
        )
    return tables


def _relative_rows(case: str, rows: list[dict]) -> tuple[list[list[str]], str]:
    """Published relative figures (Simba 2018's −37 %) against ours: rows and a sentence."""
    by = {r["controller"]: r["metrics"] for r in rows}
    out, text = [], ""
    for rel in RELATIVE:
        if rel.case != case or rel.controller not in by:
            continue
        for other in rel.against:
            if other not in by:
                continue
            a, b = by[rel.controller].get(rel.metric), by[other].get(rel.metric)
            ratio = a / b if a is not None and b else None
            out.append(
                [
                    f"{rel.controller} / {other}, {COLUMNS.get(rel.metric, rel.metric)}",
                    _fmt(ratio),
                    f"{_fmt(rel.value)} ({rel.source}, {rel.table})",
                    ""
                    if ratio is None
                    else f"{(ratio - 1) * 100:+.0f} % vs {(rel.value - 1) * 100:+.0f} %",
                ]
            )
            if ratio is not None:
                verdict = "reproduced or exceeded" if ratio <= rel.value else "not reproduced"
                text += (
                    f" {rel.source}'s {(rel.value - 1) * 100:+.0f} % ({rel.note}) against "
                    f"{other}: ours {(ratio - 1) * 100:+.0f} %, {verdict}."
                )
    return out, text


def read_ilc(case: str, variant: str, rows: list[dict]) -> str:
    m = {r["controller"]: r["metrics"] for r in rows}
    n = next(iter(m.values()))["iterations"]
    best = min(
        (c for c in m if m[c]["rms_contour_error_um"] is not None),
        key=lambda c: m[c]["rms_contour_error_um"],
        default=None,
    )
    parts = []
    if best is not None:
        parts.append(
            f"On {case} ({variant}), after {n} trials {best} has the lowest RMS contour error "
            f"({_fmt(m[best]['rms_contour_error_um'])} µm, max "
            f"{_fmt(m[best]['max_contour_error_um'])} µm)."
        )
    falls = []
    for c, x in m.items():
        f, last = x["first_rms_contour_error_um"], x["rms_contour_error_um"]
        if f and last is not None:
            falls.append(f"{c} {_fmt(last / f)}×")
    if falls:
        parts.append("RMS of the last trial against the first: " + ", ".join(falls) + ".")
    div = [c for c in m if m[c]["diverged"]]
    if div:
        parts.append(
            "Flagged as diverged (a failed trial or a last trial worse than the first): "
            f"{', '.join(div)}."
        )
    return " ".join(parts)


def design_tables(records: list[dict]) -> list[dict]:
    """One table of the design runs: default gains and loop margins per plant × controller."""
    from .design import margins_text

    rows = [r for r in records if r["kind"] == DESIGN and not r.get("error")]
    if not rows:
        return []
    body, below = [], []
    for r in rows:
        m = r["metrics"]
        cells = [margins_text(m["margins"]), margins_text(m["structural_mode_margins"])]
        body.append([r["case"], r["controller"], m["gains"], *(c.replace("**", "") for c in cells)])
        below += [
            f"{r['controller']} on {r['case']} ({what})"
            for what, rep in (("realistic", m["margins"]), ("mode", m["structural_mode_margins"]))
            if rep is not None and not rep["meets_requirement"]
        ]
    reading = (
        f"Every one of the {len(rows)} designs meets the margin requirement on the realistic "
        "plant over the mass corners and with the structural mode."
        if not below
        else "Below the margin requirement: " + ", ".join(below) + "."
    )
    return [
        {
            "title": "default gains and loop margins (realistic plant, ±20 % mass corners)",
            "case": "",
            "sources": [],
            "header": ["plant", "controller", "default gains", "margins", "margins, mode"],
            "rows": body,
            "reading": reading,
            "figure": None,
        }
    ]


def residual_tables(records: list[dict]) -> list[dict]:
    """Per shipped agent: agent against base on each test contour."""
    groups: dict = {}
    for r in records:
        if r["kind"] == RESIDUAL_RUN and not r.get("error"):
            groups.setdefault(r["variant"], []).append(r)
    tables = []
    for model, rows in groups.items():
        body = []
        for r in rows:
            m = r["metrics"]
            body.append(
                [
                    r["case"],
                    _fmt(m["base_rms_contour_error_um"]),
                    _fmt(m["agent_rms_contour_error_um"]),
                    _fmt(m["rms_ratio"]),
                    _fmt(m["base_max_contour_error_um"]),
                    _fmt(m["agent_max_contour_error_um"]),
                    ", ".join("idle" if e is None else _fmt(e) for e in m["effort_ratio"]),
                    "ok" if m["agent_completed"] else "stopped by the crash guard",
                ]
            )
        better = [r["case"] for r in rows if r["metrics"]["rms_ratio"] < 1.0]
        m0 = rows[0]["metrics"]
        tables.append(
            {
                "title": f"residual agent {model} (plant {m0['plant']}, base {m0['base']})",
                "case": "",
                "sources": [],
                "header": [
                    "contour",
                    "base RMS ε µm",
                    "agent RMS ε µm",
                    "RMS agent/base",
                    "base max ε µm",
                    "agent max ε µm",
                    "effort agent/base",
                    "status",
                ],  # fmt: skip
                "rows": body,
                "reading": f"The agent lowers the RMS contour error of its base {m0['base']} on "
                f"{len(better)} of {len(rows)} contours"
                + (f" ({', '.join(better)})." if better else "."),
                "figure": None,
            }
        )
    return tables


# --- figures ------------------------------------------------------------------------------


def write_figures(records: list[dict], results: list[dict], out: Path) -> list[Path]:
    """contour error vs time per case, robustness bands per case, ILC learning curves, the
    circular test's polar plot per plant (:func:`.circular.write_figures`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from contour_env.io import atomic_save_figure

    written = []
    traces: dict = {}
    for r, res in zip(records, results, strict=True):
        if r.get("error") or r["kind"] not in (NOMINAL, ROBUSTNESS, ILC):
            continue  # design and residual runs have no time trace
        traces.setdefault((r["kind"], r["case"], r["variant"]), []).append((r, res["trace"]))
    for (kind, case, variant), items in traces.items():
        fig, ax = plt.subplots(figsize=(8, 4.2))
        if kind == NOMINAL:
            name = f"contour_{case}.png"
            for r, tr in items:
                t, y = np.asarray(tr["time_s"]), np.abs(np.asarray(tr["contour_error_um"], float))
                ls = "--" if ":" in r["controller"] else "-"
                ax.plot(t, np.maximum(y, 1e-3), lw=0.9, ls=ls, label=r["controller"])
            ax.set_yscale("log")
            ax.set_xlabel("time s")
            ax.set_ylabel("contour error µm")
            ax.set_title(f"{case}: contour error vs time (nominal plant)")
        elif kind == ROBUSTNESS:
            name = f"robustness_{case}.png"
            for i, (r, tr) in enumerate(items):
                color = f"C{i}"
                t = np.asarray(tr["time_s"])
                lo, mid, hi = (
                    np.asarray([np.nan if v is None else v for v in tr[k]], float)
                    for k in ("p10_um", "p50_um", "p90_um")
                )
                ax.fill_between(t, lo, hi, color=color, alpha=0.25, lw=0)
                ax.plot(t, mid, color=color, lw=1.0, label=f"{r['controller']} (median, 10–90 %)")
            ax.set_yscale("log")
            ax.set_xlabel("time s")
            ax.set_ylabel("contour error µm")
            ax.set_title(f"{case}: contour error over {variant}")
        else:
            name = f"ilc_{case}_{variant}.png"
            for r, _ in items:
                rms = [
                    np.nan if v is None else v
                    for v in r["metrics"]["rms_contour_error_um_per_iteration"]
                ]
                ax.plot(np.arange(1, len(rms) + 1), rms, marker="o", label=r["controller"])
            ax.set_yscale("log")
            ax.set_xlabel("trial")
            ax.set_ylabel("RMS contour error µm")
            ax.set_title(f"{case}, {variant}: learning curves")
        if kind != ILC:
            # from 10⁻⁴ of the largest error up: the start from rest is not worth five decades
            top = ax.get_ylim()[1]
            ax.set_ylim(bottom=max(1e-3, 1e-4 * top))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        written.append(atomic_save_figure(fig, out / name, dpi=100))
        plt.close(fig)
    written += circular.write_figures(records, results, out)
    return written


# --- documents ----------------------------------------------------------------------------


def _sections(records):
    return [
        ("Nominal plant: every case × controller", nominal_tables(records)),
        ("Robustness over plant variations", robustness_tables(records)),
        ("Repeated-batch ILC", ilc_tables(records)),
        ("Controller design", design_tables(records)),
        ("Residual agents against their bases", residual_tables(records)),
        ("Circular test (ISO 230-4)", circular.tables(records)),
    ]


def _md_table(header, rows) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in rows]
    return out


def _intro(meta: dict) -> list[str]:
    v = meta["code_version"]
    return [
        f"Suite `{meta['suite']}`: {meta['n_runs']} runs ({meta['executor']}), "
        f"{meta['wall_s']:.1f} s; {v['package']} {v['version']}, "
        f"commit {v['commit'] or 'unknown'}; "
        f"{meta['timestamp']}.",
        "",
        "Ours: this package's simulation, scored by `contour_env.metrics.score` (true contour "
        "error). Paper: the seed papers' published figures "
        "(`contour_env/app/benchmark/published.py`), from real machines or their own "
        "simulations; what should carry over is the ordering and a similar ratio to PD, not "
        "the absolute figures.",
    ]


def _errors(records) -> list[str]:
    return [
        f"{r['kind']} {r['case']} {r['controller']} ({r['variant']}, seed {r['seed']}): "
        f"{r['error']}"
        for r in records
        if r.get("error")
    ]


def render_markdown(records: list[dict], meta: dict) -> str:
    lines = ["# contour_env benchmark report", "", *_intro(meta), ""]
    if _errors(records):
        lines += ["## Failed runs", ""] + [f"- {e}" for e in _errors(records)] + [""]
    for title, tables in _sections(records):
        if not tables:
            continue
        lines += [f"## {title}", ""]
        for t in tables:
            lines += [f"### {t['title']}", ""]
            if t.get("note"):
                lines += [t["note"], ""]
            if t["sources"]:
                lines += ["Paper: " + "; ".join(t["sources"]) + ".", ""]
            lines += _md_table(t["header"], t["rows"]) + [""]
            if t.get("relative"):
                lines += _md_table(
                    ["published relative figure", "ours", "paper", "change"], t["relative"]
                )
                lines += [""]
            lines += [t["reading"], ""]
            if t["figure"]:
                lines += [f"![{t['title']}]({t['figure']})", ""]
    return "\n".join(lines) + "\n"


_CSS = """
body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:.5em 0;font-size:.9em}
th,td{border:1px solid #bbb;padding:.25em .6em;text-align:right}
th{background:#eef}td:first-child,th:first-child{text-align:left}
td.paper{background:#f6f6f6;color:#555}img{max-width:100%}p.reading{max-width:60em}
"""


def _html_table(header, rows) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = []
    for row in rows:
        cells = []
        for h, c in zip(header, row, strict=True):
            cls = ' class="paper"' if h.startswith("paper") or "(paper)" in h else ""
            cells.append(f"<td{cls}>{html.escape(c)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def render_html(records: list[dict], meta: dict, out: Path) -> str:
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        "<title>contour_env benchmark report</title>",
        f"<style>{_CSS}</style></head><body>",
        "<h1>contour_env benchmark report</h1>",
    ]
    parts += [f"<p>{html.escape(p)}</p>" for p in _intro(meta) if p]
    if _errors(records):
        parts.append("<h2>Failed runs</h2><ul>")
        parts += [f"<li>{html.escape(e)}</li>" for e in _errors(records)]
        parts.append("</ul>")
    for title, tables in _sections(records):
        if not tables:
            continue
        parts.append(f"<h2>{html.escape(title)}</h2>")
        for t in tables:
            parts.append(f"<h3>{html.escape(t['title'])}</h3>")
            if t.get("note"):
                parts.append(f"<p>{html.escape(t['note'])}</p>")
            if t["sources"]:
                parts.append(f"<p>Paper: {html.escape('; '.join(t['sources']))}.</p>")
            parts.append(_html_table(t["header"], t["rows"]))
            if t.get("relative"):
                parts.append(
                    _html_table(
                        ["published relative figure", "ours", "paper", "change"], t["relative"]
                    )
                )
            parts.append(f"<p class='reading'>{html.escape(t['reading'])}</p>")
            png = out / t["figure"] if t["figure"] else None
            if png is not None and png.exists():
                data = base64.b64encode(png.read_bytes()).decode("ascii")
                parts.append(
                    f"<p><a href='{html.escape(t['figure'])}'><img alt='{html.escape(t['title'])}' "
                    f"src='data:image/png;base64,{data}'></a></p>"
                )
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def write_report(out, results: list[dict], meta: dict, figures: bool = True) -> dict:
    """Write results.json, the figures, report.md and report.html into ``out`` (atomically,
    file by file); returns {"records", "files"}."""
    from contour_env.io import atomic_write_json, atomic_write_text

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    meta = {**meta, "code_version": meta.get("code_version") or code_version()}
    records = build_records(results, meta, meta["code_version"])
    files = []
    if figures:
        files += write_figures(records, results, out)
    files.append(atomic_write_json(out / "results.json", {"meta": meta, "records": records}))
    files.append(atomic_write_text(out / "report.md", render_markdown(records, meta)))
    files.append(atomic_write_text(out / "report.html", render_html(records, meta, out)))
    return {"records": records, "files": files}
