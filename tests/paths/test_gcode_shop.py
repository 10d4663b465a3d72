"""Real part programs: setup words, unsupported features, robust text, per-segment timing
arrays and the 2-axis projection of the G-code reader (contour_env.paths.gcode)."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest

from contour_env.paths.gcode import (
    COMMON_EXTENSIONS,
    DEFAULT_G64_TOLERANCE_M,
    GcodeNote,
    GcodeProgram,
    parse_gcode,
    read_gcode,
)
from contour_env.paths.segments import Arc, Line

CORPUS = Path(__file__).resolve().parent.parent / "data" / "gcode"
MM = 1e-3
PI = math.pi

# words each corpus program must report in its notes (setup words it contains)
EXPECTED_NOTES = {
    "fusion_pocket_mm.nc": [
        "%",
        "O1001",
        "G94",
        "G49",
        "G40",
        "G80",
        "T1",
        "M6",
        "S12000",
        "M3",
        "G54",
        "M8",
        "G43",
        "H1",
        "M5",
        "M9",
        "M30",
    ],
    "mastercam_contour_r_arcs.nc": [
        "O0002",
        "G40",
        "G49",
        "G80",
        "T2",
        "M6",
        "G54",
        "S8000",
        "M3",
        "G43",
        "H2",
        "M8",
        "G64",
        "G4 P0.25",
        "G61",
        "M1",
        "M30",
    ],
    "inch_flange.tap": [
        "O3000",
        "T4",
        "M06",
        "G54",
        "S6000",
        "M03",
        "G43",
        "H04",
        "M08",
        "G04 X0.5",
        "M05",
        "M09",
        "M30",
    ],
    "helix_entry.ngc": [
        "G64",
        "Q0.005",
        "T3",
        "M6",
        "G43",
        "H3",
        "S9000",
        "M3",
        "M7",
        "G4 P1.5",
        "M9",
        "M5",
        "M2",
    ],
    "side_fillets_g18_g19.nc": ["O5000", "G54", "T5", "M6", "S15000", "M3", "G43", "H5", "M30"],
    "slot_crlf.nc": ["O06000", "T6", "M06", "G54", "S7500", "M03", "G43", "H06", "M08", "M30"],
    "engrave_bom.gcode": ["G64", "M3", "S20000", "M5", "M30"],
    "square_cr_only.nc": ["O8000", "G94", "T1", "M6", "S3000", "M3", "G43", "H1", "M5", "M30"],
    "grbl_compact.gcode": ["g94", "m3", "s10000", "g4 p0.5", "m5", "m2"],
    "fixture_g55_incremental.nc": [
        "O1010",
        "G98",
        "T7",
        "M6",
        "G55",
        "H7",
        "/",
        "M8",
        "G09",
        "M0",
        "M30",
    ],
    # written for issue 36: a CAM post's G53 line without axis words, text after M30 (a Haas
    # M99), a dwell and Z-only moves before the first XY move, a .cnc and a .txt file
    "cam_post_g53.nc": [
        "%",
        "O2001",
        "G80",
        "G40",
        "G49",
        "G53",
        "T1",
        "M6",
        "G54",
        "S10000",
        "M3",
        "G43",
        "H1",
        "M5",
        "M30",
    ],
    "haas_after_m30.nc": [
        "O00036",
        "G40",
        "G49",
        "G80",
        "T2",
        "M06",
        "G54",
        "S5000",
        "M03",
        "G43",
        "H02",
        "M08",
        "M09",
        "M05",
        "M30",
    ],
    "dwell_first.ngc": ["G64", "G4 P1.5", "G4 P0.5", "M2"],
    "router_job.cnc": ["M3", "S18000", "M5", "M30"],
    "shapeoko_outline.txt": ["M2"],
}


def corpus_files():
    return sorted(p for p in CORPUS.iterdir() if p.suffix.lower() in COMMON_EXTENSIONS)


def seg_end(s):
    return np.asarray(s.end, float) if isinstance(s, Line) else s.end_point


# ------------------------------------------------------------------------------ corpus
def test_corpus_is_complete():
    names = [p.name for p in corpus_files()]
    assert sorted(names) == sorted(EXPECTED_NOTES)
    for p in corpus_files():
        n_lines = len(p.read_bytes().replace(b"\r\n", b"\n").replace(b"\r", b"\n").splitlines())
        assert n_lines <= 310, p.name


@pytest.mark.parametrize("name", sorted(EXPECTED_NOTES))
def test_corpus_program_parses_and_reports_setup_words(name):
    prog = read_gcode(CORPUS / name)
    assert isinstance(prog, GcodeProgram)
    n = len(prog.segments)
    assert n > 0
    assert math.isfinite(prog.path.total_length) and prog.path.total_length > 0
    for arr in (
        prog.segment_blend_m,
        prog.segment_dwell_s,
        prog.segment_feeds_m_s,
        prog.segment_is_rapid,
        prog.segment_lines,
    ):
        assert len(arr) == n
    assert np.all(prog.segment_blend_m >= 0) and prog.segment_blend_m[-1] == 0.0
    assert np.all(prog.segment_dwell_s >= 0)
    assert np.all(np.isfinite(prog.segment_feeds_m_s)) and np.all(prog.segment_feeds_m_s > 0)
    # workspace of the corpus: +-100 mm in x/y, 0..30 mm in z
    pts = prog.path.sample_points(400)
    assert np.all(np.abs(pts[:, :2]) <= 0.1 + 1e-12)
    if pts.shape[1] == 3:
        assert np.all((pts[:, 2] >= -1e-12) & (pts[:, 2] <= 0.03 + 1e-12))
    noted = [note.word for note in prog.notes]
    for word in EXPECTED_NOTES[name]:
        assert word in noted, f"{name}: {word} not reported; notes {noted}"
    assert all(isinstance(note, GcodeNote) for note in prog.notes)
    assert [note.line for note in prog.notes] == sorted(note.line for note in prog.notes)
    summary = prog.summary()
    assert summary.startswith("ignored ") and "\n" not in summary
    # a 2-axis machine can follow every corpus program
    flat = prog.planar_xy()
    assert flat.path.dim == 2 and flat.path.total_length > 0
    assert len(flat.segment_blend_m) == len(flat.segment_dwell_s) == len(flat.segments)
    with pytest.raises(ValueError, match="Z motion on"):
        prog.planar_xy(strict=True)


def test_corpus_inch_program_units():
    prog = read_gcode(CORPUS / "inch_flange.tap")
    assert prog.units == "inch"
    # G04 X0.5 (Fanuc) after the profile: a 0.5 s dwell, exact stop there
    k = int(np.flatnonzero(prog.segment_dwell_s)[0])
    assert prog.segment_dwell_s[k] == pytest.approx(0.5)
    assert prog.segment_blend_m[k] == 0.0
    # first arc: G03 X0. Y-1.6 I1.6 J0. from (-1.6, 0): radius 1.6 inch
    arc = next(s for s in prog.segments if isinstance(s, Arc))
    assert arc.radius == pytest.approx(1.6 * 0.0254)


def test_corpus_line_endings_and_bom_read_like_lf(tmp_path):
    for name in ("slot_crlf.nc", "square_cr_only.nc", "engrave_bom.gcode"):
        raw = (CORPUS / name).read_bytes()
        lf = raw.removeprefix(b"\xef\xbb\xbf").replace(b"\r\n", b"\n").replace(b"\r", b"\n")
        assert lf != raw
        p = tmp_path / name
        p.write_bytes(lf)
        a, b = read_gcode(CORPUS / name), read_gcode(p)
        np.testing.assert_array_equal(a.path.seg_data, b.path.seg_data)
        assert a.notes == b.notes


# ------------------------------------------------------------------- setup words, notes
def test_shop_header_words_are_reported_not_simulated():
    text = """%
