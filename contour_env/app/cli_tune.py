"""``contour-env tune``: default gains for a plant of your own — PD's bandwidth and CCC's
cross-coupling searched under the margin constraints the named plants' defaults meet
(:mod:`agents.tuning`), written into the plant file as ``controller_gains``
(:mod:`contour_env.plants.gains`) so that pd, ccc, adaptive-ccc and the ILC feedback take them
as their defaults on it."""

from __future__ import annotations

import datetime

__all__ = ["add_tune_command", "cmd_tune", "format_tuning"]

TUNABLE = ("pd", "ccc")


def _controllers(text: str) -> tuple[str, ...]:
    names = tuple(c.strip() for c in text.split(",") if c.strip())
    bad = [c for c in names if c not in TUNABLE]
    if bad or not names:
        raise ValueError(
            f"--controllers: {', '.join(bad) or 'none given'}; allowed: {', '.join(TUNABLE)} "
            "(ccc is tuned at pd's ω, so pd is always tuned)"
        )
    return names


def _margins(entry: dict) -> str:
    parts = []
    for key, label in (
        ("realistic_margins", ""),
        ("without_mode_margins", " without the two-mass mode"),
        ("structural_mode_margins", " with the two-mass mode"),
    ):
        if key in entry:
            m = entry[key]
            parts.append(f"{m['gain_margin_db']:.2f} dB / {m['phase_margin_deg']:.1f}°{label}")
    return "; ".join(parts)


def format_tuning(result: dict) -> str:
    """The printed report of :func:`agents.tuning.tune_plant_file`'s result."""
    from agents.tuning import R1, R2

    pd = result["pd"]
    lines = [
        f"plant {result['plant']!r}: gain margin >= {R1[0]:g} dB and phase margin >= {R1[1]:g}° "
        f"over ±20 % mass (>= {R2[0]:g} dB / {R2[1]:g}° with a two-mass mode)",
        f"  pd: ω = {pd['bandwidth_rad_s']:g} rad/s (balanced, critically damped axes); margins "
        f"{_margins(pd)}",
    ]
    ccc = result.get("ccc")
    if ccc is not None:
        if ccc["W_i"] is None:
            lines.append("  ccc: no coupling gain set meets the margins: none written")
        else:
            ratio = ccc["tuning_rms_ratio_to_pd"]
            lines.append(
                f"  ccc: W_p = {ccc['W_p']:g} 1/s², W_i = {ccc['W_i']:g} 1/s³, W_d = "
                f"{ccc['W_d']:g} 1/s (per unit mass); RMS contour error {ratio:.3f} × pd's on "
                f"the tuning paths; margins {_margins(ccc)}"
            )
            if ratio >= 1.0:
                lines.append(
                    "  (no coupling beat pd within +10 % effort and +5 % peak error: ccc = pd)"
                )
        lines.append(f"  tuning paths: {'; '.join(result['tuning_paths'])}")
    return "\n".join(lines)


def _progress(controllers, verbose: bool):
    """(log, close): every line with ``--verbose``, else a bar over the grid (terminal only)."""
    if verbose:
        return (lambda s: print(s, flush=True)), (lambda: None)
    from tqdm.auto import tqdm

    from agents.tuning import CCC_GRID, PD_GRID

    total = len(PD_GRID) + (sum(len(v) for v in CCC_GRID.values()) if "ccc" in controllers else 0)
    bar = tqdm(total=total, desc="tune", unit="gain set", disable=None, leave=False)

    def log(line: str) -> None:
        text = line.strip()
        if text.startswith(("pd ω", "W_p=")):
            bar.update(1)
        bar.set_postfix_str(text[:70], refresh=True)

    def close() -> None:
        bar.close()

    return log, close


def _plant_file(value: str):
    """The mapping in the plant file ``value``; ValueError for a named plant or no file."""
    from ..plants import FIVE_AXIS_PLANT_ALIASES
    from ..plants.catalog import PLANTS
    from ..plants.from_file import is_plant_file, load_plant_file

    if value in PLANTS or value in FIVE_AXIS_PLANT_ALIASES:
        raise ValueError(
            f"--plant: {value!r} is a named plant: its gains are built in (tuned by "
            "scripts/tune_controllers.py on its own tuning paths); give a plant file (.json), "
            "e.g. the one contour-env identify wrote"
        )
    if not is_plant_file(value):
        raise ValueError(f"--plant: a plant file (.json), got {value!r}")
    return load_plant_file(value)


