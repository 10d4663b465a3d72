"""scripts/soak.py on a small budget: every case, single and vector env, nominal and ±20 %
plants, action extremes; no NaN/inf, NaN/inf actions refused, no exception."""

import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _soak():
    spec = importlib.util.spec_from_file_location("soak", ROOT / "scripts" / "soak.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_soak_20000_steps_is_clean(tmp_path, capsys):
    soak = _soak()
    out = tmp_path / "soak.json"
    rc = soak.main(["--steps", "20000", "--seed", "1", "--quiet", "--json", str(out)])
    text = capsys.readouterr().out
    res = json.loads(out.read_text())
    assert rc == 0, text
    assert "PASS" in text
    assert res["failures"] == 0 and res["exceptions"] == 0
    assert res["steps"] >= 19000
    assert res["nonfinite_action_probes"] > 0 and res["nonfinite_action_not_refused"] == 0
    assert sum(res["terminations"].values()) > 0  # the extremes do end episodes


def test_soak_counts_a_problem():
    soak = _soak()
    c = soak.Counts()
    import numpy as np

    info = {k: np.zeros(1) for k in soak.INFO_NUMERIC}
    soak._check(c, "x", np.array([np.nan]), np.array([0.0]), info, [False])
    assert c.failures == 1 and c.nonfinite_obs == 1
