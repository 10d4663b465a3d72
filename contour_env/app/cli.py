"""The ``contour-env`` command line: ``cases``, ``run``, ``compare``, ``stability``, ``bench``."""

from __future__ import annotations

import argparse
import functools
import os
import sys
import warnings

import numpy as np

from .. import DEFAULT_CASE  # one default case: the CLI's and gym.make's
from .cli_common import add_json_option, add_target_args, print_metrics, target_kwargs

_SETUP_KEYS = (
    "case",
    "plant",
    "path",
    "feedrate_m_s",
    "ideal",
    "strict",
    "rapid_feed_m_s",
)


def _print_program_summary(kw) -> None:
    """One line on what the G-code reader ignored or approximated (nothing for other paths)."""
    from ..cases import build_setup

    setup = build_setup(**{k: kw[k] for k in _SETUP_KEYS if k in kw})
    if setup.program_summary:
        print(f"program: {setup.program_summary}")


def cmd_warm(args) -> int:
    from .warmup import warm

    if args.workers < 1:
        print(f"error: --workers: a positive integer, got {args.workers}", file=sys.stderr)
        return 2
    try:
        dt = warm(args.workers, progress=print)
    except RuntimeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(f"kernels compiled and cached in {dt:.0f} s")
    return 0


def cmd_cases(args) -> int:
    from ..cases import all_case_names, get_case

    print(f"{'case':18s} {'plant':15s} {'path':10s} {'feedrate':>12s}  notes")
    for spec in map(get_case, all_case_names()):
        print(
            f"{spec.name:18s} {spec.plant:15s} {spec.path['kind']:10s} "
            f"{spec.feedrate_m_s:9.4f} m/s  {spec.notes[:70]}…"
        )
        if args.verbose:
            print(f"    {spec.notes}\n    published: {spec.published}")
    return 0


def cmd_controllers(args) -> int:
    from agents.registry import format_controllers

    print(format_controllers())
    print("\nresidual  (compare only: the agent of --model DIR)\n  (no parameters)")
    return 0


def cmd_run(args) -> int:
    import gymnasium as gym

    from .. import ENV_ID
    from ..evaluation import run_episode
    from ..io import atomic_write_json
    from ..metrics import check_metrics, score
    from ..plotting import plot_runs

    metrics_asked = check_metrics(
        tuple(m.strip() for m in (args.metrics or "").split(",") if m.strip())
    )
    kw = target_kwargs(args)
    env = gym.make(ENV_ID, **kw)
    core = env.unwrapped.core
    setup = core.setup
    print(
        f"case {setup.name}: plant {setup.plant.name} ({'ideal' if kw['ideal'] else 'realistic'}"
        f"), path length {setup.path.total_length:.4f} m, feedrate {setup.feedrate_m_s:.4f} m/s,"
        f" {core.n_steps - 1} steps of {core.T * 1e3:g} ms"
    )
    if setup.program_summary:
        print(f"program: {setup.program_summary}")
    policy, label = None, "zero command"
    if args.controller:
        from agents import make_controller

        # env=: the controller of the env's plant family (pd on the five-axis plant is
        # Chen 2022's joint PD)
        policy, label = make_controller(args.controller, env=env).bind(env), args.controller
    record = run_episode(env, policy, seed=args.seed)
    metrics = score(record, metrics=metrics_asked)
    print_metrics(label, metrics)
    result = {
        "case": setup.name,
        "plant": setup.plant.name,
        "controller": label,
        "ideal": bool(kw["ideal"]),
        "seed": args.seed,
        "metrics": metrics,
    }
    if args.json:
        atomic_write_json(args.json, result)
        print(f"wrote {args.json}")
    if args.plot:
        plot_runs(
            {label: record},
            setup.path,
            f"{setup.name} — {label}",
            args.plot,
            {label: metrics},
        )
        print(f"wrote {args.plot}")
    return 0


