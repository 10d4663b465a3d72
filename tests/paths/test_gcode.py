"""Tests for the G-code reader (contour_env.paths.gcode)."""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pytest

from contour_env.paths import gcode
from contour_env.paths.gcode import GcodeProgram, parse_gcode, read_gcode
from contour_env.paths.geometry import PathGeometry
from contour_env.paths.segments import Arc, Line

DATA = Path(gcode.__file__).resolve().parent.parent / "data"
MM = 1e-3
PI = math.pi


def arc_point(a, theta):
    c, u, v = (np.asarray(x, dtype=float) for x in (a.center, a.u, a.v))
    w = np.cross(u, v)
    return c + a.radius * (np.cos(theta) * u + np.sin(theta) * v) + a.pitch * (theta - a.theta0) * w


def seg_start(s):
    return np.asarray(s.start, float) if isinstance(s, Line) else arc_point(s, s.theta0)


def seg_end(s):
    return np.asarray(s.end, float) if isinstance(s, Line) else arc_point(s, s.theta0 + s.sweep)


def arc_omega(a):
    """Unit angular-velocity direction of the motion at the arc start: (p - c) x dp/dtheta."""
    c, u, v = (np.asarray(x, dtype=float) for x in (a.center, a.u, a.v))
    t0 = a.theta0
    r = a.radius * (np.cos(t0) * u + np.sin(t0) * v)
    dp = a.radius * (-np.sin(t0) * u + np.cos(t0) * v) * np.sign(a.sweep)
    om = np.cross(r, dp)
    return om / np.linalg.norm(om)


def one(text, **kw) -> object:
    prog = parse_gcode(text, **kw)
    assert len(prog.segments) == 1
    return prog.segments[0]


def assert_continuous(prog, start=(0, 0, 0)):
    p = np.asarray(start, float)
    for s in prog.segments:
        np.testing.assert_allclose(seg_start(s), p, atol=1e-12)
        p = seg_end(s)


@pytest.fixture
def dims(monkeypatch):
    """Record the `dim` each PathGeometry.from_segments call receives."""
    seen = []
    orig = PathGeometry.from_segments

    def spy(segments, dim=None):
        seen.append(dim)
        return orig(segments, dim=dim)

    monkeypatch.setattr(PathGeometry, "from_segments", staticmethod(spy))
    return seen


# ---------------------------------------------------------------------------- lines, feeds
def test_line_and_feed_conversion(dims):
    prog = parse_gcode("G21 G90 G01 X10 Y5 F600")
    assert isinstance(prog, GcodeProgram)
    (s,) = prog.segments
    assert isinstance(s, Line)
    np.testing.assert_allclose(s.start, [0, 0, 0])
    np.testing.assert_allclose(s.end, [0.010, 0.005, 0], atol=1e-15)
    np.testing.assert_allclose(prog.segment_feeds_m_s, [0.01])
    assert prog.feedrate_m_s == pytest.approx(0.01)
    assert prog.units == "mm" and prog.source == "<string>"
    assert dims == [2]
    assert isinstance(prog.path, PathGeometry)


def test_modal_feed_rapids_and_highest_feed():
    text = "G21 G90\nG00 X10\nG01 Y10 F600\nX20 F1200\nG00 X0 Y0\nG01 X-5 F300"
    prog = parse_gcode(text)
    assert len(prog.segments) == 5
    np.testing.assert_allclose(prog.segment_feeds_m_s, [0.02, 0.01, 0.02, 0.02, 0.005])
    np.testing.assert_array_equal(prog.segment_is_rapid, [True, False, False, True, False])
    np.testing.assert_array_equal(prog.segment_lines, [2, 3, 4, 5, 6])
    assert prog.feedrate_m_s == pytest.approx(0.02)
    prog2 = parse_gcode(text, rapid_feed_m_s=0.5)
    np.testing.assert_allclose(prog2.segment_feeds_m_s, [0.5, 0.01, 0.02, 0.5, 0.005])
    assert prog2.feedrate_m_s == pytest.approx(0.02)
    assert_continuous(prog)


