"""What a second corpus of real programs found in the G-code reader (issue 36 items 2-6, 15):
files of any extension, pauses before the first XY move, the program end, G53 without axis
words, the quoted line of an "unexpected character", the F range."""

from __future__ import annotations

import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from contour_env.cases import build_setup
from contour_env.paths.gcode import MAX_FEED_M_S, parse_gcode, read_gcode
from contour_env.paths.segments import Arc

CORPUS = Path(__file__).resolve().parent.parent / "data" / "gcode"
MM = 1e-3


# ------------------------------------------------------------------ 2: any extension
@pytest.mark.parametrize("name", ["router_job.cnc", "shapeoko_outline.txt"])
def test_cnc_and_txt_corpus_files_are_programs(name):
    prog = read_gcode(CORPUS / name)
    assert prog.source == str(CORPUS / name)
    assert prog.path.dim == 3  # both plunge in Z
    flat = prog.planar_xy()
    if name == "router_job.cnc":
        # the rectangle (10,10)-(60,40) after the rapid to (10,10): XY length 2 (50 + 30) mm
        # + the rapid's sqrt(2) * 10 mm
        expected = 2 * (50 + 30) * MM + np.sqrt(2) * 10 * MM
    else:
        # a semicircle of radius 10 mm, then 10 + 20 + 10 mm of lines
        expected = np.pi * 10 * MM + 40 * MM
        assert any(isinstance(s, Arc) for s in flat.segments)
    assert flat.path.total_length == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("ext", [".cnc", ".txt", ".mpf", ".eia", ".ptp", ".gcode", ""])
def test_a_file_is_read_whatever_its_extension(tmp_path, ext):
    p = tmp_path / f"part{ext}"
    shutil.copyfile(CORPUS / "router_job.cnc", p)
    a, b = read_gcode(CORPUS / "router_job.cnc"), read_gcode(p)
    np.testing.assert_array_equal(a.path.seg_data, b.path.seg_data)


def test_a_file_that_is_not_gcode_is_refused_by_content(tmp_path):
    prose = tmp_path / "notes.txt"
    prose.write_text("Remember to order more end mills.\nTool: 6 mm flat\n")
    with pytest.raises(ValueError, match=r"(?s)^G-code program has 2 bad lines \[.*notes\.txt\]"):
        read_gcode(prose)  # the reader names every bad line
    binary = tmp_path / "photo.nc"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR")
    with pytest.raises(
        ValueError, match=r"photo\.nc' is not a text file \(a NUL byte at offset 8\)"
    ):
        read_gcode(binary)
    with pytest.raises(ValueError, match="is a directory"):
        read_gcode(tmp_path)
    with pytest.raises(FileNotFoundError, match="nope.cnc"):
        read_gcode(tmp_path / "nope.cnc")


# ------------------------------------------------- 3: pauses before the first XY move
def test_dwell_and_z_moves_before_the_first_xy_move_are_pauses():
    prog = read_gcode(CORPUS / "dwell_first.ngc")
    # 3-axis: only the G4 P1.5 comes before the first move; G4 P0.5 follows the Z plunge
    assert prog.start_dwell_s == 1.5
    assert prog.segment_dwell_s[1] == 0.5
    flat = prog.planar_xy()
    # 2-axis, by hand: G4 P1.5; G0 Z10 at the rapid feed (highest F, 600 mm/min = 10 mm/s):
    # 1 s; G1 Z2 at 120 mm/min (2 mm/s): 8 mm in 4 s; G4 P0.5 -- all before the first XY move
    before = 1.5 + 10 / 10 + 8 / 2 + 0.5
    after = 8 / 10  # the last G0 Z10 from Z2: a pause after the last XY segment
    assert flat.start_dwell_s == pytest.approx(before, rel=1e-12)
    assert flat.segment_dwell_s.tolist() == pytest.approx([0, 0, 0, after], rel=1e-12)
    total = flat.start_dwell_s + flat.segment_dwell_s.sum()
    assert total == pytest.approx(7.8, rel=1e-12)  # the dwells + the Z-move durations
    assert "pauses 7.8 s in all" in flat.summary()
    assert "2 dwells" in flat.summary()


def test_pauses_before_the_first_xy_move_delay_the_reference():
    setup = build_setup(plant="hsm2", path=str(CORPUS / "dwell_first.ngc"))
    square = "G21 G90 G64 P0.01\nG1 X30 F600\nG1 Y30\nG1 X0\nG1 Y0\nM2\n"
    cut_only = build_setup(plant="hsm2", path=square)
    np.testing.assert_array_equal(setup.path.seg_data, cut_only.path.seg_data)
    # the same motion, 7 s later, and 0.8 s at rest at the end
    assert setup.profile.duration == pytest.approx(cut_only.profile.duration + 7.8, abs=1e-9)
    s, v, _ = setup.profile.sample(np.array([0.0, 3.0, 6.999]))
    assert s.tolist() == [0.0, 0.0, 0.0] and v.tolist() == [0.0, 0.0, 0.0]
    t = np.linspace(0.0, cut_only.profile.duration, 101)
    s_late, _, _ = setup.profile.sample(t + 7.0)
    s_now, _, _ = cut_only.profile.sample(t)
    np.testing.assert_allclose(s_late, s_now, rtol=0, atol=1e-12)
    # the reference stands on the start point through the pauses
    ref = setup.reference
    k = int(6.9 / setup.plant.servo_period_s)
    assert np.all(ref.position[:k] == ref.position[0])


