"""``contour-env excite`` → ``contour-env identify`` → ``--plant plant.json`` end to end, and
the bad-trace errors: one line naming the file and the column or row, exit 2, no traceback."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from contour_env.app.cli import main

SIM_COLUMNS = ",".join(
    f"{k}_{a}=simulated_{k}_{a}" for a in ("x", "y") for k in ("command", "position")
)


@pytest.fixture(scope="module")
def excitation(tmp_path_factory):
    """The friction table's excitation program with its simulated response (seeded)."""
    out = tmp_path_factory.mktemp("excite") / "excite.csv"
    assert main(["excite", "--plant", "friction-table", "--out", str(out), "--seed", "1"]) == 0
    return out


@pytest.fixture(scope="module")
def good_trace(excitation, tmp_path_factory):
    """A trace in the documented format (header time_s,command_x,position_x,...)."""
    with open(excitation, newline="") as fh:
        rows = list(csv.reader(fh))
    h = rows[0]
    keep = ["time_s"] + [f"simulated_{k}_{a}" for a in ("x", "y") for k in ("command", "position")]
    idx = [h.index(c) for c in keep]
    out = tmp_path_factory.mktemp("trace") / "trace.csv"
    lines = ["time_s,command_x,position_x,command_y,position_y"]
    lines += [",".join(r[i] for i in idx) for r in rows[1:]]
    out.write_text("\n".join(lines) + "\n")
    return out


def test_excite_writes_the_program_within_the_plant_limits(excitation, capsys):
    with open(excitation, newline="") as fh:
        rows = list(csv.reader(fh))
    header, data = rows[0], np.array(rows[1:], dtype=float)
    col = {h: data[:, j] for j, h in enumerate(header)}
    assert header[0] == "time_s" and np.allclose(np.diff(col["time_s"]), 1e-3)
    from contour_env.plants import Plant

    limit = Plant("friction-table").params.force_limit_N
    for j, a in enumerate(("x", "y")):
        ref = col[f"reference_position_{a}"]
        assert np.ptp(ref) <= 0.1 + 1e-12  # the default travel, m
        u = col[f"simulated_command_{a}"]
        assert np.max(np.abs(u)) < limit[j]  # within the force limit
        v = col[f"reference_velocity_{a}"]
        assert np.count_nonzero(np.diff(np.sign(v[v != 0])) != 0) >= 20  # many reversals


def test_identify_writes_a_plant_the_cli_and_gym_load(good_trace, tmp_path, capsys):
    plant, js, png = tmp_path / "plant.json", tmp_path / "report.json", tmp_path / "fit.png"
    argv = ["identify", "--trace", str(good_trace), "--out", str(plant)]
    assert main([*argv, "--json", str(js), "--plot", str(png), "--max-samples", "15000"]) == 0
    out = capsys.readouterr().out
    assert "axis x:" in out and "held-out error" in out and f"wrote {plant}" in out
    assert png.stat().st_size > 10_000
    data = json.loads(plant.read_text())
    assert data["axes"] == ["x", "y"] and data["computation_delay"] is True
    assert data["mass"] == pytest.approx([46.2, 32.4], rel=0.05)  # the friction table's
    # what the trace covered, for contour-env train --plant: the excitation's ±40 mm stroke
    assert data["travel"] == pytest.approx([0.04, 0.04], rel=0.02)
    lo, hi = data["feed_range"]
    assert hi == pytest.approx(10 * lo) and 0.02 < hi < 0.2
    assert 0.1 < data["max_acceleration"] < 5.0
    assert data["servo_period"] == 0.001  # rounded to 12 digits, not 0.001000000000000112
    rep = json.loads(js.read_text())
    assert {"axes", "warnings"} <= set(rep)
    # the file is a plant for the circular test (and every --plant)
    ball = tmp_path / "ballbar.json"
    argv = ["circular-test", "--plant", str(plant), "--controllers", "pd", "--radius", "0.01"]
    assert main([*argv, "--feed", "0.02", "--overshoot", "10", "--json", str(ball)]) == 0
    res = json.loads(ball.read_text())
    assert res["plant"] == "identified" and res["results"]["pd"]["cw"]["completed"]


def _write(path, header, rows):
    path.write_text("\n".join([header] + [",".join(r) for r in rows]) + "\n")
    return path


@pytest.fixture(scope="module")
def rows(good_trace):
    with open(good_trace, newline="") as fh:
        r = list(csv.reader(fh))
    return r[0], r[4001:7001]  # 3 s from the friction sweep (both axes moving)


