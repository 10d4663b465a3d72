"""scripts/check_speed_regression.py: the comparison of a bench report with the recorded
figures, on synthetic reports (no timing here)."""

import copy
import json
from pathlib import Path

import pytest


@pytest.fixture
def mod(load_script):
    return load_script("check_speed_regression")


def _bench(scale=1.0, *, quick=False, load=0.05):
    # a synthetic `contour-env bench --json` report: contour_env's rates times ``scale``,
    # CartPole's unchanged
    def vec(n, ours, theirs):
        runs = [ours * scale * f for f in (0.9, 1.0, 1.1)]
        cp = [theirs] * 3
        return {
            "num_envs": n,
            "env_steps_per_s": ours * scale,
            "cartpole_env_steps_per_s": theirs,
            "ratio_to_cartpole": ours * scale / theirs,
            "env_steps_per_s_runs": runs,
            "cartpole_env_steps_per_s_runs": cp,
            "ratio_to_cartpole_runs": [a / b for a, b in zip(runs, cp, strict=True)],
        }

    contended = vec(4096, 2.0e6, 10e6)
    contended.update(ratio_to_quiet=0.5 * scale, cartpole_ratio_to_quiet=0.8)
    return {
        "case": "hsm2-circle-II",
        "quick": quick,
        "started": "2027-01-01 12:00:00 +0000",
        "load_average_at_start": [load, 0.1, 0.1],
        "machine": {"cpu": "test cpu", "cpu_count": 2},
        "code": {"commit": "abc123"},
        "single_env_steps_per_s": 60_000.0 * scale,
        "cartpole_single_steps_per_s": 100_000.0,
        "single_ratio_to_cartpole": 0.6 * scale,
        "vector": [vec(1, 50_000.0, 90_000.0), vec(4096, 4.0e6, 10e6)],
        "exploration": [
            {
                "label": "uniform random actions",
                "num_envs": 4096,
                "env_steps_per_s": 1.8e6 * scale,
                "ratio_to_tracking": 0.45 * scale,
            }
        ],
        "contended": contended,
        "controllers": [
            {"name": "pd loop, single env, steps/s", "steps_per_s": 1e6, "ratio_to_env": 16.0}
        ],
    }


def test_figures_name_every_ratio_and_rate(mod):
    ratios, rates = mod.figures(_bench())
    assert ratios == pytest.approx(
        {
            "single env / CartPole": 0.6,
            "1 envs / CartPole": 50_000 / 90_000,
            "4096 envs / CartPole": 0.4,
            "uniform random actions, 4096 envs / tracking": 0.45,
            "contended 4096 envs / quiet": 0.5,
            "contended 4096 envs / CartPole": 0.2,
            "pd loop, single env / env single": 16.0,
        }
    )
    assert rates["4096 envs, env-steps/s"] == 4.0e6
    assert rates["CartPole 4096 envs, env-steps/s"] == 10e6
    assert rates["single env, steps/s"] == 60_000
    assert rates["pd loop, single env, steps/s"] == 1e6


def test_a_report_without_stored_ratios_gives_the_median_of_the_pairs(mod):
    old = _bench()
    del old["single_ratio_to_cartpole"]
    for row in old["vector"]:
        del row["ratio_to_cartpole"], row["ratio_to_cartpole_runs"]
    ratios, _ = mod.figures(old)
    assert ratios["4096 envs / CartPole"] == pytest.approx(0.4)  # median of 0.36, 0.4, 0.44
    assert ratios["single env / CartPole"] == pytest.approx(0.6)  # ratio of the medians


def test_same_figures_pass(mod):
    ref = mod.reference_from(_bench())
    res = mod.compare(_bench(), ref)
    assert res["dropped"] == [] and res["missing"] == []
    assert "no figure dropped" in mod.format_comparison(res)


def test_a_drop_within_the_tolerance_passes_and_beyond_it_is_listed(mod):
    ref = mod.reference_from(_bench())
    assert mod.compare(_bench(0.81), ref)["dropped"] == []
    res = mod.compare(_bench(0.79), ref)
    names = {r[1] for r in res["dropped"]}
    # every ratio that scales with contour_env's speed, none of the rates (not judged)
    assert names == {
        "single env / CartPole",
        "1 envs / CartPole",
        "4096 envs / CartPole",
        "uniform random actions, 4096 envs / tracking",
        "contended 4096 envs / quiet",
        "contended 4096 envs / CartPole",
    }
    text = mod.format_comparison(res)
    assert "6 figure(s) dropped by more than 20%" in text
    assert "4096 envs / CartPole: 0.4 -> 0.316 (-21.0%)" in text


