"""Default gains for a plant of your own (:mod:`agents.tuning`, ``contour-env tune``).

Checked independently of the search: the chosen PD ω meets the margin requirement by
:func:`agents.margins.loop_margins`' full computation and the next ω of the grid does not (the
"largest ω" the search claims); the chosen CCC coupling meets the margins, keeps PD's effort
and peak within the slack on the tuning paths, and beats PD on a circle it was not tuned on
(the ISO 230-4 circular test at R 50 mm); the tuning paths stay within the plant's force.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from agents import make_controller
from agents.ccc import CCCController
from agents.margins import loop_margins, meets_requirement, requirement
from agents.pd import PDController, UntunedGainsWarning
from agents.tuning import (
    EFFORT_SLACK,
    MAX_SLACK,
    PD_GRID,
    plant_tuning_paths,
    run_paths,
    tune_pd,
    tune_plant_file,
)
from contour_env.circular_test import max_circle_feed_m_s, run_circular_test
from contour_env.plants import Plant, params_from_mapping

MILL = {
    "name": "my-mill",
    "axes": ["x", "y"],
    "mass": [300.0, 200.0],
    "viscous": [400.0, 300.0],
    "coulomb": [20.0, 15.0],
    "static": [30.0, 20.0],
    "force_limit": [3000.0, 2000.0],
    "servo_period": 0.001,
    "current_loop_time_constant": 0.0005,
    "computation_delay": True,
}


def _meets(spec_or_ctrl, plant, structural=False) -> bool:
    rep = loop_margins(spec_or_ctrl, plant)
    gm, pm = requirement(structural)
    ok = rep["stable"] and rep["min_gain_margin_db"] is not None
    return bool(ok and rep["min_gain_margin_db"] >= gm and rep["min_phase_margin_deg"] >= pm)


@pytest.fixture(scope="module")
def mill_tuned():
    plant = Plant(MILL)
    lines: list[str] = []
    return plant, tune_plant_file(plant, ("pd", "ccc"), progress=lines.append), lines


def test_pd_is_the_largest_grid_omega_meeting_the_margins(mill_tuned):
    plant, result, lines = mill_tuned
    w = result["pd"]["bandwidth_rad_s"]
    assert w in PD_GRID and w < PD_GRID[-1]
    assert _meets(PDController(bandwidth_rad_s=w), plant)
    above = PD_GRID[PD_GRID.index(w) + 1]
    assert not _meets(PDController(bandwidth_rad_s=above), plant)
    assert result["controller_gains"]["pd"] == {"bandwidth_rad_s": w}
    assert any(line.strip().startswith("pd ω") for line in lines)  # progress reported


def test_a_two_mass_mode_in_the_file_bounds_pd():
    """With the mode in the file: R1 without it and R2 (>= 2 dB / 10°) with it, as for the
    named plants; the mode lowers the ω the rigid plant allows."""
    mode = Plant("hsm2", structural_mode=True).params
    plant = Plant(mode)
    rigid = Plant(mode.replace(structural_stiffness_N_m=np.zeros(2)))
    w = tune_pd(plant)["bandwidth_rad_s"]
    w_rigid = tune_pd(rigid)["bandwidth_rad_s"]
    assert w < w_rigid
    above = PD_GRID[PD_GRID.index(w) + 1]
    assert _meets(PDController(bandwidth_rad_s=w), rigid)
    assert _meets(PDController(bandwidth_rad_s=w), plant, structural=True)
    assert not (
        _meets(PDController(bandwidth_rad_s=above), rigid)
        and _meets(PDController(bandwidth_rad_s=above), plant, structural=True)
    )


def test_ccc_coupling_meets_the_margins_and_the_slack(mill_tuned):
    plant, result, _ = mill_tuned
    w = result["pd"]["bandwidth_rad_s"]
    gains = result["controller_gains"]["ccc"]
    assert gains["W_i"] > 0 and result["ccc"]["tuning_rms_ratio_to_pd"] < 0.9
    ccc = CCCController(bandwidth_rad_s=w, **gains)
    assert meets_requirement(loop_margins(ccc, plant)) or _meets(ccc, plant)
    paths = plant_tuning_paths(plant.params)
    pd_runs = run_paths(plant, paths, lambda: PDController(bandwidth_rad_s=w))
    ccc_runs = run_paths(plant, paths, lambda: CCCController(bandwidth_rad_s=w, **gains))
    for r, b in zip(ccc_runs, pd_runs, strict=True):
        assert r["completed"] and r["max_um"] <= MAX_SLACK * b["max_um"]
        assert np.all(np.asarray(r["effort"]) <= EFFORT_SLACK * np.asarray(b["effort"]))
    ratio = np.mean([r["rms_um"] / b["rms_um"] for r, b in zip(ccc_runs, pd_runs, strict=True)])
    assert ratio == pytest.approx(result["ccc"]["tuning_rms_ratio_to_pd"], abs=1e-4)


def test_tuned_file_helps_on_a_circle_it_was_not_tuned_on(mill_tuned, tmp_path):
    """The ISO 230-4 circular test (R 50 mm, 0.2 m/s; the tuning circle is 30 mm) on the file
    with its controller_gains: ccc and pd run silently with the tuned defaults, and ccc's
    circular deviation is below pd's in both directions."""
    _, result, _ = mill_tuned
    path = tmp_path / "tuned.json"
    path.write_text(json.dumps({**MILL, "controller_gains": result["controller_gains"]}))

    def factory(spec):
        return lambda env: make_controller(spec, env=env).bind(env)

    with warnings.catch_warnings():
        warnings.simplefilter("error", UntunedGainsWarning)
        rep = run_circular_test(str(path), {"pd": factory("pd"), "ccc": factory("ccc")})
    res = rep["results"]
    for d in ("cw", "ccw"):
        assert res["ccc"][d]["completed"] and res["pd"][d]["completed"]
        assert res["ccc"][d]["circular_deviation_um"] < res["pd"][d]["circular_deviation_um"]


