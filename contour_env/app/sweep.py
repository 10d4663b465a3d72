"""``contour-env train --sweep FILE``: a grid of residual trainings in one folder.

The sweep file (YAML, docs/SWEEP.md)::

    out: sweeps/lm            # optional; --out on the command line wins
    grid:                     # every combination is one trial (product, in this order)
      case: [lm-circle3d, sharp-corner]
      seed: [0, 1]
      algo: [sac]
    fixed:                    # any other `contour-env train` option, for every trial
      base: pd
      timesteps: 500
    max_concurrent: 2         # optional: at most this many trials at once under Ray

Keys of ``grid`` and ``fixed`` are ``contour-env train``'s options with ``_`` for ``-``
(``n_envs`` for ``--n-envs``). Every trial's arguments go through the train command's own
parser and :func:`contour_env.app.cli_rl.config_from_args` before anything runs, and each trial
runs :func:`contour_env.app.cli_rl.train_from_args`, the function ``contour-env train`` runs, into
``OUT/<trial name>``, a model DIR like ``contour-env train --out`` writes. ``OUT/sweep.json``
lists every trial (options, status, wall time, figures), ``OUT/sweep.yaml`` is a copy of the
file, ``OUT/_logs/<trial>.log`` the trainer's log, ``OUT/_ray`` Ray Tune's experiment files.
The execution (serial or Ray Tune) is :mod:`contour_env.app.sweep_run`.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import itertools
import re
from dataclasses import dataclass
from pathlib import Path

from .cli_rl import train_entry, train_parser

SWEEP_KEYS = ("out", "grid", "fixed", "max_concurrent")
# train options that a sweep sets itself, or that make no sense per trial
# ("func": the command line's entry, train_or_sweep, not an option)
NOT_IN_SWEEP = ("out", "resume", "sweep", "ray", "no_progress", "func")


@dataclass(frozen=True)
class Trial:
    name: str  # a file-system-safe folder name, e.g. case=lm-circle3d,seed=0,algo=sac
    options: dict  # the grid values and the fixed options, as in the file
    argv: tuple  # the `contour-env train` arguments, --out included
    out: str  # the model DIR (absolute)
    log: str  # the trainer's log file (absolute)
    cpus: int  # torch threads: the CPUs it takes under Ray


@dataclass(frozen=True)
class Sweep:
    file: str
    text: str
    out: Path
    trials: tuple
    max_concurrent: int | None


def train_or_sweep(args: argparse.Namespace) -> int:
    """``contour-env train``: a sweep of trials with ``--sweep FILE``, else one training run."""
    if args.sweep is not None:
        return cmd_sweep(args)
    return train_entry(args)


def _parse(parser, argv, where: str):
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            return parser.parse_args(list(argv))
    except SystemExit:
        lines = err.getvalue().strip().splitlines() or ["invalid value"]
        msg = lines[-1].split("error: ", 1)[-1]
        msg = re.sub(r"^argument [-\w/]+: ", "", msg)
        raise ValueError(f"{where}: {msg}") from None


def _options(parser) -> dict:
    return {
        a.dest: a
        for a in parser._actions
        if a.option_strings and a.dest not in NOT_IN_SWEEP and a.dest != "help"
    }


def _scalar(value, where: str) -> str:
    if value is None:
        raise ValueError(f"{where}: no value (leave the key out for the default)")
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise ValueError(f"{where}: expected a number or a string, got {value!r}")
    return str(value)


def _tokens(key: str, value, action, where: str) -> list:
    flag = "--" + key.replace("_", "-")
    if isinstance(action, argparse._StoreTrueAction):
        if not isinstance(value, bool):
            raise ValueError(f"{where}: expected true or false, got {value!r}")
        return [flag] if value else []
    if isinstance(action, argparse._AppendAction):  # --gcode FILE (repeatable)
        values = value if isinstance(value, list) else [value]
        return [f"{flag}={_scalar(v, where)}" for v in values]
    if isinstance(value, list):  # a comma-separated option: cases, paths, net_arch, …
        if not value:
            raise ValueError(f"{where}: an empty list")
        return [f"{flag}=" + ",".join(_scalar(v, where) for v in value)]
    return [f"{flag}={_scalar(value, where)}"]


def _label(value) -> str:
    if isinstance(value, list):
        return "+".join(_label(v) for v in value)
    if isinstance(value, str) and ("/" in value or "\\" in value):
        return Path(value).name  # a G-code file: its name
    return str(value)


def trial_name(grid_values: dict) -> str:
    name = ",".join(f"{k}={_label(v)}" for k, v in grid_values.items())
    return re.sub(r"[^A-Za-z0-9._=,+-]", "_", name)[:200]


def _mapping(doc, key: str, where: str) -> dict:
    value = doc.get(key) or {}
    if not isinstance(value, dict):
        raise ValueError(f"{where}: {key}: expected a mapping of train options, got {value!r}")
    return value


def read_sweep_file(file: str) -> tuple[str, dict]:
    try:
        import yaml
    except ImportError:
        raise ValueError("--sweep: PyYAML is not installed; pip install pyyaml") from None
    try:
        text = Path(file).read_text()
    except FileNotFoundError:
        raise ValueError(f"--sweep: no such file {file!r}") from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or type(exc).__name__
        raise ValueError(f"{file}: not valid YAML ({problem}{at})") from None
    if not isinstance(doc, dict):
        raise ValueError(f"{file}: expected a mapping with keys {', '.join(SWEEP_KEYS)}")
    return text, doc


def load_sweep(file: str, out: str | None = None) -> Sweep:
    """The sweep of ``file``, every trial checked as ``contour-env train`` checks its
    arguments; ``ValueError`` naming the file and the key otherwise."""
    from .cli_rl import apply_train_defaults, config_from_args

    text, doc = read_sweep_file(file)
    unknown = [k for k in doc if k not in SWEEP_KEYS]
    if unknown:
        raise ValueError(f"{file}: unknown key {unknown[0]!r}; allowed: {', '.join(SWEEP_KEYS)}")
    grid, fixed = _mapping(doc, "grid", file), _mapping(doc, "fixed", file)
    if not grid:
        raise ValueError(f"{file}: grid: give at least one option and its values")
    mc = doc.get("max_concurrent")
    if mc is not None and (isinstance(mc, bool) or not isinstance(mc, int) or mc < 1):
        raise ValueError(f"{file}: max_concurrent: expected an integer >= 1, got {mc!r}")
    out = out if out is not None else doc.get("out")
    if not out or not isinstance(out, str):
        raise ValueError(f"{file}: out: give the sweep's folder (out: DIR, or --out DIR)")
    parser = train_parser()
    options = _options(parser)
    allowed = ", ".join(sorted(options))
    tokens: dict = {}  # (key, index in the grid list or None) -> argv tokens
    for section, items in (("grid", grid), ("fixed", fixed)):
        for key, value in items.items():
            where = f"{file}: {section}.{key}"
            if key not in options:
                raise ValueError(f"{where}: unknown train option; allowed: {allowed}")
            if section == "fixed":
                if key in grid:
                    raise ValueError(f"{where}: in grid too; give it in one of them")
                values = [(None, value)]
            else:
                if not isinstance(value, list) or not value:
                    raise ValueError(f"{where}: expected a non-empty list of values, got {value!r}")
                values = list(enumerate(value))
            for i, v in values:
                at = where if i is None else f"{where}[{i}]"
                tokens[key, i] = _tokens(key, v, options[key], at)
                _parse(parser, tokens[key, i], at)
    root = Path(out)
    trials, names = [], {}
    combos = list(itertools.product(*(range(len(v)) for v in grid.values())))
    for combo in combos:
        chosen = {k: grid[k][i] for k, i in zip(grid, combo, strict=True)}
        name = trial_name(chosen)
        if name in names:
            raise ValueError(
                f"{file}: grid: the trials {names[name]} and {chosen} get the same folder "
                f"name {name!r}; make the values distinct"
            )
        names[name] = chosen
    for combo, (name, chosen) in zip(combos, names.items(), strict=True):
        argv = [t for k, i in zip(grid, combo, strict=True) for t in tokens[k, i]]
        argv += [t for k in fixed for t in tokens[k, None]]
        model_dir = (root / name).resolve()
        argv += ["--out", str(model_dir), "--no-progress"]
        args = _parse(parser, argv, f"{file}: trial {name}")
        apply_train_defaults(args)
        try:
            config_from_args(args)
        except (ValueError, FileNotFoundError) as exc:
            raise ValueError(f"{file}: trial {name}: {exc}") from None
        log = (root / "_logs" / f"{name}.log").resolve()
        options_of = {**chosen, **fixed}
        trials.append(Trial(name, options_of, tuple(argv), str(model_dir), str(log), args.threads))
    return Sweep(file, text, root, tuple(trials), mc)


def check_out(sweep: Sweep) -> None:
    """``OUT`` can be written and holds no sweep or trial of the same names yet."""
    from contour_env.io import check_output_dir

    check_output_dir(sweep.out)
    if (sweep.out / "sweep.json").exists():
        raise ValueError(f"--out: {sweep.out} already holds a sweep (sweep.json); use another")
    for t in sweep.trials:
        if Path(t.out).exists():
            raise ValueError(f"--out: {sweep.out / t.name} exists already; use another --out")


def cmd_sweep(args) -> int:
    """``contour-env train --sweep FILE [--out DIR] [--ray auto|ADDRESS]``."""
    from .sweep_run import check_ray, run_sweep

    defaults = train_parser().parse_args([])
    given = [
        d
        for d, v in vars(args).items()
        if d not in NOT_IN_SWEEP and hasattr(defaults, d) and v != getattr(defaults, d)
    ]
    if given:
        flag = "--" + given[0].replace("_", "-")
        raise ValueError(
            f"{flag}: not with --sweep; put it in the sweep file (fixed: {given[0]}: …)"
        )
    if args.resume:
        raise ValueError("--resume: not with --sweep (each trial is a new run)")
    address = check_ray(args.ray)
    sweep = load_sweep(args.sweep, out=args.out)
    check_out(sweep)
    return run_sweep(sweep, ray=address)