def cmd_tune(args) -> int:
    from agents.tuning import PD_GRID, tune_plant_file

    from ..io import atomic_write_json
    from ..plants import Plant
    from .cli_machine import _out_file

    controllers = _controllers(args.controllers)
    if args.max_bandwidth is not None and not args.max_bandwidth >= PD_GRID[0]:
        raise ValueError(
            f"--max-bandwidth: at least {PD_GRID[0]:g} rad/s (the search's grid is "
            f"{PD_GRID[0]:g}–{PD_GRID[-1]:g}), got {args.max_bandwidth:g}"
        )
    out = _out_file(args.out_file)
    data = _plant_file(args.plant)
    data.pop("controller_gains", None)  # searched afresh
    plant = Plant(data)
    log, close = _progress(controllers, args.verbose)
    try:
        result = tune_plant_file(
            plant, controllers, progress=log, max_bandwidth_rad_s=args.max_bandwidth
        )
    finally:
        close()
    print(format_tuning(result))
    if not plant.params.has_structural_mode:
        print(
            "  note: the plant has no two-mass mode (an identification does not see one): if "
            "the machine has a structural resonance, bound ω with --max-bandwidth or add "
            "structural_stiffness to the file (the named hsm2's mode holds its pd at 80 rad/s)"
        )
    gains = result["controller_gains"]
    stamp = datetime.date.today().isoformat()
    told = ", ".join(f"{c} {v}" for c, v in gains.items())
    note = f"controller_gains by contour-env tune ({stamp}): {told}."
    data["notes"] = f"{data['notes']} {note}".strip() if data.get("notes") else note
    data["controller_gains"] = gains
    Plant(data)  # what is written loads
    atomic_write_json(out, data)
    takers = ("pd, ccc, " if "ccc" in gains else "pd, ") + "adaptive-ccc and the ILC feedback"
    print(f"wrote {out}: {takers} take these gains by default on --plant {out}")
    if args.json:
        atomic_write_json(args.json, result)
        print(f"wrote {args.json}")
    return 0


def add_tune_command(subparsers) -> None:
    """Register ``contour-env tune`` on ``subparsers``."""
    p = subparsers.add_parser(
        "tune",
        help="default gains for a plant file: PD's ω and CCC's coupling under the margin "
        "constraints (>= 6 dB / 30° over ±20 %% mass), written into the file",
        description="Search PD's bandwidth (the largest ω of 40–400 rad/s whose loops keep "
        "gain margin >= 6 dB and phase margin >= 30° over ±20 %% mass, stable with a two-mass "
        "mode if the plant has one) and CCC's cross-coupling PID at that ω (the lowest RMS "
        "contour error over two tuning paths — a circle of 30 mm and a square of 40 mm turned "
        "by 30°, or their 3-D forms — within +10 %% of PD's effort and +5 %% of its peak "
        "error, under the same margins) on a plant file, and write them into it as "
        "controller_gains: pd, ccc, adaptive-ccc and the ILC feedback take them as defaults.",
    )
    p.add_argument(
        "--plant",
        required=True,
        metavar="PLANT.json",
        help="a plant file (e.g. the one contour-env identify wrote)",
    )
    p.add_argument(
        "--out",
        dest="out_file",
        required=True,
        metavar="PLANT.json",
        help="write the plant file with its controller_gains here (may be --plant's file)",
    )
    p.add_argument(
        "--controllers",
        default="pd,ccc",
        help="what to tune: pd, or pd,ccc (default pd,ccc; ccc is tuned at pd's ω)",
    )
    p.add_argument(
        "--max-bandwidth",
        type=float,
        default=None,
        metavar="W",
        help="largest PD ω to consider, rad/s (default: the grid's 400): a bound the model "
        "cannot show, e.g. a structural resonance",
    )
    p.add_argument("--json", help="write the search's report (gains, margins, paths) here")
    p.add_argument("-v", "--verbose", action="store_true", help="print every gain set tried")
    p.set_defaults(func=cmd_tune)
