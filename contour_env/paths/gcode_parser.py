"""The G-code reader's line parser: words, modal groups, units, planes, arcs, dwell and
blending, with every bad line collected (the rules: :mod:`contour_env.paths.gcode`). Shared by the
three-axis reader (:mod:`.gcode`) and the five-axis one (:mod:`.gcode_five_axis`)."""

from __future__ import annotations

import math
import re
from typing import NamedTuple

import numpy as np

MM_M = 1e-3
INCH_M = 0.0254
# what part programs are usually called; `read_gcode` reads a file whatever its name (as
# senders such as UGS and bCNC do) and refuses by content
COMMON_EXTENSIONS = (".nc", ".ngc", ".gcode", ".tap", ".cnc", ".txt", ".mpf", ".eia", ".ptp")
SUPPORTED_WORDS = (
    "G00 G01 G02 G03 G04 G09 G17 G18 G19 G20 G21 G61 G61.1 G64 G90 G91 X Y Z I J K R F P N; "
    "reported: M S T H D O G40 G43 G44 G49 G53 (no axis words) G54-G59 G80 G94 G91.1 G98 G99 "
    "G15 G50 G69"
)
ARC_ABS_TOL_M = 5e-6
ARC_REL_TOL = 1e-4
FULL_CIRCLE_TOL_M = 1e-9
ZERO_LENGTH_TOL_M = 1e-12
DEFAULT_G64_TOLERANCE_M = 1e-5  # G64 without P: 0.01 mm (grbl's default junction deviation)
MAX_COORDINATE_M = 1e3  # |coordinate| limit: keeps every length finite (no machine is 1 km)
# F limit: 100 m/s (6e6 mm/min), far above any feed drive (the fastest run a few m/s); keeps
# every time and distance of the feed planner finite
MAX_FEED_M_S = 100.0
MAX_LISTED_ERRORS = 50
PLANAR_CHORD_TOL_M = 1e-6  # chord error of a projected G18/G19 helix in planar_xy

_AXES = "XYZ"
_OFFSETS = "IJK"  # offset letter for axis index 0, 1, 2
# plane code -> (u axis, v axis, w axis) indices; w = u x v is the normal
_PLANES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
# G codes read (value -> modal group); "noted" ones are reported and have no effect
_G_GROUPS = {
    0.0: "motion",
    1.0: "motion",
    2.0: "motion",
    3.0: "motion",
    4.0: "non-modal",
    53.0: "non-modal",  # machine coordinates: read only without axis words (moves nothing)
    9.0: "exact stop",
    17.0: "plane",
    18.0: "plane",
    19.0: "plane",
    20.0: "units",
    21.0: "units",
    90.0: "distance",
    91.0: "distance",
    61.0: "path mode",
    61.1: "path mode",
    64.0: "path mode",
    15.0: "polar",
    40.0: "cutter compensation",
    43.0: "length offset",
    44.0: "length offset",
    49.0: "length offset",
    50.0: "scaling",
    54.0: "work offset",
    55.0: "work offset",
    56.0: "work offset",
    57.0: "work offset",
    58.0: "work offset",
    59.0: "work offset",
    69.0: "rotation",
    80.0: "canned cycle",
    91.1: "arc distance",
    94.0: "feed mode",
    98.0: "return level",
    99.0: "return level",
}
_G_NOTED = {
    15.0: "ignored: polar coordinates off (never on here)",
    40.0: "ignored: cutter compensation off (never on here)",
    43.0: "ignored: tool length offset (contour unaffected)",
    44.0: "ignored: tool length offset (contour unaffected)",
    49.0: "ignored: tool length offset off",
    50.0: "ignored: scaling off (never on here)",
    69.0: "ignored: rotation off (never on here)",
    80.0: "ignored: canned cycle off (never on here)",
    91.1: "ignored: incremental arc centres (as assumed)",
    94.0: "ignored: feed per minute (as assumed)",
    98.0: "ignored: canned-cycle return level (no cycles here)",
    99.0: "ignored: canned-cycle return level (no cycles here)",
}
for _c in range(54, 60):
    _G_NOTED[float(_c)] = f"work offset G{_c} taken as identity"
