"""scripts/time_to_target.py (the time-to-target table, issue 34) and scripts/ppo_preset.py end
to end with a tiny budget: every configuration of the table trains, its row carries the
run's own wall time, evaluation share and targets, and the table is rebuilt from the JSON."""

import importlib.util
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
HAS_JAX = (
    importlib.util.find_spec("sbx") is not None and importlib.util.find_spec("jax") is not None
)


def _script(name):
    sys.path.insert(0, str(ROOT / "scripts"))
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


TTT = _script("time_to_target")
TINY = ["--budget", "1", "--eval-every", "100", "--validation-paths", "1"]


def test_every_configuration_trains_end_to_end_and_the_table_follows(tmp_path, capsys):
    names = [n for n in TTT.CONFIGS if HAS_JAX or not n.startswith("sbx")]
    assert TTT.main([*TINY, "--configs", ",".join(names), "--out", str(tmp_path)]) == 0
    rec = json.loads((tmp_path / "time_to_target.json").read_text())
    assert [r["config"] for r in rec["runs"]] == names
    assert rec["target_ratio"] == 0.70 and rec["base"] == "ccc"
    for r in rec["runs"]:
        assert r["keywords"] == TTT.CONFIGS[r["config"]]
        assert 0 < r["eval_share"] < 1 and r["train_s"] >= 1.0
        assert r["run_wall_s"] >= r["train_s"] and r["agent_steps_per_s"] > 0
        assert set(r["time_to_target"]) >= {"validation_base_level", "training_tasks_target"}
    md = (tmp_path / "time_to_target.md").read_text()
    assert md.count("\n| ") == len(names) + 1  # header + one row each
    # rebuilt from the JSON (targets re-read from the runs' curve files): the same table
    again = tmp_path / "again"
    assert (
        TTT.main(["--from-json", str(tmp_path / "time_to_target.json"), "--out", str(again)]) == 0
    )
    assert (again / "time_to_target.md").read_text() == md


@pytest.mark.parametrize(
    "argv, match",
    [
        (["--configs", "nope"], "--configs: unknown"),
        (["--budget", "0"], "--budget: seconds > 0"),
        (["--validation-paths", "0"], "--validation-paths: >= 1"),
    ],
)
def test_bad_arguments_are_named(argv, match, capsys, tmp_path):
    assert TTT.main([*argv, "--out", str(tmp_path)]) == 2
    assert match in capsys.readouterr().err


def test_ppo_preset_variants_run_and_unknown_ones_are_refused(tmp_path, capsys):
    mod = _script("ppo_preset")
    argv = [*TINY, "--variants", "reference,lr-1e-3", "--out", str(tmp_path)]
    assert mod.main(argv) == 0
    rec = json.loads((tmp_path / "ppo_preset.json").read_text())
    assert [r["keywords"]["learning_rate"] for r in rec["runs"]] == [3e-4, 1e-3]
    assert mod.main(["--variants", "nope", "--out", str(tmp_path)]) == 2
    assert mod.main(["--validation-paths", "0", "--out", str(tmp_path)]) == 2
    assert "--validation-paths: >= 1" in capsys.readouterr().err
