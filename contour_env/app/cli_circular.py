"""``contour-env circular-test``: the ISO 230-4 circular ("ballbar") test of a plant under one
or several controllers, clockwise and counter-clockwise (:mod:`contour_env.circular_test`)."""

from __future__ import annotations

import argparse
import json
import os

from ..circular_test import (
    DEFAULT_FEED_M_S,
    DEFAULT_OVERSHOOT_DEG,
    DEFAULT_RADIUS_M,
    DEFAULT_SPIKE_WINDOW_DEG,
    OVERSHOOT_MAX_DEG,
)

__all__ = ["add_circular_test_command", "cmd_circular_test"]

DEFAULT_PLANT = "hsm2"
DEFAULT_CONTROLLERS = "pd"


def _plant_arg(value: str):
    """``--plant``: a plant name, or a JSON file of plant parameters (a name ending in .json,
    or an existing file) read as a mapping; ValueError naming the option otherwise."""
    if not (value.lower().endswith(".json") or os.path.isfile(value)):
        return value
    try:
        with open(value, encoding="utf-8") as fh:
            data = json.load(fh)
    except FileNotFoundError:
        raise ValueError(f"--plant: no such file: {value}") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"--plant: {value} is not valid JSON ({exc})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(
            f"--plant: cannot read {value} ({getattr(exc, 'strerror', exc)})"
        ) from None
    if not isinstance(data, dict):
        raise ValueError(
            f"--plant: {value} must hold a JSON object of plant parameters, got "
            f"{type(data).__name__}"
        )
    return data


def _controller_option(args) -> tuple[str, list[str]]:
    """(the option used, the controller names) of ``--controller`` / ``--controllers``."""
    if args.controller is not None and args.controllers is not None:
        raise ValueError("--controller, --controllers: give one of them, not both")
    option, value = "--controllers", args.controllers
    if args.controller is not None:
        option, value = "--controller", args.controller
    if value is None:
        value = DEFAULT_CONTROLLERS
    return option, [c.strip() for c in value.split(",") if c.strip()]


def cmd_circular_test(args) -> int:
    from ..circular_test import circular_test_errors
    from ..env.core import check_seed
    from ..io import atomic_write_json
    from .circular_test_run import check_controller_names, circular_test, format_report

    option, names = _controller_option(args)
    plant = _plant_arg(args.plant)
    # every option first, all bad ones named in one line, before anything runs
    errors = circular_test_errors(
        plant,
        args.radius,
        args.feed,
        args.overshoot,
        ideal=args.ideal,
        labels={
            "plant": "--plant",
            "radius_m": "--radius",
            "feed_m_s": "--feed",
            "overshoot_deg": "--overshoot",
        },
    )
    options = {"controllers": option, "model": "--model"}
    errors += [
        f"{options[key]}: {text}" for key, text in check_controller_names(names, args.model).items()
    ]
    try:
        check_seed(args.seed)
    except ValueError as exc:
        errors.append(f"--{exc}")
    if errors:
        raise ValueError("; ".join(errors))

    def show(label, direction, row):
        if row["completed"]:
            text = (
                f"G {row['circular_deviation_um']:.2f} µm, F_max "
                f"{row['radial_deviation_max_um']:.2f} µm, F_min "
                f"{row['radial_deviation_min_um']:.2f} µm"
            )
        else:
            text = f"did not complete ({row['incomplete_reason']})"
        print(f"  {label} {direction}: {text}", flush=True)

    try:
        result = circular_test(
            plant,
            names,
            args.radius,
            args.feed,
            overshoot_deg=args.overshoot,
            model=args.model,
            ideal=args.ideal,
            seed=args.seed,
            progress=show,
        )
    except ValueError as exc:
        # a controller that cannot work with the plant (jee-ccc on a force drive, a residual
        # agent of another plant) is refused when bound, before any run
        if str(exc).startswith(("controller ", "residual", "model")):
            raise ValueError(f"{option}: {exc}") from None
        raise
    traces = result.pop("traces")
    if isinstance(plant, dict):
        result["plant_file"] = args.plant
    print(format_report(result))
    if args.json:
        atomic_write_json(args.json, result)
        print(f"wrote {args.json}")
    if args.plot:
        # matplotlib only when a plot is asked for
        from .circular_plot import plot_circular_test

        plot_circular_test(result, traces, args.plot)
        print(f"wrote {args.plot}")
    return 0


