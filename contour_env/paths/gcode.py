"""Read G-code as shops and CAM post-processors write it into a path (`GcodeProgram`).

Words that shape the path
-------------------------
``G00 G01 G02 G03`` (modal motion), ``G17 G18 G19`` (arc plane), ``G20 G21`` (inch / mm),
``G90 G91`` (absolute / incremental), ``X Y Z`` (target), ``I J K`` (arc centre offsets),
``R`` (arc radius), ``F`` (feed, modal), ``N`` (line number, ignored).

Words that time the path
------------------------
* ``G64`` continuous path (blending) with an optional ``P`` tolerance (program units,
  converted to m; ``G64`` alone or ``G64 P0`` = `DEFAULT_G64_TOLERANCE_M`, 0.01 mm, grbl's
  junction deviation; a LinuxCNC ``Q`` is noted and ignored); ``G61`` / ``G61.1`` exact stop
  (modal); ``G09`` exact stop at the end of its own line's move. A program that says
  nothing runs in ``G64`` with the default tolerance, like most controls. The mode in force
  on a move's own line governs how that move ends (Fanuc / LinuxCNC): it is
  ``segment_blend_m[k]``, the tolerance at the junction after segment k; ``0.0`` means an
  exact stop there. The last segment always ends in a stop (0.0), and so does a segment
  followed by a dwell or by ``M00`` / ``M01``.
* ``G04`` dwell: ``G04 P<seconds>`` (RS274/NGC, LinuxCNC, grbl: P is in seconds, with or
  without a decimal point -- note that a Fanuc control reads an integer P as milliseconds;
  the note of such a dwell says so) or ``G04 X<seconds>`` (Fanuc). The line must not move
  (no other axis word, no motion code). The dwell is added to ``segment_dwell_s`` of the
  segment before it (several add up); a dwell before the first move is a pause at the start
  point, ``GcodeProgram.start_dwell_s`` (the feed planner starts the motion that much later).
* ``M00`` / ``M01`` (program / optional stop): an exact stop after the preceding move, no
  wait. ``M02`` / ``M30`` end the program: lines after them are not read (noted), neither
  for motion nor for errors (a Haas ``M99`` after ``M30`` is not a bad line).

Words that are read and reported (``GcodeProgram.notes``), not simulated
------------------------------------------------------------------------
``M`` (spindle M03/M04/M05, tool change M06, coolant M07/M08/M09, any other machine function except
M97/M98/M99), ``S`` (spindle speed), ``T`` (tool), ``H`` / ``D`` (offset numbers), ``O<n>`` alone on
a line (program number), lines starting with ``%`` (tape markers, the whole line is ignored), a
leading ``/`` (block delete: the line is executed), ``G54``-``G59`` (work offsets, taken as
identity), ``G43`` / ``G44 H..`` (tool length offset, ignored for contouring), ``G40 G49 G80 G15 G50
G69`` (cancel codes), ``G94`` (feed per minute, as assumed), ``G91.1`` (incremental arc centres, as
assumed), ``G98`` / ``G99`` (canned-cycle return level), ``G53`` without axis words (``G53 G00 G17``
of a CAM post: moves nothing; its other words apply). Each such word gives one `GcodeNote` ``(line,
word, action)``, in line order; ``GcodeProgram.summary()`` condenses them into one line for the CLI.

Features that change the geometry and are not implemented
---------------------------------------------------------
O-word subroutines and control flow (``O100 sub``, ``o<name> call``), ``M97 M98 M99``, ``#``
parameters and ``[ ]`` expressions, Fanuc macro words (``GOTO``, ``WHILE``, ...), cutter
compensation ``G41 G42``, canned cycles ``G73 G74 G76 G81``-``G89``, rotation / scaling /
mirroring ``G68 G51 G51.1``, offsets ``G10 G52 G92``, reference returns ``G28 G30``,
machine-coordinate moves (``G53`` with an axis word), polar coordinates ``G16``, feed modes
``G93 G95``, absolute arc centres ``G90.1``, splines, threading, probing, any other G code, the
letters ``A B C U V W E L`` and a ``P`` / ``Q`` outside ``G04`` / ``G64``. Also rejected: a
word without a number, a number that does not parse (numbers are ASCII only: ``[+-]`` digits
``0-9`` with an optional ``.``; exponent notation such as ``X1e3`` and non-ASCII digits such as
``X١٠`` or full-width ``１０`` are errors), a coordinate beyond ``MAX_COORDINATE_M`` (so every
path length is finite), a feed beyond ``0 < F <= MAX_FEED_M_S`` (100 m/s: 6e6 mm/min, 236220
inch/min; the error gives the range in the program's units), two codes of one modal group or
two of one letter on one line, an inconsistent arc, a feed move before any ``F``, ``F <= 0``, a
negative dwell or tolerance, an axis word before any motion mode (``G43 H1 Z15.`` as the first
move: write ``G0 G43 H1 Z15.``, as posts do; ``G80`` does not select a motion mode here).

Errors: the reader does not stop at the first bad line. It raises one ``ValueError`` listing
every bad line, each as ``"G-code line <n>: <what>"`` (``n`` = 1-based line of the text,
counting blank and comment lines; unsupported features and unexpected characters quote the
line's text as written, comments removed), at most
`MAX_LISTED_ERRORS` of them plus a count. A single bad line gives just that one
``"G-code line <n>: ..."`` message. After the first error the machine position is unknown,
so later lines are checked only for line-local errors (unsupported words, bad numbers,
characters, duplicate words); errors that depend on the position (arcs, feeds) are listed
only up to the first error.

Files: `read_gcode` reads a file whatever its extension (``.nc .ngc .gcode .tap .cnc .txt .mpf
.eia .ptp`` or none, `COMMON_EXTENSIONS` are the usual ones) and refuses by content: a file
with NUL bytes is not a program, a text that is not G-code gets the error listing its lines.

Text: UTF-8, a leading byte-order mark is dropped; LF, CRLF and CR-only line endings are
accepted (`read_gcode` decodes bytes as UTF-8, replacing bytes that are not). Letters may be
lower case, whitespace inside a line is ignored (RS274/NGC), leading zeros are allowed
(``G1`` == ``G01``), numbers may omit the leading digit (``.5``) or the fraction (``5.``).
Comments in parentheses and after ``;`` are removed, blank lines are allowed.

Conventions
-----------
* Units: the program is read in mm until a ``G20`` (inch) or ``G21`` (mm) word; every length
  is converted to metres. ``F`` is in program units per minute and converted to m/s with the
  units in effect on its own line (``G20``/``G21`` on the same line apply first); the feed
  keeps its physical value when the units change later. ``GcodeProgram.units`` is the unit
  system in effect at the first move.
* Order inside a line: plane, units, ``F``, distance mode, path mode (``G61``/``G64``),
  dwell, motion, stop / end (``M00 M01 M02 M30``); so ``G20``/``G21`` and ``G90``/``G91``
  apply to every number on their own line. The word order on a line does not matter.
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

Two-axis machines: `GcodeProgram.planar_xy`
-------------------------------------------
``program.planar_xy()`` returns the program as an XY machine follows it while an unsimulated Z axis
does the rest: every point gets z = 0, and each segment keeps its duration (length / feed) on the
real machine. A Z-only move becomes a pause of that duration, added to ``segment_dwell_s`` of the XY
segment before it (before the first XY move: to ``start_dwell_s``, a pause at the start, like a
dwell there); a line with XY and Z motion becomes its XY projection with the feed scaled by (XY
length / length); a ``G17`` helix becomes its XY arc (same centre, radius and sweep) with the feed
scaled by r / sqrt(r^2 + pitch^2); a ``G18``/``G19`` arc projects onto the XY plane as a straight
stroke that reverses at the arc's extremes: it becomes exact lines split at the reversal points
(exact stops there), each at its average speed; a ``G18``/``G19`` helix projects onto a sine-like
curve that is approximated by chords within `PLANAR_CHORD_TOL_M` (1 um) and noted so (the junctions
between those chords blend within max(G64 tolerance, 1 um) even under G61: they lie inside one
block). Each changed line gives a note starting ``"Z motion taken by an unsimulated axis: "``.
``planar_xy(strict=True)`` raises instead, naming every line with Z motion. A program whose path is
already 2-D is returned as is.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "COMMON_EXTENSIONS",
    "DEFAULT_G64_TOLERANCE_M",
    "GcodeNote",
    "GcodeProgram",
    "MAX_COORDINATE_M",
    "MAX_FEED_M_S",
    "parse_gcode",
    "read_gcode",
]

from .gcode_parser import (
    COMMON_EXTENSIONS,
    DEFAULT_G64_TOLERANCE_M,
    MAX_COORDINATE_M,
    MAX_FEED_M_S,
    MAX_LISTED_ERRORS,
    PLANAR_CHORD_TOL_M,
    ZERO_LENGTH_TOL_M,
    GcodeNote,
    LineMove,
    Parser,
    format_seconds,
    is_planar_xy,
)
from .geometry import PathGeometry
from .segments import Arc, Line


@dataclass(frozen=True, eq=False)
class GcodeProgram:
    """A parsed G-code program.

    ``segments`` are `Line` / `Arc` objects in metres, ``segment_feeds_m_s`` the feed of each
    (rapids at the rapid feed), ``path`` the `PathGeometry` built from the segments,
    ``feedrate_m_s`` the highest cutting (G01/G02/G03) feed (the rapid feed if the program
    has only rapids), ``units`` 'mm' or 'inch', ``source`` a name for messages.
    Per segment k (numpy arrays, one entry per segment): ``segment_is_rapid`` (bool),
    ``segment_lines`` (1-based source line), ``segment_blend_m`` (G64 path tolerance in m at
    the junction after segment k, 0.0 = exact stop there; the last segment ends in a stop),
    ``segment_dwell_s`` (pause in s after segment k, >= 0). ``start_dwell_s``: the pause (s,
    >= 0) at the start point before the first segment (dwells before the first move; in
    `planar_xy` also the Z-only moves before the first XY move). ``notes``: list of
    `GcodeNote` for the words read but not simulated as written (see the module docstring);
    ``summary()`` condenses them.
    """

    segments: list
    segment_feeds_m_s: np.ndarray
    path: Any
    feedrate_m_s: float
    units: str
    source: str
    segment_is_rapid: np.ndarray
    segment_lines: np.ndarray
    segment_blend_m: np.ndarray | None = None
    segment_dwell_s: np.ndarray | None = None
    notes: list = field(default_factory=list)
    start_dwell_s: float = 0.0

    def __post_init__(self):
        n = len(self.segments)
        if self.segment_blend_m is None:
            blend = np.full(n, DEFAULT_G64_TOLERANCE_M)
            if n:
                blend[-1] = 0.0
            object.__setattr__(self, "segment_blend_m", blend)
        if self.segment_dwell_s is None:
            object.__setattr__(self, "segment_dwell_s", np.zeros(n))

    # ------------------------------------------------------------------ reporting
    def summary(self) -> str:
        """One line for the CLI: the words ignored, dwells, path modes, Z handling."""
        ignored, modes, n_dwell, n_z = [], [], 0, 0
        for note in self.notes:
            a = note.action
            if note.word == "%":
                continue  # tape markers: not worth a word in the summary
            if a.startswith("dwell"):
                n_dwell += 1
            elif a.startswith("path mode "):
                mode = a[len("path mode ") :].split(":")[0]
                if mode not in modes:
                    modes.append(mode)
            elif a.startswith("Z motion taken"):
                n_z += 1
            else:
                ignored.append(note)
        parts = []
        if ignored:
            words = list(dict.fromkeys(n.word for n in ignored))
            shown = " ".join(words[:8]) + (" …" if len(words) > 8 else "")
            n_lines = len({n.line for n in ignored})
            parts.append(
                f"ignored {len(ignored)} word{'s' * (len(ignored) != 1)} ({shown}) "
                f"on {n_lines} line{'s' * (n_lines != 1)}"
            )
        else:
            parts.append("nothing ignored")
        if n_dwell:
            parts.append(f"{n_dwell} dwell{'s' * (n_dwell != 1)}")
        if n_z:
            parts.append(f"{n_z} line{'s' * (n_z != 1)} with Z motion taken by an unsimulated axis")
        pause = float(np.sum(self.segment_dwell_s)) + float(self.start_dwell_s)
        if pause > 0:
            parts.append(f"pauses {pause:.3g} s in all")
        if not any(m.startswith(("G61", "G64")) for m in modes):
            modes.insert(0, f"G64 (default {DEFAULT_G64_TOLERANCE_M * 1e3:g} mm)")
        parts.append(", ".join(modes))
        return "; ".join(parts)

    # ------------------------------------------------------------------ 2-axis machines
    def planar_xy(self, strict: bool = False) -> GcodeProgram:
        """The program for an XY machine; Z is taken by an unsimulated axis (module docstring).

        Returns ``self`` when the path is already 2-D. ``strict=True`` raises ``ValueError``
        naming every line with Z motion instead of converting it.
        """
        if self.path.dim == 2:
            return self
        where = "" if self.source == "<string>" else f" [{self.source}]"
        if strict:
            _refuse_z_motion(self, where)
        out = _PlanarXY(self)
        for k, s in enumerate(self.segments):
            if isinstance(s, Line):
                out.line(k, s)
            elif s.u[2] == 0.0 and s.v[2] == 0.0:  # G17 arc / helix about +-Z
                out.xy_arc(k, s)
            else:  # G18 / G19 arc or helix
                out.tilted_arc(k, s)
            if self.segment_dwell_s[k] > 0:
                out.wait(float(self.segment_dwell_s[k]))
        if not out.segs:
            raise ValueError(f"G-code program has no XY motion; planar_xy needs some{where}")
        return out.program()


def _refuse_z_motion(program: GcodeProgram, where: str) -> None:
    """`GcodeProgram.planar_xy` with strict=True: the error naming every line with Z motion."""
    z_lines = sorted(
        {
            int(ln)
            for s, ln in zip(program.segments, program.segment_lines, strict=True)
            if _has_z_motion(s)
        }
    )
    if z_lines:
        shown = ", ".join(map(str, z_lines[:MAX_LISTED_ERRORS]))
        more = len(z_lines) - MAX_LISTED_ERRORS
        raise ValueError(
            f"G-code program has Z motion on {len(z_lines)} line"
            f"{'s' * (len(z_lines) != 1)} ({shown}{f' and {more} more' if more > 0 else ''})"
            f"; a 2-axis (XY) machine cannot follow it (strict=True){where}"
        )


class _PlanarXY:
    """The XY program of `GcodeProgram.planar_xy`, built segment by segment of ``source``:
    the per-segment lists of the new program, the pause before its first segment and the
    notes saying what became of the Z motion."""

    def __init__(self, source: GcodeProgram):
        self.source = source
        self.segs, self.feeds, self.rapid, self.lines, self.blend, self.dwell = (
            [], [], [], [], [], []
        )  # fmt: skip
        self.notes: list[GcodeNote] = []
        self.start_dwell = float(source.start_dwell_s)  # the pause before the first XY segment

    def note(self, k: int, word: str, what: str) -> None:
        ln = int(self.source.segment_lines[k])
        self.notes.append(GcodeNote(ln, word, f"Z motion taken by an unsimulated axis: {what}"))

    def wait(self, t: float) -> None:
        if self.segs:
            self.dwell[-1] += t
            self.blend[-1] = 0.0
        else:
            self.start_dwell += t

    def add(self, seg, feed: float, k: int, b: float) -> None:
        self.segs.append(seg)
        self.feeds.append(feed)
        self.rapid.append(bool(self.source.segment_is_rapid[k]))
        self.lines.append(int(self.source.segment_lines[k]))
        self.blend.append(b)
        self.dwell.append(0.0)

    def pause(self, t: float, k: int, word: str) -> None:
        where = "" if self.segs else " before the first XY move"
        self.wait(t)
        self.note(k, word, f"pause {format_seconds(t)}{where}")

    def line(self, k: int, s) -> None:
        """A line: its XY projection at the feed of the same duration, or a pause."""
        f = float(self.source.segment_feeds_m_s[k])
        b = float(self.source.segment_blend_m[k])
        p0, p1 = s.start, s.end
        dxy = math.hypot(p1[0] - p0[0], p1[1] - p0[1])
        word = "G0" if self.source.segment_is_rapid[k] else "G1"
        if dxy <= ZERO_LENGTH_TOL_M:
            self.pause(s.length / f, k, word)
            return
        ratio = dxy / s.length
        self.add(Line((p0[0], p0[1], 0.0), (p1[0], p1[1], 0.0)), f * ratio, k, b)
        if p1[2] != p0[2]:
            self.note(k, word, f"XY feed x{ratio:.4g} (same duration)")

    def xy_arc(self, k: int, s) -> None:
        """A G17 arc or helix about +-Z: its XY arc at the feed of the same duration."""
        f = float(self.source.segment_feeds_m_s[k])
        b = float(self.source.segment_blend_m[k])
        c = (s.center[0], s.center[1], 0.0)
        helix = s.pitch != 0.0
        ratio = s.radius / math.hypot(s.radius, s.pitch)
        self.add(Arc(c, s.u, s.v, s.radius, s.theta0, s.sweep, 0.0), f * ratio, k, b)
        if helix:
            self.note(
                k,
                "G3" if s.sweep > 0 else "G2",
                f"helix kept as its XY arc, feed x{ratio:.4g} (same duration)",
            )

    def tilted_arc(self, k: int, s) -> None:
        """A G18 / G19 arc or helix: its XY projection as lines, each piece in its own time."""
        f = float(self.source.segment_feeds_m_s[k])
        b = float(self.source.segment_blend_m[k])
        ln = int(self.source.segment_lines[k])
        pieces, exact = _project_arc_xy(s)
        dur_per_rad = math.hypot(s.radius, s.pitch) / f
        w = s.w
        plane = "G18" if abs(w[1]) > 0.5 else "G19"
        word = "G3" if s.sweep > 0 else "G2"
        n_kept = 0
        for q0, q1, dth, stop in pieces:
            t = abs(dth) * dur_per_rad
            L = math.hypot(q1[0] - q0[0], q1[1] - q0[1])
            if L <= ZERO_LENGTH_TOL_M:
                self.wait(t)
                continue
            # chord junctions inside one block blend whatever the mode (G61 included)
            inner = max(b, PLANAR_CHORD_TOL_M)
            q0z, q1z = (q0[0], q0[1], 0.0), (q1[0], q1[1], 0.0)
            self.add(Line(q0z, q1z), L / t, k, 0.0 if stop else inner)
            n_kept += 1
        if n_kept and self.lines[-1] == ln and self.dwell[-1] == 0.0:
            self.blend[-1] = b  # the block's own end: the mode in force
        kind = (
            (
                f"{plane} arc projected onto XY as {n_kept} line"
                f"{'s' * (n_kept != 1)} (exact, stops where it reverses)"
            )
            if exact
            else (
                f"{plane} helix projected onto XY as a polyline of {n_kept} chords "
                f"within {PLANAR_CHORD_TOL_M * 1e6:g} um"
            )
        )
        self.note(k, word, kind)

    def program(self) -> GcodeProgram:
        """The XY program (at least one segment added): its last segment ends in a stop."""
        src = self.source
        self.blend[-1] = 0.0
        feeds_arr = np.asarray(self.feeds, dtype=float)
        rapid_arr = np.asarray(self.rapid, dtype=bool)
        cutting = feeds_arr[~rapid_arr]
        feedrate = float(cutting.max()) if cutting.size else float(feeds_arr.max())
        all_notes = sorted(list(src.notes) + self.notes, key=lambda n: n.line)
        return GcodeProgram(
            segments=self.segs,
            segment_feeds_m_s=feeds_arr,
            path=PathGeometry.from_segments(self.segs, dim=2),
            feedrate_m_s=feedrate,
            units=src.units,
            source=src.source,
            segment_is_rapid=rapid_arr,
            segment_lines=np.asarray(self.lines, dtype=np.int64),
            segment_blend_m=np.asarray(self.blend, dtype=float),
            segment_dwell_s=np.asarray(self.dwell, dtype=float),
            notes=all_notes,
            start_dwell_s=self.start_dwell,
        )


def _has_z_motion(seg) -> bool:
    if hasattr(seg, "radius"):
        return bool(seg.u[2] != 0.0 or seg.v[2] != 0.0 or seg.pitch * seg.w[2] != 0.0)
    return bool(seg.start[2] != seg.end[2])


def _project_arc_xy(a) -> tuple[list, bool]:
    """XY projection of a G18/G19 arc/helix as pieces (p0, p1, dtheta, stop_after).

    Without pitch the projection is a stroke along one axis: exact lines split at the angles
    where it reverses (stop_after True there). With pitch: chords within PLANAR_CHORD_TOL_M
    (the chord error of the projection is at most that of the circle, r (1 - cos(dth / 2))).
    """
    r, th0, sw = a.radius, a.theta0, a.sweep
    th1 = th0 + sw
    pu, pv = a.u[:2], a.v[:2]
    # the in-plane axis lying in XY; its coordinate r (cos th pu + sin th pv) . d is extreme
    # where -sin th (pu . d) + cos th (pv . d) = 0
    d = pu if abs(pu[0]) + abs(pu[1]) > 0.5 else pv
    phi = math.atan2(float(pv @ d), float(pu @ d))
    lo, hi = min(th0, th1), max(th0, th1)
    k0 = math.floor((lo - phi) / math.pi) + 1
    turns = []
    k = k0
    while phi + k * math.pi < hi:
        t = phi + k * math.pi
        if t - lo > 1e-12 and hi - t > 1e-12:
            turns.append(t)
        k += 1
    exact = a.pitch == 0.0
    if exact:
        grid = [th0, *(turns if sw > 0 else turns[::-1]), th1]
        stops = [True] * (len(grid) - 2) + [False]
    else:
        dmax = 2.0 * math.acos(max(1.0 - PLANAR_CHORD_TOL_M / r, -1.0))
        n = max(1, math.ceil(abs(sw) / dmax))
        pts = set(np.linspace(lo, hi, n + 1).tolist()) | set(turns)
        grid = sorted(pts, reverse=sw < 0)
        stops = [False] * (len(grid) - 1)  # the projection turns smoothly: no reversal
    g = np.asarray(grid)
    p = a.point(g)
    p[0], p[-1] = a.start_point, a.end_point
    return [(p[i], p[i + 1], g[i + 1] - g[i], stops[i]) for i in range(len(g) - 1)], exact


def parse_gcode(
    text: str,
    *,
    start=(0.0, 0.0, 0.0),
    rapid_feed_m_s: float | None = None,
    source: str = "<string>",
    five_axis=None,
) -> GcodeProgram:
    """Parse G-code ``text`` into a `GcodeProgram` (rules: module docstring).

    ``start`` is the machine position before the first move (metres, 2 or 3 coordinates).
    ``rapid_feed_m_s`` is the feed used for G00 moves (default: the highest F programmed).
    ``source`` names the program in error messages. Raises one ``ValueError`` listing every
    bad line.

    ``five_axis``: a :class:`~contour_env.plants.five_axis.FiveAxisGeometry` reads the program
    for the five-axis machine instead (``X Y Z A C`` words, A and C in degrees, G00/G01 only,
    linear in joint space; ``start`` then has 5 joints, default all 0) and returns a
    :class:`~contour_env.paths.gcode_five_axis.FiveAxisProgram`
    (:mod:`contour_env.paths.gcode_five_axis`).
    """
    if rapid_feed_m_s is not None and not (math.isfinite(rapid_feed_m_s) and rapid_feed_m_s > 0):
        raise ValueError(f"rapid_feed_m_s must be finite and > 0, got {rapid_feed_m_s!r}")
    if five_axis is not None:
        from .gcode_five_axis import parse_five_axis

        return parse_five_axis(text, five_axis, start, rapid_feed_m_s, source)
    parser = Parser(source)
    moves, units, feeds_seen = parser.parse(text, start)
    where = "" if source == "<string>" else f" [{source}]"
    errors = parser.errors
    if len(errors) == 1:
        raise ValueError(f"{errors[0]}{where}")
    if errors:
        listed = "\n".join(errors[:MAX_LISTED_ERRORS])
        more = len(errors) - MAX_LISTED_ERRORS
        tail = f"\n... and {more} more bad lines" if more > 0 else ""
        raise ValueError(
            f"G-code program has {len(errors)} bad lines{where} (after the first, only "
            f"line-local checks):\n{listed}{tail}"
        )
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
        if isinstance(m, LineMove):
            segments.append(Line(m.start, m.end))
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
    dim = 2 if is_planar_xy(moves) else 3
    path = PathGeometry.from_segments(segments, dim=dim)
    blend = np.asarray(parser.move_blend, dtype=float)
    blend[-1] = 0.0  # the program ends in a stop
    return GcodeProgram(
        segments=segments,
        segment_feeds_m_s=feeds_arr,
        path=path,
        feedrate_m_s=feedrate,
        units=units or "mm",
        source=source,
        segment_is_rapid=rapid_arr,
        segment_lines=np.asarray(lines, dtype=np.int64),
        segment_blend_m=blend,
        segment_dwell_s=np.asarray(parser.move_dwell, dtype=float),
        notes=parser.notes,
        start_dwell_s=float(parser.start_dwell),
    )


def read_gcode(path_or_file, **kw) -> GcodeProgram:
    """Read a G-code file (a path, whatever its extension: ``.nc .ngc .gcode .tap .cnc .txt
    .mpf .eia .ptp`` or none) or an open file object.

    Keyword arguments go to `parse_gcode`; ``source`` defaults to the file's path. A file is
    refused by its content, not its name: a missing path raises ``FileNotFoundError``, a
    folder or a file with NUL bytes (binary, UTF-16) ``ValueError``, a text that is not
    G-code the reader's ``ValueError`` naming its bad lines. Bytes are decoded as UTF-8 (a
    byte-order mark is dropped; bytes that are not UTF-8 are replaced, which matters only
    inside comments).
    """
    if hasattr(path_or_file, "read"):
        data = path_or_file.read()
        kw.setdefault("source", str(getattr(path_or_file, "name", "<file>")))
    else:
        p = Path(os.fspath(path_or_file))
        if p.is_dir():
            raise ValueError(f"G-code file {str(p)!r} is a directory, not a program")
        if not p.is_file():
            raise FileNotFoundError(f"G-code file not found: {str(p)!r}")
        data = p.read_bytes()
        kw.setdefault("source", str(p))
    nul = data.find(b"\0" if isinstance(data, bytes) else "\0")
    if nul >= 0:
        raise ValueError(
            f"G-code file {kw['source']!r} is not a text file (a NUL byte at offset {nul}); "
            "a program is UTF-8 or ASCII text"
        )
    if isinstance(data, bytes):
        data = data.decode("utf-8-sig", errors="replace")
    return parse_gcode(data, **kw)
