"""The contour-env command line, end to end (small cases)."""

import json

import pytest

from contour_env.app.cli import main


def test_cases_lists_every_named_case(capsys):
    assert main(["cases"]) == 0
    out = capsys.readouterr().out
    for name in (
        "hsm2-circle-I",
        "hsm2-circle-II",
        "hsm2-circle-III",
        "jee-circle3d",
        "lm-circle3d",
        "sharp-corner",
    ):
        assert name in out


def test_run_writes_json_and_plot(tmp_path, capsys):
    js, png = tmp_path / "r.json", tmp_path / "r.png"
    # PD: the zero command would be stopped by the tracking guard after 150 steps
    argv = ["run", "--case", "hsm2-circle-III", "--controller", "pd"]
    assert main([*argv, "--json", str(js), "--plot", str(png)]) == 0
    data = json.loads(js.read_text())
    assert data["case"] == "hsm2-circle-III"
    m = data["metrics"]
    assert m["n_steps"] > 900 and m["max_contour_error_um"] >= 0
    assert png.stat().st_size > 10_000
    assert "max_contour_error_um" in capsys.readouterr().out


def test_run_gcode_file(tmp_path):
    f = tmp_path / "sq.nc"
    f.write_text("G21 G90 G17 G61\nG01 X5 Y0 F300\nG01 X5 Y5\n")
    js = tmp_path / "g.json"
    assert main(["run", "--plant", "friction-table", "--gcode", str(f), "--json", str(js)]) == 0
    assert json.loads(js.read_text())["plant"] == "friction-table"


def test_run_unknown_case_is_a_clean_error(capsys):
    assert main(["run", "--case", "nope"]) == 2
    assert "unknown case 'nope'" in capsys.readouterr().err


def test_gcode_without_plant_is_a_clean_error():
    with pytest.raises(SystemExit, match="--gcode needs --plant"):
        main(["run", "--gcode", "x.nc"])


def test_bench_small(tmp_path, monkeypatch):
    from contour_env.app import speed as bench

    # the exploration/contended rows at 8 envs; the controller rows are tested below (the
    # full bench's 4096-env controller row compiles the parallel loop: minutes)
    res = bench.run_bench(
        "hsm2-circle-III", seconds=0.05, sizes=(1, 8), repeats=3, extra_envs=8, controllers=False
    )
    assert res["single_env_steps_per_s"] > 0
    assert [r["num_envs"] for r in res["vector"]] == [1, 8]
    assert "CartPole" in bench.format_bench(res)
    # each figure is the median of its alternating windows, all of them kept
    for row in res["vector"]:
        runs = row["env_steps_per_s_runs"]
        assert len(runs) == 3 and len(row["cartpole_env_steps_per_s_runs"]) == 3
        assert row["env_steps_per_s"] == sorted(runs)[1]
    assert len(res["single_env_steps_per_s_runs"]) == 3
    # the ratios to CartPole: the median of the window pairs' ratios, stored in the JSON
    pairs = [
        a / b
        for a, b in zip(
            res["single_env_steps_per_s_runs"], res["cartpole_single_steps_per_s_runs"], strict=True
        )
    ]
    assert res["single_ratio_to_cartpole"] == sorted(pairs)[1]
    for row in res["vector"] + [res["contended"]]:
        assert row["ratio_to_cartpole"] == sorted(row["ratio_to_cartpole_runs"])[1]
        assert len(row["ratio_to_cartpole_runs"]) == 3
    assert res["machine"]["cpu_count"] and "commit" in res["code"]
    assert res["load_average_at_start"] is None or len(res["load_average_at_start"]) == 3
    json.dumps(res, allow_nan=False)  # what --json writes


def test_bench_controller_rows_quick():
    from contour_env.app.speed_controllers import controller_rates

    rows = controller_rates(quick=True)
    assert [label for label, _ in rows] == ["controller in the loop, single env (pd), steps/s"]
    assert all(rate > 0 for _, rate in rows)


@pytest.mark.parametrize(
    "kwargs, word", [({"repeats": 0}, "repeats"), ({"seconds": 0.0}, "seconds")]
)
def test_bench_rejects_bad_settings(kwargs, word):
    from contour_env.app import speed as bench

    with pytest.raises(ValueError, match=word):
        bench.run_bench("hsm2-circle-III", sizes=(1,), **kwargs)


def test_run_with_pd_controller(tmp_path):
    js = tmp_path / "pd.json"
    assert main(["run", "--case", "hsm2-circle-I", "--controller", "pd", "--json", str(js)]) == 0
    data = json.loads(js.read_text())
    assert data["controller"] == "pd"
    assert 0 < data["metrics"]["rms_contour_error_um"] < 500


def test_run_unknown_controller_is_a_clean_error(capsys):
    assert main(["run", "--case", "hsm2-circle-I", "--controller", "nope"]) == 2
    assert "unknown controller 'nope'" in capsys.readouterr().err


def test_stability_reports_jee_limit_and_writes_json(tmp_path, capsys):
    js = tmp_path / "s.json"
    assert main(["stability", "--plant", "jee-triaxial", "--json", str(js)]) == 0
    out = capsys.readouterr().out
    assert "16.639855" in out
    rep = json.loads(js.read_text())
    assert rep["axial_gain_limit_per_s"] == pytest.approx(16.64, abs=5e-3)
    sim = rep["simulation"]
    assert sim["stable_below"] and sim["diverged_above"]
    ratios = [r["contour_ratio"] for r in rep["steady_state"]]
    assert sum(abs(r - 1.0) < 0.1 for r in ratios) >= 2


