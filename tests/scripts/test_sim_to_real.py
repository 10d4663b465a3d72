"""scripts/sim_to_real.py's pieces: the base the machine runs (CCC with the plant file's tuned
gains) and the summary of a held-out suite. The chain itself trains three agents (minutes
each) and runs from the command line (README "Your controller")."""

from __future__ import annotations

import json

import pytest


@pytest.fixture
def s2r(load_script):
    return load_script("sim_to_real")


def test_base_spec_carries_the_tuned_gains_of_the_plant_file(s2r, tmp_path):
    from agents.registry import make_controller

    f = tmp_path / "p.json"
    gains = {"pd": {"bandwidth_rad_s": 120.0}, "ccc": {"W_p": 3000.0, "W_i": 1e6}}
    f.write_text(json.dumps({"controller_gains": gains}))
    spec = s2r.base_spec(str(f))
    assert spec == "ccc:w=120.0:wp=3000.0:wi=1000000.0"
    ctrl = make_controller(spec)
    assert ctrl._user["W_p"] == 3000.0 and ctrl._user["W_i"] == 1e6
    assert s2r.base_spec(None) == "ccc"


def test_summary_counts_a_program_worse_in_rms_or_max(s2r):
    rows = [
        {"rms_ratio": 0.5, "max_ratio": 0.8},
        {"rms_ratio": 0.9, "max_ratio": 1.1},
        {"rms_ratio": 1.2, "max_ratio": 0.9},
    ]
    s = s2r.summary(rows)
    assert s["mean_rms_ratio"] == pytest.approx(2.6 / 3) and s["worst_max_ratio"] == 1.1
    assert s["programs_worse"] == 2 and s["programs"] == 3