O1000 (PART)
(T1 D=6 FLAT)
G90 G94 G17 G21
G54
T1 M6
S12000 M3
G0 G43 H1 Z15.
M8
G0 X10 Y10
G1 Z5 F300
G1 X20 F1200
M5 M9
M30
%
"""
    prog = parse_gcode(text)
    plain = parse_gcode("G0 X0 Y0 Z15\nG0 X10 Y10\nG1 Z5 F300\nG1 X20 F1200\n")
    np.testing.assert_array_equal(prog.path.seg_data, plain.path.seg_data)
    got = {(n.line, n.word) for n in prog.notes}
    assert {
        (1, "%"),
        (2, "O1000"),
        (4, "G94"),
        (5, "G54"),
        (6, "T1"),
        (6, "M6"),
        (7, "S12000"),
        (7, "M3"),
        (8, "G43"),
        (8, "H1"),
        (9, "M8"),
        (13, "M5"),
        (13, "M9"),
        (14, "M30"),
    } <= got
    actions = {n.word: n.action for n in prog.notes}
    assert actions["G54"] == "work offset G54 taken as identity"
    assert actions["M3"].startswith("ignored: spindle")
    assert actions["G43"].startswith("ignored: tool length offset")
    s = prog.summary()
    assert s.startswith("ignored 13 words (O1000 G94 G54 T1 M6 S12000 M3 G43 …) on 9 lines")
    assert "G64 (default 0.01 mm)" in s


@pytest.mark.parametrize(
    "words",
    [
        "G40 G49 G80 G94 G17",
        "G54",
        "G55",
        "G59",
        "M0",
        "M1",
        "M7",
        "M8 M9",
        "T12",
        "S800.",
        "D3",
        "H4",
        "G43 H4",
        "G91.1",
        "G98",
        "G15 G50 G69",
        "G61",
        "G61.1",
        "G64",
        "G64 P0.02",
        "G64 P0.01 Q0.005",
        "M48",
    ],
)
def test_accepted_words_do_not_change_the_contour(words):
    base = "G21 G90 F600\nG1 X10\nY10\n"
    a = parse_gcode(base)
    b = parse_gcode(f"{words}\n" + base + f"{words}\nX0\n")
    np.testing.assert_array_equal(b.path.seg_data[:2], a.path.seg_data)
    assert len(b.notes) >= 1


def test_program_end_stops_reading():
    prog = parse_gcode("G1 X1 F60\nM30\nG1 X2\nthis is not g-code\n%\n")
    assert len(prog.segments) == 1
    assert prog.notes[-1] == GcodeNote(2, "M30", "program end: 2 lines after it not read")


def test_block_delete_line_is_executed():
    prog = parse_gcode("G1 X1 F60\n/G1 X2\n")
    assert len(prog.segments) == 2
    assert prog.notes[0].word == "/" and prog.notes[0].line == 2


# --------------------------------------------------------------------- timing arrays
def test_dwell_and_path_mode_arrays():
    text = """G21 G90 F600
