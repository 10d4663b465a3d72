"""``contour-env circular-test`` end to end (a small circle on hsm2) and its bad-input errors:
one line naming the option, exit 2, no traceback, nothing run."""

from __future__ import annotations

import contextlib
import io
import json

import pytest

from contour_env.app.cli import build_parser, main

# a tiny test: r = 20 mm at 0.1 m/s, 45° overshoot arcs (1.9 s of path per direction)
TINY = ["--plant", "hsm2", "--radius", "0.02", "--feed", "0.1", "--overshoot", "45"]


def test_circular_test_writes_json_and_png(tmp_path, capsys):
    js, png = tmp_path / "out" / "ballbar.json", tmp_path / "ballbar.png"
    argv = ["circular-test", *TINY, "--controllers", "pd,ccc", "--json", str(js)]
    assert main([*argv, "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "ISO 230-4 circular test" in out and f"wrote {js}" in out and f"wrote {png}" in out
    data = json.loads(js.read_text())
    assert data["plant"] == "hsm2" and data["radius_m"] == 0.02 and data["feed_m_s"] == 0.1
    assert data["overshoot_deg"] == 45.0 and data["units"]["deviations"] == "µm"
    assert list(data["results"]) == ["pd", "ccc"]
    for label, row in data["results"].items():
        assert set(row) == {"cw", "ccw", "hysteresis_um"}
        assert row["hysteresis_um"] >= 0
        for d in ("cw", "ccw"):
            r = row[d]
            assert r["completed"], (label, d)
            assert r["circular_deviation_um"] >= 0
            assert r["radial_deviation_max_um"] >= r["radial_deviation_min_um"]
            spikes = r["reversal_spikes_um"]
            assert [(s["angle_deg"], s["axis"]) for s in spikes] == [
                (0.0, "x"),
                (90.0, "y"),
                (180.0, "x"),
                (270.0, "y"),
            ]
            assert all(isinstance(s["height_um"], float) for s in spikes)
    res = data["results"]
    assert res["ccc"]["cw"]["circular_deviation_um"] < res["pd"]["cw"]["circular_deviation_um"]
    head = png.read_bytes()
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and len(head) > 20_000
    # atomic writes: no temporary file left beside the outputs
    assert sorted(p.name for p in js.parent.iterdir()) == ["ballbar.json"]


def test_one_controller_and_a_plant_file(tmp_path, capsys):
    plant = tmp_path / "table.json"
    plant.write_text(
        json.dumps(
            {
                "name": "my-table",
                "axes": ["x", "y"],
                "mass": [40, 35],
                "viscous": [50, 50],
                "force_limit": 1500,
                "servo_period": 0.001,
            }
        )
    )
    js = tmp_path / "t.json"
    argv = ["circular-test", "--plant", str(plant), "--controller", "pd", "--radius", "0.02"]
    assert main([*argv, "--feed", "0.1", "--overshoot", "45", "--json", str(js)]) == 0
    data = json.loads(js.read_text())
    assert data["plant"] == "my-table" and data["plant_file"] == str(plant)
    assert list(data["results"]) == ["pd"] and data["results"]["pd"]["ccw"]["completed"]


def test_the_subcommand_has_help():
    with contextlib.redirect_stdout(io.StringIO()) as out, pytest.raises(SystemExit) as exc:
        build_parser().parse_args(["circular-test", "-h"])
    assert exc.value.code == 0
    for option in ("--radius", "--feed", "--overshoot", "--controllers", "--plot", "--json"):
        assert option in out.getvalue()


@pytest.fixture
def one_axis_plant(tmp_path):
    p = tmp_path / "one.json"
    p.write_text(json.dumps({"axes": ["x"], "mass": 10, "force_limit": 100, "servo_period": 1e-3}))
    return str(p)


@pytest.mark.parametrize(
    "args,fragments",
    [
        (["--radius", "-0.01"], ["--radius: must be > 0", "got -0.01"]),
        (["--radius", "0"], ["--radius: must be > 0"]),
        (["--feed", "0"], ["--feed: must be > 0"]),
        (["--feed", "2"], ["--feed: must be > 0 and <= 0.", "on plant 'hsm2'", "force limit"]),
        (["--overshoot", "0"], ["--overshoot: must be > 0 and <= 360 degrees"]),
        (["--overshoot", "400"], ["--overshoot: must be > 0 and <= 360 degrees", "got 400"]),
        (["--overshoot", "2"], ["--overshoot:", "shorter than the feed ramp", "at least 18"]),
        (["--controllers", "pd,nope"], ["--controllers: unknown controller 'nope'", "ccc"]),
        (["--controller", "nope"], ["--controller: unknown controller 'nope'"]),
        (["--controllers", "jee-ccc"], ["--controllers:", "jee-ccc", "velocity-command"]),
        (["--controller", "pd", "--controllers", "ccc"], ["give one of them, not both"]),
        (["--plant", "nope"], ["--plant: unknown plant 'nope'", "hsm2"]),
        (["--plant", "five-axis"], ["--plant:", "five-axis", "not supported"]),
        (["--plant", "missing.json"], ["--plant: no such file: missing.json"]),
        (["--model", "somewhere"], ["--model:", "add residual"]),
        (["--seed", "-1"], ["--seed:"]),
        (
            ["--radius", "-1", "--feed", "-1", "--controllers", "zz"],
            ["--radius:", "--feed:", "--controllers:"],
        ),
    ],
)
def test_bad_input_is_one_line_naming_the_option(args, fragments, capsys):
    assert main(["circular-test", *args]) == 2
    cap = capsys.readouterr()
    err = cap.err.strip()
    assert err.startswith("error: ") and "\n" not in err and "Traceback" not in err
    for fragment in fragments:
        assert fragment in err
    assert cap.out == ""  # refused before any run


def test_a_one_axis_plant_is_not_supported(one_axis_plant, capsys):
    assert main(["circular-test", "--plant", one_axis_plant]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "error: --plant: a plant with 1 axis is not supported by the circular test: it needs "
        "2 or 3 axes (x, y)"
    )
