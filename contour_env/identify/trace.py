"""The measured trace of :mod:`contour_env.identify`: the :class:`Trace`, reading it from a CSV
(:func:`read_trace`) or arrays, writing one, and the checks before a fit."""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..plants.params import PARAM_RANGES
from ..schema import Key, check_column

DEFAULT_HOLDOUT = 0.25
MIN_ROWS = 1000
# the plausible ranges of a trace's columns (docs/FILES.md): a force command within the
# largest force limit a plant may have, an encoder within ±100 m, no axis faster than 10 m/s
# between two samples. A trace in µm or mm, a command scaled by mistake or a glitch (1e308)
# is refused here, naming the line, before a fit on it could run out of memory or time.
TRACE_KEYS = (
    Key("time_s", "number", "s", doc="sample time, one servo period apart, increasing"),
    Key(
        "command_<axis>",
        "number",
        "N",
        -PARAM_RANGES["force_limit_N"][1],
        PARAM_RANGES["force_limit_N"][1],
        required=True,
        doc="force (current) command, N; in A with --force-constant N/A (checked in N)",
    ),
    Key("position_<axis>", "number", "m", -100.0, 100.0, required=True, doc="encoder reading"),
    Key(
        "speed <axis>",
        "number",
        "m/s",
        -10.0,
        10.0,
        doc="the position's step over one servo period (derived, not a column)",
    ),
)
_COMMAND, _POSITION, _SPEED = TRACE_KEYS[1:]
UNIT_HINT = "positions are in metres: a trace in µm or mm? divide the column by 1e6 or 1e3"
SAMPLE_TOLERANCE = 0.1  # a row's time step may differ from the servo period by 10 %


@dataclass(frozen=True)
class Trace:
    """A measured trace: ``time_s`` (n,), ``command`` (n, A) in N, ``position`` (n, A) in m,
    ``axes`` (names), ``servo_period_s``, ``source`` (file name, for messages), ``columns``
    {axis: (command column, position column)}."""

    time_s: np.ndarray
    command: np.ndarray
    position: np.ndarray
    axes: tuple
    servo_period_s: float
    source: str = "trace"
    columns: dict = field(default_factory=dict)

    @property
    def n_rows(self) -> int:
        return len(self.time_s)


def parse_columns(text: str | None, label: str = "--columns") -> dict:
    """``"command_x=ux,position_x=enc_x"`` → {"command_x": "ux", "position_x": "enc_x"}."""
    out: dict = {}
    if not text:
        return out
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        key, sep, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not key or not value:
            raise ValueError(
                f"{label}: expected NAME=COLUMN pairs such as command_x=ux,position_x=enc_x, "
                f"got {item!r}"
            )
        if not (key == "time_s" or key.startswith(("command_", "position_"))):
            raise ValueError(
                f"{label}: {key!r} is not a trace column (time_s, command_<axis>, position_<axis>)"
            )
        if key in out:
            raise ValueError(f"{label}: {key!r} given twice")
        out[key] = value
    return out


def _axes_list(axes) -> list | None:
    if axes is None:
        return None
    if isinstance(axes, str):
        axes = [a.strip() for a in axes.split(",") if a.strip()]
    axes = list(axes)
    if not 2 <= len(axes) <= 3 or len(set(axes)) != len(axes):
        raise ValueError(
            f"axes: 2 or 3 different axis names such as x,y or x,y,z (a plant has 2 or 3 "
            f"axes), got {','.join(map(str, axes))!r}"
        )
    return axes


