"""The CLI's bad-input catalogue: every bad input is one line ``error: …`` and a non-zero exit,
never a traceback (issue 20 item 4: unusable output paths, models --dir)."""

import pytest

from contour_env.app.cli import main
from contour_env.io import OutputPathError, atomic_write_json, check_output_dir


def _fails(argv, capsys, *fragments):
    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse and _target_kwargs: message already printed
        rc = exc.code if isinstance(exc.code, int) else 1
        err = capsys.readouterr().err + ("" if isinstance(exc.code, int) else str(exc.code))
    else:
        err = capsys.readouterr().err
    assert rc != 0, argv
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert "Traceback" not in err
    assert lines[-1].startswith("error:") or "error:" in lines[-1], err
    for frag in fragments:
        assert frag in err, (frag, err)
    return err


@pytest.fixture
def a_file(tmp_path):
    p = tmp_path / "plain.txt"
    p.write_text("x")
    return p


def test_json_under_a_file(a_file, capsys):
    err = _fails(
        ["run", "--case", "hsm2-circle-II", "--json", str(a_file / "m.json")],
        capsys,
        "--json",
        str(a_file / "m.json"),
    )
    assert err.count("\n") == 1


def test_json_naming_a_directory(tmp_path, capsys):
    _fails(
        ["run", "--case", "hsm2-circle-II", "--json", str(tmp_path)],
        capsys,
        "--json",
        "is a directory",
    )


def test_plot_under_a_file(a_file, capsys):
    _fails(["run", "--case", "hsm2-circle-II", "--plot", str(a_file / "p.png")], capsys, "--plot")


def test_train_out_under_a_file(a_file, capsys):
    _fails(
        ["train", "--case", "hsm2-circle-II", "--out", str(a_file / "run"), "--timesteps", "10"],
        capsys,
        "--out",
        str(a_file / "run"),
    )


def test_train_out_is_a_file(a_file, capsys):
    _fails(
        ["train", "--case", "hsm2-circle-II", "--out", str(a_file), "--timesteps", "10"],
        capsys,
        "--out",
        "not a directory",
    )


@pytest.mark.parametrize("kind", ["missing", "file"])
def test_models_dir_that_is_not_a_folder(tmp_path, a_file, capsys, kind):
    d = tmp_path / "nonexistent" if kind == "missing" else a_file
    _fails(["models", "--dir", str(d)], capsys, "--dir", str(d))


def test_models_dir_that_is_an_empty_folder_lists_nothing(tmp_path, capsys):
    assert main(["models", "--dir", str(tmp_path)]) == 0
    assert "no trained agents" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["run", "--case", "nope"], "unknown case"),
        (["run", "--case", "hsm2-circle-II", "--feedrate", "-1"], "feedrate_m_s"),
        (["run", "--case", "hsm2-circle-II", "--feedrate", "nan"], "feedrate_m_s"),
        (["run", "--case", "hsm2-circle-II", "--controller", "nope"], "nope"),
        (["run", "--plant", "hsm2", "--gcode", "/nonexistent/part.nc"], "part.nc"),
        (["run", "--plant", "nope", "--gcode", "/nonexistent/part.nc"], ""),
        (["run", "--case", "hsm2-circle-II", "--rapid-feed", "0"], "rapid"),
        (["run", "--case", "hsm2-circle-II", "--seed", "x"], "--seed"),
    ],
)
def test_bad_input_catalogue(argv, fragment, capsys):
    _fails(argv, capsys, fragment)


def test_gcode_naming_a_directory(tmp_path, capsys):
    d = tmp_path / "prog.nc"
    d.mkdir()
    _fails(["run", "--plant", "hsm2", "--gcode", str(d)], capsys)


def test_io_raises_output_path_error_naming_the_path(a_file, tmp_path):
    with pytest.raises(OutputPathError, match="is not a directory"):
        atomic_write_json(a_file / "x.json", {})
    with pytest.raises(OutputPathError, match="it is a directory"):
        atomic_write_json(tmp_path, {})
    with pytest.raises(OutputPathError, match="not a directory"):
        check_output_dir(a_file)
    assert check_output_dir(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"
    assert not (tmp_path / "new").exists()  # checking creates nothing
    assert isinstance(OutputPathError("p", "r"), ValueError)
