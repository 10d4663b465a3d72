"""``--gcode`` names a file, always (issue 36 item 1): a missing one is one line
``error: --gcode: no such file: VALUE`` and a non-zero exit, whatever the value looks like;
an existing one is read whatever its name or extension."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from contour_env.app.cli import main
from contour_env.paths.gcode import read_gcode

CORPUS = Path(__file__).resolve().parents[1] / "data" / "gcode"


def _exit_message(argv, capsys) -> str:
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code not in (0, None)
    msg = str(e.value.code)
    assert "\n" not in msg and "Traceback" not in capsys.readouterr().err
    return msg


@pytest.mark.parametrize(
    "value", ["G1X5F600", "G1 X5 F600", "jobs_g2/lathe_jaws.cnc", "G1_parts/shapeoko.txt"]
)
def test_missing_gcode_file_is_one_line_and_a_non_zero_exit(value, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = ["run", "--plant", "hsm2", "--gcode", value, "--controller", "pd"]
    assert _exit_message(argv, capsys) == f"error: --gcode: no such file: {value}"


def test_gcode_naming_a_folder(tmp_path, capsys):
    msg = _exit_message(["run", "--plant", "hsm2", "--gcode", str(tmp_path)], capsys)
    assert msg == f"error: --gcode: not a file: {tmp_path}"


def test_train_gcode_is_a_file_too(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = ["train", "--plant", "hsm2", "--gcode", "G1X5F600", "--out", str(tmp_path / "r")]
    assert _exit_message(argv, capsys) == "error: --gcode: no such file: G1X5F600"
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("name", ["shapeoko_outline.txt", "router_job.cnc"])
def test_existing_file_runs_whatever_its_name(name, tmp_path, capsys):
    # a folder whose name holds a G1 and a file without a G-code extension of its own
    folder = tmp_path / "G1_parts"
    folder.mkdir()
    f = folder / name
    shutil.copyfile(CORPUS / name, f)
    js = tmp_path / "m.json"
    argv = ["run", "--plant", "friction-table", "--gcode", str(f), "--controller", "pd"]
    assert main([*argv, "--json", str(js)]) == 0
    out = capsys.readouterr().out
    expected = read_gcode(CORPUS / name).planar_xy().path.total_length
    assert f"case {name}: plant friction-table" in out
    assert f"path length {expected:.4f} m" in out
    assert json.loads(js.read_text())["metrics"]["completed"] is True