def cmd_compare(args) -> int:
    from agents.compare import compare, format_table, robustness

    from ..io import atomic_write_json
    from .cli_checks import check_compare_options

    # every option first, all bad ones named in one error, before anything runs
    check_compare_options(args)
    # rows are names or variants (ccc:wp=3e4:wd=20); each row is labelled as typed
    names = [c.strip() for c in args.controllers.split(",") if c.strip()]
    kw = target_kwargs(args)

    def show(name, row):
        if "rms_contour_error_um" in row:
            status = "" if row["stable"] else f" UNSTABLE ({row['termination_reason']})"
            if not row["stable"] and row.get("termination_reason") is None:
                status = f" (incomplete: {row.get('incomplete_reason')})"
            rms = row["rms_contour_error_um"]
            text = f"{rms:.2f} µm" if rms is not None else "n/a"
            if row.get("below_resolution"):
                text = f"≤{row['encoder_resolution_um']:g} µm (below one encoder count)"
            theta = row.get("rms_orientation_error_arcsec")  # five-axis runs
            text += f", RMS orientation error {theta:.2f}″" if theta is not None else ""
            print(f"  {name}: RMS contour error {text}{status}", flush=True)
            if row.get("agent_is_base"):
                why = row.get("agent_base_reason") or "no checkpoint beat it on validation"
                print(f"    ({name}: the agent is its base {row['agent_base']}: {why})", flush=True)
            if row.get("outside_envelope_fraction") is not None:
                print(
                    f"    ({name}: {row['outside_envelope_fraction']:.1%} of its decisions outside "
                    "the ranges it was trained on, its gate faded there)",
                    flush=True,
                )

    metrics = tuple(m.strip() for m in (args.metrics or "").split(",") if m.strip())
    if args.randomize is not None:
        from agents.compare import check_randomizable

        check_randomizable(**kw)  # before any run: the five-axis plant takes no variations
    _print_program_summary(kw)
    result = compare(names, seed=args.seed, progress=show, model=args.model, metrics=metrics, **kw)
    robust = None
    if args.randomize is not None:
        from tqdm import tqdm

        bar = tqdm(total=len(names), desc="robustness", unit="controller")

        def tick(name, row):
            bar.update(1)

        robust = robustness(
            names,
            args.randomize,
            args.episodes,
            seed=args.seed,
            progress=tick,
            model=args.model,
            traces=bool(args.plot),
            **kw,
        )
        bar.close()
    print(format_table(result, robust))
    # the per-variation ε(t) traces are for the plot only (arrays, not JSON)
    traces = {r["controller"]: r.pop("traces", None) for r in robust or []}
    records = result.pop("records")
    out = {
        "case": result["case"],
        "plant": result["plant"],
        "ideal": bool(kw["ideal"]),
        "seed": args.seed,
        "results": result["results"],
    }
    if robust is not None:
        out["robustness"] = robust
    if args.json:
        atomic_write_json(args.json, out)
        print(f"wrote {args.json}")
    if args.plot:
        # matplotlib only when a plot is asked for (about a second of start-up)
        from ..cases import build_setup
        from ..plotting import plot_runs

        keys = ("case", "plant", "path", "ideal", "feedrate_m_s")
        path = build_setup(**{k: kw[k] for k in keys if k in kw}).path  # cached: compare's
        metrics = {r["controller"]: r for r in result["results"]}
        rows = [{**r, "traces": traces.get(r["controller"])} for r in robust or []]
        plot_runs(
            records,
            path,
            f"{result['case']} — {', '.join(names)}",
            args.plot,
            metrics,
            rows or None,
        )
        print(f"wrote {args.plot}")
    return 0