_G_NOTED[53.0] = "ignored: machine coordinates without axis words (moves nothing)"
_G_UNSUPPORTED = {
    41.0: "cutter radius compensation",
    42.0: "cutter radius compensation",
    41.1: "cutter radius compensation",
    42.1: "cutter radius compensation",
    10.0: "setting offsets",
    52.0: "local coordinate offset",
    92.0: "coordinate offset",
    92.1: "coordinate offset",
    92.2: "coordinate offset",
    92.3: "coordinate offset",
    28.0: "return to reference position, machine home unknown",
    28.1: "setting the reference position",
    30.0: "return to reference position, machine home unknown",
    30.1: "setting the reference position",
    29.0: "return from reference position",
    53.0: "move in machine coordinates, machine zero unknown",
    68.0: "coordinate rotation",
    68.2: "coordinate rotation",
    51.0: "scaling",
    51.1: "mirroring",
    16.0: "polar coordinates",
    93.0: "inverse-time feed",
    95.0: "feed per revolution",
    90.1: "absolute arc centres",
    5.0: "spline",
    5.1: "spline",
    5.2: "NURBS",
    6.1: "NURBS",
    33.0: "threading",
    33.1: "rigid tapping",
    7.0: "lathe diameter mode",
    8.0: "lathe radius mode",
}
for _c in (73, 74, 76, 81, 82, 83, 84, 85, 86, 87, 88, 89):
    _G_UNSUPPORTED[float(_c)] = "canned cycle"
for _c in (38.2, 38.3, 38.4, 38.5):
    _G_UNSUPPORTED[_c] = "probing"
_M_NOTED = {
    0: "program stop: exact stop here, no wait",
    1: "optional stop: exact stop here, no wait",
    2: "program end",
    30: "program end",
    3: "ignored: spindle on (clockwise)",
    4: "ignored: spindle on (counter-clockwise)",
    5: "ignored: spindle stop",
    6: "ignored: tool change (tool-change motion not simulated)",
    7: "ignored: coolant on (mist)",
    8: "ignored: coolant on (flood)",
    9: "ignored: coolant off",
}
_M_UNSUPPORTED = {
    97: "local subprogram call",
    98: "subprogram call",
    99: "subprogram return / program loop",
}
_LETTER_NOTED = {
    "S": "ignored: spindle speed",
    "T": "ignored: tool select",
    "H": "ignored: tool length offset number",
    "D": "ignored: tool diameter offset number (no cutter compensation)",
    "O": "ignored: program number",
}
_LETTER_UNSUPPORTED = {
    "A": "rotary axis; only X Y Z are simulated",
    "B": "rotary axis; only X Y Z are simulated",
    "C": "rotary axis; only X Y Z are simulated",
    "U": "extra axis; only X Y Z are simulated",
    "V": "extra axis; only X Y Z are simulated",
    "W": "extra axis; only X Y Z are simulated",
    "E": "extruder / extra axis word",
    "L": "repeat count or G10 L word",
}
_LETTERS = set("GXYZIJKRFNPQM") | set(_LETTER_NOTED) | set(_LETTER_UNSUPPORTED)
_TOKEN = re.compile(r"([A-Za-z])([^A-Za-z]*)")
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)")  # ASCII digits only
_EXPONENT = re.compile(r"[0-9.][eE][+-]?[0-9.]")
_OWORD = re.compile(
    r"O(?:<[^>]*>|[0-9]+)(SUB|ENDSUB|CALL|RETURN|IF|ELSEIF|ELSE|ENDIF|DO|WHILE|ENDWHILE|"
    r"REPEAT|ENDREPEAT|BREAK|CONTINUE)"
)
_MACRO = re.compile(r"GOTO|WHILE|THEN|END[0-9]|DO[0-9]")