def test_rapid_only_program_needs_rapid_feed():
    prog = parse_gcode("G00 X10 Y10", rapid_feed_m_s=0.3)
    assert prog.feedrate_m_s == 0.3 and prog.segment_is_rapid.all()
    with pytest.raises(ValueError, match="only rapid"):
        parse_gcode("G00 X10 Y10")
    with pytest.raises(ValueError, match="rapid_feed_m_s"):
        parse_gcode("G01 X1 F100", rapid_feed_m_s=0.0)


def test_inch_conversion():
    prog = parse_gcode("G20 G90 G01 X1 Y-0.5 F10")
    (s,) = prog.segments
    np.testing.assert_allclose(s.end, [0.0254, -0.0127, 0], atol=1e-15)
    assert prog.feedrate_m_s == pytest.approx(10 * 0.0254 / 60)
    assert prog.units == "inch"
    # units switch keeps the physical feed; later coordinates in mm
    prog = parse_gcode("G20 G01 X1 F10\nG21 X30")
    np.testing.assert_allclose(prog.segments[1].end, [0.030, 0, 0])
    np.testing.assert_allclose(prog.segment_feeds_m_s, [10 * 0.0254 / 60] * 2)
    assert prog.units == "inch"


def test_default_units_are_mm():
    prog = parse_gcode("G1 X2 F60")
    assert prog.units == "mm"
    np.testing.assert_allclose(prog.segments[0].end, [0.002, 0, 0])
    assert prog.feedrate_m_s == pytest.approx(0.001)


def test_incremental_mode():
    prog = parse_gcode("G91 G01 X10 F600\nX10\nY5\nG90 X0\nG91 G03 X-10 Y10 I-10 J0")
    ends = [seg_end(s) for s in prog.segments]
    np.testing.assert_allclose(
        ends,
        [[0.01, 0, 0], [0.02, 0, 0], [0.02, 0.005, 0], [0, 0.005, 0], [-0.01, 0.015, 0]],
        atol=1e-15,
    )
    a = prog.segments[-1]
    np.testing.assert_allclose(a.center, [-0.01, 0.005, 0], atol=1e-15)
    assert a.sweep == pytest.approx(PI / 2)
    assert_continuous(prog)


def test_word_order_within_a_line_does_not_matter():
    (s,) = parse_gcode("X10 F600 G91 G1", start=(0.005, 0, 0)).segments
    np.testing.assert_allclose(s.end, [0.015, 0, 0])
    (s,) = parse_gcode("X1 F10 G1 G20").segments
    np.testing.assert_allclose(s.end, [0.0254, 0, 0])


def test_start_point_and_zero_length_moves():
    prog = parse_gcode("G01 X10 F100\nX10\nG00 X10 Y0\nY5", start=(0.01, 0, 0))
    (s,) = prog.segments  # first three are zero-length (start is already X10)
    np.testing.assert_allclose(s.start, [0.01, 0, 0])
    np.testing.assert_allclose(s.end, [0.01, 0.005, 0])
    assert prog.segment_lines.tolist() == [4]
    prog = parse_gcode("G1 X1 F100", start=(0.5, 0.5))
    np.testing.assert_allclose(prog.segments[0].start, [0.5, 0.5, 0])
    np.testing.assert_allclose(prog.segments[0].end, [0.001, 0.5, 0])


def test_first_move_from_origin_is_part_of_path():
    prog = parse_gcode("G00 X10 Y10\nG01 X20 F100")
    np.testing.assert_allclose(prog.segments[0].start, [0, 0, 0])
    assert len(prog.segments) == 2