def cmd_ilc(args) -> int:
    import gymnasium as gym

    from agents import make_controller
    from agents.registry import (
        KEEPING_CONTROLLERS,
        LEARNING_CONTROLLERS,
        learns_between_trials,
        parse_spec,
    )
    from agents.repeated_batch import run_batch

    from .. import ENV_ID
    from ..io import atomic_write_json
    from ..metrics import format_um, resolution_fields
    from ..plotting import plot_learning

    spec = parse_spec(args.controller)  # read once; the calls below take the record
    if not learns_between_trials(spec):
        raise ValueError(
            f"--controller: {args.controller!r} does not learn between trials; learning "
            f"controllers: {', '.join(LEARNING_CONTROLLERS)}, or "
            f"{' / '.join(f'{n}:keep=1' for n in KEEPING_CONTROLLERS)} (the network kept "
            "across trials)"
        )
    if (args.save or args.load) and not hasattr(make_controller(spec), "save"):
        raise ValueError(
            f"--save/--load: {args.controller!r} has no saved learning state (it keeps its "
            "network within one run of contour-env ilc)"
        )
    if args.iterations < 1:
        raise ValueError(f"--iterations: must be >= 1, got {args.iterations}")
    kw = target_kwargs(args)
    if args.noise is not None:
        kw["measurement_noise_std_m"] = args.noise
    if args.disturbance_phase:
        kw["disturbance_phase"] = args.disturbance_phase
    env = gym.make(ENV_ID, **kw)
    controller = make_controller(spec, env=env)
    if args.load:
        controller.load_state(args.load)
    controller.bind(env)
    result = run_batch(env, controller, args.iterations, seed=args.seed, progress=True)
    result["controller"] = args.controller  # the spec as typed (ilc-pd:gain=0.8)
    resolution_m = env.unwrapped.core.setup.plant.params.encoder_resolution_m
    for r in result["iterations"]:
        if r.get("encoder_resolution_um") is None:  # trial records do not carry the encoder
            r.update(resolution_fields(r, resolution_m))
    print(f"case {result['case']} (plant {result['plant']}), controller {result['controller']}")
    print(f"{'iteration':>9s} {'max ε µm':>10s} {'RMS ε µm':>10s} {'RMS/first':>10s}")
    first = result["iterations"][0]["rms_contour_error_um"]
    for r in result["iterations"]:
        rms = r["rms_contour_error_um"]
        ratio = f"{rms / first:10.4f}" if rms is not None and first else f"{'–':>10s}"
        mx = r["max_contour_error_um"]
        res = r["encoder_resolution_um"]
        flag = "  error growing" if r["error_growing"] else ""
        if not r["completed"]:
            flag = f"  stopped: {r['termination_reason']}"
        print(
            f"{r['iteration']:9d} {format_um(mx, res, '.3f'):>10s} "
            f"{format_um(rms, res, '.3f'):>10s} {ratio}{flag}"
        )
    if result["diverged"]:
        print("warning: the learning diverged (a trial failed or the last is worse than the first)")
    if args.save:
        controller.save(args.save)
        print(f"wrote {args.save} (learning state after {controller.iteration} trials)")
    if args.json:
        data = {k: v for k, v in result.items() if k != "trials"}
        atomic_write_json(args.json, data)
        print(f"wrote {args.json}")
    if args.plot:
        plot_learning(result, args.plot)
        print(f"wrote {args.plot}")
    return 0


def cmd_stability(args) -> int:
    import json

    from ..analysis import format_stability_report, stability_report
    from ..io import atomic_write_json

    plant = args.plant
    if args.params:
        try:
            with open(args.params) as fh:
                plant = json.load(fh)
        except json.JSONDecodeError as exc:
            raise ValueError(f"--params {args.params}: not valid JSON ({exc})") from None
        except OSError as exc:
            raise ValueError(f"--params {args.params}: {exc.strerror or exc}") from None
    kw = {"radius_m": args.radius}
    if args.kp is not None:
        kw["kp"] = args.kp
    if args.feedrates:
        try:
            kw["feedrates_m_s"] = [float(f) / 60.0 for f in args.feedrates.split(",")]
        except ValueError:
            raise ValueError(
                f"--feedrates: expected comma-separated numbers in m/min, got {args.feedrates!r}"
            ) from None
    rep = stability_report(plant, ideal=not args.realistic, **kw)
    print(format_stability_report(rep))
    if args.cross_coupling or args.plot or args.cp is not None or args.verify_margins:
        from .jee_chart import run_cross_coupling

        cc, text = run_cross_coupling(
            plant,
            realistic=args.realistic,
            cp=args.cp,
            plot=args.plot,
            verify_margins=args.verify_margins,
            **kw,
        )
        print(text)
        rep.update(cc)
    if args.json:
        atomic_write_json(args.json, rep)
        print(f"wrote {args.json}")
    return 0


def cmd_margins(args) -> int:
    from agents.margins import format_margins, loop_margins, meets_requirement

    from ..io import atomic_write_json
    from ..plants import FIVE_AXIS_PLANT_ALIASES

    analyse = loop_margins
    if args.plant in FIVE_AXIS_PLANT_ALIASES:  # the joint loops at poses (docs/FIVE_AXIS.md)
        from agents.five_axis_margins import five_axis_loop_margins as analyse
    rep = analyse(
        args.controller,
        args.plant,
        ideal=args.ideal,
        structural_mode=args.structural_mode,
        mass_variation=args.mass_variation,
    )
    print(format_margins(rep))
    if args.json:
        atomic_write_json(args.json, rep)
        print(f"wrote {args.json}")
    return 0 if not args.check or meets_requirement(rep) else 1


