"""The generated tables of the README and the docs pages from a benchmark report: the ``readme``
suite, the renderers (:mod:`contour_env.app.benchmark.readme_tables`) and
``scripts/readme_figures.py --report``.

Synthetic records for the layout (every table, no run), a few real runs for the kinds the
README adds (``design``) and one real table (Lee 2012, one circle)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from contour_env.app.benchmark import readme_tables as T
from contour_env.app.benchmark import suite as S
from contour_env.app.benchmark.report import build_records, write_report
from contour_env.app.benchmark.runs import execute

ROOT = Path(__file__).resolve().parents[3]
VERSION = {"package": "contour_env", "version": "0.0", "commit": "0123456789abcdef-dirty"}


# --------------------------------------------------------------------- the readme suite


def test_the_readme_suite_has_every_run_of_every_table_and_nothing_else():
    suite = S.get_suite("readme")
    assert suite.name == "readme"
    keys = [r.key() for r in suite.runs]
    assert len(keys) == len(set(keys))
    needed = {r.key() for name in S.README_TABLES for r in S.README_TABLES[name]()}
    assert set(keys) == needed
    by_table = {name: S.README_TABLES[name]() for name in S.README_TABLES}
    # Lee 2012: the three circles × pd, ccc:wi=0, ccc, adaptive-ccc (the paper suite's rows)
    assert [(r.case, r.controller) for r in by_table["lee2012_table"]] == [
        (c, k)
        for c in ("hsm2-circle-I", "hsm2-circle-II", "hsm2-circle-III")
        for k in ("pd", "ccc:wi=0", "ccc", "adaptive-ccc")
    ]
    paper = {r.key() for r in S.get_suite("paper").runs}
    assert {r.key() for r in by_table["lee2012_table"]} <= paper
    # corner-blend: pd, ccc, adaptive-ccc over seeds 0–4
    assert sorted((r.controller, r.seed) for r in by_table["corner_blend_table"]) == sorted(
        (c, s) for c in ("pd", "ccc", "adaptive-ccc") for s in range(5)
    )
    # the ILC benchmark: scripts/ilc_benchmark.py's settings (10 trials, seed 0, 50 nm noise)
    ilc = by_table["ilc_table"]
    assert [(r.case, r.variant, r.controller) for r in ilc] == [
        (c, v, k)
        for c in ("sharp-corner", "hsm2-circle-II")
        for v in ("repeatable", "random")
        for k in ("ilc-pd", "ilc-contour", "vilcfd")
    ]
    for r in ilc:
        assert r.kind == S.ILC and r.seed == 0 and r.settings["iterations"] == 10
        assert r.settings.get("noise_m") == (5e-8 if r.variant == "random" else None)
    # the controller table: every plant × the controllers that configure for it
    design = by_table["controller_table"]
    assert all(r.kind == S.DESIGN for r in design)
    assert ("jee-triaxial", "jee-ccc") in {(r.case, r.controller) for r in design}
    assert ("hsm2", "jee-ccc") not in {(r.case, r.controller) for r in design}
    # the residual agents: each shipped agent on its cases, the polygon and the spline
    residual = by_table["residual_table"]
    assert all(r.kind == S.RESIDUAL_RUN for r in residual)
    for model in {r.variant for r in residual}:
        targets = [r.case for r in residual if r.variant == model]
        assert targets[-2:] == ["polygon", "spline"] and len(targets) >= 3


def test_a_readme_subset_suite_and_its_errors():
    sub = S.get_suite("readme:ilc_table,lee2012_table")
    assert sub.name == "readme:ilc_table,lee2012_table"
    assert {r.kind for r in sub.runs} == {S.ILC, S.NOMINAL} and len(sub.runs) == 24
    with pytest.raises(ValueError, match="--suite: readme:TABLE"):
        S.get_suite("readme:nope")
    with pytest.raises(ValueError, match="--suite: unknown suite"):
        S.get_suite("readmes")


# --------------------------------------------------------------------- synthetic records


def _fake_metrics(spec: S.RunSpec, i: int) -> tuple[str, dict]:
    x = 1.0 + i / 100
    if spec.kind == S.NOMINAL:
        m = {
            "max_contour_error_um": 10 * x,
            "rms_contour_error_um": x,
            "rms_effort": [20 * x, 1000 * x],
            "completed": True,
        }
        if spec.case.startswith("hsm2"):
            m.update(rms_x_torque_Nm=0.088 * x, rms_y_force_N=1000 * x)
        return ("hsm2" if spec.case.startswith("hsm2") else "friction-table"), m
    if spec.kind == S.ILC:
        return "friction-table", {
            "iterations": 10,
            "first_max_contour_error_um": 98.6 * x,
            "first_rms_contour_error_um": 69.7 * x,
            "max_contour_error_um": 2.5 * x,
            "rms_contour_error_um": 0.4 * x,
            "encoder_resolution_um": 2.0 if spec.case.startswith("hsm2") else None,
            "diverged": False,
            "rms_contour_error_um_per_iteration": [69.7 * x, 0.4 * x],
        }
    if spec.kind == S.DESIGN:
        rep = {
            "stable": True,
            "min_gain_margin_db": 9.6,
            "min_phase_margin_deg": 49.0,
            "meets_requirement": True,
        }
        return spec.case, {"gains": f"gains {i}", "margins": rep, "structural_mode_margins": None}
    return "friction-table", {
        "model": spec.variant,
        "plant": spec.variant,
        "base": "ccc",
        "target": spec.case,
        "base_rms_contour_error_um": 2 * x,
        "agent_rms_contour_error_um": x,
        "base_max_contour_error_um": 20 * x,
        "agent_max_contour_error_um": 10 * x,
        "rms_ratio": 0.5,
        "effort_ratio": [1.0, None],
        "agent_completed": True,
    }


def _fake_results(specs) -> list[dict]:
    out = []
    for i, spec in enumerate(specs):
        plant, metrics = _fake_metrics(spec, i)
        trace = {"time_s": [0.0, 1.0], "contour_error_um": [1.0, 2.0]}
        trace = trace if spec.kind == S.NOMINAL else {}
        out.append({"spec": spec.to_dict(), "plant": plant, "metrics": metrics, "trace": trace})
    return out


@pytest.fixture(scope="module")
def fake_report(tmp_path_factory):
    """A report folder of the whole readme suite with synthetic metrics (no run)."""
    out = tmp_path_factory.mktemp("readme_report")
    specs = S.get_suite("readme").runs
    meta = {
        "suite": "readme",
        "description": "test",
        "n_runs": len(specs),
        "executor": "serial",
        "workers": 1,
        "ray": None,
        "wall_s": 0.0,
        "timestamp": "2031-04-05T06:07:08+00:00",
        "code_version": VERSION,
    }
    write_report(out, _fake_results(specs), meta, figures=True)
    return out


def test_the_report_of_the_readme_suite_shows_the_new_kinds_and_draws_no_figure_for_them(
    fake_report,
):
    md = (fake_report / "report.md").read_text()
    assert "## Controller design" in md and "## Residual agents against their bases" in md
    assert "gains 0" in md
    assert (fake_report / "contour_corner-blend.png").exists()
    assert not list(fake_report.glob("*design*")) and not list(fake_report.glob("*hsm2.png"))
    data = json.loads((fake_report / "results.json").read_text())
    kinds = {r["kind"] for r in data["records"]}
    assert kinds == {S.NOMINAL, S.ILC, S.DESIGN, S.RESIDUAL_RUN}


def test_every_table_renders_from_the_records_in_the_readme_layout(fake_report, readme_figures):
    records = json.loads((fake_report / "results.json").read_text())["records"]
    readme = {
        name: readme_figures.sections(path.read_text(encoding="utf-8"))[name]
        for name, path in readme_figures.locate().items()
    }
    for name in S.README_TABLES:
        text = T.render(name, records)
        lines = text.splitlines()
        old = readme[name].splitlines()
        assert lines[:2] == old[:2], name  # the header of today's table in the docs
        assert len(lines) - 2 == len(S.README_TABLES[name]()) or name == "corner_blend_table"
    lee = T.render("lee2012_table", records).splitlines()
    # our figures, then Lee's (published.py) beside them; our ccc has no published row
    assert re.match(
        r"\| hsm2-circle-I \| `pd` \| [\d.]+ / [\d.]+ \| 1\.000 \| [\d.]+, \d+ \|", lee[2]
    )
    assert lee[2].endswith("| 119 / 43 | 1.000 | 3.85, 287 |")
    assert lee[3].endswith("| 46 / 15 | 0.349 | 3.83, 293 |")
    assert lee[4].endswith("| — | — | — |")
    assert lee[-1].endswith("| 219 / 49 | 0.196 | 24.2, 1990 |")
    assert T.render("lee2012_table", records).count("24.0, 1980") == 1
    corner = T.render("corner_blend_table", records).splitlines()
    assert corner[0].startswith("| controller | max ε µm (mean of 5) |")
    assert len(corner) == 5 and corner[2].startswith("| `pd` | ")
    ilc = T.render("ilc_table", records).splitlines()
    assert ilc[0] == "| case | condition | law | trial 1 max / RMS | trial 10 max / RMS |"
    assert ilc[2].startswith("| sharp-corner | repeatable | ilc-pd | ")
    assert ilc[3].startswith("| | | ilc-contour | ")
    assert "≤2 (enc)" in ilc[-1]  # hsm2's encoder count
    design = T.render("controller_table", records).splitlines()
    assert design[2] == "| `hsm2` | `pd` | gains 0 | 9.6 dB / 49° | (no mode) |"
    residual = T.render("residual_table", records).splitlines()
    assert residual[2].startswith("| `")
    assert residual[2].endswith("| 0.500 | 1.000, (idle in base) |")


def test_a_missing_or_failed_run_is_an_error_naming_the_table(fake_report):
    records = json.loads((fake_report / "results.json").read_text())["records"]
    without = [r for r in records if not (r["kind"] == S.ILC and r["controller"] == "vilcfd")]
    with pytest.raises(ValueError, match="ilc_table: the report has no run ilc sharp-corner"):
        T.render("ilc_table", without)
    failed = [dict(r, error="RuntimeError: boom") if r["kind"] == S.DESIGN else r for r in records]
    with pytest.raises(ValueError, match="controller_table: the run design .* failed: .*boom"):
        T.render("controller_table", failed)
    with pytest.raises(ValueError, match="unknown README table"):
        T.render("nope", records)


def test_the_stamp_is_the_reports_date_and_short_commit():
    data = {"meta": {"timestamp": "2031-04-05T06:07:08+00:00", "code_version": VERSION}}
    assert T.report_stamp(data) == ("2031-04-05", "0123456-dirty")
    rec = {"timestamp": "2030-01-02T00:00:00+00:00", "code_version": {"commit": "abcdef0123"}}
    assert T.report_stamp({"records": [rec]}) == ("2030-01-02", "abcdef0")
    assert T.short_commit(None) == "unknown"


# ------------------------------------------------------------ scripts/readme_figures.py


def _copy_pages(mod, tmp_path) -> list[Path]:
    """Copies of the files that hold the generated tables (README.md and docs pages)."""
    copies = []
    for page in sorted(set(mod.locate().values())):
        copies.append(tmp_path / page.name)
        shutil.copy(page, copies[-1])
    return copies


def _joined(copies) -> str:
    return "\n".join(c.read_text(encoding="utf-8") for c in copies)


def test_readme_figures_renders_copies_of_the_pages_from_a_report(
    fake_report, tmp_path, readme_figures
):
    mod = readme_figures
    copies = _copy_pages(mod, tmp_path)
    files = [a for c in copies for a in ("--readme", str(c))]
    before = _joined(copies)
    args = ["--report", str(fake_report), *files]
    assert mod.main([*args, "--check"]) == 1  # synthetic figures: every table would change
    assert _joined(copies) == before
    assert mod.main([*args, "--only", "ilc_table,corner_blend_table"]) == 0
    new = _joined(copies)
    records = json.loads((fake_report / "results.json").read_text())["records"]
    assert mod.sections(new)["ilc_table"] == T.render("ilc_table", records) + "\n"
    stamps = mod.stamps(new)
    assert stamps["ilc_table"] == "(scripts/readme_figures.py; 2031-04-05, commit 0123456-dirty)"
    assert stamps["corner_blend_table"] == stamps["ilc_table"]
    for name in ("controller_table", "lee2012_table", "residual_table"):
        assert mod.sections(new)[name] == mod.sections(before)[name]
        assert stamps[name] == mod.stamps(before)[name]
    outside = re.sub(r"<!-- BEGIN.*?<!-- END generated: \w+ -->", "", before, flags=re.S)
    assert re.sub(r"<!-- BEGIN.*?<!-- END generated: \w+ -->", "", new, flags=re.S) == outside
    # a report without a table's runs, or no report at all, is an error; nothing written
    partial = tmp_path / "partial"
    partial.mkdir()
    data = json.loads((fake_report / "results.json").read_text())
    data["records"] = [r for r in data["records"] if r["kind"] != S.DESIGN]
    (partial / "results.json").write_text(json.dumps(data))
    with pytest.raises(SystemExit):
        mod.main(["--report", str(partial), *files, "--only", "controller_table"])
    with pytest.raises(SystemExit):
        mod.main(["--report", str(tmp_path / "none"), *files])
    assert _joined(copies) == new


def test_readme_figures_without_a_report_runs_the_readme_suite_of_the_named_tables(
    fake_report, tmp_path, monkeypatch, readme_figures
):
    mod = readme_figures
    copies = _copy_pages(mod, tmp_path)
    files = [a for c in copies for a in ("--readme", str(c))]
    calls = []

    def fake_run(out, tables=None, workers=1):
        calls.append((str(out), tables, workers))
        return mod.read_report(fake_report)

    monkeypatch.setattr(mod, "run_benchmark", fake_run)
    out = tmp_path / "rep"
    argv = [*files, "--only", "lee2012_table", "--out", str(out), "--workers", "2"]
    assert mod.main(argv) == 0
    assert calls == [(str(out), ["lee2012_table"], "2")]
    assert "2031-04-05, commit 0123456-dirty" in mod.stamps(_joined(copies))["lee2012_table"]


# --------------------------------------------------------------------- real runs


def test_a_real_design_run_gives_the_gains_and_margins_of_the_table():
    from contour_env.app.benchmark.design import margins_text

    spec = S.design("friction-table", "pd")
    res = execute(spec.to_dict())
    assert res.get("error") is None and res["plant"] == "friction-table"
    m = T.Records(build_records([res], {"suite": "test"}, VERSION)).metrics(spec)
    json.dumps(m)  # JSON-ready
    assert m["gains"].startswith("ω = 75 rad/s, ζ = 1 (P = ") and "N s/m" in m["gains"]
    assert m["margins"]["stable"] and m["margins"]["meets_requirement"]
    assert re.fullmatch(r"[\d.]+ dB / \d+°", margins_text(m["margins"]))
    assert m["structural_mode_margins"] is not None  # the friction table has a mode


def test_lee2012_table_from_real_runs_of_one_circle():
    from contour_env.app.benchmark.runner import run_all

    specs = [S.nominal("hsm2-circle-I", c) for c in S.PAPER_NOMINAL["hsm2-circle-I"]]
    records = build_records(run_all(specs), {"suite": "test"}, VERSION)
    lines = T.lee2012_table(records, ["hsm2-circle-I"]).splitlines()
    assert len(lines) == 6
    assert re.fullmatch(
        r"\| hsm2-circle-I \| `pd` \| [\d.]+ / [\d.]+ \| 1\.000 \| [\d.]+, \d+ "
        r"\| 119 / 43 \| 1\.000 \| 3\.85, 287 \|",
        lines[2],
    )
    assert [ln.split(" | ")[1] for ln in lines[2:]] == [
        "`pd`",
        "`ccc:wi=0`",
        "`ccc`",
        "`adaptive-ccc`",
    ]