def test_a_faster_run_passes(mod):
    assert mod.compare(_bench(1.5), mod.reference_from(_bench()))["dropped"] == []


def test_absolute_rates_are_judged_only_when_asked(mod):
    ref = mod.reference_from(_bench())
    slow_machine = _bench()
    for row in slow_machine["vector"]:  # everything half as fast, CartPole too: same ratios
        row["env_steps_per_s"] /= 2
        row["cartpole_env_steps_per_s"] /= 2
    assert mod.compare(slow_machine, ref)["dropped"] == []
    dropped = {r[1] for r in mod.compare(slow_machine, ref, absolute=True)["dropped"]}
    assert "4096 envs, env-steps/s" in dropped and "CartPole 1 envs, env-steps/s" in dropped


def test_tolerance_is_a_parameter(mod):
    ref = mod.reference_from(_bench())
    assert mod.compare(_bench(0.85), ref, tolerance=0.1)["dropped"]
    with pytest.raises(ValueError, match="tolerance"):
        mod.compare(_bench(), ref, tolerance=1.5)


def test_figures_missing_from_the_run_are_listed_not_failed(mod):
    ref = mod.reference_from(_bench())
    quick = _bench(quick=True)
    quick["vector"] = quick["vector"][:1]
    del quick["contended"]
    res = mod.compare(quick, ref)
    assert "4096 envs / CartPole" in res["missing"] and res["dropped"] == []
    assert res["new"] == []
    assert any("--quick" in n for n in res["notes"])
    assert "not in this run" in mod.format_comparison(res)


def test_figures_new_in_the_run_are_listed(mod):
    ref = mod.reference_from(_bench())
    del ref["ratios"]["4096 envs / CartPole"]
    res = mod.compare(_bench(), ref)
    assert res["new"] == ["4096 envs / CartPole"] and res["dropped"] == []
    assert "4096 envs / CartPole" in mod.format_comparison(res).split("not in the reference")[0]


def test_another_case_or_nothing_in_common_cannot_be_compared(mod):
    ref = mod.reference_from(_bench())
    other = _bench()
    other["case"] = "sharp-corner"
    with pytest.raises(mod.Incomparable, match="case"):
        mod.compare(other, ref)
    empty = copy.deepcopy(ref)
    empty["ratios"] = {"something else": 1.0}
    with pytest.raises(mod.Incomparable, match="no ratio in common"):
        mod.compare(_bench(), empty)


def test_reference_records_date_commit_machine_and_rates(mod):
    ref = mod.reference_from(_bench())
    assert ref["date"] == "2027-01-01 12:00:00 +0000"
    assert ref["commit"] == "abc123"
    assert ref["machine"]["cpu"] == "test cpu"
    assert ref["rates"]["4096 envs, env-steps/s"] == 4.0e6
    assert ref["ratios"]["4096 envs / CartPole"] == pytest.approx(0.4)


def _files(tmp_path, run, ref=None):
    run_path = tmp_path / "run.json"
    run_path.write_text(json.dumps(run))
    ref_path = tmp_path / "ref.json"
    if ref is not None:
        ref_path.write_text(json.dumps(ref))
    return str(run_path), str(ref_path)


def test_main_exit_codes(mod, tmp_path, capsys):
    run, ref = _files(tmp_path, _bench(0.7), mod.reference_from(_bench()))
    assert mod.main([run, "--reference", ref]) == 1
    assert "DROPPED" in capsys.readouterr().out
    run, ref = _files(tmp_path, _bench(0.95), mod.reference_from(_bench()))
    assert mod.main([run, "--reference", ref]) == 0
    assert mod.main([str(tmp_path / "absent.json"), "--reference", ref]) == 2
    assert mod.main([run, "--reference", str(tmp_path / "none.json")]) == 2


def test_update_writes_the_reference_and_refuses_a_busy_or_quick_run(mod, tmp_path, capsys):
    run, ref = _files(tmp_path, _bench())
    assert mod.main([run, "--reference", ref, "--update"]) == 0
    written = json.loads(Path(ref).read_text())
    assert written == json.loads(json.dumps(mod.reference_from(_bench())))
    # no temporary file left behind
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ref.json", "run.json"]

    for bad, word in ((_bench(load=1.2), "busy"), (_bench(quick=True), "quick")):
        run, _ = _files(tmp_path, bad)
        before = Path(ref).read_text()
        assert mod.main([run, "--reference", ref, "--update"]) == 2
        assert word in capsys.readouterr().err
        assert Path(ref).read_text() == before
        assert mod.main([run, "--reference", ref, "--update", "--force"]) == 0