G1 X10          (0: default G64 0.01 mm)
G04 P0.5        (dwell after 0)
G4 P0.25        (adds up)
G64 P0.02
G1 X20          (1: 0.02 mm)
G61
G1 X30          (2: exact stop)
Y10             (3: exact stop)
G64
G1 X40          (4: default again)
G20 G64 P0.001
G1 X2           (5: 0.001 inch)
G21 G09 X60     (6: G09 exact stop on this line only)
G1 X70          (7)
G04 X1.5        (Fanuc X seconds after 7)
G1 Y20          (8)
M01             (stop after 8)
G1 Y30          (9: last segment ends in a stop)
"""
    prog = parse_gcode(text)
    assert len(prog.segments) == 10
    np.testing.assert_allclose(
        prog.segment_blend_m,
        [0.0, 2e-5, 0.0, 0.0, 1e-5, 0.001 * 0.0254, 0.0, 0.0, 0.0, 0.0],
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        prog.segment_dwell_s, [0.75, 0, 0, 0, 0, 0, 0, 1.5, 0, 0], rtol=0, atol=0
    )
    assert DEFAULT_G64_TOLERANCE_M == 1e-5
    # default mode and the blend of an undisturbed junction
    prog = parse_gcode("G1 X1 F60\nY1\nX0\n")
    np.testing.assert_array_equal(prog.segment_blend_m, [1e-5, 1e-5, 0.0])
    np.testing.assert_array_equal(prog.segment_dwell_s, [0, 0, 0])
    dwells = [n for n in parse_gcode(text).notes if n.action.startswith("dwell")]
    assert [n.word for n in dwells] == ["G04 P0.5", "G4 P0.25", "G04 X1.5"]
    assert "3 dwells" in parse_gcode(text).summary()


def test_dwell_conventions_and_errors():
    prog = parse_gcode("G4 P2\nG1 X1 F60\nG4 P3\n")
    # a dwell before the first move is a pause at the start point (issue 36 item 3)
    assert prog.notes[0].action.startswith("dwell 2 s before the first move")
    assert prog.start_dwell_s == 2.0
    assert prog.segment_dwell_s.tolist() == [3.0]
    assert "a Fanuc control reads P3 as ms" in prog.notes[1].action
    for text, pattern in [
        ("G1 X1 F60\nG4", r"line 2: dwell 'G4' needs P"),
        ("G1 X1 F60\nG4 P-1", r"line 2: dwell time must be >= 0 s, got 'P-1'"),
        ("G1 X1 F60\nG4 P1 X1", r"line 2: dwell 'G4' with both 'P1' and 'X1'"),
        ("G1 X1 F60\nG4 P1 Y2", r"line 2: dwell 'G4' line cannot move \('Y2'\)"),
        ("G1 X1 F60\nG4 G1 P1", r"line 2: dwell 'G4' and motion 'G1' on one line"),
        ("G1 X1 F60\nG64 P-0.1", r"line 2: G64 tolerance must be >= 0"),
        ("G1 X1 F60 P2", r"line 1: word 'P2' needs G04 \(dwell, P in s\) or G64"),
    ]:
        with pytest.raises(ValueError, match=rf"^G-code {pattern}"):
            parse_gcode(text)


# -------------------------------------------------------------- unsupported features
@pytest.mark.parametrize(
    "bad, pattern",
    [
        ("O100 sub", r"O-word subroutine"),
        ("o<probe> call", r"O-word subroutine"),
        ("O100 endsub", r"O-word subroutine"),
        ("M98 P1000", r"'M98' \(subprogram call\)"),
        ("M99", r"'M99' \(subprogram return"),
        ("#1 = 5", r"'#' parameters"),
        ("G1 X[1+2]", r"'\[ \]' expressions"),
        ("GOTO10", r"macro control flow"),
        ("G41 D1 X5", r"'G41' \(cutter radius compensation\)"),
        ("G42 X5", r"'G42' \(cutter radius compensation\)"),
        ("G81 X5 Y5 Z-3 R1", r"'G81' \(canned cycle\)"),
        ("G83 Z-3 R1 Q1", r"'G83' \(canned cycle\)"),
        ("G68 X0 Y0 R30", r"'G68' \(coordinate rotation\)"),
        ("G52 X10", r"'G52' \(local coordinate offset\)"),
        ("G92 X0 Y0", r"'G92' \(coordinate offset\)"),
        ("G28 G91 Z0", r"'G28' \(return to reference position"),
        ("G30 Z0", r"'G30' \(return to reference position"),
        ("G53 G0 Z0", r"'G53' \(move in machine coordinates"),
        ("G16", r"'G16' \(polar coordinates\)"),
        ("G12 I5", r"'G12' \(G code not implemented\)"),
        ("G1 X1 A30", r"'A30' \(rotary axis"),
        ("G10 L2 P1 X0", r"'G10' \(setting offsets\), 'L2'"),
        ("G95 F0.1", r"'G95' \(feed per revolution\)"),
    ],
)
def test_unsupported_feature_is_named_with_its_line(bad, pattern):
    text = f"G21 G90\nG1 X1 F60\n{bad}\nG1 X2\n"
    with pytest.raises(ValueError, match=rf"^G-code line 3: unsupported .*{pattern}") as e:
        parse_gcode(text)
    assert "not implemented" in str(e.value)


def test_every_bad_line_is_listed_in_one_error():
    text = "\n".join(
        [
            "G21 G90",
            "G1 X1 F600",
            "G41 D1 X5",  # 3
            "G1 X6",
            "G81 Z-3 R1",  # 5
            "G1 X7",
            "M98 P100",  # 7
            "G1 X8",
            "G1 X1.2.3",  # 9
        ]
    )
    with pytest.raises(ValueError) as e:
        parse_gcode(text, source="part.nc")
    msg = str(e.value)
    assert msg.startswith("G-code program has 4 bad lines [part.nc]")
    for n, text_ in [(3, "G41 D1 X5"), (5, "G81 Z-3 R1"), (7, "M98 P100"), (9, "X1.2.3")]:
        assert f"G-code line {n}: " in msg and text_ in msg
    assert msg.count("G-code line") == 4
    # three bad lines: all three line numbers
    with pytest.raises(ValueError) as e:
        parse_gcode("G1 X1 F60\nG28 Z0\nG1 X2\nG68 R10\nG92 X0\n")
    assert [int(m) for m in __import__("re").findall(r"G-code line (\d+):", str(e.value))] == [
        2,
        4,
        5,
    ]


def test_error_list_is_capped():
    text = "G1 X1 F60\n" + "G41 X2\n" * 120
    with pytest.raises(ValueError) as e:
        parse_gcode(text)
    msg = str(e.value)
    assert msg.startswith("G-code program has 120 bad lines")
    assert msg.count("G-code line") == 50
    assert msg.endswith("... and 70 more bad lines")


def test_position_dependent_errors_are_listed_up_to_the_first_error():
    # the arc on line 4 would be wrong only because line 2 was not executed: not listed
    text = "G1 X10 F60\nG28 X5\nG1 X0 Y0\nG3 X0 Y0 I5\nG1 X1.2.3\n"
    with pytest.raises(ValueError) as e:
        parse_gcode(text)
    msg = str(e.value)
    assert "G-code line 2:" in msg and "G-code line 5:" in msg and "line 4" not in msg


# ------------------------------------------------------------------------ robust text
def test_bom_cr_crlf_give_the_same_path_as_lf():
    lf = "%\nO1\nG21 G90 (mm)\nG1 X10 Y5 F600\nG3 X0 Y15 R10\nG4 P0.5\nG1 X-3\nM30\n%\n"
    ref = parse_gcode(lf)
    for text in (
        "\ufeff" + lf,
        lf.replace("\n", "\r\n"),
        lf.replace("\n", "\r"),
        "\ufeff" + lf.replace("\n", "\r"),
    ):
        prog = parse_gcode(text)
        np.testing.assert_array_equal(prog.path.seg_data, ref.path.seg_data)
        np.testing.assert_array_equal(prog.segment_lines, ref.segment_lines)
        np.testing.assert_array_equal(prog.segment_dwell_s, ref.segment_dwell_s)
        assert prog.notes == ref.notes
    # read_gcode of bytes with a BOM
    import io

    prog = read_gcode(io.BytesIO(("\ufeff" + lf).encode("utf-8")))
    np.testing.assert_array_equal(prog.path.seg_data, ref.path.seg_data)


@pytest.mark.parametrize(
    "text, lineno, pattern",
    [
        ("G1 X1 F60\nG1 X\u0661\u0660", 2, r"non-ASCII character '\u0661' \(U\+0661\)"),
        ("G1 X1 F60\nG1 X\uff11\uff10", 2, r"non-ASCII character '\uff11' \(U\+FF11\)"),
        ("G1 X1 F60\nG1 X1\u0660", 2, r"cannot parse the number in word 'X1\u0660'"),
        ("G1 X\u0967 F60", 1, r"non-ASCII character"),  # Devanagari one
        ("\uff27\uff11 X1 F60", 1, r"unexpected character '\uff27' \(U\+FF27\)"),
        ("G1 X1e308 F60", 1, r"exponent notation 'G1 X1e308"),
        ("G1 X1E3 F60", 1, r"exponent notation"),
        ("G1 X" + "9" * 400 + " F60", 1, r"cannot parse the number in word 'X9999"),
        ("G1 X1" + "0" * 308 + " F60", 1, r"coordinate 'X10000.*' puts X at 1e\+305 m"),
        ("G1 X1" + "0" * 306 + " F60\nX-1" + "0" * 306, 1, r"within \+-1000 m"),
        ("G1 X1 F60\nG91 X600000\nX600000", 3, r"puts X at 1\.2e\+03 m"),
        ("G1 X1 F60\nG2 X2 R1" + "0" * 10, 2, r"arc word 'R10000000000' is 1e\+07 m"),
    ],
)
def test_bad_numbers_are_rejected_with_their_line(text, lineno, pattern):
    with pytest.raises(ValueError, match=rf"^G-code line {lineno}: .*{pattern}"):
        parse_gcode(text)


def test_plain_ascii_numbers_still_parse():
    prog = parse_gcode("G1 X+1.5 Y-.5 Z2. F600.")
    np.testing.assert_allclose(prog.segments[0].end, [0.0015, -0.0005, 0.002])


# -------------------------------------------------------------------------- planar_xy
def test_planar_xy_of_a_planar_program_is_itself():
    prog = parse_gcode("G1 X10 F600\nG3 X0 Y10 R10\n")
    assert prog.path.dim == 2
    assert prog.planar_xy() is prog
    assert prog.planar_xy(strict=True) is prog


def test_planar_xy_z_only_move_becomes_a_dwell():
    text = "G21 G90\nG1 X10 F600\nG1 Z-3 F300\nG4 P0.5\nG1 X20 F600\nG0 Z5\nG1 Y10\n"
    prog = parse_gcode(text)
    flat = prog.planar_xy()
    assert flat.path.dim == 2
    assert [type(s).__name__ for s in flat.segments] == ["Line", "Line", "Line"]
    np.testing.assert_allclose(seg_end(flat.segments[0]), [0.01, 0, 0])
    np.testing.assert_allclose(seg_end(flat.segments[1]), [0.02, 0, 0])
    # Z-3 at 300 mm/min = 0.6 s, then the G4 P0.5; rapid Z+8 at the rapid feed 600 mm/min
    np.testing.assert_allclose(flat.segment_dwell_s, [0.6 + 0.5, 0.8, 0.0])
    np.testing.assert_array_equal(flat.segment_blend_m, [0.0, 0.0, 0.0])
    np.testing.assert_allclose(flat.segment_feeds_m_s, [0.01, 0.01, 0.01])
    np.testing.assert_array_equal(flat.segment_lines, [2, 5, 7])
    z_notes = [n for n in flat.notes if n.action.startswith("Z motion taken")]
    assert [(n.line, n.action) for n in z_notes] == [
        (3, "Z motion taken by an unsimulated axis: pause 0.6 s"),
        (6, "Z motion taken by an unsimulated axis: pause 0.8 s"),
    ]
    assert "2 lines with Z motion taken by an unsimulated axis" in flat.summary()
    # strict: names the lines with Z motion
    with pytest.raises(ValueError, match=r"Z motion on 2 lines \(3, 6\)"):
        prog.planar_xy(strict=True)


def test_planar_xy_z_before_any_xy_motion_is_a_pause_at_the_start():
    # G0 Z10 at the rapid feed (the highest F, 600 mm/min): 1 s; Z10 -> Z2 at 120 mm/min: 4 s
    flat = parse_gcode("G0 Z10\nG1 Z2 F120\nX10 F600\n").planar_xy()
    assert len(flat.segments) == 1 and flat.segment_dwell_s.tolist() == [0.0]
    assert flat.start_dwell_s == pytest.approx(5.0, rel=1e-12)
    assert [n.action for n in flat.notes][:2] == [
        "Z motion taken by an unsimulated axis: pause 1 s before the first XY move",
        "Z motion taken by an unsimulated axis: pause 4 s before the first XY move",
    ]
    assert "pauses 5 s in all" in flat.summary()


def test_planar_xy_sloped_line_keeps_its_duration():
    prog = parse_gcode("G1 X3 Z4 F600\n")  # 5 mm in 0.5 s
    flat = prog.planar_xy()
    (s,) = flat.segments
    np.testing.assert_allclose(s.end, [0.003, 0, 0])
    assert flat.segment_feeds_m_s[0] == pytest.approx(0.01 * 3 / 5)
    assert s.length / flat.segment_feeds_m_s[0] == pytest.approx(0.5)


def test_planar_xy_helix_becomes_its_xy_arc():
    text = "G17 G1 X10 F600\nG3 X-10 Y0 Z-2 I-10 J0\nG2 Z-3 I10 J0\n"
    prog = parse_gcode(text)
    flat = prog.planar_xy()
    helices = [s for s in prog.segments if isinstance(s, Arc)]
    arcs = [s for s in flat.segments if isinstance(s, Arc)]
    assert len(arcs) == 2
    for h, a in zip(helices, arcs, strict=True):
        assert a.radius == h.radius and a.sweep == h.sweep and a.theta0 == h.theta0
        assert a.pitch == 0.0 and a.center[2] == 0.0
        np.testing.assert_array_equal(a.center[:2], h.center[:2])
    # the same duration: the XY feed is scaled by r / sqrt(r^2 + pitch^2)
    for k, (h, a) in enumerate(zip(helices, arcs, strict=True), start=1):
        assert a.length / flat.segment_feeds_m_s[k] == pytest.approx(
            h.length / prog.segment_feeds_m_s[k]
        )
    assert flat.segments[2].sweep == pytest.approx(-2 * PI)
    helix_notes = [n for n in flat.notes if "helix kept as its XY arc" in n.action]
    assert [n.line for n in helix_notes] == [2, 3]
    with pytest.raises(ValueError, match=r"Z motion on 2 lines \(2, 3\)"):
        prog.planar_xy(strict=True)


def test_planar_xy_g18_arc_projects_onto_exact_lines():
    # G18 G3 (from +Z towards +X) quarter arc from (0,0,10) to (10,0,0) about the origin:
    # its projection runs X 0 -> 10
    prog = parse_gcode("G0 Z10\nG18 G3 X10 Z0 I0 K-10 F600\n")
    flat = prog.planar_xy()
    (s,) = flat.segments
    assert isinstance(s, Line)
    np.testing.assert_allclose(s.start, [0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(s.end, [0.01, 0, 0], atol=1e-15)
    assert s.length / flat.segment_feeds_m_s[0] == pytest.approx(0.01 * PI / 2 / 0.01)
    # a G18 half circle that passes the X extreme: out to X20 and back -> 2 lines, stop between
    prog = parse_gcode("G1 X10 Z10 F600\nG18 G3 X10 Z-10 I0 K-10\nG1 Y5\n")
    flat = prog.planar_xy()
    ends = [seg_end(s) for s in flat.segments]
    np.testing.assert_allclose(
        ends, [[0.01, 0, 0], [0.02, 0, 0], [0.01, 0, 0], [0.01, 0.005, 0]], atol=1e-15
    )
    assert flat.segment_blend_m[1] == 0.0  # reversal: exact stop
    assert flat.segment_blend_m[2] == pytest.approx(DEFAULT_G64_TOLERANCE_M)
    note = next(n for n in flat.notes if n.line == 2)
    assert "G18 arc projected onto XY as 2 lines (exact" in note.action


def test_planar_xy_g19_helix_is_a_polyline_within_1um():
    prog = parse_gcode("G0 Y10\nG19 G3 Y-10 Z0 X5 J-10 K0 F600\n")
    (h,) = [s for s in prog.segments if isinstance(s, Arc)]
    flat = prog.planar_xy()
    chords = flat.segments[1:]
    assert len(chords) > 10
    # every chord's midpoint lies within 1 um of the projected helix
    th = np.linspace(h.theta0, h.theta0 + h.sweep, 20001)
    curve = h.point(th)[:, :2]
    for c in chords:
        mid = 0.5 * (c.start[:2] + c.end[:2])
        assert np.min(np.linalg.norm(curve - mid, axis=1)) <= 1.0e-6 + 1e-9
    np.testing.assert_allclose(seg_end(chords[-1]), [0.005, -0.01, 0], atol=1e-15)
    # the same duration as the helix
    dur = sum(c.length / f for c, f in zip(chords, flat.segment_feeds_m_s[1:], strict=True))
    assert dur == pytest.approx(h.length / prog.segment_feeds_m_s[1])
    assert any("polyline of" in n.action for n in flat.notes)


def test_planar_xy_constant_height_program_projects_without_notes():
    prog = parse_gcode("G1 X10 F600\nG3 X0 Y10 R10\n", start=(0, 0, 0.005))
    assert prog.path.dim == 3
    flat = prog.planar_xy(strict=True)
    assert flat.path.dim == 2 and flat.notes == []
    assert flat.path.total_length == pytest.approx(prog.path.total_length)


# ------------------------------------------------------------------------------- speed
def cam_program(n_lines: int = 5000) -> str:
    """A CAM-style program: header, G1 polyline with 3-decimal mm words, an I/J arc every
    25 lines, footer."""
    out = [
        "%",
        "O2000 (BENCH)",
        "G90 G94 G17 G21",
        "G54",
        "T1 M6",
        "S12000 M3",
        "G0 G43 H1 Z15.",
        "M8",
        "G0 X0. Y0.",
        "G1 Z5. F400.",
        "F1500.",
    ]
    k, x, y = 0, 0.0, 0.0
    while len(out) < n_lines - 4:
        k += 1
        if k % 25 == 0:
            out.append(f"G3 X{x - 2:.3f} Y{y + 2:.3f} I-2. J0.")
            x, y = x - 2, y + 2
            out.append("G1")
        else:
            t = k * 0.005
            x = round(40 * math.cos(t) + (0.3 * k) % 7, 3)
            y = round(40 * math.sin(t), 3)
            out.append(f"X{x:.3f} Y{y:.3f}")
    out += ["G0 Z15.", "M5 M9", "M30", "%"]
    return "\n".join(out) + "\n"


def test_parse_time_of_a_5000_line_program(capsys):
    text = cam_program()
    assert len(text.splitlines()) == 5000
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        prog = parse_gcode(text)
        best = min(best, time.perf_counter() - t0)
    assert len(prog.segments) > 4000
    with capsys.disabled():
        print(
            f"\nparse_gcode of a 5000-line CAM program ({len(prog.segments)} segments): "
            f"{best * 1e3:.0f} ms"
        )