@pytest.mark.parametrize("axes", [2, 3])
def test_tuning_paths_within_the_plant(axes):
    names = ["x", "y", "z"][:axes]
    per_axis = {"mass": 300.0, "viscous": 400.0, "coulomb": 20.0, "static": 30.0}
    params = params_from_mapping({**MILL, **per_axis, "axes": names, "force_limit": 3000.0})
    paths = plant_tuning_paths(params)
    assert len(paths) == 2
    (label, ring, feed, acc, jerk), (_, corner, feed2, _, _) = paths
    assert feed <= 0.4 * max_circle_feed_m_s(params, 0.03) + 1e-12 and feed <= 0.25
    assert feed2 == pytest.approx(0.5 * feed)
    headroom = np.min((params.force_limit_N - params.static_N) / params.mass_kg)
    assert acc <= 0.25 * headroom + 1e-12 and acc <= 2.0 and jerk == pytest.approx(20 * acc)
    assert "r=30 mm" in label
    pts = corner.sample_points(200)
    if axes == 3:  # a 3-D path: all three axes move
        assert np.all(np.ptp(pts[:, :3], axis=0) > 1e-3)


def test_no_circle_possible_is_a_clear_error():
    params = params_from_mapping({**MILL, "coulomb": 3000.0, "static": 3000.0})
    with pytest.raises(ValueError, match="does not hold a circle of 30 mm"):
        plant_tuning_paths(params)


def test_max_bandwidth_bounds_the_search(mill_tuned):
    plant, result, _ = mill_tuned
    w = result["pd"]["bandwidth_rad_s"]
    bound = PD_GRID[PD_GRID.index(w) - 2]
    low = tune_plant_file(plant, ("pd",), max_bandwidth_rad_s=bound + 1.0)
    assert low["pd"]["bandwidth_rad_s"] == bound and "ccc" not in low["controller_gains"]
    with pytest.raises(ValueError, match="max_bandwidth_rad_s: at least 40 rad/s"):
        tune_plant_file(plant, ("pd",), max_bandwidth_rad_s=10.0)
