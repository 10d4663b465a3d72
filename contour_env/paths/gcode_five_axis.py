"""Five-axis G-code (``X Y Z A C``) for the A–C table machine, read by the same reader as
three-axis programs (:func:`contour_env.paths.gcode.parse_gcode` with ``five_axis=geometry``).

Words: ``X Y Z`` are the linear joints (program units, converted to m) and ``A C`` the
rotary joints in **degrees** (converted to rad), machine coordinates as a control without
tool-centre-point control (RTCP off) reads them. ``G00``/``G01`` move all five joints
**linearly in joint space**, as such controls interpolate; the tool tip then follows the
forward kinematics of that line (a curve in the workpiece frame). ``F`` is the joint-space
feed with degrees counted as program units (ISO / Fanuc without RTCP: ``F`` mm/min moves
√(Δx² + Δy² + Δz² + ΔA² + ΔC²) "mm" per minute, ΔA, ΔC in degrees). ``G90 G91 G20 G21``,
comments and the reported words (``M S T N`` …) are as in the three-axis reader.

Not on the five-axis plant (a clear ``ValueError`` naming the line): arcs ``G02 G03``,
dwells ``G04``, ``B`` words, every word the three-axis reader refuses, a joint beyond the
machine's travel (the message names the joint, its travel and the value; A = −120…+30° on
the NXV560A class), a program without any A or C word (a three-axis program: run it on a
three-axis plant). Every block ends in an exact stop (the feed profile stops at each).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .gcode_parser import Parser, short_text

__all__ = ["FiveAxisProgram", "parse_five_axis"]


@dataclass(frozen=True, eq=False)
class FiveAxisProgram:
    """A five-axis program as joint-space blocks.

    joints (m + 1, 5): the block end points (m, m, m, rad, rad), the first the start;
    segment_feeds_m_s (m,): the joint-space feed of each block (rapids at the rapid feed);
    segment_lengths_m (m,): joint-space length (degrees as program units);
    segment_is_rapid, segment_lines (m,); feedrate_m_s: the highest cutting feed; units;
    source; notes (GcodeNote list).
    """

    joints: np.ndarray
    segment_feeds_m_s: np.ndarray
    segment_lengths_m: np.ndarray
    segment_is_rapid: np.ndarray
    segment_lines: np.ndarray
    feedrate_m_s: float
    units: str
    source: str
    notes: list = field(default_factory=list)

    def summary(self) -> str:
        """One line for the CLI: the words ignored and how the program is interpolated."""
        words = list(dict.fromkeys(n.word for n in self.notes if n.word != "%"))
        ignored = f"ignored {' '.join(words[:8])}" if words else "nothing ignored"
        return (
            f"{ignored}; {len(self.segment_feeds_m_s)} five-axis blocks, linear in joint "
            "space, exact stop at each"
        )


class _FiveAxisParser(Parser):
    rotary_letters = "AC"
    motion_codes = "G00 or G01"

    def __init__(self, source: str, geometry):
        super().__init__(source)
        self.geometry = geometry
        self.rot = [0.0, 0.0]
        self.rotary_seen = False

    def execute(self, lineno, words, gcodes, values, block_delete) -> bool:
        motion = gcodes.get("motion")
        if motion is not None and motion[0] in (2.0, 3.0):
            raise self.error(
                lineno,
                f"arc {motion[1]!r} is not available on the five-axis plant: its moves are "
                "linear in joint space (G00 / G01)",
            )
        n_before = len(self.moves)
        end = super().execute(lineno, words, gcodes, values, block_delete)
        rotary = [values[a] for a in "AC" if a in values]
        if rotary and len(self.moves) == n_before and not any(a in values for a in "XYZ"):
            # an A / C-only line: the base reader moves on X Y Z words only
            self.move(lineno, values, gcodes.get("motion", (None, None))[1], False)
        return end

    def dwell(self, lineno, gcodes, values, axis_words, arc_words) -> None:
        raise self.error(
            lineno, f"dwell {gcodes['non-modal'][1]!r} is not available on the five-axis plant"
        )

    def move(self, lineno, values, motion_text, exact_here) -> None:
        motion, label = self.active_motion(lineno, values, motion_text)
        if any(a in values for a in "IJKR"):
            w = next(values[a] for a in "IJKR" if a in values)
            raise self.error(lineno, f"arc word {w.text!r} on the five-axis plant (no arcs)")
        self.begin_move(lineno, motion, label)
        start = list(self.pos) + list(self.rot)
        target = list(start)
        for k, a in enumerate("XYZAC"):
            w = values.get(a)
            if w is None:
                continue
            d = w.value * self.unit if k < 3 else math.radians(w.value)
            target[k] = d if self.absolute else start[k] + d
            if k >= 3:
                self.rotary_seen = True
        try:
            self.geometry.check_joint(np.array(target), name="q")
        except ValueError as exc:
            words = " ".join(short_text(values[a].text) for a in "XYZAC" if a in values)
            raise self.error(lineno, f"{words}: beyond the machine's travel ({exc})") from None
        # joint-space length (m): one degree of A or C counts as one program unit
        diff = np.array(target) - np.array(start)
        diff[3:] = np.degrees(diff[3:]) * self.unit
        length = float(np.sqrt(np.sum(diff * diff)))
        if length <= 1e-12:
            return  # zero-length move: skipped
        self.moves.append((start, target, None if motion == 0 else self.feed, lineno, length))
        self.move_blend.append(0.0)
        self.move_dwell.append(0.0)
        self.pos = target[:3]
        self.rot = target[3:]


def parse_five_axis(text: str, geometry, start, rapid_feed_m_s, source) -> FiveAxisProgram:
    """The program ``text`` for the five-axis machine of ``geometry`` (module docstring)."""
    start = np.asarray(start, dtype=np.float64).reshape(-1)
    if start.shape == (3,):
        start = np.append(start, (0.0, 0.0))
    if start.shape != (5,) or not np.all(np.isfinite(start)):
        raise ValueError(f"start: 3 or 5 finite joint values (m, rad), got {start.tolist()}")
    parser = _FiveAxisParser(source, geometry)
    parser.rot = [float(start[3]), float(start[4])]
    moves, units, feeds_seen = parser.parse(text, start[:3])
    where = "" if source == "<string>" else f" [{source}]"
    if parser.errors:
        if len(parser.errors) == 1:
            raise ValueError(f"{parser.errors[0]}{where}")
        raise ValueError(
            f"G-code program has {len(parser.errors)} bad lines{where}:\n"
            + "\n".join(parser.errors[:50])
        )
    if not moves:
        raise ValueError(f"G-code program has no motion{where}")
    if not parser.rotary_seen:
        raise ValueError(
            f"G-code program{where} has no A or C word: a three-axis program; run it on a "
            "three-axis plant (hsm2, jee-triaxial, linear-motor, friction-table), or program "
            "the rotary joints for the five-axis plant"
        )
    rapid = rapid_feed_m_s if rapid_feed_m_s is not None else max(feeds_seen, default=None)
    if rapid is None:
        raise ValueError(f"G-code program has only rapid (G00) moves and no F word{where}")
    joints = np.array([moves[0][0]] + [m[1] for m in moves], dtype=np.float64)
    is_rapid = np.array([m[2] is None for m in moves])
    feeds = np.array([rapid if m[2] is None else m[2] for m in moves], dtype=np.float64)
    lengths = np.array([m[4] for m in moves])
    cutting = feeds[~is_rapid]
    return FiveAxisProgram(
        joints=joints,
        segment_feeds_m_s=feeds,
        segment_lengths_m=lengths,
        segment_is_rapid=is_rapid,
        segment_lines=np.array([m[3] for m in moves], dtype=np.int64),
        feedrate_m_s=float(cutting.max()) if cutting.size else float(rapid),
        units=units or "mm",
        source=source,
        notes=list(parser.notes),
    )
