"""contour-env benchmark: suites, records, report files, executors, flag errors.

Most tests run a tiny suite (a few fast runs registered as ``tiny``); the quick suite's
contents are checked without running it (its run is the slow test)."""

from __future__ import annotations

import json
import sys

import pytest

from contour_env.app import cli_benchmark
from contour_env.app.benchmark import suite as S
from contour_env.app.benchmark.published import PUBLISHED, RELATIVE, published_for
from contour_env.app.benchmark.runner import run_all

TINY = (
    S.nominal("hsm2-circle-I", "pd"),
    S.nominal("hsm2-circle-I", "adaptive-ccc"),
    S.nominal("hsm2-circle-I", "ccc:wi=0"),
    S.nominal("sharp-corner", "pd"),
    S.nominal("sharp-corner", "ccc"),
    S.robust("hsm2-circle-I", "pd", 0.2, 2, seed=3),
    S.robust("hsm2-circle-I", "ccc", 0.2, 2, seed=3),
    S.ilc("sharp-corner", "ilc-contour", "repeatable", 2),
    S.ilc("sharp-corner", "vilcfd", "repeatable", 2),
)


@pytest.fixture
def tiny(monkeypatch):
    monkeypatch.setitem(S.SUITES, "tiny", lambda: S.Suite("tiny", "test suite", TINY))
    return TINY


def _figures(path) -> list:
    """What must not depend on the executor: per record, what ran and its metrics."""
    data = json.loads((path / "results.json").read_text())
    return [
        (r["kind"], r["case"], r["controller"], r["variant"], r["seed"], r["metrics"])
        for r in data["records"]
    ]


