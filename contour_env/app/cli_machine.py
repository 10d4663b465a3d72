"""``contour-env identify`` and ``contour-env excite``: your machine in the package — an
excitation program to play on a drive (:mod:`contour_env.excite`) and the package's axis
model fitted to the trace recorded while it plays (:mod:`contour_env.identify`), written as a
plant file that ``--plant plant.json`` and ``gym.make(..., plant="plant.json")`` load."""

from __future__ import annotations

import argparse
import math

__all__ = ["add_machine_commands", "cmd_excite", "cmd_identify"]


def _out_file(value: str, option: str = "--out"):
    """``--out``: a file name that can be written (checked before any work)."""
    from ..io import OutputPathError, check_output_file

    try:
        check_output_file(value)
    except OutputPathError as exc:
        raise ValueError(f"{option}: {exc}") from None
    return value


def _fmt(value, ci=None, unit="") -> str:
    if value is None:
        return "n/a"
    text = f"{value:.5g}"
    if ci is not None and math.isfinite(ci):
        text += f" ± {ci:.2g}"
    elif ci is None:
        text += " (± not determined)"
    return f"{text} {unit}".rstrip()


def format_identification(ident) -> str:
    """The printed report: per axis the parameters with 95 % intervals, delay, periodic forces
    and the normalised errors; warnings last."""
    from ..identify import PARAM_NAMES, UNITS

    tr = ident.trace
    lines = [
        f"trace {tr.source}: {tr.n_rows} rows, servo period {tr.servo_period_s * 1e3:g} ms, "
        f"axes {', '.join(tr.axes)}; held out for validation: the last "
        f"{ident.settings['holdout']:.0%}"
    ]
    for f in ident.axes:
        lines.append(f"axis {f.axis}:")
        screening = ", ".join(
            f"{d}: {'-' if c is None else f'{c:.4g}'}" for d, c in f.delay_costs.items()
        )
        lines.append(
            f"  {'delay':22s} {f.delay_periods} servo period(s) (screening cost by delay "
            f"{screening})"
        )
        for name in PARAM_NAMES:
            if name not in f.fitted:
                continue
            lines.append(f"  {name:22s} {_fmt(f.values[name], f.ci95.get(name), UNITS[name])}")
        lines.append(f"  {'force limit':22s} {f.force_limit_N:.5g} N")
        res = f.encoder_resolution_m
        lines.append(
            f"  {'encoder resolution':22s} "
            + (f"{res * 1e6:.4g} µm" if res > 0 else "0 (not quantised / unknown)")
        )
        for key, per in (f.periodic or {}).items():
            if per is None:
                continue
            where = (
                f"{per['frequency_hz']:.4g} Hz"
                if key == "disturbance"
                else f"period {per['period_m'] * 1e3:.4g} mm"
            )
            lines.append(
                f"  {key:22s} {_fmt(per['amplitude_N'], per.get('ci95_amplitude_N'), 'N')} at "
                f"{where}, phase {per['phase_deg']:.1f}°"
            )
        for label, err in (("fit", f.fit_error), ("held-out", f.holdout_error)):
            if err.get("position") is None:
                continue
            lines.append(
                f"  {label + ' error':22s} position {err['position']:.3g}, velocity "
                f"{err['velocity']:.3g} (RMS over the measured RMS, windows of "
                f"{f.window_steps} samples)"
            )
    lines += [f"warning: {w}" for w in ident.warnings]
    return "\n".join(lines)


def _fit_progress(axes, verbose: bool):
    """(log, close) for the fit: with ``--verbose`` every line printed; otherwise a progress
    bar over the axes (on a terminal only) showing the step the fit is at."""
    if verbose:
        return (lambda s: print(s, flush=True)), (lambda: None)
    from tqdm.auto import tqdm

    bar = tqdm(total=len(axes), desc="identify", unit="axis", disable=None, leave=False)
    begun = [0]

    def log(line: str) -> None:
        text = line.strip()
        if text.startswith("axis ") and text.endswith(":"):  # the next axis begins
            if begun[0]:
                bar.update(1)
            begun[0] += 1
        bar.set_postfix_str(text[:70], refresh=True)

    def close() -> None:
        bar.update(bar.total - bar.n)
        bar.close()

    return log, close