def add_circular_test_command(subparsers) -> argparse.ArgumentParser:
    """Register ``contour-env circular-test`` on ``subparsers`` (build_parser's)."""
    p = subparsers.add_parser(
        "circular-test",
        help="ISO 230-4 circular (ballbar) test: CW and CCW circles with overshoot arcs; "
        "circular deviation G, radial deviation F, hysteresis H, reversal spikes",
        description="ISO 230-4 circular test on the plant's x-y plane: a circle of --radius at "
        "--feed, clockwise and counter-clockwise, each with feed-in and feed-out overshoot arcs "
        "around the 360-degree data-capture arc. Reports the circular deviation G (about the "
        "least-squares centre), the radial deviations F_max/F_min (about the nominal centre), "
        "the circular hysteresis H (CW vs CCW) and the reversal spikes (µm).",
    )
    p.add_argument(
        "--plant",
        default=DEFAULT_PLANT,
        help=f"plant name (hsm2, jee-triaxial, linear-motor, friction-table; default "
        f"{DEFAULT_PLANT}) or a JSON file of plant parameters; 2- or 3-axis plants only",
    )
    p.add_argument(
        "--controller",
        default=None,
        help="controller or variant (pd, ccc, adaptive-ccc, jee-ccc, residual, ccc:wp=3e4; "
        "see `contour-env controllers`); comma-separated for several, as --controllers",
    )
    p.add_argument(
        "--controllers",
        default=None,
        help="comma-separated controllers overlaid in one report, e.g. pd,ccc,adaptive-ccc "
        f"(default {DEFAULT_CONTROLLERS})",
    )
    p.add_argument(
        "--model",
        default=None,
        metavar="DIR",
        help="model DIR of the residual controller (default: the shipped agent for the plant)",
    )
    p.add_argument(
        "--radius",
        type=float,
        default=DEFAULT_RADIUS_M,
        help=f"circle radius, m (> 0, <= 10; default {DEFAULT_RADIUS_M:g})",
    )
    p.add_argument(
        "--feed",
        type=float,
        default=DEFAULT_FEED_M_S,
        help=f"feed along the circle, m/s (> 0, within what the plant can hold on the circle; "
        f"default {DEFAULT_FEED_M_S:g})",
    )
    p.add_argument(
        "--overshoot",
        type=float,
        default=DEFAULT_OVERSHOOT_DEG,
        metavar="DEG",
        help=f"feed-in and feed-out overshoot arcs, degrees each (> 0, <= "
        f"{OVERSHOOT_MAX_DEG:g}, long enough for the feed ramp; default "
        f"{DEFAULT_OVERSHOOT_DEG:g})",
    )
    p.add_argument(
        "--ideal",
        action="store_true",
        help="textbook plant: no delay, current lag, added friction, ripple, mismatch",
    )
    p.add_argument("--seed", type=int, default=0, help="episode seed (default 0)")
    p.add_argument(
        "--json",
        help="write the report as JSON to this file (per controller and direction cw/ccw: "
        "circular_deviation_um, radial_deviation_max_um, radial_deviation_min_um, "
        "reversal_spikes_um; per controller hysteresis_um)",
    )
    p.add_argument(
        "--plot",
        help="write the ballbar plot (PNG): radial deviation magnified on the nominal circle, "
        f"CW and CCW, one polar panel per controller, G/F/H table (spike window "
        f"{DEFAULT_SPIKE_WINDOW_DEG:g} degrees)",
    )
    p.set_defaults(func=cmd_circular_test)
    return p
