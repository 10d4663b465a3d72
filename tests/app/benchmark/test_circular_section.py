"""The benchmark's circular-test section (ISO 230-4): its runs in the suites, its records in
results.json, its table, reading and polar plot in the report.

One small real run (hsm2, pd and ccc, the section's circle: two short episodes per controller)
registered as a suite ``circ``, run once for the module through ``contour-env benchmark``."""

from __future__ import annotations

import json

import pytest

from contour_env.app import cli_benchmark
from contour_env.app.benchmark import circular as C
from contour_env.app.benchmark import suite as S
from contour_env.app.benchmark.report import render_markdown

RUNS = (S.circular("hsm2", "pd", seed=0), S.circular("hsm2", "ccc", seed=0))


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setitem(S.SUITES, "circ", lambda: S.Suite("circ", "test suite", RUNS))
    path = tmp_path_factory.mktemp("circ")
    try:
        assert cli_benchmark.main(["--suite", "circ", "--out", str(path)]) == 0
    finally:
        mp.undo()
    return path


@pytest.fixture(scope="module")
def records(out):
    return json.loads((out / "results.json").read_text())["records"]


def _by_controller(records):
    return {r["controller"]: r for r in records if r["kind"] == C.KIND}


def test_specs_carry_the_sections_circle():
    spec = RUNS[0]
    assert spec.kind == S.CIRCULAR == "circular" and spec.case == "hsm2"
    assert spec.settings == {"radius_m": C.RADIUS_M, "feed_m_s": C.FEED_M_S, "overshoot_deg": 180.0}
    assert spec.variant == "R50mm F0.2m/s"
    # the CLI's defaults, within what every plant of the section holds on the circle
    from contour_env.circular_test import DEFAULT_FEED_M_S, DEFAULT_RADIUS_M, circular_test_errors

    assert (C.RADIUS_M, C.FEED_M_S) == (DEFAULT_RADIUS_M, DEFAULT_FEED_M_S)
    for plant in C.plants():
        assert circular_test_errors(plant, C.RADIUS_M, C.FEED_M_S, C.OVERSHOOT_DEG) == []


def test_quick_and_full_suites_run_the_section_on_every_2_and_3_axis_plant():
    assert C.plants() == ["hsm2", "jee-triaxial", "linear-motor", "friction-table"]
    pairs = C.section_runs()
    assert ("jee-triaxial", "jee-ccc") in pairs and ("hsm2", "jee-ccc") not in pairs
    for plant in C.plants():
        assert {(plant, c) for c in ("pd", "ccc", "adaptive-ccc")} <= set(pairs)
    quick = {(r.case, r.controller) for r in S.quick_suite().runs if r.kind == S.CIRCULAR}
    assert quick == set(pairs) and ("hsm2", "pd") in quick and ("hsm2", "ccc") in quick
    assert not any(p.startswith("five-axis") for p, _ in quick)
    assert S.CIRCULAR not in {r.kind for r in S.paper_suite().runs}


def test_records_are_the_circular_tests_figures(records):
    assert [(r["kind"], r["case"], r["controller"]) for r in records] == [
        ("circular", "hsm2", "pd"),
        ("circular", "hsm2", "ccc"),
    ]
    by = _by_controller(records)
    for r in by.values():
        m = r["metrics"]
        assert r["plant"] == "hsm2" and r["error"] is None and r["seed"] == 0
        assert m["completed"] and m["radius_m"] == 0.05 and m["feed_m_s"] == 0.2
        for d in ("cw", "ccw"):
            assert m[d]["completed"]
            assert m[d]["radial_deviation_max_um"] >= m[d]["radial_deviation_min_um"]
            assert len(m[d]["reversal_spikes_um"]) == 4
        assert m["hysteresis_um"] >= 0
        gs = [m[d]["circular_deviation_um"] for d in ("cw", "ccw")]
        assert m["max_circular_deviation_um"] == max(gs) > 0
        assert r["figure"] == {
            "metric": "max_circular_deviation_um",
            "ours": max(gs),
            "paper": None,
        }
    pd, ccc = by["pd"], by["ccc"]
    # CCC keeps the tool on the circle: its G is smaller than PD's, in both directions
    for d in ("cw", "ccw"):
        assert (
            ccc["metrics"][d]["circular_deviation_um"] < pd["metrics"][d]["circular_deviation_um"]
        )
    assert pd["ratio_to_pd"] == 1.0
    assert ccc["ratio_to_pd"] == pytest.approx(
        ccc["metrics"]["max_circular_deviation_um"] / pd["metrics"]["max_circular_deviation_um"]
    )
    assert ccc["ratio_to_pd"] < 1.0