# ---------------------------------------------------------------------------------- arcs
@pytest.mark.parametrize(
    "code, centre_mm, theta0, sweep",
    [
        ("G03 X0 Y10 I-10 J0", (0, 0), 0.0, PI / 2),  # CCW quarter, I/J
        ("G02 X0 Y-10 I-10 J0", (0, 0), 0.0, -PI / 2),  # CW quarter, I/J
        ("G03 X0 Y10 R10", (0, 0), 0.0, PI / 2),  # CCW, R > 0: shorter arc
        ("G03 X0 Y10 R-10", (10, 10), -PI / 2, 3 * PI / 2),  # CCW, R < 0: longer arc
        ("G02 X0 Y10 R10", (10, 10), -PI / 2, -PI / 2),  # CW, R > 0
        ("G02 X0 Y10 R-10", (0, 0), 0.0, -3 * PI / 2),  # CW, R < 0
        ("G03 X-10 Y0 R10", (0, 0), 0.0, PI),  # semicircle, R = chord / 2
        ("G02 X-10 Y0 R10", (0, 0), 0.0, -PI),
        ("G03 X-10 Y0 I-10", (0, 0), 0.0, PI),  # missing J = 0
        ("G02 X10 Y20 I0 J10", (10, 10), -PI / 2, -PI),  # CW half, centre above
    ],
)
def test_xy_arcs(code, centre_mm, theta0, sweep, dims):
    prog = parse_gcode(f"G21 G90 G17 F600\n{code}", start=(0.01, 0, 0))
    (a,) = prog.segments
    assert isinstance(a, Arc)
    np.testing.assert_allclose(a.center, [centre_mm[0] * MM, centre_mm[1] * MM, 0], atol=1e-15)
    np.testing.assert_allclose(a.u, [1, 0, 0])
    np.testing.assert_allclose(a.v, [0, 1, 0])
    assert a.radius == pytest.approx(0.01)
    assert a.theta0 == pytest.approx(theta0)
    assert a.sweep == pytest.approx(sweep)
    assert a.pitch == 0.0
    assert_continuous(prog, start=(0.01, 0, 0))
    assert dims == [2]
    # direction: G03 is CCW about +Z, G02 CW
    np.testing.assert_allclose(arc_omega(a), [0, 0, 1 if code.startswith("G03") else -1])


def test_arc_end_point_matches_programme_after_centre_projection():
    # centre off by 2 um (within tolerance): arc still ends exactly at the programmed end
    a = one("G03 X0 Y10 I-10.002 J0 F100", start=(0.01, 0, 0))
    np.testing.assert_allclose(seg_end(a), [0, 0.01, 0], atol=1e-15)
    np.testing.assert_allclose(seg_start(a), [0.01, 0, 0], atol=1e-15)
    assert a.sweep == pytest.approx(PI / 2, abs=1e-3)


