"""scripts/train_agents.py and scripts/residual_benchmark.py end to end on a tiny run."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from agents.residual import ResidualAgent
from agents.rl import TrainConfig, train

ROOT = Path(__file__).resolve().parents[2]


def _script(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def tiny_model(tmp_path_factory):
    gcode = tmp_path_factory.mktemp("g") / "short.nc"
    gcode.write_text("G21 G90 G17 G61\nG01 X2 F1200\nG01 Y2\n")
    out = tmp_path_factory.mktemp("runs") / "tiny"
    cfg = TrainConfig(
        plant="friction-table", gcode=(str(gcode),), algo="sac", timesteps=200, seed=0,
        learning_starts=50, buffer_size=1000, batch_size=32, eval_freq=200, net_arch=(8, 8),
        teacher_parts=2, teacher_trials=2,
    )  # fmt: skip
    train(cfg, out, progress=False, log=lambda s: None)
    return out


def test_install_copies_the_model_files_and_the_copy_is_a_working_agent(
    tiny_model, tmp_path, monkeypatch
):
    mod = _script("train_agents")
    monkeypatch.setattr(mod, "MODELS", tmp_path / "models")
    dest = mod.install(tiny_model, "friction-table")
    optional = [f for f in mod.OPTIONAL_FILES if (tiny_model / f).is_file()]
    assert set(optional) >= {"validation_curve.json", "validation_curve.png"}
    assert sorted(p.name for p in dest.iterdir()) == sorted(mod.SHIPPED_FILES + tuple(optional))
    assert not (dest / "checkpoints").exists()
    # the shipped copy gives the same actions as the run folder
    import gymnasium as gym

    from contour_env import ENV_ID
    from contour_env.evaluation import evaluate

    path = "G21 G90 G17 G61\nG01 X2 F1200\nG01 Y2\n"
    a = evaluate(gym.make(ENV_ID, plant="friction-table", path=path), ResidualAgent(dest))
    b = evaluate(gym.make(ENV_ID, plant="friction-table", path=path), ResidualAgent(tiny_model))
    assert a == b
    # installing again replaces the folder whole
    assert mod.install(tiny_model, "friction-table") == dest


def test_shipped_configurations_are_valid_and_unknown_names_are_refused():
    mod = _script("train_agents")
    for name, kw in mod.SHIPPED.items():
        cfg = TrainConfig(seed=0, **kw)
        assert cfg.plant_name == name
    with pytest.raises(SystemExit, match="unknown"):
        mod.main(["--only", "five-axis"])


def test_residual_benchmark_scores_agent_and_base_on_polygon_and_spline(tiny_model, tmp_path):
    mod = _script("residual_benchmark")
    js = tmp_path / "bench.json"
    assert mod.main(["--models", str(tiny_model), "--json", str(js)]) == 0
    rows = json.loads(js.read_text())["rows"]
    # the friction table's named cases, the held-out programs, the polygon and the spline
    from agents.rl.scorecard import heldout_programs, program_label

    held = [program_label(p) for p in heldout_programs(2, "friction-table")]
    assert [r["target"] for r in rows] == [
        "sharp-corner",
        "corner-blend",
        *held,
        "polygon",
        "spline",
    ]
    for r in rows:
        assert r["plant"] == "friction-table" and r["base"] == "pd"
        assert r["rms_ratio"] == pytest.approx(
            r["agent_rms_contour_error_um"] / r["base_rms_contour_error_um"]
        )
        assert all(e is None or np.isfinite(e) for e in r["effort_ratio"])
    # hsm2 agents are scored on every hsm2 case (its training case first) and the suite
    targets = [t for t, _ in mod.test_targets({"plant": "hsm2", "cases": ["hsm2-circle-II"]})]
    assert targets[:4] == ["hsm2-circle-I", "hsm2-circle-II", "hsm2-circle-III", "hsm2-payload"]
    held_hsm2 = [program_label(p) for p in heldout_programs(2, "hsm2")]
    assert targets[4:] == [*held_hsm2, "polygon", "spline"]


def _card(held, cases, kept):
    rows = [{"kind": "heldout", "rms_ratio": r} for r in held]
    rows += [{"kind": "case", "rms_ratio": r} for r in cases]
    from agents.rl.scorecard import summary

    return {"kept": kept, **summary(rows)}


def test_ablation_summary_and_table_follow_from_the_cards():
    mod = _script("residual_ablation")
    cards = {
        "path": [_card([0.5, 0.7], [0.9], "best-validation"), _card([1.0, 1.0], [1.0], "base")],
        "axes": [_card([2.0, None], [1.0], "final"), _card([1.5, 0.5], [3.0], "final")],
    }
    s = mod.summarise(cards)
    assert s["path"]["heldout_mean_ratio"]["mean"] == pytest.approx((0.6 + 1.0) / 2)
    assert s["path"]["worst_ratio"]["values"] == [0.9, 1.0]
    assert s["path"]["kept_base"] == 1 and s["path"]["seeds"] == 2
    # a part not completed by one seed: no mean, no max (an infinite ratio), the min of the rest
    assert s["axes"]["heldout_mean_ratio"]["mean"] is None
    assert s["axes"]["heldout_worst_ratio"]["min"] == pytest.approx(1.5)
    table = mod.markdown({"plant": "friction-table", "summary": s, "summary_final": s})
    assert "| `path` | 0.80 (0.60–1.00) | 0.95 (0.90–1.00) | 1 of 2 |" in table
    assert "not completed on every part" in table


def test_installing_a_run_checks_that_it_is_the_shipped_configuration(tiny_model, tmp_path):
    mod = _script("train_agents")
    with pytest.raises(
        SystemExit, match=r"differs from SHIPPED\['friction-table'\] in \[.*'path_variety'"
    ):
        mod.check_run(tiny_model, "friction-table")
    with pytest.raises(SystemExit, match="not a finished run"):
        mod.check_run(tmp_path, "friction-table")
    with pytest.raises(SystemExit, match="--only NAME"):
        mod.main(["--from-run", str(tiny_model), "--only", "friction-table"])


def test_the_release_gate_refuses_an_agent_worse_than_its_base_anywhere():
    """Issue 48's release criteria: RMS <= 1 everywhere, max <= 1.05 (<= 1.00 on the plant's
    own parts); a refused agent is installed as its base."""
    mod = _script("train_agents")

    def row(target, rms, mx):
        return {"target": target, "rms_ratio": rms, "max_ratio": mx}

    card = {
        "plant": "hsm2",
        "rows": [
            row("hsm2-circle-II", 0.7, 1.04),
            row("cam_lobe.nc", 1.0, 1.0),
            row("hsm2/rotated_corners.nc", 0.8, 1.0),
        ],
    }
    assert mod.release_failures(card) == []
    card["rows"].append(row("hsm2-payload", 0.98, 1.067))
    card["rows"].append(row("hsm2/fast_traverse.nc", 1.0, 1.01))
    card["rows"].append(row("gear_profile.ngc", 1.001, 0.9))
    card["rows"].append(row("star_exact_stop.nc", None, None))
    bad = mod.release_failures(card)
    assert [b.split(":")[0] for b in bad] == [
        "hsm2-payload", "hsm2/fast_traverse.nc", "gear_profile.ngc", "star_exact_stop.nc"
    ]  # fmt: skip


def test_a_refused_agent_is_installed_as_its_base(tiny_model, tmp_path, monkeypatch):
    import shutil

    from agents.rl import scorecard as sc

    mod = _script("train_agents")
    d = tmp_path / "run"
    shutil.copytree(tiny_model, d)
    meta = json.loads((d / "agent.json").read_text())
    meta["kept"] = "best-validation"
    (d / "agent.json").write_text(json.dumps(meta))
    fake = {
        "plant": "friction-table",
        "rows": [{"target": "cam_lobe.nc", "rms_ratio": 0.5, "max_ratio": 1.2}],
        "heldout_mean_ratio": 0.5, "heldout_max_mean_ratio": 1.2,
        "heldout_worst_ratio": 0.5, "heldout_max_worst_ratio": 1.2,
    }  # fmt: skip
    monkeypatch.setattr(sc, "scorecard", lambda *a, **k: fake)
    rec = mod.release_gate(d)
    assert rec["released"] is False and rec["refused_kept"] == "best-validation"
    agent = ResidualAgent(d)
    assert agent.is_base and "release gate refused" in agent.base_reason()
    fake["rows"][0]["max_ratio"] = 0.9
    meta["kept"] = "best-validation"
    (d / "agent.json").write_text(json.dumps(meta))
    assert mod.release_gate(d)["released"] is True and not ResidualAgent(d).is_base


def test_teacher_ablation_commands_and_table_from_its_record():
    """scripts/teacher_ablation.py: each variant is one contour-env train command with its
    options; the table of docs/training.md is made from the recorded cards
    (docs/teacher_ablation_*.json)."""
    mod = _script("teacher_ablation")
    cmd = mod.command("friction-table", "ccc", 180, 2, "teacher+rl-noenv", Path("o"))
    assert cmd[cmd.index("--teacher") + 1] == "ilc-contour" and "--no-envelope" in cmd
    assert cmd[cmd.index("--time-budget") + 1] == "180" and cmd[cmd.index("--seed") + 1] == "2"
    assert "--no-fine-tune" in mod.command("hsm2", "pd", 60, 0, "teacher", Path("o"))
    rec = json.loads((ROOT / "docs" / "teacher_ablation_friction-table.json").read_text())
    assert set(rec["cards"]) == set(mod.VARIANTS) and rec["seeds"] == [0, 1, 2]
    assert rec["summary"] == mod.summarise(rec["cards"])
    table = mod.markdown(rec)
    assert table in (ROOT / "docs" / "training.md").read_text()
    assert len(table.splitlines()) == 2 + len(mod.VARIANTS)
