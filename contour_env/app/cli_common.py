"""What the ``contour-env`` commands share: the target options (``--case`` or ``--plant`` with
``--gcode``), their keyword arguments for ``gym.make``, the ``--json`` option and the metrics
printout."""

from __future__ import annotations

import argparse
import os

from .. import DEFAULT_CASE  # one default case: the CLI's and gym.make's


def add_target_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--case", help="named case (see `contour-env cases`)")
    p.add_argument(
        "--plant",
        help="plant name, with --gcode (hsm2, jee-triaxial, linear-motor, friction-table)",
    )
    p.add_argument(
        "--gcode",
        metavar="FILE",
        help="G-code file to follow, with --plant (any extension: .nc .ngc .gcode .tap .cnc "
        ".txt ...; always a file name, never program text)",
    )
    p.add_argument(
        "--feedrate",
        type=float,
        default=None,
        help="feedrate override, m/s (default: the case's or the program's F words)",
    )
    p.add_argument(
        "--ideal",
        action="store_true",
        help="textbook plant: no delay, current lag, added friction, ripple, mismatch",
    )
    p.add_argument("--seed", type=int, default=0, help="episode seed (default 0)")
    p.add_argument(
        "--strict",
        action="store_true",
        help="refuse a G-code program with Z motion on a 2-axis plant (default: Z is taken by "
        "an unsimulated axis, Z-only moves become pauses)",
    )
    p.add_argument(
        "--rapid-feed",
        type=float,
        default=None,
        help="the machine's rapid rate for G00 moves, m/s (default: the program's highest F)",
    )


def add_json_option(p: argparse.ArgumentParser, what: str) -> None:
    """``--json FILE``: write ``what`` (e.g. "the metrics") as JSON to this file."""
    p.add_argument("--json", help=f"write {what} as JSON to this file")


def gcode_file(value: str) -> str:
    """``--gcode VALUE``: a file, always (program text belongs to the Python API); SystemExit
    with one line naming the option when there is no such file."""
    if not os.path.exists(value):
        raise SystemExit(f"error: --gcode: no such file: {value}")
    if not os.path.isfile(value):
        raise SystemExit(f"error: --gcode: not a file: {value}")
    return value


def target_kwargs(args) -> dict:
    if args.case and args.gcode:
        raise SystemExit("error: give --case, or --plant with --gcode, not both")
    if args.gcode and not args.plant:
        raise SystemExit(
            "error: --gcode needs --plant (hsm2, jee-triaxial, linear-motor, friction-table)"
        )
    if args.plant and not args.gcode and not args.case:
        raise SystemExit("error: --plant needs --gcode (or use --case)")
    kw = {"ideal": args.ideal}
    if args.gcode:
        # an existing file is read as a file by build_setup whatever its name
        # (contour_env.paths.gcode_source)
        kw.update(plant=args.plant, path=gcode_file(args.gcode))
    else:
        kw["case"] = args.case or DEFAULT_CASE
        if args.plant:
            kw["plant"] = args.plant
    if args.feedrate is not None:
        kw["feedrate_m_s"] = args.feedrate
    if getattr(args, "strict", False):
        kw["strict"] = True
    if getattr(args, "rapid_feed", None) is not None:
        kw["rapid_feed_m_s"] = args.rapid_feed
    return kw


def print_metrics(name: str, m: dict) -> None:
    def fmt(v):
        if v is None:
            return "n/a"
        if isinstance(v, list):
            return "[" + ", ".join(fmt(x) for x in v) + "]"
        return f"{v:.4g}" if isinstance(v, float) else str(v)

    # a contour error below one encoder count prints as such (the JSON keeps the number)
    below = {
        "max_contour_error_um": m.get("max_below_resolution"),
        "rms_contour_error_um": m.get("below_resolution"),
    }
    print(f"{name}:")
    for key, value in m.items():
        text = f"≤{m['encoder_resolution_um']:g} (enc)" if below.get(key) else fmt(value)
        print(f"  {key:28s} {text}")
