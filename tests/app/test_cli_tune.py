"""``contour-env tune`` end to end: a plant file gets ``controller_gains`` (PD's ω and CCC's
coupling under the margin constraints), the controllers take them silently as defaults on it,
and bad input is one line naming the option, exit 2."""

from __future__ import annotations

import json

import pytest

from contour_env.app.cli import main

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
    "notes": "a mill of ours",
}


@pytest.fixture
def mill(tmp_path):
    path = tmp_path / "mill.json"
    path.write_text(json.dumps(MILL))
    return path


def _ball(plant, out, capsys):
    argv = ["circular-test", "--plant", str(plant), "--controllers", "pd,ccc", "--radius", "0.04"]
    assert main([*argv, "--feed", "0.1", "--json", str(out)]) == 0
    err = capsys.readouterr().err
    return json.loads(out.read_text())["results"], err


def test_tune_writes_gains_the_controllers_take(mill, tmp_path, capsys):
    tuned, rep = tmp_path / "tuned.json", tmp_path / "rep.json"
    argv = ["tune", "--plant", str(mill), "--out", str(tuned), "--json", str(rep)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "pd: ω = " in out and "ccc: W_p = " in out and f"wrote {tuned}" in out
    assert "no two-mass mode" in out  # what the file cannot show is said
    data, report = json.loads(tuned.read_text()), json.loads(rep.read_text())
    gains = data.pop("controller_gains")
    assert gains == report["controller_gains"]
    assert gains["pd"]["bandwidth_rad_s"] == report["pd"]["bandwidth_rad_s"]
    assert set(gains["ccc"]) == {"W_p", "W_i", "W_d"} and gains["ccc"]["W_i"] > 0
    assert data.pop("notes").startswith("a mill of ours controller_gains by contour-env tune")
    assert data == {k: v for k, v in MILL.items() if k != "notes"}  # the plant is unchanged
    # untuned: a one-line warning per controller; tuned: silent, and ccc beats pd
    res0, err0 = _ball(mill, tmp_path / "b0.json", capsys)
    assert err0.count("warning: pd: no tuned gains for plant 'my-mill'") == 1
    assert err0.count("warning: ccc: no tuned gains for plant 'my-mill'") == 1
    res, err = _ball(tuned, tmp_path / "b1.json", capsys)
    assert "warning" not in err
    for d in ("cw", "ccw"):
        assert res["ccc"][d]["circular_deviation_um"] < res["pd"][d]["circular_deviation_um"]
        # untuned ccc is pd (no coupling): the tuned coupling is what made the difference
        assert res0["ccc"][d]["circular_deviation_um"] == res0["pd"][d]["circular_deviation_um"]


def test_tune_in_place_and_pd_only(mill, capsys):
    argv = ["tune", "--plant", str(mill), "--out", str(mill), "--controllers", "pd"]
    assert main([*argv, "--max-bandwidth", "100"]) == 0
    gains = json.loads(mill.read_text())["controller_gains"]
    assert list(gains) == ["pd"] and gains["pd"]["bandwidth_rad_s"] <= 100
    assert main(["tune", "--plant", str(mill), "--out", str(mill), "--controllers", "pd"]) == 0
    again = json.loads(mill.read_text())
    assert again["controller_gains"]["pd"]["bandwidth_rad_s"] >= gains["pd"]["bandwidth_rad_s"]
    assert again["notes"].count("contour-env tune") == 2  # each run is recorded


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        (["--plant", "hsm2"], "--plant: 'hsm2' is a named plant"),
        (["--plant", "five-axis"], "--plant: 'five-axis' is a named plant"),
        (["--plant", "nope.json"], "nope.json: no such file (plant file)"),
        (["--controllers", "pd,ilc"], "--controllers: ilc; allowed: pd, ccc"),
        (["--max-bandwidth", "10"], "--max-bandwidth: at least 40 rad/s"),
    ],
)
def test_bad_input_one_line(mill, tmp_path, capsys, extra, expected):
    out = tmp_path / "t.json"
    argv = ["tune", "--plant", str(mill), "--out", str(out), *extra]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and expected in err and "\n" not in err
    assert not out.exists()


def test_out_a_folder_is_refused_before_the_search(mill, tmp_path, capsys):
    assert main(["tune", "--plant", str(mill), "--out", str(tmp_path)]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("error: --out") and "\n" not in err
    assert "pd: ω" not in captured.out  # refused before any work
