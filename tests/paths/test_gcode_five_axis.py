"""Five-axis G-code (X Y Z A C) through the one reader: joint-space blocks, units, and the
clear errors of issue 16 item 5."""

import math

import numpy as np
import pytest

from contour_env.cases import build_setup
from contour_env.paths.gcode import parse_gcode
from contour_env.paths.gcode_five_axis import FiveAxisProgram
from contour_env.plants.five_axis import FiveAxisGeometry

GEOM = FiveAxisGeometry()


def test_words_units_and_joint_space_lengths():
    p = parse_gcode(
        "G21 G90\nG01 X10 Y5 Z2 A-10 C30 F600\nG91 X10 A-10\nG90 C45\nM30\n", five_axis=GEOM
    )
    assert isinstance(p, FiveAxisProgram)
    np.testing.assert_allclose(
        p.joints,
        [
            [0, 0, 0, 0, 0],
            [0.01, 0.005, 0.002, math.radians(-10), math.radians(30)],
            [0.02, 0.005, 0.002, math.radians(-20), math.radians(30)],
            [0.02, 0.005, 0.002, math.radians(-20), math.radians(45)],
        ],
        atol=1e-15,
    )
    # degrees count as mm: √(10² + 5² + 2² + 10² + 30²) mm, √(10² + 10²) mm, 15 mm
    np.testing.assert_allclose(
        p.segment_lengths_m, [math.sqrt(1129) * 1e-3, math.sqrt(200) * 1e-3, 15e-3]
    )
    assert p.feedrate_m_s == pytest.approx(0.01)
    assert not p.segment_is_rapid.any() and list(p.segment_lines) == [2, 3, 4]


def test_inch_units_keep_degrees():
    p = parse_gcode("G20\nG01 X1 A-10 F10\n", five_axis=GEOM)
    np.testing.assert_allclose(p.joints[-1], [0.0254, 0, 0, math.radians(-10), 0])


@pytest.mark.parametrize(
    "text, match",
    [
        ("G01 X1 A40 F100\n", r"line 1: X1 A40: beyond the machine's travel .*joint A.*40 deg"),
        ("G01 X300 A-5 F100\n", r"joint x"),
        ("G02 X1 Y1 I1 A-5 F100\n", "arc 'G02' is not available on the five-axis plant"),
        ("G01 A-5 F100\nG04 P1\n", "dwell 'G04' is not available"),
        ("G01 X1 B3 A-5 F100\n", r"'B3'"),
        ("G01 X1 Y1 F100\n", "no A or C word: a three-axis program"),
        ("X1 A-5\n", "no motion mode"),
        ("G01 X1 A-5\n", "before any feed rate"),
    ],
)
def test_bad_five_axis_programs(text, match):
    with pytest.raises(ValueError, match=match):
        parse_gcode(text, five_axis=GEOM)


@pytest.mark.parametrize("plant", ["hsm2", "jee-triaxial"])
def test_rotary_words_on_a_linear_plant_name_word_and_plant(plant):
    with pytest.raises(ValueError, match=rf"'C15'.*plant '{plant}'.*plant='five-axis'"):
        build_setup(plant=plant, path="G21\nG01 X1 Y1 C15 F100\n", feedrate_m_s=0.01)


def test_three_axis_reader_unchanged():
    p = parse_gcode("G21\nG01 X1 Y1 F100\n")
    assert p.path.dim == 2 and len(p.segments) == 1
