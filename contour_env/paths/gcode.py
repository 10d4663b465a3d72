"""Read the common G-code subset into a path (`GcodeProgram`).

Supported words
---------------
``G00 G01 G02 G03`` (modal motion), ``G17 G18 G19`` (arc plane), ``G20 G21`` (inch / mm),
``G90 G91`` (absolute / incremental), ``X Y Z`` (target), ``I J K`` (arc centre offsets),
``R`` (arc radius), ``F`` (feed, modal), ``N`` (line number, ignored). Letters may be lower
case, words may be separated by spaces (all whitespace inside a line is ignored, as in
RS274/NGC), leading zeros are allowed (``G1`` == ``G01``), numbers may omit the leading digit
(``.5``) or the fraction (``5.``). Comments in parentheses and after ``;`` are removed, lines
that start with ``%`` (tape markers) are ignored, blank lines are allowed.

Anything else -- ``M``/``S``/``T``/``O`` words, ``G04``, ``G41``, any other G-code or letter,
a word without a number, a number that does not parse, two codes of one modal group or two
of the same letter on one line, an inconsistent arc, a feed move before any ``F``, ``F <= 0``
-- raises ``ValueError`` whose message starts ``"G-code line <n>: "`` (``n`` = 1-based line
of the text, counting blank and comment lines) and quotes the offending word.

Conventions
-----------
* Units: the program is read in mm until a ``G20`` (inch) or ``G21`` (mm) word; every length
  is converted to metres. ``F`` is in program units per minute and converted to m/s with the
  units in effect on its own line (``G20``/``G21`` on the same line apply first); the feed
  keeps its physical value when the units change later. ``GcodeProgram.units`` is the unit
  system in effect at the first move.
* Order inside a line: plane, units, ``F``, distance mode, motion; so ``G20``/``G21`` and
  ``G90``/``G91`` apply to every number on their own line. The word order on a line does not
  matter.
* ``I J K`` are always incremental from the arc start point (Fanuc / RS274 default, i.e.
  ``G91.1``), in both ``G90`` and ``G91``. Only the two offsets of the active plane may be
  given (``G17``: I J, ``G18``: I K, ``G19``: J K); a missing one is 0.
* ``R > 0`` selects the shorter arc (sweep <= 180 deg), ``R < 0`` the longer one. An ``R``
  shorter than half the chord by at most the arc tolerance (below) is taken as a semicircle.
  An R-form arc must not end where it starts (use I/J/K for a full circle).
* Arc direction: ``G02`` is clockwise, ``G03`` counter-clockwise as seen from the positive
  end of the axis normal to the plane looking towards the origin. The resulting `Arc` uses
  the fixed in-plane axes ``(u, v)`` and normal ``w = u x v``:
  ``G17``: u = X, v = Y, w = +Z; ``G18``: u = Z, v = X, w = +Y (in-plane coordinates are
  (Z, X), so G03 turns from +Z towards +X); ``G19``: u = Y, v = Z, w = +X. ``G03`` gives
  ``sweep > 0`` and ``G02`` gives ``sweep < 0`` (clockwise about w); ``theta0`` is the angle
  of the start point about the centre in the (u, v) axes.
* Full circle: an I/J/K arc whose end point equals its start point in the plane (within
  ``FULL_CIRCLE_TOL_M``; an arc line with I/J/K but no axis word also ends at its start) has
  ``sweep = +-2 pi``.
* Helix: motion along the plane's normal axis during ``G02``/``G03`` gives an `Arc` with
  ``pitch = (normal rise) / sweep`` (m/rad); the centre lies at the start point's height.
* Arc tolerance: with I/J/K the distances centre-start and centre-end may differ by at most
  ``max(ARC_ABS_TOL_M, ARC_REL_TOL * radius)`` = max(5 um, 1e-4 r) -- about the rounding of a
  CAM program written to 3 decimals in mm, and close to what common controls accept. Within
  tolerance the centre is moved onto the perpendicular bisector of the chord, so the arc ends
  exactly at the programmed end point and the path stays continuous.
* Start: the machine position before the first move is ``start`` (default the origin, in
  metres); a first move from there is part of the path.
* ``G00`` rapids are part of the path, traversed at ``rapid_feed_m_s`` (default: the highest
  ``F`` programmed anywhere). Lines whose end equals their start (within
  ``ZERO_LENGTH_TOL_M``) are skipped. A program without any move raises
  ``ValueError("G-code program has no motion")``.
* The path is 2-D (``dim = 2``) when every point of it has z = 0 exactly (lines with
  z = 0 at both ends, plane arcs in z = 0 about +-Z), else 3-D.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "ALLOWED_EXTENSIONS",
    "GcodeProgram",
    "parse_gcode",
    "read_gcode",
]

MM_M = 1e-3
INCH_M = 0.0254
ALLOWED_EXTENSIONS = (".nc", ".gcode", ".ngc", ".tap")
SUPPORTED_WORDS = "G00 G01 G02 G03 G17 G18 G19 G20 G21 G90 G91 X Y Z I J K R F N"
ARC_ABS_TOL_M = 5e-6
ARC_REL_TOL = 1e-4
FULL_CIRCLE_TOL_M = 1e-9
ZERO_LENGTH_TOL_M = 1e-12

_AXES = "XYZ"
_OFFSETS = "IJK"  # offset letter for axis index 0, 1, 2
_LETTERS = set("GXYZIJKRFN")
# plane code -> (u axis, v axis, w axis) indices; w = u x v is the normal
_PLANES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
_GROUPS = {
    0: "motion",
    1: "motion",
    2: "motion",
    3: "motion",
    17: "plane",
    18: "plane",
    19: "plane",
    20: "units",
    21: "units",
    90: "distance",
    91: "distance",
}
_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)")


class _LineMove(NamedTuple):
    """A straight move; ``feed`` is m/s, or None for a rapid (G00)."""

    start: np.ndarray
    end: np.ndarray
    feed: float | None
    line: int


class _ArcMove(NamedTuple):
    """A circular / helical move in the `Arc` parametrisation (see module docstring)."""

    center: np.ndarray
    u: np.ndarray
    v: np.ndarray
    radius: float
    theta0: float
    sweep: float
    pitch: float
    start: np.ndarray
    end: np.ndarray
    feed: float
    line: int


class _Word(NamedTuple):
    letter: str  # upper case
    value: float
    text: str  # as written (whitespace removed)


@dataclass(frozen=True, eq=False)
class GcodeProgram:
    """A parsed G-code program.

    ``segments`` are `Line` / `Arc` objects in metres, ``segment_feeds_m_s`` the feed of each
    (rapids at the rapid feed), ``path`` the `PathGeometry` built from the segments,
    ``feedrate_m_s`` the highest cutting (G01/G02/G03) feed (the rapid feed if the program
    has only rapids), ``units`` 'mm' or 'inch', ``source`` a name for messages.
    Extras: ``segment_is_rapid`` (bool per segment) and ``segment_lines`` (1-based source line
    of each segment).
    """

    segments: list
    segment_feeds_m_s: np.ndarray
    path: Any
    feedrate_m_s: float
    units: str
    source: str
    segment_is_rapid: np.ndarray
    segment_lines: np.ndarray


class _Parser:
    def __init__(self, source: str):
        self.source = source

    def error(self, lineno: int, msg: str) -> ValueError:
        where = "" if self.source == "<string>" else f" [{self.source}]"
        return ValueError(f"G-code line {lineno}: {msg}{where}")

    # ---------------------------------------------------------------- lexing
    def strip_comments(self, raw: str, lineno: int) -> str:
        out = []
        i = 0
        while i < len(raw):
            ch = raw[i]
            if ch == "(":
                j = raw.find(")", i + 1)
                if j < 0:
                    raise self.error(lineno, f"unclosed comment {raw[i:].strip()!r}")
                i = j + 1
                continue
            if ch == ";":
                break
            out.append(ch)
            i += 1
        return "".join(out)

    def words(self, code: str, lineno: int) -> list[_Word]:
        s = "".join(code.split())
        words = []
        i = 0
        while i < len(s):
            ch = s[i]
            if not (ch.isascii() and ch.isalpha()):
                raise self.error(lineno, f"unexpected character {ch!r} in {s[i:]!r}")
            j = i + 1
            while j < len(s) and not (s[j].isascii() and s[j].isalpha()):
                j += 1
            text, raw = s[i:j], s[i + 1 : j]
            letter = ch.upper()
            i = j
            if letter not in _LETTERS:
                raise self.unsupported(lineno, text)
            if raw == "":
                raise self.error(lineno, f"word {text!r} has no number")
            if _NUMBER.fullmatch(raw) is None:
                raise self.error(lineno, f"cannot parse the number in word {text!r}")
            value = float(raw)
            if not math.isfinite(value):
                raise self.error(lineno, f"cannot parse the number in word {text!r}")
            if letter == "G" and not (value.is_integer() and int(value) in _GROUPS):
                raise self.unsupported(lineno, text)
            words.append(_Word(letter, value, text))
        return words

    def unsupported(self, lineno: int, text: str) -> ValueError:
        return self.error(lineno, f"unsupported word {text!r} (supported: {SUPPORTED_WORDS})")

    # ---------------------------------------------------------------- parsing
    def parse(self, text: str, start) -> tuple[list, str | None, list[float]]:
        pos = np.array(start, dtype=float).reshape(-1)
        if pos.shape == (2,):
            pos = np.append(pos, 0.0)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)):
            raise ValueError(f"start must be 2 or 3 finite coordinates in metres, got {start!r}")

        unit = MM_M
        units_name = "mm"
        first_units: str | None = None
        absolute = True
        plane = 17
        motion: int | None = None
        feed: float | None = None
        feeds_seen: list[float] = []
        moves: list = []

        for lineno, raw in enumerate(text.split("\n"), start=1):
            if raw.strip().startswith("%"):
                continue
            words = self.words(self.strip_comments(raw, lineno), lineno)
            if not words:
                continue

            gcodes: dict[str, tuple[int, str]] = {}
            values: dict[str, _Word] = {}
            for w in words:
                if w.letter == "G":
                    code = int(w.value)
                    group = _GROUPS[code]
                    if group in gcodes:
                        raise self.error(
                            lineno,
                            f"two {group} codes on one line: {gcodes[group][1]!r} and {w.text!r}",
                        )
                    gcodes[group] = (code, w.text)
                else:
                    if w.letter in values:
                        raise self.error(
                            lineno,
                            f"duplicate word {w.text!r} ({w.letter} already given as "
                            f"{values[w.letter].text!r})",
                        )
                    values[w.letter] = w

            # modal state, in RS274/NGC order (units before F so that F uses this line's units)
            if "plane" in gcodes:
                plane = gcodes["plane"][0]
            if "units" in gcodes:
                inch = gcodes["units"][0] == 20
                unit, units_name = (INCH_M, "inch") if inch else (MM_M, "mm")
            if "F" in values:
                fw = values["F"]
                if not fw.value > 0:
                    raise self.error(lineno, f"feed rate must be > 0, got {fw.text!r}")
                feed = fw.value * unit / 60.0
                feeds_seen.append(feed)
            if "distance" in gcodes:
                absolute = gcodes["distance"][0] == 90
            motion_text = None
            if "motion" in gcodes:
                motion, motion_text = gcodes["motion"]

            axis_words = [values[a] for a in _AXES if a in values]
            arc_words = [values[a] for a in "IJKR" if a in values]
            if arc_words and motion not in (2, 3):
                raise self.error(
                    lineno, f"arc word {arc_words[0].text!r} used without G02/G03 motion"
                )
            if not axis_words and not arc_words:
                continue  # modal settings only
            if motion is None:
                raise self.error(
                    lineno,
                    f"axis word {axis_words[0].text!r} with no motion mode active "
                    "(program G00, G01, G02 or G03 first)",
                )
            label = motion_text if motion_text is not None else f"G{motion:02d} (modal)"

            target = pos.copy()
            for k, a in enumerate(_AXES):
                if a in values:
                    d = values[a].value * unit
                    target[k] = d if absolute else pos[k] + d

            if motion != 0 and feed is None:
                raise self.error(
                    lineno, f"feed move {label!r} before any feed rate (F word) was programmed"
                )
            if first_units is None:
                first_units = units_name

            if motion in (0, 1):
                if np.linalg.norm(target - pos) <= ZERO_LENGTH_TOL_M:
                    continue  # zero-length move: skipped, position unchanged
                moves.append(_LineMove(pos, target, None if motion == 0 else feed, lineno))
            else:
                moves.append(
                    self.arc(lineno, label, pos, target, plane, motion == 2, values, unit, feed)
                )
            pos = target
        return moves, first_units, feeds_seen

    def arc(self, lineno, label, start, end, plane, cw, values, unit, feed) -> _ArcMove:
        iu, iv, iw = _PLANES[plane]
        su, sv = start[iu], start[iv]
        eu, ev = end[iu], end[iv]
        chord = math.hypot(eu - su, ev - sv)
        r_word = values.get("R")
        off_words = [values[c] for c in "IJK" if c in values]
        if r_word is not None and off_words:
            raise self.error(
                lineno, f"arc with both R and I/J/K ({r_word.text!r}, {off_words[0].text!r})"
            )
        if r_word is None and not off_words:
            raise self.error(lineno, f"arc {label!r} needs R or I/J/K")

        def fmt(x_m: float) -> str:
            return f"{x_m / unit:.6g} {'inch' if unit == INCH_M else 'mm'}"

        full = False
        if r_word is not None:
            r = r_word.value * unit
            if r == 0.0:
                raise self.error(lineno, f"arc radius {r_word.text!r} is zero")
            if chord <= FULL_CIRCLE_TOL_M:
                raise self.error(
                    lineno,
                    f"R-form arc {r_word.text!r} ends at its start point; "
                    "use I/J/K for a full circle",
                )
            R, half = abs(r), 0.5 * chord
            if R < half - max(ARC_ABS_TOL_M, ARC_REL_TOL * R):
                raise self.error(
                    lineno,
                    f"arc radius {r_word.text!r} is smaller than half the chord ({fmt(half)})",
                )
            h = math.sqrt(max(R * R - half * half, 0.0))
            tu, tv = (eu - su) / chord, (ev - sv) / chord
            nu, nv = -tv, tu  # left normal of the chord (turned +90 deg about w)
            # the shorter arc's centre lies left of the chord for CCW, right for CW
            sigma = 1.0 if (not cw) == (r > 0) else -1.0
            cu = 0.5 * (su + eu) + sigma * h * nu
            cv = 0.5 * (sv + ev) + sigma * h * nv
        else:
            for w in off_words:
                if "IJK".index(w.letter) == iw:
                    raise self.error(
                        lineno,
                        f"arc centre word {w.text!r} is along the normal of G{plane} "
                        f"(allowed: {_OFFSETS[iu]} {_OFFSETS[iv]})",
                    )
            off = [values[c].value * unit if c in values else 0.0 for c in _OFFSETS]
            cu, cv = su + off[iu], sv + off[iv]
            rs = math.hypot(su - cu, sv - cv)
            centre_text = " ".join(w.text for w in off_words)
            if rs <= FULL_CIRCLE_TOL_M:
                raise self.error(lineno, f"arc centre {centre_text!r} gives a zero radius")
            if chord <= FULL_CIRCLE_TOL_M:
                full = True
            else:
                re_ = math.hypot(eu - cu, ev - cv)
                tol = max(ARC_ABS_TOL_M, ARC_REL_TOL * max(rs, re_))
                if abs(rs - re_) > tol:
                    raise self.error(
                        lineno,
                        f"arc centre {centre_text!r} is not equidistant from start and end "
                        f"(radius {fmt(rs)} at the start, {fmt(re_)} at the end; "
                        f"tolerance {fmt(tol)})",
                    )
                # move the centre onto the chord's perpendicular bisector
                tu, tv = (eu - su) / chord, (ev - sv) / chord
                mu, mv = 0.5 * (su + eu), 0.5 * (sv + ev)
                d = (cu - mu) * -tv + (cv - mv) * tu
                cu, cv = mu - d * tv, mv + d * tu

        radius = math.hypot(su - cu, sv - cv)
        theta0 = math.atan2(sv - cv, su - cu)
        two_pi = 2.0 * math.pi
        if full:
            sweep = -two_pi if cw else two_pi
        else:
            theta1 = math.atan2(ev - cv, eu - cu)
            if cw:
                sweep = -((theta0 - theta1) % two_pi)
                if sweep >= 0.0:
                    sweep -= two_pi
            else:
                sweep = (theta1 - theta0) % two_pi
                if sweep <= 0.0:
                    sweep += two_pi
        pitch = (end[iw] - start[iw]) / sweep
        center = np.empty(3)
        center[iu], center[iv], center[iw] = cu, cv, start[iw]
        eye = np.eye(3)
        return _ArcMove(
            center, eye[iu], eye[iv], radius, theta0, sweep, pitch, start, end, feed, lineno
        )


def _is_planar_xy(moves: list) -> bool:
    for m in moves:
        if isinstance(m, _LineMove):
            if m.start[2] != 0.0 or m.end[2] != 0.0:
                return False
        elif m.center[2] != 0.0 or m.pitch != 0.0 or m.u[2] != 0.0 or m.v[2] != 0.0:
            return False
    return True


def parse_gcode(
    text: str,
    *,
    start=(0.0, 0.0, 0.0),
    rapid_feed_m_s: float | None = None,
    source: str = "<string>",
) -> GcodeProgram:
    """Parse G-code ``text`` into a `GcodeProgram` (conventions: module docstring).

    ``start`` is the machine position before the first move (metres, 2 or 3 coordinates).
    ``rapid_feed_m_s`` is the feed used for G00 moves (default: the highest F programmed).
    ``source`` names the program in error messages.
    """
    from contour_env.paths.geometry import PathGeometry
    from contour_env.paths.segments import Arc, Line

    if rapid_feed_m_s is not None and not (math.isfinite(rapid_feed_m_s) and rapid_feed_m_s > 0):
        raise ValueError(f"rapid_feed_m_s must be finite and > 0, got {rapid_feed_m_s!r}")
    moves, units, feeds_seen = _Parser(source).parse(text, start)
    where = "" if source == "<string>" else f" [{source}]"
    if not moves:
        raise ValueError(f"G-code program has no motion{where}")

    rapid = rapid_feed_m_s
    if rapid is None:
        if not feeds_seen:
            raise ValueError(
                f"G-code program has only rapid (G00) moves and no F word; "
                f"pass rapid_feed_m_s{where}"
            )
        rapid = max(feeds_seen)

    segments, feeds, is_rapid, lines = [], [], [], []
    for m in moves:
        if isinstance(m, _LineMove):
            segments.append(Line(m.start.copy(), m.end.copy()))
            is_rapid.append(m.feed is None)
            feeds.append(rapid if m.feed is None else m.feed)
        else:
            segments.append(
                Arc(m.center, m.u.copy(), m.v.copy(), m.radius, m.theta0, m.sweep, m.pitch)
            )
            is_rapid.append(False)
            feeds.append(m.feed)
        lines.append(m.line)
    feeds_arr = np.asarray(feeds, dtype=float)
    rapid_arr = np.asarray(is_rapid, dtype=bool)
    cutting = feeds_arr[~rapid_arr]
    feedrate = float(cutting.max()) if cutting.size else float(rapid)
    dim = 2 if _is_planar_xy(moves) else 3
    path = PathGeometry.from_segments(segments, dim=dim)
    return GcodeProgram(
        segments=segments,
        segment_feeds_m_s=feeds_arr,
        path=path,
        feedrate_m_s=feedrate,
        units=units or "mm",
        source=source,
        segment_is_rapid=rapid_arr,
        segment_lines=np.asarray(lines, dtype=np.int64),
    )


def read_gcode(path_or_file, **kw) -> GcodeProgram:
    """Read a G-code file (``.nc``, ``.gcode``, ``.ngc``, ``.tap``) or an open file object.

    Keyword arguments go to `parse_gcode`; ``source`` defaults to the file's path. The
    extension is checked only for paths (case-insensitive); file objects are read as they are.
    """
    if hasattr(path_or_file, "read"):
        data = path_or_file.read()
        kw.setdefault("source", str(getattr(path_or_file, "name", "<file>")))
    else:
        p = Path(os.fspath(path_or_file))
        if p.suffix.lower() not in ALLOWED_EXTENSIONS:
            raise ValueError(
                f"G-code file {str(p)!r} has extension {p.suffix!r}; "
                f"allowed: {' '.join(ALLOWED_EXTENSIONS)}"
            )
        if not p.is_file():
            raise FileNotFoundError(f"G-code file not found: {str(p)!r}")
        data = p.read_bytes()
        kw.setdefault("source", str(p))
    if isinstance(data, bytes):
        data = data.decode("utf-8", errors="replace")
    return parse_gcode(data, **kw)