def cmd_identify(args) -> int:
    from ..identify import identify, parse_columns, read_trace, write_plant
    from ..io import atomic_write_json

    out = _out_file(args.out_file)
    columns = parse_columns(args.columns)
    trace = read_trace(
        args.trace,
        axes=args.axes,
        columns=columns,
        force_constant=args.force_constant,
        servo_period_s=args.servo_period,
    )
    log, close = _fit_progress(trace.axes, args.verbose)
    try:
        ident = identify(
            trace,
            friction=not args.no_friction,
            holdout=args.holdout,
            max_delay=args.max_delay,
            force_limit=args.force_limit,
            encoder_resolution=args.encoder_resolution,
            max_fit_samples=args.max_samples,
            log=log,
        )
    finally:
        close()
    print(format_identification(ident))
    write_plant(out, ident, name=args.name, input_kind=args.input_kind)
    print(f"wrote {out} (load it with --plant {out}, or gym.make(..., plant={out!r}))")
    if args.json:
        atomic_write_json(args.json, ident.report())
        print(f"wrote {args.json}")
    if args.plot:
        from .identify_plot import plot_identification

        plot_identification(ident, args.plot)
        print(f"wrote {args.plot}")
    return 0


def cmd_excite(args) -> int:
    from ..excite import excite, write_excitation_csv

    out = _out_file(args.out_file)
    plant = args.plant
    exc = excite(
        plant,
        args.axis,
        travel_m=args.travel,
        force_fraction=args.force_fraction,
        dither_fraction=args.dither,
        plateau_s=args.plateau,
        seed=args.seed,
        ideal=args.ideal,
        simulate=not args.no_simulate,
        noise_m=args.noise,
    )
    s = exc.settings
    print(
        f"excitation for plant {exc.plant_name}, axes {', '.join(exc.axes)}: "
        f"{len(exc.time_s)} samples of {exc.servo_period_s * 1e3:g} ms ({s['duration_s']:.4g} s); "
        f"travel ±{s['travel_m'] / 2 * 1e3:.4g} mm about the start; validation part from "
        f"{s['holdout_from_s']:.4g} s"
    )
    for a in exc.axes:
        speeds = s["speeds_m_s"][a]
        line = (
            f"  axis {a}: friction sweep {len(speeds)} speeds {speeds[0] * 1e3:.3g}–"
            f"{speeds[-1] * 1e3:.4g} mm/s"
        )
        if exc.simulated_command is not None:
            lo, hi = s["simulated_position_range_m"][a]
            line += (
                f"; simulated: peak command {s['simulated_peak_command_fraction'][a]:.0%} of the "
                f"force limit, position {lo * 1e3:.4g} … {hi * 1e3:.4g} mm"
            )
        print(line)
    write_excitation_csv(out, exc)
    print(f"wrote {out}")
    return 0


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return v


def add_machine_commands(subparsers) -> None:
    """Register ``contour-env identify`` and ``contour-env excite`` on ``subparsers``."""
    _add_identify_parser(subparsers)
    _add_excite_parser(subparsers)


def _add_identify_parser(subparsers) -> None:
    """``contour-env identify``: its options."""
    from ..identify import DEFAULT_HOLDOUT, DEFAULT_MAX_DELAY, MAX_FIT_SAMPLES

    p = subparsers.add_parser(
        "identify",
        help="fit the package's axis model (mass, viscous, Coulomb/static friction, delay, "
        "current-loop lag) to a measured trace; write a plant file",
        description="Fit, per axis, the package's axis model to a trace of time, command and "
        "measured position (CSV header time_s,command_x,position_x,command_y,position_y[,"
        "command_z,position_z]; commands in N, positions in m): mass, viscous, Coulomb and "
        "static friction with the Stribeck velocity, current-loop lag and the computation "
        "delay in servo periods, with 95 %% confidence intervals and the error on the held-out "
        "end of the trace. The plant file loads with --plant FILE and gym.make(plant=FILE).",
    )
    p.add_argument("--trace", required=True, metavar="TRACE.csv", help="the measured trace (CSV)")
    p.add_argument(
        "--out",
        dest="out_file",
        required=True,
        metavar="PLANT.json",
        help="write the identified plant here (JSON of plant parameters)",
    )
    p.add_argument("--axes", help="axes to identify, e.g. x,y or x,y,z (default: those present)")
    p.add_argument(
        "--columns",
        help="other column names, e.g. command_x=ux,position_x=enc_x,time_s=t",
    )
    p.add_argument(
        "--servo-period",
        type=_positive_float,
        metavar="T",
        help="servo period, s (default: the time column's step; checked against it)",
    )
    p.add_argument(
        "--force-constant",
        metavar="N/A",
        help="commands are in A: multiply by this force constant (one, or one per axis a,b[,c])",
    )
    p.add_argument(
        "--force-limit",
        metavar="N",
        help="force limit, N (one, or one per axis; default: the trace's largest command)",
    )
    p.add_argument(
        "--encoder-resolution",
        metavar="M",
        help="encoder count, m (one or per axis; default: the quantum of the trace's positions)",
    )
    p.add_argument(
        "--no-friction",
        action="store_true",
        help=(
            "fit no Coulomb/static friction (mass, viscous, delay, lag only); without it,"
            " friction is kept on an axis only where it lowers the fit's cost by 20 %% or more"
        ),
    )
    p.add_argument(
        "--max-delay",
        type=int,
        default=DEFAULT_MAX_DELAY,
        help=f"largest computation delay searched, servo periods (default {DEFAULT_MAX_DELAY})",
    )
    p.add_argument(
        "--holdout",
        type=float,
        default=DEFAULT_HOLDOUT,
        help=f"share of the trace's end kept out of the fit for validation (default "
        f"{DEFAULT_HOLDOUT:g})",
    )
    p.add_argument(
        "--max-samples",
        type=int,
        default=MAX_FIT_SAMPLES,
        help=f"samples simulated per evaluation of the fit, spread over the trace (default "
        f"{MAX_FIT_SAMPLES}; fewer: faster, less precise)",
    )
    p.add_argument(
        "--input-kind",
        choices=("force", "velocity-command"),
        default="force",
        help="what the command is (default force; velocity-command: a drive with its velocity "
        "loop closed, commands in its units)",
    )
    p.add_argument("--name", default="identified", help="plant name in the file")
    p.add_argument(
        "--json",
        help="write the full report as JSON (parameters, intervals, delays, errors, warnings)",
    )
    p.add_argument(
        "--plot",
        help="write a PNG: measured vs simulated position and velocity, and residuals, on the "
        "held-out part",
    )
    p.add_argument("-v", "--verbose", action="store_true", help="print the fit's progress")
    p.set_defaults(func=cmd_identify)