# ------------------------------------------------------------ 4: the program end
def test_haas_program_with_m99_after_m30_reads_to_m30():
    prog = read_gcode(CORPUS / "haas_after_m30.nc")
    end = [n for n in prog.notes if n.word == "M30"]
    # M99, the comment line, G1 X50 and N100 G65 P9000 are not read (the '%' is no line)
    assert end[0].action == "program end: 4 lines after it not read"
    assert max(prog.segment_lines) < end[0].line
    assert prog.units == "inch"
    # the rapid to (-1, -1) inch, then the 2 x 2 inch square
    assert prog.planar_xy().path.total_length == pytest.approx((2**0.5 + 8) * 0.0254, rel=1e-12)


def test_checks_stop_at_the_program_end_after_an_error():
    text = (CORPUS / "haas_after_m30.nc").read_text()
    bad = text.replace("Y1.\n", "Y1. G41\n", 1)  # cutter compensation: refused
    bad_line = bad.splitlines().index("Y1. G41") + 1
    with pytest.raises(ValueError) as e:
        parse_gcode(bad)
    msg = str(e.value)
    # one bad line: the M99 and the G65 after M30 are not listed
    assert re.findall(r"G-code line (\d+):", msg) == [str(bad_line)]
    assert "M99" not in msg and "G65" not in msg
    # M2 ends the checks too; without an end every line is checked
    with pytest.raises(ValueError) as e:
        parse_gcode("G1 X1 F60\nG41\nM2\nM99\n")
    assert str(e.value).startswith("G-code line 2: unsupported word 'G41'")
    assert "line 4" not in str(e.value)
    with pytest.raises(ValueError, match=r"(?s)has 2 bad lines.*line 2.*line 3"):
        parse_gcode("G1 X1 F60\nG41\nM99\n")


# ------------------------------------------------------------------- 5: G53 alone
def test_g53_without_axis_words_is_a_modal_only_line():
    prog = read_gcode(CORPUS / "cam_post_g53.nc")
    g53 = [n for n in prog.notes if n.word == "G53"]
    assert [n.line for n in g53] == [5, 21]
    assert all(
        n.action == "ignored: machine coordinates without axis words (moves nothing)" for n in g53
    )
    # it moves nothing: the same path as the program without its G53 lines
    plain = (CORPUS / "cam_post_g53.nc").read_text().replace("G53 G00 G17", "G00 G17")
    np.testing.assert_array_equal(prog.path.seg_data, parse_gcode(plain).path.seg_data)
    # its modal words apply: G53 G00 sets rapid mode for the next axis word
    p2 = parse_gcode("G1 X1 F60\nG53 G00\nX2\n")
    assert p2.segment_is_rapid.tolist() == [False, True]
    for text in ("G53 G0 Z0", "G53 X10", "G53 G1 Y1 F60"):
        with pytest.raises(ValueError, match=r"line 2: unsupported word 'G53' \(move in machine"):
            parse_gcode("G1 X1 F60\n" + text)


# ------------------------------------------------------ 6: the line as written
def test_unexpected_character_quotes_the_line_as_written():
    with pytest.raises(ValueError) as e:
        parse_gcode("G1 X1 F60\n$H  X 5   (home)\n")
    assert str(e.value) == "G-code line 2: unexpected character '$' (U+0024) in '$H  X 5'"
    long = "~ " + "X1 " * 30
    with pytest.raises(ValueError, match=r"in '~ X1 X1 X1 .*\.\.\.'$"):
        parse_gcode(long)


# --------------------------------------------------------------------- 15: F range
@pytest.mark.parametrize(
    "word, units, limit",
    [
        ("F1" + "0" * 160, "G21", "6e+06 mm/min"),
        ("F6000001", "G21", "6e+06 mm/min"),
        ("F236221", "G20", "236220 inch/min"),
    ],
)
def test_an_absurd_feed_is_refused_with_the_allowed_range(word, units, limit):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow RuntimeWarning on the way
        with pytest.raises(ValueError) as e:
            build_setup(plant="hsm2", path=f"{units} G1 X5 {word}")
    msg = str(e.value)
    assert msg.startswith("G-code line 1: feed rate must be > 0 and <= ")
    assert f"{limit} ({MAX_FEED_M_S:g} m/s), got 'F" in msg


def test_the_largest_feed_plans_without_warnings():
    assert MAX_FEED_M_S == 100.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        prog = parse_gcode("G21 G1 X500 F6000000\nY-500\n")
        assert prog.feedrate_m_s == pytest.approx(100.0)
        setup = build_setup(plant="hsm2", path="G21 G1 X500 F6000000\nY-500\n")
    assert np.all(np.isfinite(setup.reference.position))
    assert setup.profile.duration > 0.0


@pytest.mark.parametrize("name", ["feedrate_m_s", "rapid_feed_m_s"])
def test_api_feed_overrides_are_bounded_like_f(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=rf"^{name}: must be > 0 and <= 100 m/s, got 1e\+200$"):
            build_setup(plant="hsm2", path="G0 X5\nG1 X6 F600", **{name: 1e200})
        setup = build_setup(plant="hsm2", path="G0 X5\nG1 X6 F600", **{name: 100.0})
    assert np.all(np.isfinite(setup.reference.position))
