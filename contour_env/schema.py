"""One check for the files users hold in their hands: ``plant.json``, a model folder's
``agent.json`` and ``normalization.json``, and the trace CSV of ``contour-env identify``.

A file's schema is a tuple of :class:`Key` (name, kind, unit, allowed range, required or
not, meaning). :func:`check_object` checks a JSON object against it and :func:`check_column`
checks a column of a trace; both raise :class:`FileFormatError` (a ``ValueError``) with one
line that names the file, the key or column (and the line of a CSV), the value and what is
allowed::

    plant.json: force_limit: must be a number in [1e-06, 1e+07] N, or one per axis, got null
    agent.json: action_repeat: must be an integer in [1, 100000], got 0
    trace.csv line 5002, column 'position_x': 1e+308 m is outside [-10, 10] m ...

:func:`markdown_table` writes a schema as the table of the docs (docs/FILES.md), so the
documented keys, units and ranges are the checked ones.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = [
    "FileFormatError",
    "Key",
    "check_column",
    "check_object",
    "markdown_table",
    "read_json",
    "show",
]

KINDS = ("number", "integer", "bool", "string", "choice", "object", "strings", "numbers", "any")


class FileFormatError(ValueError):
    """A file of the package's formats that does not hold what it should; the message is one
    line naming the file, the key or column, the value and what is allowed."""


@dataclass(frozen=True)
class Key:
    """One key of a JSON object (or one column of a trace).

    kind: ``number`` (a finite real, bools refused), ``integer``, ``bool``, ``string``,
    ``choice`` (one of ``choices``), ``object`` (a JSON object), ``strings`` (a list of
    strings), ``numbers`` (a list of finite numbers, length ``length`` if given), ``any``.
    ``lo``/``hi``: the inclusive range of a number or integer (``lo_open``: > lo);
    ``per_axis``: a number or a list of one number per axis; ``nullable``: null is allowed
    (and means "not given")."""

    name: str
    kind: str
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    per_axis: bool = False
    required: bool = False
    nullable: bool = False
    choices: tuple = ()
    doc: str = ""

    def rule(self) -> str:
        """What the key must hold, as the message and the docs say it."""
        unit = f" {self.unit}" if self.unit else ""
        if self.kind in ("number", "integer", "numbers"):
            noun = {"number": "a number", "integer": "an integer", "numbers": "a list of numbers"}
            text = noun[self.kind] + _range_text(self) + unit
            if self.per_axis:
                text += ", or one per axis"
        elif self.kind == "bool":
            text = "true or false"
        elif self.kind == "string":
            text = "a string"
        elif self.kind == "choice":
            text = "one of " + ", ".join(show(c) for c in self.choices)
        elif self.kind == "object":
            text = "a JSON object"
        elif self.kind == "strings":
            text = "a list of strings"
        else:
            text = "any JSON value"
        if self.nullable:
            text += " (or null)"
        return text


def _range_text(key: Key) -> str:
    lo, hi = key.lo, key.hi
    if lo is not None and hi is not None:
        return f" in {'(' if key.lo_open else '['}{lo:g}, {hi:g}]"
    if lo is not None:
        return f" {'>' if key.lo_open else '≥'} {lo:g}"
    if hi is not None:
        return f" ≤ {hi:g}"
    return ""


def show(value) -> str:
    """A value as its file holds it: JSON's null/true/false, numbers as Python prints them,
    text quoted; long values cut."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        text = json.dumps(value)
    elif isinstance(value, float):
        text = repr(value) if math.isfinite(value) else json.dumps(value)
    else:
        try:
            text = json.dumps(value, allow_nan=True)
        except (TypeError, ValueError):
            text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(
        v, (bool, np.bool_)
    )


def _in_range(key: Key, x: float) -> bool:
    if not math.isfinite(x):
        return False
    if key.lo is not None and (x <= key.lo if key.lo_open else x < key.lo):
        return False
    return key.hi is None or x <= key.hi


def _value_ok(key: Key, v, n_axes: int | None) -> bool:
    kind = key.kind
    if kind == "number":
        if key.per_axis and isinstance(v, (list, tuple)):
            if n_axes is not None and len(v) != n_axes:
                return False
            return len(v) > 0 and all(_is_number(x) and _in_range(key, float(x)) for x in v)
        return _is_number(v) and _in_range(key, float(v))
    if kind == "integer":
        whole = isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
        return whole and _in_range(key, float(v))
    if kind == "bool":
        return isinstance(v, bool)
    if kind == "string":
        return isinstance(v, str)
    if kind == "choice":
        return isinstance(v, (str, int, float)) and not isinstance(v, bool) and v in key.choices
    if kind == "object":
        return isinstance(v, Mapping)
    if kind == "strings":
        return isinstance(v, (list, tuple)) and all(isinstance(x, str) for x in v)
    if kind == "numbers":
        return isinstance(v, (list, tuple)) and all(
            _is_number(x) and _in_range(key, float(x)) for x in v
        )
    return True