def test_g18_arcs_zx_plane(dims):
    # G18: in-plane coordinates (Z, X), normal +Y; G03 is CCW seen from +Y, i.e. from +Z to +X
    prog = parse_gcode("G18 G03 X10 Z0 I0 K-10 F600", start=(0, 0, 0.01))
    (a,) = prog.segments
    np.testing.assert_allclose(a.center, [0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(a.u, [0, 0, 1])
    np.testing.assert_allclose(a.v, [1, 0, 0])
    np.testing.assert_allclose(np.cross(a.u, a.v), [0, 1, 0])
    assert a.theta0 == pytest.approx(0.0)
    assert a.sweep == pytest.approx(PI / 2)
    h = 0.01 / math.sqrt(2)
    np.testing.assert_allclose(arc_point(a, PI / 4), [h, 0, h], atol=1e-15)
    np.testing.assert_allclose(arc_omega(a), [0, 1, 0])
    assert dims == [3]
    # G02 in G18 goes from +Z towards -X (clockwise about +Y)
    (b,) = parse_gcode("G18 G02 X-10 Z0 I0 K-10 F600", start=(0, 0, 0.01)).segments
    assert b.sweep == pytest.approx(-PI / 2)
    np.testing.assert_allclose(arc_point(b, -PI / 4), [-h, 0, h], atol=1e-15)
    np.testing.assert_allclose(arc_omega(b), [0, -1, 0])
    # R form in G18
    (c,) = parse_gcode("G18 G03 X10 Z0 R10 F600", start=(0, 0, 0.01)).segments
    np.testing.assert_allclose(c.center, [0, 0, 0], atol=1e-15)
    assert c.sweep == pytest.approx(PI / 2)


def test_g19_arcs_yz_plane():
    # G19: in-plane coordinates (Y, Z), normal +X; G03 turns from +Y towards +Z
    (a,) = parse_gcode("G19 G03 Y0 Z10 J-10 K0 F600", start=(0, 0.01, 0)).segments
    np.testing.assert_allclose(a.center, [0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(a.u, [0, 1, 0])
    np.testing.assert_allclose(a.v, [0, 0, 1])
    assert a.sweep == pytest.approx(PI / 2)
    np.testing.assert_allclose(arc_omega(a), [1, 0, 0])
    (b,) = parse_gcode("G19 G02 Y0 Z-10 R10 F600", start=(0, 0.01, 0)).segments
    assert b.sweep == pytest.approx(-PI / 2)
    np.testing.assert_allclose(b.center, [0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(arc_omega(b), [-1, 0, 0])


def test_g17_arc_in_raised_plane_is_3d(dims):
    prog = parse_gcode("G03 X0 Y10 I-10 J0 F600", start=(0.01, 0, 0.002))
    np.testing.assert_allclose(prog.segments[0].center, [0, 0, 0.002], atol=1e-15)
    assert dims == [3]


@pytest.mark.parametrize(
    "code, sweep",
    [
        ("G02 X10 Y0 I-10 J0", -2 * PI),
        ("G03 X10 Y0 I-10 J0", 2 * PI),
        ("G02 I-10", -2 * PI),  # no axis word: ends at its start
        ("G03 I-5 J-8.660254037844386", 2 * PI),
    ],
)
def test_full_circle(code, sweep):
    (a,) = parse_gcode(f"F600 {code}", start=(0.01, 0, 0)).segments
    assert a.sweep == sweep
    if "J" not in code:
        np.testing.assert_allclose(a.center, [0, 0, 0], atol=1e-15)
        assert a.radius == pytest.approx(0.01)
    np.testing.assert_allclose(seg_end(a), [0.01, 0, 0], atol=1e-15)


def test_helical_move(dims):
    prog = parse_gcode("G17 G03 X-10 Y0 Z-2 I-10 J0 F600", start=(0.01, 0, 0))
    (a,) = prog.segments
    assert a.sweep == pytest.approx(PI)
    assert a.pitch == pytest.approx(-0.002 / PI)
    np.testing.assert_allclose(a.center, [0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(seg_end(a), [-0.01, 0, -0.002], atol=1e-15)
    np.testing.assert_allclose(arc_point(a, PI / 2), [0, 0.01, -0.001], atol=1e-15)
    assert dims == [3]
    # full helical turn, CW, rising 1 mm
    (b,) = parse_gcode("G02 Z1 I-10 F600", start=(0.01, 0, 0)).segments
    assert b.sweep == -2 * PI
    assert b.pitch == pytest.approx(0.001 / (-2 * PI))
    np.testing.assert_allclose(seg_end(b), [0.01, 0, 0.001], atol=1e-15)
    # helix in G18 rises along +Y
    (c,) = parse_gcode("G18 G03 X10 Z0 Y3 K-10 F600", start=(0, 0, 0.01)).segments
    np.testing.assert_allclose(seg_end(c), [0.01, 0.003, 0], atol=1e-15)


# ----------------------------------------------------------------------------- lexical
def test_comments_line_numbers_and_lexical_forms():
    text = """%
(header comment)
; full-line comment

N10 g21 g90 (inline) g17
n20 g1 x1.5 y.5 f600. ; trailing comment
N30 G0001 X 2 Y -0.5
N40 G00X+3Y-.5(no spaces)
%
"""
    prog = parse_gcode(text)
    ends = [s.end for s in prog.segments]
    np.testing.assert_allclose(
        ends, [[0.0015, 0.0005, 0], [0.002, -0.0005, 0], [0.003, -0.0005, 0]], atol=1e-15
    )
    assert prog.segment_lines.tolist() == [6, 7, 8]
    np.testing.assert_allclose(prog.segment_feeds_m_s, [0.01, 0.01, 0.01])


def test_crlf_line_endings():
    prog = parse_gcode("G21\r\nG1 X1 F60\r\nY1\r\n")
    assert len(prog.segments) == 2


# ----------------------------------------------------------------------------- examples
def test_square_corners_example(dims):
    prog = read_gcode(DATA / "square_corners.nc")
    assert len(prog.segments) == 4
    assert all(isinstance(s, Line) for s in prog.segments)
    np.testing.assert_allclose(
        [s.end for s in prog.segments],
        [[0.04, 0, 0], [0.04, 0.04, 0], [0, 0.04, 0], [0, 0, 0]],
        atol=1e-15,
    )
    assert prog.units == "mm" and prog.feedrate_m_s == pytest.approx(0.02)
    assert prog.source.endswith("square_corners.nc")
    assert dims == [2]
    assert_continuous(prog)


def test_arc_demo_example(dims):
    prog = read_gcode(DATA / "arc_demo.nc")
    kinds = ["L" if isinstance(s, Line) else "A" for s in prog.segments]
    assert "".join(kinds) == "LLALALALALALAL"
    arcs = [s for s in prog.segments if isinstance(s, Arc)]
    np.testing.assert_allclose(
        [a.sweep for a in arcs], [PI / 2, PI / 2, -PI, PI / 2, 3 * PI / 2, -2 * PI]
    )
    np.testing.assert_allclose(
        [a.center for a in arcs],
        np.array([[40, 10, 0], [40, 30, 0], [25, 40, 0], [10, 30, 0], [0, 0, 0], [25, 20, 0]]) * MM,
        atol=1e-15,
    )
    np.testing.assert_allclose([a.radius for a in arcs], [0.01] * 5 + [0.005])
    assert prog.feedrate_m_s == pytest.approx(0.015)
    np.testing.assert_allclose(prog.segment_feeds_m_s[prog.segment_is_rapid], 0.015)
    assert prog.segment_feeds_m_s[-2] == pytest.approx(0.01)
    assert dims == [2]
    assert_continuous(prog)
    np.testing.assert_allclose(seg_end(prog.segments[-1]), [0, 0, 0], atol=1e-15)


@pytest.mark.parametrize(
    "ext", [".nc", ".gcode", ".ngc", ".tap", ".NC", ".cnc", ".txt", ".mpf", ".eia", ".ptp", ""]
)
def test_read_gcode_extensions(tmp_path, ext):
    p = tmp_path / f"prog{ext}"
    p.write_text("G21 G1 X1 F60\n")
    prog = read_gcode(str(p))
    assert len(prog.segments) == 1 and prog.source == str(p)


def test_read_gcode_errors(tmp_path):
    missing = tmp_path / "nope.nc"
    with pytest.raises(FileNotFoundError, match="nope.nc"):
        read_gcode(missing)
    bad = tmp_path / "bad.nc"
    bad.write_text("G21\nG1 X1 F60\nM98 P100\n")
    with pytest.raises(ValueError, match=r"G-code line 3: unsupported word 'M98'.*bad\.nc"):
        read_gcode(bad)


def test_read_gcode_file_objects():
    prog = read_gcode(io.StringIO("G1 X1 F60"))
    assert len(prog.segments) == 1
    prog = read_gcode(io.BytesIO(b"G1 X1 F60 (caf\xc3\xa9)"), rapid_feed_m_s=1.0)
    assert len(prog.segments) == 1


# ------------------------------------------------------------------------------ errors
@pytest.mark.parametrize(
    "text, lineno, pattern",
    [
        # M/S/T/O words, G04 and G91.1 are now read (tests/paths/test_gcode_shop.py)
        ("G21\nG1 X1 F60\nM98 P1000", 3, r"unsupported word 'M98' \(subprogram call\)"),
        ("G1 X1 F60\nG04", 2, r"dwell 'G04' needs P"),
        ("G41 D1", 1, r"unsupported word 'G41'"),
        ("G1 X1 F60 A5", 1, r"unsupported word 'A5'"),
        ("O1000 G1 X1", 1, r"unsupported word 'O1000' with other words"),
        ("G90.1", 1, r"unsupported word 'G90.1'"),
        ("G17.1", 1, r"unsupported word 'G17.1'"),
        ("m98", 1, r"unsupported word 'm98'"),
        ("G1 X F60", 1, r"word 'X' has no number"),
        ("G\nG1 X1", 1, r"word 'G' has no number"),
        ("G1 X1.2.3 F60", 1, r"cannot parse the number in word 'X1\.2\.3'"),
        ("G1 X1-2 F60", 1, r"cannot parse the number in word 'X1-2'"),
        ("G1 X-- F60", 1, r"cannot parse the number in word 'X--'"),
        ("G1 X. F60", 1, r"cannot parse the number in word 'X\.'"),
        ("G1 X" + "9" * 400 + " F60", 1, r"cannot parse the number in word 'X999"),
        ("#1=5", 1, r"unsupported '#' parameters"),
        ("G1 X1 F60 $", 1, r"cannot parse the number in word 'F60\$'"),
        ("G1 X1 F60 (open comment", 1, r"unclosed comment '\(open comment'"),
        ("F60\nG1 G2 X1 R5", 2, r"two motion codes on one line: 'G1' and 'G2'"),
        ("F60\nG00 G01 X1", 2, r"two motion codes.*'G00' and 'G01'"),
        ("G20 G21", 1, r"two units codes.*'G20' and 'G21'"),
        ("G17 G18", 1, r"two plane codes.*'G18'"),
        ("G90 G91", 1, r"two distance codes.*'G91'"),
        ("G1 X1 X2 F60", 1, r"duplicate word 'X2' \(X already given as 'X1'\)"),
        ("G1 X1 F60 F70", 1, r"duplicate word 'F70'"),
        ("N1 N2 G1 X1 F1", 1, r"duplicate word 'N2'"),
        ("G21\nG1 X1", 2, r"feed move 'G1' before any feed rate"),
        ("G0 X1\nX2\nG2 X0 Y0 I-1", 3, r"feed move 'G2' before any feed rate"),
        ("G1 X1 F0", 1, r"feed rate must be > 0 and <= 6e\+06 mm/min \(100 m/s\), got 'F0'"),
        ("G1 X1 F-5", 1, r"feed rate must be > 0 and <= 6e\+06 mm/min.*got 'F-5'"),
        ("X1", 1, r"axis word 'X1' with no motion mode"),
        ("F60 G1 X1 I5", 1, r"arc word 'I5' used without G02/G03"),
        ("F60\nG0 X1 R2", 2, r"arc word 'R2' used without G02/G03"),
        ("F60\nG1 X10\nG2 X0 Y10", 3, r"arc 'G2' needs R or I/J/K"),
        ("F60\nG1 X10\nG03\nX0 Y10", 4, r"arc 'G03 \(modal\)' needs R or I/J/K"),
        ("F60\nG1 X10\nG2 X0 Y10 R2", 3, r"arc radius 'R2' is smaller than half the chord"),
        ("F60\nG1 X10\nG2 X0 Y10 R-7", 3, r"arc radius 'R-7' is smaller than half"),
        ("F60\nG1 X10\nG2 X10 Y0 R5", 3, r"R-form arc 'R5' ends at its start point"),
        ("F60\nG1 X10\nG2 X0 Y10 R0", 3, r"arc radius 'R0' is zero"),
        ("F60\nG1 X10\nG3 X0 Y12 I-10 J0", 3, r"arc centre 'I-10 J0' is not equidistant"),
        ("F60\nG1 X10\nG3 X0 Y10 I-10.01", 3, r"arc centre 'I-10.01' is not equidistant"),
        ("F60\nG1 X10\nG3 X0 Y10 I0 J0", 3, r"arc centre 'I0 J0' gives a zero radius"),
        ("F60\nG1 X10\nG3 X0 Y10 R10 I-10", 3, r"arc with both R and I/J/K \('R10', 'I-10'\)"),
        ("F60\nG1 X10\nG3 X0 Y10 I-10 K1", 3, r"centre word 'K1' is along the normal of G17"),
        ("F60\nG18 G1 Z10\nG3 X10 Z0 J1 K-10", 3, r"centre word 'J1' is along the normal of G18"),
        ("F60\nG19 G1 Y10\nG3 Y0 Z10 I1 J-10", 3, r"centre word 'I1' is along the normal of G19"),
    ],
)
def test_bad_input_raises_with_line_and_word(text, lineno, pattern):
    with pytest.raises(ValueError, match=rf"^G-code line {lineno}: .*{pattern}"):
        parse_gcode(text)


def test_error_line_numbers_count_blank_and_comment_lines():
    text = "%\n(comment)\n\nG21 G90\n; another\nG1 X1 F60\nM98 P1\n%"
    with pytest.raises(ValueError, match=r"^G-code line 7: unsupported word 'M98'"):
        parse_gcode(text)


@pytest.mark.parametrize(
    "text", ["", "%\n%\n", "(only a comment)\n", "G21 G90 G17 F600", "G1 X0 Y0 F60"]
)
def test_empty_program(text):
    with pytest.raises(ValueError, match="G-code program has no motion"):
        parse_gcode(text)


def test_bad_start():
    with pytest.raises(ValueError, match="start"):
        parse_gcode("G1 X1 F60", start=(0, 0, 0, 0))
    with pytest.raises(ValueError, match="start"):
        parse_gcode("G1 X1 F60", start=(0, float("nan"), 0))