def cmd_bench(args) -> int:
    from ..io import atomic_write_json
    from .speed import format_bench, run_bench

    res = run_bench(
        args.case,
        seconds=args.seconds,
        repeats=args.repeats,
        quick=args.quick,
        progress=lambda s: print(s, flush=True),
    )
    print(format_bench(res))
    if args.json:
        atomic_write_json(args.json, res)
        print(f"wrote {args.json}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="contour-env",
        description="Multi-axis CNC feed-drive contouring: cases, runs, benchmarks (SI units).",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    _add_cases_parser(sub)
    _add_controllers_parser(sub)
    _add_run_parser(sub)
    _add_compare_parser(sub)
    _add_ilc_parser(sub)
    _add_stability_parser(sub)
    _add_margins_parser(sub)
    _add_bench_parser(sub)
    _add_warm_parser(sub)
    from .cli_rl import add_rl_commands  # train, evaluate, models (residual RL agents)
    from .sweep import train_or_sweep  # train --sweep FILE: a sweep of trials

    add_rl_commands(sub)
    sub.choices["train"].set_defaults(func=train_or_sweep)
    from .cli_benchmark import add_benchmark_command  # the whole benchmark and its report

    add_benchmark_command(sub)
    from .cli_circular import add_circular_test_command  # ISO 230-4 circular (ballbar) test

    add_circular_test_command(sub)
    from .cli_machine import add_machine_commands  # identify, excite: your machine

    add_machine_commands(sub)
    from .cli_export import add_export_command  # the agent's law as C99 and ONNX

    add_export_command(sub)
    from .cli_tune import add_tune_command  # default gains for your plant file

    add_tune_command(sub)
    return parser


def _add_metrics_option(p: argparse.ArgumentParser, total_unit: str) -> None:
    # --metrics of run and compare; ``total_unit``: how the total contour error is given
    p.add_argument(
        "--metrics",
        default=None,
        help="extra metrics, comma-separated: total (Chen & Lee 2020's total contour error "
        f"Σ|ε|, {total_unit})",
    )


def _add_cases_parser(sub) -> None:
    p = sub.add_parser("cases", help="list the named cases")
    p.add_argument("-v", "--verbose", action="store_true", help="full notes and published results")
    p.set_defaults(func=cmd_cases)


def _add_controllers_parser(sub) -> None:
    p = sub.add_parser(
        "controllers", help="every controller with its parameters (for NAME:key=value variants)"
    )
    p.set_defaults(func=cmd_controllers)


def _add_run_parser(sub) -> None:
    p = sub.add_parser("run", help="run one episode and print its metrics")
    add_target_args(p)
    p.add_argument(
        "--controller",
        default=None,
        help="controller used as the policy: a name or a variant NAME:key=value[:key=value] "
        "(pd, ccc:wp=3e4; see `contour-env controllers`); default: zero command",
    )
    add_json_option(p, "the metrics")
    _add_metrics_option(p, "µm")
    p.add_argument("--plot", help="write a plot (PNG) to this file")
    p.set_defaults(func=cmd_run)


def _add_compare_parser(sub) -> None:
    p = sub.add_parser("compare", help="controllers side by side (Lee 2012 Tables 2, 3)")
    add_target_args(p)
    p.add_argument(
        "--controllers",
        default="pd,ccc,adaptive-ccc",
        help="comma-separated controllers (pd, ccc, adaptive-ccc, jee-ccc, residual) or "
        "variants NAME:key=value[:key=value] (e.g. pd,ccc:wp=3e4:wd=20,adaptive-ccc:gamma=0; "
        "see `contour-env controllers`); default pd,ccc,adaptive-ccc",
    )
    p.add_argument(
        "--model",
        default=None,
        metavar="DIR",
        help="model DIR (contour-env train --out) of the residual row; default: the shipped "
        "agent for the plant (contour-env models)",
    )
    add_json_option(p, "the results")
    _add_metrics_option(p, "printed in mm, total_contour_error_um in the JSON")
    p.add_argument(
        "--plot",
        help="write a PNG: the path with each controller's contour error magnified, contour "
        "and tracking error vs time, and with --randomize the spread over the variations",
    )
    p.add_argument(
        "--randomize",
        type=float,
        default=None,
        metavar="FRACTION",
        help="also score over plant-parameter variations of ±FRACTION (e.g. 0.2)",
    )
    p.add_argument(
        "--episodes",
        type=int,
        default=32,
        help="number of variations with --randomize (default 32)",
    )
    p.set_defaults(func=cmd_compare)


def _add_ilc_parser(sub) -> None:
    p = sub.add_parser("ilc", help="repeated-batch trials with a learning controller")
    add_target_args(p)
    p.add_argument(
        "--controller",
        default="ilc-contour",
        help="learning controller: ilc-pd, ilc-contour, vilcfd, or a variant such as "
        "vilcfd:dob=0:friction=false (see `contour-env controllers`; default ilc-contour)",
    )
    p.add_argument("--iterations", type=int, default=10, help="number of trials (default 10)")
    add_json_option(p, "the per-iteration metrics")
    p.add_argument("--plot", help="write the learning curve and first/last trial (PNG)")
    p.add_argument("--save", help="write the learning state (.npz) after the last trial")
    p.add_argument("--load", help="continue from a saved learning state (.npz)")
    p.add_argument(
        "--noise",
        type=float,
        default=None,
        metavar="STD_M",
        help="encoder noise standard deviation, m (new in every trial; default none)",
    )
    p.add_argument(
        "--disturbance-phase",
        choices=("fixed", "random"),
        default=None,
        help="plant disturbance phase: fixed (default, repeats) or random per trial",
    )
    p.set_defaults(func=cmd_ilc)


def _add_stability_parser(sub) -> None:
    p = sub.add_parser(
        "stability", help="Jee 2007: Jury range of the axial P gain and circle steady state"
    )
    p.add_argument(
        "--plant",
        default="jee-triaxial",
        help="plant name (default jee-triaxial; hsm2, linear-motor, friction-table too)",
    )
    p.add_argument(
        "--params",
        help="JSON file of custom plant parameters (a plain mapping; overrides --plant)",
    )
    p.add_argument(
        "--kp", type=float, help="axial gain for the steady state (default: half the limit)"
    )
    p.add_argument(
        "--feedrates",
        help="comma-separated circle feedrates in m/min (default 5,10,20)",
    )
    p.add_argument("--radius", type=float, default=0.05, help="circle radius, m (default 0.05)")
    p.add_argument(
        "--realistic",
        action="store_true",
        help="simulate the plant with its realistic effects (default: ideal, as the paper)",
    )
    _add_cross_coupling_options(p)
    add_json_option(p, "the report")
    p.set_defaults(func=cmd_stability)


def _add_cross_coupling_options(p: argparse.ArgumentParser) -> None:
    # stability's Jee cross-coupling analysis (contour_env.app.jee_chart)
    p.add_argument(
        "--cross-coupling",
        action="store_true",
        help="add Jee's cross-coupling analysis (velocity-command plants): stable (C_P, C_I) "
        "and (C_P, C_D) regions, design chart, recommended gains, steady state with G_C",
    )
    p.add_argument(
        "--cp",
        type=float,
        help="cross-coupling C_P for its steady state (C_I = 2.62 C_P, C_D = 0.02 C_P; "
        "default: the recommended gains; implies --cross-coupling)",
    )
    p.add_argument(
        "--plot", help="write Jee's Figs. 4a/4b/5 to this PNG (implies --cross-coupling)"
    )
    p.add_argument(
        "--verify-margins",
        action="store_true",
        help="check the realistic recommended gains with agents.margins.loop_margins "
        "(implies --cross-coupling)",
    )


def _add_margins_parser(sub) -> None:
    p = sub.add_parser(
        "margins",
        help="gain and phase margins of every loop a controller closes (realistic plant)",
    )
    p.add_argument(
        "--plant",
        default="hsm2",
        help="plant name (default hsm2); five-axis (alias nxv560a): each joint loop linearised "
        "at poses over the A/C travel and along the named paths (docs/FIVE_AXIS.md)",
    )
    p.add_argument(
        "--controller",
        default="pd",
        help="controller or variant, e.g. pd, ccc, ccc:wp=3e4, adaptive-ccc, jee-ccc (default "
        "pd); on the five-axis plant pid, pid:w=80, or pd (the paper's gains)",
    )
    p.add_argument(
        "--structural-mode",
        action="store_true",
        help="with the plant's axial two-mass mode (encoder on the drive side)",
    )
    p.add_argument("--ideal", action="store_true", help="the textbook plant instead")
    p.add_argument(
        "--mass-variation",
        type=float,
        default=0.2,
        help="± fraction of the mass corners (default 0.2)",
    )
    add_json_option(p, "the report")
    p.add_argument(
        "--check",
        action="store_true",
        help="exit 1 when the margins miss the requirement (6 dB / 30°; structural mode "
        "2 dB / 10°)",
    )
    p.set_defaults(func=cmd_margins)


def _add_bench_parser(sub) -> None:
    p = sub.add_parser("bench", help="steps/s of the single and the vectorised env")
    p.add_argument("--case", default=DEFAULT_CASE, help=f"case (default {DEFAULT_CASE})")
    p.add_argument(
        "--seconds",
        type=float,
        default=None,
        help="measuring time per figure, s (default 2; 0.3 with --quick); each window is at "
        "least one whole episode, so large vector sizes take longer",
    )
    p.add_argument(
        "--repeats",
        type=int,
        default=None,
        help="timing windows per figure, alternating with CartPole's; the figure is their "
        "median (default 5; 1 with --quick)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="a first look in under 30 s: one 0.3 s window per figure, 1, 64 and 1024 envs "
        "(no 4096)",
    )
    p.add_argument(
        "--json",
        help="write the results as JSON to this file: every window's rate and each figure's "
        "ratio to CartPole (scripts/check_speed_regression.py compares them with "
        "docs/bench_reference.json)",
    )
    p.set_defaults(func=cmd_bench)


def _add_warm_parser(sub) -> None:
    p = sub.add_parser(
        "warm",
        help="compile the numba kernels once, in parallel (minutes on a fresh install; later "
        "commands load them in seconds)",
    )
    p.add_argument("--workers", type=int, default=2, help="processes compiling at once (default 2)")
    p.set_defaults(func=cmd_warm)


# options that name an output file or folder: checked before the command runs (a `train` of
# hours must not fail at its first write)
OUTPUT_FILE_OPTIONS = ("json", "plot", "save")
OUTPUT_DIR_OPTIONS = ("out",)


def _option_of(args, path) -> str | None:
    for dest, value in vars(args).items():
        if (
            value is not None
            and isinstance(value, (str, os.PathLike))
            and (os.fspath(value) == os.fspath(path))
        ):
            return "--" + dest.replace("_", "-")
    return None


def _check_outputs(args) -> None:
    from ..io import check_output_dir, check_output_file

    for dests, check in (
        (OUTPUT_FILE_OPTIONS, check_output_file),
        (OUTPUT_DIR_OPTIONS, check_output_dir),
    ):
        for dest in dests:
            value = getattr(args, dest, None)
            if value is not None:
                check(value)


def _one_line_warning(message, category, filename, lineno, file=None, line=None, seen=None):
    """The package's warnings (e.g. a controller without tuned gains for a plant file) as one
    line on stderr, ``warning: ...``, each text once per command (``seen``: the texts printed
    so far; a controller bound for every run of a command warns once); others as Python
    prints them."""
    if issubclass(category, UserWarning) and not issubclass(category, DeprecationWarning):
        text = str(message)
        if seen is not None:
            if text in seen:
                return
            seen.add(text)
        print(f"warning: {text}", file=sys.stderr)
    else:
        print(warnings.formatwarning(message, category, filename, lineno, line), file=sys.stderr)


# commands that run no compiled kernel (listing and checking only)
NO_KERNEL_COMMANDS = ("cases", "controllers", "models")


def _cold_cache_note(args) -> None:
    """One line on stderr before a command that will compile the kernels first (a fresh
    install sits silent for minutes otherwise, and looks hung)."""
    from ..kernel_cache import COLD_NOTE, cache_is_cold

    if getattr(args, "command", None) not in NO_KERNEL_COMMANDS and cache_is_cold():
        print(COLD_NOTE, file=sys.stderr, flush=True)


def main(argv=None) -> int:
    from ..io import OutputPathError

    parser = build_parser()
    args = parser.parse_args(argv)
    np.set_printoptions(precision=4)
    _cold_cache_note(args)
    try:
        _check_outputs(args)
        with warnings.catch_warnings():
            # restored on leaving the block
            warnings.showwarning = functools.partial(_one_line_warning, seen=set())
            return args.func(args)
    except OutputPathError as exc:
        option = _option_of(args, exc.path)
        print(f"error: {option + ': ' if option else ''}{exc}", file=sys.stderr)
        return 2
    except (ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        # a file that cannot be read or written (permission, a folder named as a file, ...)
        where = f": {exc.filename}" if exc.filename else ""
        print(f"error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