def check_object(data, keys, file: str, *, n_axes: int | None = None, unknown: str = "error"):
    """``data`` checked against ``keys`` (a sequence of :class:`Key`); returns it.

    ``file`` names the file (or the argument) in messages; ``n_axes``: the length a per-axis
    list must have (None: any); ``unknown``: "error" (a key the schema does not have is refused,
    the allowed keys listed: a typo is not silently ignored) or "ignore"."""
    if not isinstance(data, Mapping):
        raise FileFormatError(
            f'{file} must hold a JSON object ({{"key": value, ...}}), got {_json_type(data)}'
        )
    by_name = {k.name: k for k in keys}
    if unknown == "error":
        extra = [k for k in data if k not in by_name]
        if extra:
            raise FileFormatError(
                f"{file}: unknown key {show(extra[0])}; allowed: {', '.join(by_name)}"
            )
    for key in keys:
        if key.name not in data:
            if key.required:
                raise FileFormatError(f"{file}: {key.name}: required ({key.rule()}), missing")
            continue
        v = data[key.name]
        if v is None and key.nullable:
            continue
        if not _value_ok(key, v, n_axes):
            axes = (
                f" ({n_axes} per-axis values)"
                if key.per_axis and n_axes and isinstance(v, (list, tuple))
                else ""
            )
            raise FileFormatError(f"{file}: {key.name}: must be {key.rule()}{axes}, got {show(v)}")
    return data


def _json_type(v) -> str:
    if isinstance(v, list):
        return f"a list ({show(v)})"
    if isinstance(v, str):
        return f"a string ({show(v)})"
    if v is None:
        return "null"
    if isinstance(v, bool):
        return show(v)
    if _is_number(v):
        return f"a number ({show(v)})"
    return type(v).__name__


def read_json(path, what: str = "file"):
    """The JSON value in ``path``; FileFormatError naming the file (and where JSON broke) when
    it is missing, unreadable or not JSON. ``what`` says what the file is for."""
    name = os.fspath(path)
    try:
        with open(name, encoding="utf-8") as fh:
            return json.load(fh)
    except FileNotFoundError:
        raise FileFormatError(f"{name}: no such file ({what})") from None
    except IsADirectoryError:
        raise FileFormatError(f"{name}: is a folder, not a {what}") from None
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{name}: not valid JSON ({exc})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"{name}: cannot read it ({getattr(exc, 'strerror', exc)})") from None


def check_column(
    file: str, column: str, values, lines, key: Key, *, hint: str = "", what: str = ""
) -> np.ndarray:
    """A trace column (``values`` (n,), ``lines`` their line numbers in the file) checked
    against ``key``'s range: FileFormatError naming the first line outside it, the column,
    the value and the range (and ``hint``, what a value out of range usually means; ``what``
    names a derived value, e.g. "the speed from the previous row")."""
    x = np.asarray(values, dtype=np.float64)
    ok = np.isfinite(x)
    if key.lo is not None:
        ok &= x > key.lo if key.lo_open else x >= key.lo
    if key.hi is not None:
        ok &= x <= key.hi
    bad = np.flatnonzero(~ok)
    if bad.size:
        j = int(bad[0])
        unit = f" {key.unit}" if key.unit else ""
        rng = _range_text(key).strip().removeprefix("in ")
        more = (
            f" ({bad.size} rows outside)"
            if bad.size > 1
            else " (the only row outside: a glitch? remove or repair that row)"
        )
        raise FileFormatError(
            f"{file} line {int(lines[j])}, column {column!r}: {what + ' ' if what else ''}"
            f"{float(x[j]):.6g}{unit} is outside {rng}{unit}{more}"
            f"{'; ' + hint if hint and bad.size > 1 else ''}"
        )
    return x


def markdown_table(keys, *, per_axis_note: bool = True) -> str:
    """The schema as a Markdown table: key, unit, allowed values, required, meaning."""
    rows = ["| key | unit | allowed | required | meaning |", "|---|---|---|---|---|"]
    for k in keys:
        unit = k.unit or "–"
        allowed = k.rule()
        if k.unit:
            allowed = allowed.replace(f" {k.unit}", "")
        rows.append(
            f"| `{k.name}` | {unit} | {allowed.replace('|', '/')} | "
            f"{'yes' if k.required else 'no'} | {k.doc} |"
        )
    return "\n".join(rows) + "\n"