class GcodeNote(NamedTuple):
    """A word that was read but not simulated as written: ``line`` (1-based), ``word`` as
    written (``"%"`` for a tape marker line), ``action`` what was done with it."""

    line: int
    word: str
    action: str


class _LineError(ValueError):
    pass


class LineMove(NamedTuple):
    """A straight move (m); ``feed`` is m/s, or None for a rapid (G00)."""

    start: tuple
    end: tuple
    feed: float | None
    line: int


class ArcMove(NamedTuple):
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


def short_text(text: str) -> str:
    return text if len(text) <= 24 else text[:20] + "..."


def format_seconds(t: float) -> str:
    return f"{t:.3g} s"


class Parser:
    # rotary-axis letters read as axis words (the five-axis parser's A and C)
    rotary_letters = ""
    # the motion codes it reads, for the message of an axis word with no motion mode
    motion_codes = "G00, G01, G02 or G03"

    def __init__(self, source: str):
        self.source = source
        self.errors: list[str] = []
        self.notes: list[GcodeNote] = []

    def error(self, lineno: int, msg: str) -> _LineError:
        return _LineError(f"G-code line {lineno}: {msg}")

    def note(self, lineno: int, word: str, action: str) -> None:
        self.notes.append(GcodeNote(lineno, word, action))

    # ---------------------------------------------------------------- lexing
    def strip_comments(self, raw: str, lineno: int) -> str:
        if "(" not in raw and ";" not in raw:
            return raw
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

    def lex(self, code: str, lineno: int):
        """Line-local checks; returns (words, gcodes, values, block_delete) or None if empty."""
        s = "".join(code.split())
        if not s:
            return None
        shown = " ".join(code.split())
        if len(shown) > 80:
            shown = shown[:77] + "..."
        block_delete = s.startswith("/")
        if block_delete:
            s = s[1:]
            if not s:
                return None
        self.check_syntax(code, s, shown, lineno)
        words = self.read_words(s, shown, lineno)
        gcodes, values = self.group_words(words, lineno)
        self.check_word_context(words, gcodes, values, shown, lineno)
        return words, gcodes, values, block_delete

    def check_syntax(self, code: str, s: str, shown: str, lineno: int) -> None:
        """Refuses what is not plain words: parameters, expressions, subroutines, macros,
        exponent notation, a line not starting with a letter (``s``: ``code`` without
        whitespace or block delete; ``shown``: the line for messages)."""
        up = s.upper()
        feats = []
        if "#" in s:
            feats.append("'#' parameters / variables")
        if "[" in s or "]" in s:
            feats.append("'[ ]' expressions")
        if "<" in s or _OWORD.match(up):
            feats.append("O-word subroutine / control flow")
        elif not feats and _MACRO.search(up):
            feats.append("macro control flow (GOTO / WHILE / END)")
        if feats:
            raise self.error(
                lineno, f"unsupported {', '.join(feats)}: not implemented, in {shown!r}"
            )
        m = _EXPONENT.search(code)
        if m is not None:
            raise self.error(
                lineno,
                f"exponent notation {code[max(m.start() - 6, 0) : m.end() + 4].strip()!r} is not "
                "G-code (write numbers as digits with an optional '.')",
            )
        if not ("A" <= s[0] <= "Z" or "a" <= s[0] <= "z"):
            ch = s[0]
            written = code.strip()
            if len(written) > 40:
                written = written[:37] + "..."
            raise self.error(
                lineno, f"unexpected character {ch!r} (U+{ord(ch):04X}) in {written!r}"
            )

    def read_words(self, s: str, shown: str, lineno: int) -> list[_Word]:
        """The words of ``s`` with their numbers; refuses unknown or unsupported words (all
        of them in one message) and numbers that do not parse."""
        words: list[_Word] = []
        unsupported: list[str] = []
        for tok in _TOKEN.finditer(s):
            text = tok.group(0)
            letter, raw = tok.group(1).upper(), tok.group(2)
            if letter not in _LETTERS:
                unsupported.append(f"{text!r} (unknown word)")
                continue
            value = self.word_number(text, raw, lineno)
            if letter == "G":
                if value not in _G_GROUPS:
                    why = _G_UNSUPPORTED.get(value, "G code not implemented")
                    unsupported.append(f"{text!r} ({why})")
                    continue
            elif letter == "M":
                if value in _M_UNSUPPORTED:
                    unsupported.append(f"{text!r} ({_M_UNSUPPORTED[value]})")
                    continue
            elif letter in _LETTER_UNSUPPORTED and letter not in self.rotary_letters:
                unsupported.append(f"{text!r} ({_LETTER_UNSUPPORTED[letter]})")
                continue
            words.append(_Word(letter, value, text))
        if unsupported:
            what = "word" if len(unsupported) == 1 else "words"
            raise self.error(
                lineno,
                f"unsupported {what} {', '.join(unsupported)}: not implemented, in {shown!r}",
            )
        return words

    def word_number(self, text: str, raw: str, lineno: int) -> float:
        """The number ``raw`` of the word ``text``: ASCII digits, finite."""
        if raw == "":
            raise self.error(lineno, f"word {text!r} has no number")
        if _NUMBER.fullmatch(raw) is None:
            bad = [c for c in raw if not c.isascii()]
            if bad:
                raise self.error(
                    lineno,
                    f"cannot parse the number in word {text!r}: non-ASCII character "
                    f"{bad[0]!r} (U+{ord(bad[0]):04X}); numbers use the ASCII digits 0-9, "
                    "'.', '+' and '-' only",
                )
            raise self.error(lineno, f"cannot parse the number in word {text!r}")
        value = float(raw)
        if not math.isfinite(value):
            raise self.error(
                lineno, f"cannot parse the number in word {short_text(text)!r} (not finite)"
            )
        return value

    def group_words(self, words: list[_Word], lineno: int) -> tuple[dict, dict]:
        """(G codes by modal group: (value, text), the other words but M by letter); refuses
        two codes of one group or two words of one letter."""
        gcodes: dict[str, tuple[float, str]] = {}
        values: dict[str, _Word] = {}
        for w in words:
            if w.letter == "G":
                group = _G_GROUPS[w.value]
                if group in gcodes:
                    raise self.error(
                        lineno,
                        f"two {group} codes on one line: {gcodes[group][1]!r} and {w.text!r}",
                    )
                gcodes[group] = (w.value, w.text)
            elif w.letter != "M":
                if w.letter in values:
                    raise self.error(
                        lineno,
                        f"duplicate word {w.text!r} ({w.letter} already given as "
                        f"{values[w.letter].text!r})",
                    )
                values[w.letter] = w
        return gcodes, values

    def check_word_context(self, words, gcodes, values, shown: str, lineno: int) -> None:
        """Refuses words that need a code on their line: G53 with axis words, P without G04
        or G64, Q without G64, an O word with other words."""
        non_modal = gcodes.get("non-modal", (None, ""))
        if non_modal[0] == 53.0:
            axes = "XYZIJKR" + self.rotary_letters
            if any(w.letter in axes for w in words):
                raise self.error(
                    lineno,
                    f"unsupported word {non_modal[1]!r} ({_G_UNSUPPORTED[53.0]}) with axis words: "
                    f"not implemented, in {shown!r}",
                )
        dwell = non_modal[0] == 4.0
        g64 = gcodes.get("path mode", (None,))[0] == 64.0
        if "P" in values and not (dwell or g64):
            raise self.error(
                lineno,
                f"word {values['P'].text!r} needs G04 (dwell, P in s) or G64 (tolerance) "
                "on its line",
            )
        if "Q" in values and not g64:
            raise self.error(
                lineno,
                f"unsupported word {values['Q'].text!r} (cycle / peck word; Q is read only "
                f"with G64) in {shown!r}",
            )
        if "O" in values and any(w.letter not in "ON" for w in words):
            raise self.error(
                lineno,
                f"unsupported word {values['O'].text!r} with other words (subroutine / "
                f"program call; an O word is read only as a program number alone on its line) "
                f"in {shown!r}",
            )

    # ---------------------------------------------------------------- parsing
    def parse(self, text: str, start):
        pos = np.array(start, dtype=float).reshape(-1)
        if pos.shape == (2,):
            pos = np.append(pos, 0.0)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)):
            raise ValueError(f"start must be 2 or 3 finite coordinates in metres, got {start!r}")
        self.pos = [float(x) for x in pos]
        self.unit = MM_M
        self.units_name = "mm"
        self.first_units: str | None = None
        self.absolute = True
        self.plane = 17
        self.motion: int | None = None
        self.feed: float | None = None
        self.feeds_seen: list[float] = []
        self.blend = DEFAULT_G64_TOLERANCE_M
        self.moves: list = []
        self.move_blend: list[float] = []
        self.move_dwell: list[float] = []
        self.start_dwell = 0.0  # s: dwells before the first move

        if text.startswith("\ufeff"):
            text = text[1:]
        if "\r" in text:
            text = text.replace("\r\n", "\n").replace("\r", "\n")
        lines = text.split("\n")
        for lineno, raw in enumerate(lines, start=1):
            st = raw.strip()
            if not st:
                continue
            if st.startswith("%"):
                self.note(lineno, "%", "ignored: tape marker line")
                continue
            try:
                lexed = self.lex(self.strip_comments(raw, lineno), lineno)
            except _LineError as e:
                self.errors.append(str(e))
                continue
            if lexed is None:
                continue
            if self.errors:
                # after an error the position is unknown: line-local checks only, up to the
                # program end (a control stops reading there; what follows is not checked)
                if any(w.letter == "M" and w.value in (2.0, 30.0) for w in lexed[0]):
                    break
                continue
            try:
                ended = self.execute(lineno, *lexed)
            except _LineError as e:
                self.errors.append(str(e))
                continue
            if ended:
                rest = sum(1 for r in lines[lineno:] if r.strip() and not r.strip().startswith("%"))
                if rest:
                    last = self.notes[-1]
                    self.notes[-1] = last._replace(
                        action=f"{last.action}: {rest} line{'s' * (rest != 1)} after it not read"
                    )
                break
        return self.moves, self.first_units, self.feeds_seen

    def execute(self, lineno, words, gcodes, values, block_delete) -> bool:
        """Run one lexed line; True when it ends the program (M02 / M30)."""
        unit = self.unit
        if "units" in gcodes:  # needed for the notes of G64 P
            unit = INCH_M if gcodes["units"][0] == 20.0 else MM_M
        if block_delete:
            self.note(lineno, "/", "ignored: block delete (the line is executed)")
        stop = end = False
        for w in words:
            if w.letter == "G":
                action = _G_NOTED.get(w.value)
                if action is not None:
                    self.note(lineno, w.text, action)
            elif w.letter == "M":
                code = int(w.value) if w.value.is_integer() else None
                action = _M_NOTED.get(code, "ignored: machine function")
                self.note(lineno, w.text, action)
                stop = stop or code in (0, 1)
                end = end or code in (2, 30)
            elif w.letter in _LETTER_NOTED:
                self.note(lineno, w.text, _LETTER_NOTED[w.letter])
            elif w.letter == "Q":
                self.note(lineno, w.text, "ignored: G64 Q (CAM path merging tolerance)")

        # modal state, in RS274/NGC order (units before F so that F uses this line's units)
        if "plane" in gcodes:
            self.plane = int(gcodes["plane"][0])
        if "units" in gcodes:
            inch = gcodes["units"][0] == 20.0
            self.unit, self.units_name = (INCH_M, "inch") if inch else (MM_M, "mm")
        if "F" in values:
            fw = values["F"]
            if not 0 < fw.value * unit / 60.0 <= MAX_FEED_M_S:
                lim = MAX_FEED_M_S * 60.0 / unit
                name = "inch" if unit == INCH_M else "mm"
                raise self.error(
                    lineno,
                    f"feed rate must be > 0 and <= {lim:.6g} {name}/min ({MAX_FEED_M_S:g} m/s), "
                    f"got {short_text(fw.text)!r}",
                )
            self.feed = fw.value * unit / 60.0
            self.feeds_seen.append(self.feed)
        if "distance" in gcodes:
            self.absolute = gcodes["distance"][0] == 90.0
        if "path mode" in gcodes:
            code, text = gcodes["path mode"]
            if code == 64.0:
                pw = values.get("P")
                if pw is not None and pw.value < 0:
                    raise self.error(lineno, f"G64 tolerance must be >= 0, got {pw.text!r}")
                if pw is None or pw.value == 0:
                    self.blend = DEFAULT_G64_TOLERANCE_M
                    desc = f"{text}: blend within {DEFAULT_G64_TOLERANCE_M * 1e3:g} mm (default)"
                    if pw is not None:
                        desc = f"{text} {pw.text}: blend within "
                        desc += f"{DEFAULT_G64_TOLERANCE_M * 1e3:g} mm (default)"
                else:
                    self.blend = pw.value * unit
                    desc = (
                        f"{text} {pw.text} {self.units_name}: blend within "
                        f"{self.blend * 1e3:.4g} mm"
                    )
                self.note(lineno, text, f"path mode {desc}")
            else:
                self.blend = 0.0
                self.note(lineno, text, f"path mode {text}: exact stop at every junction")
        exact_here = "exact stop" in gcodes
        if exact_here:
            t9 = gcodes["exact stop"][1]
            self.note(lineno, t9, f"path mode {t9}: exact stop after this line's move")

        axis_words = [values[a] for a in _AXES if a in values]
        arc_words = [values[a] for a in "IJKR" if a in values]
        if gcodes.get("non-modal", (None,))[0] == 4.0:
            self.dwell(lineno, gcodes, values, axis_words, arc_words)
            axis_words = arc_words = []
        else:
            motion_text = None
            if "motion" in gcodes:
                self.motion, motion_text = int(gcodes["motion"][0]), gcodes["motion"][1]
            if arc_words and self.motion not in (2, 3):
                raise self.error(
                    lineno, f"arc word {arc_words[0].text!r} used without G02/G03 motion"
                )
            if axis_words or arc_words:
                self.move(lineno, values, motion_text, exact_here)
        if stop and self.moves:
            self.move_blend[-1] = 0.0
        return end

    def dwell(self, lineno, gcodes, values, axis_words, arc_words) -> None:
        gt = gcodes["non-modal"][1]
        if "motion" in gcodes:
            raise self.error(lineno, f"dwell {gt!r} and motion {gcodes['motion'][1]!r} on one line")
        moving = [w for w in axis_words + arc_words if w.letter != "X"]
        if moving:
            raise self.error(lineno, f"dwell {gt!r} line cannot move ({moving[0].text!r})")
        pw, xw = values.get("P"), values.get("X")
        if pw is not None and xw is not None:
            raise self.error(
                lineno, f"dwell {gt!r} with both {pw.text!r} and {xw.text!r}: give one (s)"
            )
        tw = pw if pw is not None else xw
        if tw is None:
            raise self.error(lineno, f"dwell {gt!r} needs P<seconds> (or X<seconds>)")
        if tw.value < 0:
            raise self.error(lineno, f"dwell time must be >= 0 s, got {tw.text!r}")
        t = tw.value
        word = f"{gt} {tw.text}"
        hint = ""
        if tw.letter == "P" and "." not in tw.text:
            hint = f" (P in seconds, RS274/NGC; a Fanuc control reads {tw.text} as ms)"
        if not self.moves:
            self.start_dwell += t  # a pause at the start point
            self.note(lineno, word, f"dwell {t:g} s before the first move{hint}")
            return
        self.move_dwell[-1] += t
        self.move_blend[-1] = 0.0
        self.note(lineno, word, f"dwell {t:g} s{hint}")

    def active_motion(self, lineno, values, motion_text) -> tuple[int, str]:
        """(the motion mode in force, its label for messages: the code as written on the
        line, or "Gnn (modal)"); refuses axis words with no motion mode active."""
        motion = self.motion
        if motion is None:
            letters = "XYZ" + self.rotary_letters + "IJKR"
            first = next(values[a] for a in letters if a in values)
            raise self.error(
                lineno,
                f"axis word {first.text!r} with no motion mode active "
                f"(program {self.motion_codes} first)",
            )
        label = motion_text if motion_text is not None else f"G{motion:02d} (modal)"
        return motion, label

    def begin_move(self, lineno, motion, label) -> None:
        """Refuses a feed move before any F word; the first move fixes the program's units."""
        if motion != 0 and self.feed is None:
            raise self.error(
                lineno, f"feed move {label!r} before any feed rate (F word) was programmed"
            )
        if self.first_units is None:
            self.first_units = self.units_name

    def move(self, lineno, values, motion_text, exact_here) -> None:
        motion, label = self.active_motion(lineno, values, motion_text)
        pos = self.pos
        unit = self.unit
        target = list(pos)
        for k, a in enumerate(_AXES):
            w = values.get(a)
            if w is not None:
                d = w.value * unit
                target[k] = d if self.absolute else pos[k] + d
                if not abs(target[k]) <= MAX_COORDINATE_M:
                    raise self.error(
                        lineno,
                        f"coordinate {short_text(w.text)!r} puts {a} at {target[k]:.3g} m; "
                        f"coordinates must be within +-{MAX_COORDINATE_M:g} m (path length not "
                        "finite or not a machine path)",
                    )
        for a in "IJKR":
            w = values.get(a)
            if w is not None and not abs(w.value * unit) <= 2 * MAX_COORDINATE_M:
                raise self.error(
                    lineno,
                    f"arc word {short_text(w.text)!r} is {w.value * unit:.3g} m; must be within "
                    f"+-{2 * MAX_COORDINATE_M:g} m",
                )
        self.begin_move(lineno, motion, label)
        if motion in (0, 1):
            dx, dy, dz = target[0] - pos[0], target[1] - pos[1], target[2] - pos[2]
            if math.sqrt(dx * dx + dy * dy + dz * dz) <= ZERO_LENGTH_TOL_M:
                return  # zero-length move: skipped, position unchanged
            self.moves.append(
                LineMove(tuple(pos), tuple(target), None if motion == 0 else self.feed, lineno)
            )
        else:
            self.moves.append(
                self.arc(
                    lineno,
                    label,
                    np.array(pos),
                    np.array(target),
                    self.plane,
                    motion == 2,
                    values,
                    unit,
                    self.feed,
                )
            )
        self.move_blend.append(0.0 if exact_here else self.blend)
        self.move_dwell.append(0.0)
        self.pos = target

    def arc(self, lineno, label, start, end, plane, cw, values, unit, feed) -> ArcMove:
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
        return ArcMove(
            center, eye[iu], eye[iv], radius, theta0, sweep, pitch, start, end, feed, lineno
        )


def is_planar_xy(moves: list) -> bool:
    for m in moves:
        if isinstance(m, LineMove):
            if m.start[2] != 0.0 or m.end[2] != 0.0:
                return False
        elif m.center[2] != 0.0 or m.pitch != 0.0 or m.u[2] != 0.0 or m.v[2] != 0.0:
            return False
    return True
