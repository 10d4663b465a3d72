"""The Python API's rule for ``path=``: a G-code file or program text
(contour_env.paths.gcode_source; issue 36 item 1)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from contour_env.cases import build_setup
from contour_env.paths.gcode import read_gcode
from contour_env.paths.gcode_source import is_program_text

CORPUS = Path(__file__).resolve().parent.parent / "data" / "gcode"


@pytest.mark.parametrize(
    "value, text",
    [
        ("G1 X5 F600", True),
        ("G1X5F600", True),
        ("g01 x5 f600", True),
        ("X5\nY5", True),
        ("part.nc", False),
        ("G1_parts/shapeoko.txt", False),  # a usual extension: a file, though it has "G1"
        ("jobs_g2/lathe_jaws.cnc", False),
        ("PART.MPF", False),
        ("part", False),
        (Path("G1 X5 F600"), False),  # an os.PathLike is always a file
    ],
)
def test_program_text_or_file(value, text):
    assert is_program_text(value) is text


def test_an_existing_file_is_a_file_whatever_its_name(tmp_path, monkeypatch):
    folder = tmp_path / "G1_parts"
    folder.mkdir()
    shutil.copyfile(CORPUS / "shapeoko_outline.txt", folder / "G2 job")
    monkeypatch.chdir(tmp_path)
    assert is_program_text("G2 job") is True  # no such file here: program text
    assert is_program_text("G1_parts/G2 job") is False  # it exists: the file
    setup = build_setup(plant="hsm2", path="G1_parts/G2 job")
    assert setup.name == "G2 job"
    expected = read_gcode(folder / "G2 job").planar_xy().path
    np.testing.assert_array_equal(setup.path.seg_data, expected.seg_data)


def test_api_text_and_missing_files():
    setup = build_setup(plant="hsm2", path="G1 X5 F600")
    assert setup.path.total_length == pytest.approx(0.005, rel=1e-12)
    for missing in ("G1_parts/shapeoko.txt", "no_such_program"):
        with pytest.raises(FileNotFoundError, match="G-code file not found"):
            build_setup(plant="hsm2", path=missing)
