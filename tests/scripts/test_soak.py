"""scripts/soak.py on a small budget: every case (the five-axis ones included), single and
vector env, nominal and ±20 % plants, action extremes; no NaN/inf, NaN/inf actions refused
(at an autoreset too), no exception."""

import importlib.util
import json
from pathlib import Path

from contour_env.cases import all_case_names

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
    # issue 36 item 8: every named case, the two five-axis ones included
    assert res["cases"] == all_case_names()
    assert {"five-axis-line", "five-axis-circle"} <= set(res["cases"])
    assert "five-axis-circle vector" in res["blocks"]
    assert res["autoreset_action_probes"] > 0


def test_soak_finds_a_nonfinite_action_accepted_at_an_autoreset(monkeypatch):
    # the defect of issue 36 item 8 put back: the vector env no longer checks the action of
    # an env it autoresets; the soak's autoreset probes must report it
    from contour_env.env.core import EnvCore

    monkeypatch.setattr(EnvCore, "refuse_nonfinite", lambda self, action, rows: None)
    soak = _soak()
    res = soak.soak(8000, seed=1, progress=None, cases=["hsm2-circle-I"])
    assert res["nonfinite_action_not_refused"] > 0
    assert any("autoreset of env" in p for p in res["first_problems"])


def test_soak_counts_a_problem():
    soak = _soak()
    c = soak.Counts()
    import numpy as np

    info = {"contour_error": np.zeros(1), "step": np.zeros(1, int)}
    soak._check(c, "x", np.array([np.nan]), np.array([0.0]), info, [False])
    assert c.failures == 1 and c.nonfinite_obs == 1
    # every floating-point info field is checked (the five-axis env's own ones too)
    soak._check(c, "x", np.zeros(1), np.zeros(1), {"tool_tip": np.array([np.inf])}, [False])
    assert c.failures == 2 and c.nonfinite_info == 1