def _per_axis(label: str, value, n: int) -> np.ndarray | None:
    if value is None:
        return None
    if isinstance(value, str):
        try:
            value = [float(v) for v in value.split(",")]
        except ValueError:
            raise ValueError(f"{label}: expected a number or one per axis, got {value!r}") from None
    arr = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if arr.size == 1:
        arr = np.full(n, float(arr[0]))
    if arr.shape != (n,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(f"{label}: expected a number > 0 or one per axis ({n}), got {value!r}")
    return arr


def read_trace(
    path,
    *,
    axes=None,
    columns=None,
    force_constant=None,
    servo_period_s=None,
) -> Trace:
    """Read a trace CSV: a header line, then one row per servo sample. ``columns`` maps the
    names this module uses to the file's (a mapping or ``"command_x=ux,..."``);
    ``force_constant`` (N/A, one or per axis) converts commands in A to N; ``servo_period_s``
    checks the time column (default: its median step). ValueError with one line naming the
    file, the column or the line for a missing column, a field that is not a finite number
    (NaN, inf, text), a time that does not increase or skips samples, or a trace too short."""
    name = os.fspath(path)
    cmap = parse_columns(columns) if isinstance(columns, (str, type(None))) else dict(columns)
    try:
        fh = open(name, encoding="utf-8-sig", newline="")
    except FileNotFoundError:
        raise ValueError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise ValueError(f"{name}: is a directory, not a trace file") from None
    with fh:
        reader = csv.reader(fh)
        header = _read_header(name, reader)
        ax, wanted = _trace_columns(name, header, cmap, axes)
        rows = _read_rows(name, reader, header, wanted)
    return _trace_of_rows(name, rows, ax, cmap, force_constant, servo_period_s)


def _col(cmap: dict, key: str) -> str:
    """The file's name of the trace column ``key`` (``--columns`` maps it, else the same)."""
    return cmap.get(key, key)


def _read_header(name: str, reader) -> list:
    """The header line's column names (stripped)."""
    try:
        header = next(reader)
    except StopIteration:
        raise ValueError(f"{name}: empty file (expected a header line: {_example()})") from None
    except (csv.Error, UnicodeDecodeError) as exc:
        raise ValueError(f"{name} line 1: not a CSV header ({exc})") from None
    return [h.strip() for h in header]


def _trace_columns(name: str, header: list, cmap: dict, axes) -> tuple[list, list]:
    """The axes (given, else those the header has) and the file's columns to read: time, then
    command and position per axis; every one checked against the header."""
    index = {h: j for j, h in enumerate(header)}
    unknown = [f"{k}={v}" for k, v in cmap.items() if v not in index]
    if unknown:
        raise ValueError(
            f"{name}: --columns names a column the header does not have ({', '.join(unknown)});"
            f" the header has: {', '.join(header)}"
        )
    ax = _axes_list(axes)
    if ax is None:
        ax = [
            a
            for a in ("x", "y", "z")
            if _col(cmap, f"command_{a}") in index or _col(cmap, f"position_{a}") in index
        ]
        if len(ax) < 2:
            ax = ["x", "y"]  # the missing column is named below
    wanted = [_col(cmap, "time_s")]
    for a in ax:
        wanted += [_col(cmap, f"command_{a}"), _col(cmap, f"position_{a}")]
    for key in wanted:
        if key not in index:
            raise ValueError(
                f"{name}: missing column {key!r} (the header has: {', '.join(header)}); "
                "map other names with --columns, e.g. --columns command_x=ux,position_x=enc_x"
            )
    return ax, wanted


def _read_rows(name: str, reader, header: list, wanted: list) -> list:
    """(line number, [the ``wanted`` columns' values]) of every data row (blank lines skipped);
    every field a finite number."""
    index = {h: j for j, h in enumerate(header)}
    picks = [index[k] for k in wanted]
    rows = []
    try:
        for line_no, row in enumerate(reader, start=2):
            if not row or all(not f.strip() for f in row):
                continue
            if len(row) < len(header):
                raise ValueError(
                    f"{name} line {line_no}: {len(row)} fields, the header has {len(header)}"
                )
            vals = []
            for key, j in zip(wanted, picks, strict=True):
                text = row[j].strip()
                try:
                    v = float(text)
                except ValueError:
                    v = math.nan
                if not math.isfinite(v):
                    raise ValueError(
                        f"{name} line {line_no}, column {key!r}: not a finite number ({text!r})"
                    )
                vals.append(v)
            rows.append((line_no, vals))
    except (csv.Error, UnicodeDecodeError) as exc:
        raise ValueError(f"{name} line {reader.line_num}: not valid CSV ({exc})") from None
    return rows


def _trace_of_rows(name, rows, ax, cmap, force_constant, servo_period_s) -> Trace:
    """The :class:`Trace` of the rows read: commands in N, the time column checked (increasing,
    one servo period apart), the servo period and the length checked."""
    if not rows:
        raise ValueError(f"{name}: no data rows after the header")
    lines = np.array([r[0] for r in rows])
    data = np.array([r[1] for r in rows], dtype=np.float64)
    t = data[:, 0]
    A = len(ax)
    command = data[:, 1::2][:, :A].copy()
    position = data[:, 2::2][:, :A].copy()
    fk = _per_axis("--force-constant", force_constant, A)
    if fk is not None:
        command *= fk
    _check_ranges(name, lines, t, command, position, ax, cmap)
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        j = bad[0] + 1
        raise ValueError(
            f"{name} line {lines[j]}: {_col(cmap, 'time_s')} {float(t[j])!r} is not after the "
            f"previous row's {float(t[j - 1])!r} (time must increase)"
        )
    if servo_period_s is None:
        if dt.size == 0:
            raise ValueError(f"{name}: one data row; a trace needs at least {MIN_ROWS} rows")
        T = float(np.median(dt))
    else:
        T = _per_axis("--servo-period", servo_period_s, 1)[0]
    off = np.flatnonzero(np.abs(dt - T) > SAMPLE_TOLERANCE * T)
    if off.size:
        j = off[0] + 1
        raise ValueError(
            f"{name} line {lines[j]}: time step {dt[j - 1]:.6g} s, the servo period is {T:.6g} s "
            "(rows must be one servo period apart, none missing)"
        )
    if not PARAM_RANGES["servo_period_s"][0] <= T <= PARAM_RANGES["servo_period_s"][1]:
        raise ValueError(f"{name}: servo period {T:g} s outside [1e-06, 0.1] s")
    if len(t) < MIN_ROWS:
        raise ValueError(
            f"{name}: {len(t)} rows, too short to identify: at least {MIN_ROWS} servo samples "
            f"({MIN_ROWS * T:g} s here); record a longer trace (contour-env excite)"
        )
    return Trace(
        time_s=t,
        command=command,
        position=position,
        axes=tuple(ax),
        servo_period_s=T,
        source=name,
        columns={a: (_col(cmap, f"command_{a}"), _col(cmap, f"position_{a}")) for a in ax},
    )


def _check_ranges(name, lines, t, command, position, ax, cmap) -> None:
    """Every command, position and speed in its plausible range (:data:`TRACE_KEYS`)."""
    for j, a in enumerate(ax):
        ccol, pcol = _col(cmap, f"command_{a}"), _col(cmap, f"position_{a}")
        check_column(
            name, ccol, command[:, j], lines, _COMMAND,
            hint="commands are forces in N (give --force-constant N/A for a current in A)",
        )  # fmt: skip
        check_column(name, pcol, position[:, j], lines, _POSITION, hint=UNIT_HINT)
    dt = np.diff(t)
    if dt.size == 0 or np.any(dt <= 0):
        return  # the time column's own check names the line
    for j, a in enumerate(ax):
        speed = np.diff(position[:, j]) / dt
        check_column(
            name, _col(cmap, f"position_{a}"), speed, lines[1:], _SPEED,
            hint=UNIT_HINT + ", or an encoder glitch", what="the speed from the previous row",
        )  # fmt: skip


def _example() -> str:
    return "time_s,command_x,position_x,command_y,position_y"


def trace_from_arrays(time_s, command, position, axes=("x", "y"), source="trace") -> Trace:
    """A :class:`Trace` from arrays (command N, position m, (n, A))."""
    t = np.asarray(time_s, dtype=np.float64)
    T = float(np.median(np.diff(t)))
    return Trace(
        t,
        np.asarray(command, dtype=np.float64).reshape(len(t), -1),
        np.asarray(position, dtype=np.float64).reshape(len(t), -1),
        tuple(axes),
        T,
        source,
        {a: (f"command_{a}", f"position_{a}") for a in axes},
    )


def write_trace_csv(path, time_s, command, position, axes=("x", "y")):
    """Write a trace in the format :func:`read_trace` reads (atomically)."""
    from ..io import atomic_write_text

    header = ["time_s"]
    cols = [np.asarray(time_s, dtype=np.float64)]
    command = np.asarray(command, dtype=np.float64).reshape(len(cols[0]), -1)
    position = np.asarray(position, dtype=np.float64).reshape(len(cols[0]), -1)
    for j, a in enumerate(axes):
        header += [f"command_{a}", f"position_{a}"]
        cols += [command[:, j], position[:, j]]
    rows = np.column_stack(cols)
    lines = [",".join(header)]
    lines += [",".join(repr(float(x)) for x in row) for row in rows]
    return atomic_write_text(path, "\n".join(lines) + "\n")


def _check_trace_for_fit(trace: Trace, friction: bool, holdout: float) -> None:
    name = trace.source
    for j, a in enumerate(trace.axes):
        ccol, pcol = trace.columns.get(a, (f"command_{a}", f"position_{a}"))
        u = trace.command[:, j]
        y = trace.position[:, j]
        if np.ptp(u) == 0.0:
            raise ValueError(f"{name}, column {ccol!r}: the command is constant; nothing to fit")
        if np.ptp(y) == 0.0:
            raise ValueError(
                f"{name}, column {pcol!r}: the position never changes (the axis did not move)"
            )
        if friction and not (np.any(u > 0) and np.any(u < 0)):
            raise ValueError(
                f"{name}, column {ccol!r}: the command never reverses (changes sign), so friction "
                "cannot be told from an offset; record a trace with reversals (contour-env "
                "excite) or fit without friction (--no-friction)"
            )
    n_fit = int(round((1 - holdout) * trace.n_rows))
    if n_fit < MIN_ROWS * (1 - DEFAULT_HOLDOUT):
        raise ValueError(
            f"{name}: {n_fit} rows left to fit after holding out {holdout:.0%}; too short to "
            "identify"
        )


def _quantum(y: np.ndarray) -> float:
    """The encoder's count: the smallest step between distinct positions, when every
    position lies on that grid (else 0: not quantised, or unknown)."""
    u = np.unique(y)
    if len(u) < 3:
        return 0.0
    steps = np.diff(u)
    q = float(np.min(steps))
    if q <= 0:
        return 0.0
    k = (u - u[0]) / q
    scale = max(1.0, float(np.max(np.abs(k))))
    if np.max(np.abs(k - np.round(k))) > max(1e-3, 1e-9 * scale):
        return 0.0
    return q
