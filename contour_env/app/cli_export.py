"""``contour-env export``: a trained residual agent's whole law for a real controller — C99
(``residual.c``/``residual.h``), ONNX (``residual.onnx``, the ``[deploy]`` extra) and a
``README.md`` of its inputs and outputs; ``--bench`` times it on this CPU."""

from __future__ import annotations

import tempfile

FORMATS = ("c", "onnx")


def _formats(text: str) -> list:
    got = [f.strip() for f in (text or "").split(",") if f.strip()]
    bad = [f for f in got if f not in FORMATS]
    if bad or not got:
        raise ValueError(f"--format: a comma-separated list of {', '.join(FORMATS)}, got {text!r}")
    return list(dict.fromkeys(got))


def _deploy_check() -> None:
    try:
        import onnx  # noqa: F401
    except ImportError as exc:
        raise ValueError(
            f"--format onnx: the onnx package is not installed ({exc}); install the optional "
            'extra with pip install -e ".[deploy]", or export --format c (no dependency)'
        ) from None


def _bench_inputs(model_dir, plant=None):
    """The inputs of a sample in motion of a part of the agent's plant (a circle at its
    envelope's mid feed), and the axis mask, for the latency runs."""
    import gymnasium as gym
    import numpy as np

    from agents.export.c_law import plant_of
    from agents.export.replay import inputs_from_core
    from agents.residual import ResidualAgent, make_base
    from contour_env import ENV_ID
    from contour_env.paths import circle

    agent = ResidualAgent(model_dir)
    plant = plant_of(model_dir, agent.meta, plant)
    feed = 0.05
    env_ = agent.envelope
    if env_ is not None and env_.feed_range is not None:
        feed = float(np.mean(env_.feed_range))
    path = circle((0.0, 0.0, 0.0), 0.02)
    env = gym.make(ENV_ID, plant=plant, path=path, feedrate_m_s=feed)
    env.reset(seed=0)
    core = env.unwrapped.core
    base = make_base(agent.base_name, env, agent.base_kwargs)
    for _ in range(min(2000, core.n_steps // 2)):
        env.step(np.clip(np.asarray(base.action(core.signals_batch()))[0], -1, 1))
    return inputs_from_core(core, np.ones(core.dim), np.zeros(core.dim))


def cmd_export(args) -> int:
    from agents.export import write_c
    from agents.export.readme import readme_text
    from contour_env.io import atomic_write_json, atomic_write_text, check_output_dir

    formats = _formats(args.format)
    if "onnx" in formats:
        _deploy_check()
    out = check_output_dir(args.out)
    if "c" in formats:
        iface = write_c(args.model, out, plant=args.plant)
        files = list(iface["files"])
    else:  # the interface only (the same description the C form's README gives)
        with tempfile.TemporaryDirectory(prefix="residual-iface-") as tmp:
            iface = write_c(args.model, tmp, plant=args.plant)
        files = []
    if "onnx" in formats:
        from agents.export.onnx_law import write_onnx

        files.append(str(write_onnx(args.model, out, plant=args.plant)))
    from agents.residual import read_model_metadata

    iface["algo"] = read_model_metadata(args.model)["algo"]
    bench = None
    if args.bench:
        bench = _run_bench(args.model, out, formats, iface, args.plant)
    atomic_write_text(out / "README.md", readme_text(iface, files, bench))
    for f in files:
        print(f"wrote {f}")
    print(f"wrote {out / 'README.md'} (inputs, state, outputs, servo period "
          f"{iface['servo_period_s']:g} s)")  # fmt: skip
    if bench:
        for form, b in bench.items():
            print(
                f"{form}: median {b['median_us']:.2f} µs, p99 {b['p99_us']:.2f} µs per call; "
                f"deciding calls ({_every(iface['action_repeat'])}): median "
                f"{b['deciding_median_us']:.2f} µs, p99 {b['deciding_p99_us']:.2f} µs "
                f"({b['calls']} calls)"
            )
    if args.json:
        atomic_write_json(args.json, {"interface": iface, "bench": bench})
    return 0


def _every(k: int) -> str:
    return "every call" if int(k) == 1 else f"every {int(k)}th"


def _run_bench(model_dir, out, formats, iface, plant=None) -> dict:
    from agents.export.bench import bench_c, bench_onnx
    from agents.export.onnx_law import reset_state

    inputs = _bench_inputs(model_dir, plant)
    order = [r["name"] for r in iface["inputs"]]
    repeat = int(iface["action_repeat"])
    res = {}
    if "c" in formats:
        res["C law"] = bench_c(out, inputs, order, repeat)
    if "onnx" in formats:
        res["ONNX Runtime"] = bench_onnx(out / "residual.onnx", inputs,
                                         reset_state(iface["n_axes"]), repeat)  # fmt: skip
    return res


def add_export_command(subparsers) -> None:
    """Register ``contour-env export`` on ``subparsers``."""
    p = subparsers.add_parser(
        "export",
        help="a trained residual agent's whole law as C99 and ONNX for a real controller",
        description="Write the residual law of a trained agent — from the signals a CNC has "
        "each servo period (the interpolator's reference sample and look-ahead, the "
        "encoders, the base command) to the command per axis: observation, normalisation, "
        "actor, gate, path frame, envelope, fade at rest, bound, axis mask — as dependency-"
        "free C99 (residual.c/.h, one residual_step call per period, no allocation) and as "
        "an ONNX graph (residual.onnx, opset 17; needs the [deploy] extra), with a README.md "
        "of its inputs and outputs. An agent whose plant is not a feed-drive plant is "
        "refused.",
    )
    p.add_argument("--model", required=True, help="trained model DIR (from `contour-env train`)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument(
        "--plant",
        default=None,
        metavar="PLANT.json",
        help="the plant file of an agent trained on one (default: the path its run's "
        "config.json gives)",
    )
    p.add_argument("--format", default="c,onnx", help="c, onnx or c,onnx (default c,onnx)")
    p.add_argument(
        "--bench",
        action="store_true",
        help="time the law on this CPU: µs per call, median and p99 (C compiled -O2; ONNX "
        "Runtime from Python, one thread)",
    )
    p.add_argument("--json", default=None, help="write the interface (and timings) as JSON")
    p.set_defaults(func=cmd_export)


__all__ = ["add_export_command", "cmd_export"]