def test_table_rows_and_reading_come_from_the_records(records):
    from agents.compare import significant

    (table,) = C.tables(records)
    assert table["header"] == [
        "plant",
        "controller",
        "direction",
        "G µm",
        "F_max µm",
        "F_min µm",
        "H µm",
        "largest reversal spike µm",
    ]
    assert table["figure"] == "circular_hsm2.png" and table["title"].startswith("hsm2: R = 50 mm")
    by = _by_controller(records)
    assert [row[:3] for row in table["rows"]] == [
        ["hsm2", "pd", "CW"],
        ["hsm2", "pd", "CCW"],
        ["hsm2", "ccc", "CW"],
        ["hsm2", "ccc", "CCW"],
    ]
    for row in table["rows"]:
        m = by[row[1]]["metrics"]
        x = m[row[2].lower()]
        assert row[3:6] == [
            significant(x["circular_deviation_um"], 3),
            significant(x["radial_deviation_max_um"], 3),
            significant(x["radial_deviation_min_um"], 3),
        ]
        assert row[6] == (significant(m["hysteresis_um"], 3) if row[2] == "CW" else "")
        spike = max(x["reversal_spikes_um"], key=lambda s: abs(s["height_um"]))
        assert significant(abs(spike["height_um"]), 3) in row[7]
        assert row[7].startswith("+" if spike["height_um"] > 0 else "-")
        assert f"({spike['axis']} {spike['angle_deg']:g}°)" in row[7]
    g_pd, g_ccc = (by[c]["metrics"]["max_circular_deviation_um"] for c in ("pd", "ccc"))
    assert table["reading"].startswith(
        f"On hsm2, ccc has the smallest circular deviation G ({significant(g_ccc, 3)} µm in its "
        f"worse direction, {significant(g_ccc / g_pd, 3)}× pd's {significant(g_pd, 3)} µm)"
    )
    assert table["reading"].count(".") >= 1 and "did not complete" not in table["reading"]


def test_report_has_the_section_and_its_figure(out):
    md = (out / "report.md").read_text()
    page = (out / "report.html").read_text()
    assert "## Circular test (ISO 230-4)" in md
    assert "### hsm2: R = 50 mm, F = 0.2 m/s (12 m/min), overshoot 180° (seed 0)" in md
    assert "| plant | controller | direction | G µm | F_max µm | F_min µm | H µm |" in md
    assert "| hsm2 | ccc | CCW |" in md
    assert "](circular_hsm2.png)" in md
    assert "<h2>Circular test (ISO 230-4)</h2>" in page and "href='circular_hsm2.png'" in page
    png = out / "circular_hsm2.png"
    head = png.read_bytes()
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and len(head) > 20_000
    # atomic writes: nothing but the outputs in the folder
    assert sorted(p.name for p in out.iterdir()) == [
        "circular_hsm2.png",
        "report.html",
        "report.md",
        "results.json",
    ]


def _rec(ctrl, g, h, completed=True):
    row = {
        "completed": completed,
        "circular_deviation_um": g,
        "radial_deviation_max_um": g,
        "radial_deviation_min_um": 0.0,
        "reversal_spikes_um": [],
    }
    if not completed:
        row["incomplete_reason"] = "stopped"
    return {
        "kind": C.KIND,
        "case": "p",
        "plant": "p",
        "controller": ctrl,
        "variant": "R50mm F0.2m/s",
        "seed": 0,
        "metrics": {
            "radius_m": 0.05,
            "feed_m_s": 0.2,
            "overshoot_deg": 180.0,
            "completed": completed,
            "max_circular_deviation_um": g if completed else None,
            "hysteresis_um": h,
            "cw": row,
            "ccw": row,
        },
    }


def test_reading_follows_the_numbers_not_a_fixed_claim():
    rows = [_rec("pd", 10.0, 2.0), _rec("ccc", 40.0, 8.0), _rec("adaptive-ccc", 20.0, 1.0)]
    text = C.read("p", rows)
    # PD best: its ratio to the next best, and the largest named
    assert text.startswith(
        "On p, pd has the smallest circular deviation G (10.0 µm in its worse direction, "
        "0.500× adaptive-ccc's 20.0 µm) and ccc the largest (40.0 µm); the hysteresis H runs "
        "from 1.00 µm (adaptive-ccc) to 8.00 µm (ccc)."
    )
    rows = [_rec("pd", 10.0, 2.0), _rec("ccc", 5.0, 1.0), _rec("adaptive-ccc", 0, 1.0, False)]
    text = C.read("p", rows)
    assert "ccc has the smallest circular deviation G (5.00 µm" in text and "0.500× pd's" in text
    assert "adaptive-ccc did not complete the CW circle (stopped)." in text
    # the section renders from records alone (no figure needed)
    md = render_markdown(rows, {**_META, "n_runs": len(rows)})
    assert "## Circular test (ISO 230-4)" in md and "| p | adaptive-ccc | CW |" in md


_META = {
    "suite": "x",
    "executor": "serial",
    "wall_s": 0.0,
    "timestamp": "t",
    "code_version": {"package": "contour_env", "version": "0", "commit": None},
}