def _add_excite_parser(subparsers) -> None:
    """``contour-env excite``: its options."""
    from ..excite import (
        DEFAULT_DITHER_FRACTION,
        DEFAULT_FORCE_FRACTION,
        DEFAULT_PLATEAU_S,
        DEFAULT_TRAVEL_M,
    )

    p = subparsers.add_parser(
        "excite",
        help="an excitation program (friction sweep with low-speed reversals, chirp, PRBS) to "
        "play on a drive for a trace that identifies well; CSV",
        description="Write an excitation program for the axes of a plant as CSV: per axis the "
        "position reference (m, from the start position) and its velocity to play through the "
        "drive's position loop, and a PRBS force dither (N) to add to the current command "
        "where the drive allows; with the package's simulated response of the plant (columns "
        "simulated_command_<axis>, simulated_position_<axis>) unless --no-simulate.",
    )
    p.add_argument(
        "--plant",
        required=True,
        help="plant name (hsm2, jee-triaxial, linear-motor, friction-table) or a JSON file of "
        "plant parameters (e.g. one contour-env identify wrote)",
    )
    p.add_argument(
        "--axis",
        default=None,
        help="axis or axes to excite, e.g. x or x,y (default: every axis of the plant)",
    )
    p.add_argument(
        "--out", dest="out_file", required=True, metavar="EXCITE.csv", help="write the CSV here"
    )
    p.add_argument(
        "--travel",
        type=float,
        default=DEFAULT_TRAVEL_M,
        help=f"whole stroke the program may use, m, centred on the start position (default "
        f"{DEFAULT_TRAVEL_M:g}: ±{DEFAULT_TRAVEL_M / 2 * 1e3:g} mm)",
    )
    p.add_argument(
        "--force-fraction",
        type=float,
        default=DEFAULT_FORCE_FRACTION,
        help=f"share of the force limit the program plans with (default "
        f"{DEFAULT_FORCE_FRACTION:g})",
    )
    p.add_argument(
        "--dither",
        type=float,
        default=DEFAULT_DITHER_FRACTION,
        help=f"PRBS force dither, share of the force limit (default {DEFAULT_DITHER_FRACTION:g}; "
        "0: none)",
    )
    p.add_argument(
        "--plateau",
        type=float,
        default=DEFAULT_PLATEAU_S,
        help=f"constant-velocity time per stroke of the friction sweep, s (default "
        f"{DEFAULT_PLATEAU_S:g})",
    )
    p.add_argument("--seed", type=int, default=0, help="PRBS start and simulated noise (default 0)")
    p.add_argument(
        "--noise",
        type=float,
        default=0.0,
        metavar="STD_M",
        help="encoder noise of the simulated response, m (default 0: quantisation only)",
    )
    p.add_argument(
        "--ideal",
        action="store_true",
        help="simulate the textbook plant (default: the named plant's realistic one)",
    )
    p.add_argument(
        "--no-simulate",
        action="store_true",
        help="write the program only (no simulated_* columns)",
    )
    p.set_defaults(func=cmd_excite)