def _bad(tmp_path, rows, kind):
    header, body = rows
    body = [list(r) for r in body]
    h = ",".join(header)
    if kind == "missing":
        return _write(tmp_path / "t.csv", ",".join(header[:4]), [r[:4] for r in body])
    if kind == "time":
        body[499][0] = body[497][0]  # line 501 of the file goes back in time
    elif kind == "nan":
        body[699][2] = "nan"  # line 701, position_x
    elif kind == "short":
        body = body[:400]
    elif kind == "reverse":
        for r in body:
            r[1] = str(abs(float(r[1])))
    elif kind == "gap":
        del body[999]  # a missing sample: line 1001 is two periods after line 1000
    elif kind == "glitch":
        body[1499][2] = "1e308"  # line 1501, position_x: one glitch, finite
    elif kind == "micrometres":
        for r in body:
            r[2], r[4] = repr(float(r[2]) * 1e6), repr(float(r[4]) * 1e6)
    elif kind == "command1e30":
        for r in body:
            r[1] = repr(float(r[1]) * 1e30)
    return _write(tmp_path / "t.csv", h, body)


@pytest.mark.parametrize(
    ("kind", "expected"),
    [
        ("missing", "missing column 'position_y'"),
        ("time", "line 501: time_s"),
        ("nan", "line 701, column 'position_x': not a finite number ('nan')"),
        ("short", "400 rows, too short to identify"),
        ("reverse", "column 'command_x': the command never reverses"),
        ("gap", "line 1001: time step"),
        # issue 49, items 3, 9, 10: ranges checked before any fit, naming the line and value
        ("glitch", "line 1501, column 'position_x': 1e+308 m is outside [-100, 100] m (the only "
         "row outside: a glitch? remove or repair that row)"),
        ("micrometres", "m is outside [-100, 100] m"),
        ("command1e30", "column 'command_x': "),
    ],
)  # fmt: skip
def test_bad_trace_one_line_error(tmp_path, rows, capsys, kind, expected):
    trace = _bad(tmp_path, rows, kind)
    code = main(["identify", "--trace", str(trace), "--out", str(tmp_path / "p.json")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert expected in err and "t.csv" in err
    assert not (tmp_path / "p.json").exists()
    if kind == "micrometres":
        assert "positions are in metres: a trace in µm or mm?" in err
    if kind == "command1e30":
        assert "N is outside [-1e+07, 1e+07] N" in err and "--force-constant" in err


def test_a_micrometre_trace_is_refused_before_the_scan_and_the_scan_is_bounded():
    from contour_env.identify.regression import MAX_SCAN_POINTS, _grid

    # the ripple scan of a 2e5 "m" stroke asked for 8e8 wavenumbers (2.8 GB and growing)
    span = 2e5
    k = _grid(2 * np.pi / (0.5 * span), 2 * np.pi / 1e-3, 2 * np.pi / (4.0 * span))
    assert len(k) == MAX_SCAN_POINTS
    small = _grid(1.0, 2.0, 0.25)
    np.testing.assert_array_equal(small, [1.0, 1.25, 1.5, 1.75])


def test_columns_map_other_names(tmp_path, rows, capsys):
    header, body = rows
    renamed = ["t", "ux", "enc_x", "uy", "enc_y"]
    trace = _write(tmp_path / "renamed.csv", ",".join(renamed), body)
    cols = "time_s=t,command_x=ux,position_x=enc_x,command_y=uy,position_y=enc_y"
    from contour_env.identify import read_trace

    tr = read_trace(trace, columns=cols)
    assert tr.axes == ("x", "y") and tr.n_rows == len(body)
    assert tr.columns == {"x": ("ux", "enc_x"), "y": ("uy", "enc_y")}
    with pytest.raises(ValueError, match="--columns names a column the header does not have"):
        read_trace(trace, columns="command_x=nope")


def test_force_constant_scales_the_commands(tmp_path, rows):
    from contour_env.identify import read_trace

    header, body = rows
    trace = _write(tmp_path / "amps.csv", ",".join(header), body)
    n = read_trace(trace)
    a = read_trace(trace, force_constant="2.5,4")
    assert np.allclose(a.command, n.command * [2.5, 4.0])
    with pytest.raises(ValueError, match="--force-constant"):
        read_trace(trace, force_constant="-1")


def test_excite_bad_axis_and_plant(tmp_path, capsys):
    assert main(["excite", "--plant", "hsm2", "--axis", "q", "--out", str(tmp_path / "e.csv")]) == 2
    err = capsys.readouterr().err
    assert "axis" in err and "x, y" in err and len(err.strip().splitlines()) == 1
    code = main(
        ["excite", "--plant", str(tmp_path / "nope.json"), "--out", str(tmp_path / "e.csv")]
    )
    assert code == 2 and "no such file" in capsys.readouterr().err
