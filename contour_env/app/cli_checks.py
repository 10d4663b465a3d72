"""Checks of ``contour-env compare``'s options, all before anything runs: one error naming every
bad option (``--randomize -1 --episodes 0`` names both), each as ``--option: rule, got value``."""

from __future__ import annotations

import math

from ..paths.gcode import MAX_FEED_M_S

__all__ = ["check_compare_options"]


def _strip(msg: str, *prefixes: str) -> str:
    for p in prefixes:
        if msg.startswith(p + ": "):
            return msg[len(p) + 2 :]
    return msg


def _number_rule(value, rule: str) -> bool:
    if not math.isfinite(value):
        return False
    return {"feed": 0 < value <= MAX_FEED_M_S, "[0, 1)": 0 <= value < 1}[rule]


def compare_option_errors(args) -> list[str]:
    """Every bad option of a ``compare`` command line (``args`` from its parser), as
    ``"--option: ..."`` strings, in the order of the options; [] when all are good."""
    from agents.compare import check_controllers

    from ..env.core import check_seed
    from ..metrics import check_metrics

    errors = []
    names = [c.strip() for c in (args.controllers or "").split(",") if c.strip()]
    try:
        check_controllers(names)
    except ValueError as exc:
        errors.append(f"--controllers: {_strip(str(exc), 'controllers')}")
    if args.model is not None and "residual" not in names:
        errors.append(
            "--model: DIR is the agent of the 'residual' row; add residual to --controllers"
        )
    metrics = tuple(m.strip() for m in (args.metrics or "").split(",") if m.strip())
    try:
        check_metrics(metrics)
    except ValueError as exc:
        errors.append(f"--metrics: {_strip(str(exc), 'metrics')}")
    for option, value, rule in (
        ("--feedrate", args.feedrate, "feed"),
        ("--rapid-feed", args.rapid_feed, "feed"),
        ("--randomize", args.randomize, "[0, 1)"),
    ):
        if value is not None and not _number_rule(value, rule):
            what = (
                "a fraction in [0, 1)" if rule == "[0, 1)" else f"> 0 and <= {MAX_FEED_M_S:g} m/s"
            )
            errors.append(f"{option}: must be {what}, got {value:g}")
    if args.episodes < 1:
        errors.append(f"--episodes: must be >= 1, got {args.episodes}")
    try:
        check_seed(args.seed)
    except ValueError as exc:
        errors.append(f"--{exc}")
    return errors


def check_compare_options(args) -> None:
    """``ValueError`` naming every bad option of a ``compare`` command line, in one line."""
    errors = compare_option_errors(args)
    if errors:
        raise ValueError("; ".join(errors))