def test_stability_custom_params_file(tmp_path, capsys):
    f = tmp_path / "p.json"
    f.write_text(
        json.dumps(
            {
                "mass": [0.01, 0.02],
                "viscous": [1.0, 1.0],
                "force_limit": 1e3,
                "servo_period": 1e-3,
                "input_kind": "velocity-command",
            }
        )
    )
    assert main(["stability", "--params", str(f), "--feedrates", "5,10"]) == 0
    out = capsys.readouterr().out
    assert "custom" in out and "2016.8" in out


def test_stability_bad_inputs_are_clean_errors(tmp_path, capsys):
    assert main(["stability", "--plant", "nope"]) == 2
    assert "known plants" in capsys.readouterr().err
    assert main(["stability", "--feedrates", "5,fast"]) == 2
    assert "--feedrates" in capsys.readouterr().err


def test_ilc_writes_json_plot_and_state_and_continues(tmp_path, capsys):
    g = tmp_path / "corner.nc"
    g.write_text("G21 G90 G17 G61\nG01 X3 F1200\nG01 Y3\n")
    js, png, st = tmp_path / "i.json", tmp_path / "i.png", tmp_path / "s.npz"
    base = ["ilc", "--plant", "friction-table", "--gcode", str(g), "--controller", "ilc-contour"]
    assert (
        main([*base, "--iterations", "4", "--json", str(js), "--plot", str(png), "--save", str(st)])
        == 0
    )
    data = json.loads(js.read_text())
    rows = data["iterations"]
    assert [r["iteration"] for r in rows] == [1, 2, 3, 4]
    assert rows[-1]["rms_contour_error_um"] < rows[0]["rms_contour_error_um"]
    assert png.stat().st_size > 10_000 and st.stat().st_size > 0
    assert main([*base, "--iterations", "1", "--load", str(st)]) == 0
    assert (
        main(["ilc", "--case", "sharp-corner", "--controller", "ilc-contour", "--load", str(st)])
        == 2
    )
    assert "does not match the learning state" in capsys.readouterr().err


def test_ilc_rejects_a_controller_that_does_not_learn(capsys):
    assert main(["ilc", "--case", "sharp-corner", "--controller", "pd"]) == 2
    assert "learning controllers: ilc-pd, ilc-contour, vilcfd" in capsys.readouterr().err


def test_compare_controller_variants_are_rows_labelled_as_typed(tmp_path, capsys):
    js = tmp_path / "v.json"
    argv = ["compare", "--case", "hsm2-circle-I", "--controllers", "pd,pd:w=60", "--json", str(js)]
    assert main(argv) == 0
    rows = json.loads(js.read_text())["results"]
    assert [r["controller"] for r in rows] == ["pd", "pd:w=60"]
    assert rows[0]["rms_contour_error_um"] != pytest.approx(rows[1]["rms_contour_error_um"])
    for r in rows:
        assert r["encoder_resolution_um"] == pytest.approx(2.0)  # hsm2: x counts 2 µm
        assert r["below_resolution"] in (True, False)
    out = capsys.readouterr().out
    assert "pd:w=60" in out and "RMS/PD" in out


@pytest.mark.parametrize(
    "argv, words",
    [
        (["compare", "--controllers", "pd,ccc:wx=1"], "unknown parameter 'wx' of 'ccc'"),
        (["compare", "--controllers", "pd,ccc:wp=nan"], "wp must be a number"),
        (["compare", "--controllers", "pd,residual:x=1"], "residual takes no parameters"),
        (["run", "--controller", "pd:w"], "'w' is not key=value"),
        (["ilc", "--controller", "pd:w=80"], "learning controllers: ilc-pd"),
        (["ilc", "--controller", "vilcfd:friction=maybe"], "friction must be true or false"),
    ],
)
def test_bad_controller_variants_are_clean_errors(argv, words, capsys):
    assert main([*argv, "--case", "hsm2-circle-I"]) == 2
    assert words in capsys.readouterr().err


def test_run_and_ilc_accept_variants(tmp_path, capsys):
    js = tmp_path / "r.json"
    argv = ["run", "--case", "hsm2-circle-I", "--controller", "ccc:wp=3e4:wd=20", "--json", str(js)]
    assert main(argv) == 0
    assert json.loads(js.read_text())["controller"] == "ccc:wp=3e4:wd=20"
    g = tmp_path / "corner.nc"
    g.write_text("G21 G90 G17 G61\nG01 X3 F1200\nG01 Y3\n")
    ji = tmp_path / "i.json"
    spec = "ilc-contour:gn=1.2:q=20"
    argv = ["ilc", "--plant", "friction-table", "--gcode", str(g), "--controller", spec]
    assert main([*argv, "--iterations", "2", "--json", str(ji)]) == 0
    data = json.loads(ji.read_text())
    assert data["controller"] == spec
    assert all(r["encoder_resolution_um"] == pytest.approx(0.1) for r in data["iterations"])
    assert all(r["below_resolution"] is False for r in data["iterations"])


def test_controllers_command_lists_every_parameter_with_units(capsys):
    assert main(["controllers"]) == 0
    out = capsys.readouterr().out
    for name in ("pd", "ccc", "adaptive-ccc", "jee-ccc", "ilc-pd", "ilc-contour", "vilcfd"):
        assert f"\n{name}" in out
    assert "wp" in out and "1/s²" in out and "gamma_m" in out and "rad/s" in out