@pytest.fixture(scope="module")
def serial_out(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setitem(S.SUITES, "tiny", lambda: S.Suite("tiny", "test suite", TINY))
    out = tmp_path_factory.mktemp("serial")
    try:
        assert cli_benchmark.main(["--suite", "tiny", "--out", str(out)]) == 0
    finally:
        mp.undo()
    return out


def test_results_json_one_record_per_run(serial_out):
    data = json.loads((serial_out / "results.json").read_text())
    recs = data["records"]
    assert [(r["kind"], r["case"], r["controller"]) for r in recs] == [
        (s.kind, s.case, s.controller) for s in TINY
    ]
    for r in recs:
        for key in ("plant", "variant", "seed", "settings", "metrics", "timestamp", "figure"):
            assert key in r
        assert r["code_version"]["package"] == "contour_env"
        assert r["code_version"]["version"]
        assert "commit" in r["code_version"]
    nominal = {
        r["controller"]: r for r in recs if r["kind"] == "nominal" and r["case"] == "hsm2-circle-I"
    }
    # our figure, the paper's where one exists, the ratio to PD (ours and the paper's)
    pd, acc = nominal["pd"], nominal["adaptive-ccc"]
    assert pd["figure"]["ours"] == pd["metrics"]["rms_contour_error_um"] > 0
    assert pd["figure"]["paper"] == 43.0 and acc["figure"]["paper"] == 12.0
    assert nominal["ccc:wi=0"]["figure"]["paper"] == 15.0
    assert pd["ratio_to_pd"] == 1.0
    assert acc["ratio_to_pd"] == pytest.approx(acc["figure"]["ours"] / pd["figure"]["ours"])
    assert acc["paper_ratio_to_pd"] == pytest.approx(12 / 43)
    assert acc["published"]["max_contour_error_um"]["value"] == 63.0
    assert acc["published"]["rms_x_torque_Nm"]["table"] == "Table 3"
    # no published figure: None, not a guess
    sc = [r for r in recs if r["kind"] == "nominal" and r["case"] == "sharp-corner"]
    assert all(r["figure"]["paper"] is None and r["published"] == {} for r in sc)
    assert sc[1]["ratio_to_pd"] == pytest.approx(sc[1]["figure"]["ours"] / sc[0]["figure"]["ours"])
    rob = [r for r in recs if r["kind"] == "robustness"]
    assert rob[0]["variant"] == "random±20%x2" and rob[0]["seed"] == 3
    assert len(rob[0]["metrics"]["rms_contour_error_um_per_episode"]) == 2
    assert rob[1]["ratio_to_pd"] is not None
    ilc = [r for r in recs if r["kind"] == "ilc"]
    assert len(ilc[0]["metrics"]["rms_contour_error_um_per_iteration"]) == 2


def test_report_files_have_every_row(serial_out):
    md = (serial_out / "report.md").read_text()
    page = (serial_out / "report.html").read_text()
    for name in ("report.md", "report.html", "results.json"):
        assert (serial_out / name).stat().st_size > 0
    for png in (
        "contour_hsm2-circle-I.png",
        "contour_sharp-corner.png",
        "robustness_hsm2-circle-I.png",
        "ilc_sharp-corner_repeatable.png",
    ):
        assert (serial_out / png).stat().st_size > 1000
        assert f"]({png})" in md and f"href='{png}'" in page
    assert "data:image/png;base64," in page  # self-contained
    for s in TINY:
        assert f"| {s.controller} |" in md
        assert f"<td>{s.controller}</td>" in page
    # the paper's figure beside ours, and a generated reading
    assert "| 63.0 |" in md and "| 12.0 |" in md
    assert "The paper's ordering by RMS (adaptive-ccc < ccc:wi=0 < pd)" in md
    assert "Simba et al. 2018" in md


def test_workers_give_identical_figures(serial_out, tiny, tmp_path):
    assert cli_benchmark.main(["--suite", "tiny", "--out", str(tmp_path), "--workers", "2"]) == 0
    assert _figures(tmp_path) == _figures(serial_out)


def test_ray_gives_identical_figures(serial_out, tiny, tmp_path):
    pytest.importorskip("ray")
    assert cli_benchmark.main(["--suite", "tiny", "--out", str(tmp_path), "--ray", "local"]) == 0
    assert _figures(tmp_path) == _figures(serial_out)


@pytest.mark.parametrize(
    "args, flag",
    [
        (["--suite", "nope"], "--suite"),
        (["--workers", "0"], "--workers"),
        (["--workers", "two"], "--workers"),
        (["--ray", " "], "--ray"),
        (["--workers", "2", "--ray", "auto"], "--workers"),
    ],
)
def test_bad_flag_values_give_one_line_errors(args, flag, tmp_path, capsys, monkeypatch):
    if flag == "--workers" and "--ray" in args:
        monkeypatch.setitem(sys.modules, "ray", object())  # as if installed
    assert cli_benchmark.main(["--out", str(tmp_path / "o"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(f"error: {flag}:")
    assert not (tmp_path / "o").exists()


def test_suite_error_names_allowed_values(tmp_path, capsys):
    assert cli_benchmark.main(["--suite", "nope", "--out", str(tmp_path)]) == 2
    assert "allowed: quick, paper, full" in capsys.readouterr().err


def test_ray_missing_names_the_extra(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray → ImportError
    assert cli_benchmark.main(["--out", str(tmp_path), "--ray", "auto"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert err.startswith("error: --ray:") and 'pip install -e ".[ray]"' in err


def test_out_that_is_a_file_is_an_error(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    assert cli_benchmark.main(["--out", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("error: --out:")


def test_runs_are_pure_functions_of_their_spec():
    spec = [S.nominal("hsm2-circle-I", "ccc")]
    a, b = run_all(spec), run_all(spec)
    assert a[0]["metrics"] == b[0]["metrics"] and a[0]["trace"] == b[0]["trace"]


def test_quick_suite_covers_every_case_and_applicable_controller():
    from contour_env.cases import all_case_names

    runs = S.quick_suite().runs
    nominal = {(r.case, r.controller) for r in runs if r.kind == S.NOMINAL}
    assert {c for c, _ in nominal} == set(all_case_names())
    for case in all_case_names():
        for ctrl in (*S.FIXED, *S.FIVE_AXIS):
            if S.applicable(case, ctrl):
                assert (case, ctrl) in nominal, (case, ctrl)
    assert ("jee-circle3d", "jee-ccc") in nominal and ("hsm2-circle-I", "jee-ccc") not in nominal
    assert ("five-axis-line", "ismc") in nominal
    # every published row is in the quick suite's nominal runs
    assert {(c, k) for c, k, _ in PUBLISHED} <= nominal
    assert any(r.kind == S.ROBUSTNESS for r in runs) and any(r.kind == S.ILC for r in runs)
    assert len({r.key() for r in runs}) == len(runs)


def test_paper_suite_has_every_published_comparison():
    runs = S.paper_suite().runs
    nominal = {(r.case, r.controller) for r in runs if r.kind == S.NOMINAL}
    assert {(c, k) for c, k, _ in PUBLISHED} <= nominal
    ilc = {(r.case, r.controller) for r in runs if r.kind == S.ILC}
    for rel in RELATIVE:
        assert {(rel.case, rel.controller), *((rel.case, a) for a in rel.against)} <= ilc
    assert published_for("five-axis-circle", "ismc")["rms_contour_error_um"].value == 17.9
    assert published_for("hsm2-circle-III", "pd")["max_contour_error_um"].value == 530


@pytest.mark.slow
def test_quick_suite_runs(tmp_path):
    import time

    t0 = time.perf_counter()
    assert cli_benchmark.main(["--suite", "quick", "--out", str(tmp_path)]) == 0
    assert time.perf_counter() - t0 < 120
    recs = json.loads((tmp_path / "results.json").read_text())["records"]
    assert len(recs) == len(S.quick_suite().runs)


def test_paper_column_is_next_to_ours(serial_out):
    md = (serial_out / "report.md").read_text()
    header = next(line for line in md.splitlines() if line.startswith("| controller | max ε"))
    cols = [c.strip() for c in header.strip("|").split("|")]
    assert cols[1:7] == [
        "max ε µm (ours)",
        "paper",
        "RMS ε µm (ours)",
        "paper",
        "RMS/PD (ours)",
        "RMS/PD (paper)",
    ]
    row = next(line for line in md.splitlines() if line.startswith("| adaptive-ccc |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[2] == "63.0" and cells[4] == "12.0" and cells[6] == "0.279"


def _rec(ctrl, ours, paper, pd_ours=100.0, pd_paper=100.0):
    return {
        "controller": ctrl,
        "metrics": {"completed": True, "rms_contour_error_um": ours},
        "published": {},
        "figure": {"ours": ours, "paper": paper},
        "ratio_to_pd": ours / pd_ours,
        "paper_ratio_to_pd": None if paper is None else paper / pd_paper,
    }


def test_reading_comes_from_the_numbers():
    from contour_env.app.benchmark.report import read_nominal

    rows = [_rec("pd", 100.0, 100.0), _rec("ccc", 10.0, 50.0), _rec("adaptive-ccc", 20.0, 30.0)]
    text = read_nominal("case-x", rows)
    assert "ccc has the lowest RMS contour error (10.0 µm, 0.100× PD's)" in text
    assert "does not hold: ours is ccc < adaptive-ccc < pd" in text
    rows[1] = _rec("ccc", 40.0, 50.0)
    text = read_nominal("case-x", rows)
    assert "adaptive-ccc has the lowest" in text
    assert "The paper's ordering by RMS (adaptive-ccc < ccc < pd) holds in ours." in text


def test_a_failed_run_is_reported_and_fails_the_command(tmp_path, capsys, monkeypatch):
    runs = (S.nominal("hsm2-circle-I", "pd"), S.nominal("hsm2-circle-I", "pd:nope=1"))
    monkeypatch.setitem(S.SUITES, "broken", lambda: S.Suite("broken", "test", runs))
    assert cli_benchmark.main(["--suite", "broken", "--out", str(tmp_path)]) == 1
    assert "error: run nominal hsm2-circle-I pd:nope=1:" in capsys.readouterr().err
    recs = json.loads((tmp_path / "results.json").read_text())["records"]
    assert recs[0]["error"] is None and recs[0]["figure"]["ours"] > 0
    assert "nope" in recs[1]["error"] and recs[1]["metrics"] == {}
    md = (tmp_path / "report.md").read_text()
    assert "## Failed runs" in md and "| pd |" in md
