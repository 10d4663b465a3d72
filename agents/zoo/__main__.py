"""``python -m agents.zoo``: score a finished RL Zoo run with the project's scoring, or export a
residual run as a model DIR for ``contour-env evaluate/compare --model``.

    python -m agents.zoo evaluate RUN [--case X] [--against pd,ccc] [--seed 0] [--json OUT]
    python -m agents.zoo export RUN OUT

RUN is the zoo's run folder (``LOG_FOLDER/ALGO/ENV_NAME_N``) or a model ``.zip`` in it, or
``LOG_FOLDER:ALGO:ENV_ID`` for the newest run there.
"""

from __future__ import annotations

import argparse
import sys
import time


def _run_path(spec: str):
    from . import latest_run

    parts = spec.split(":")
    if len(parts) == 3 and parts[2].startswith("contour_env/"):
        return latest_run(*parts)
    return spec


def _num(x, spec: str) -> str:
    return "n/a" if x is None else format(float(x), spec)


def cmd_evaluate(args) -> int:
    import gymnasium as gym

    from contour_env import ENV_ID
    from contour_env.evaluation import evaluate
    from contour_env.io import atomic_write_json

    from ..registry import make_controller
    from . import ZooRun, load_agent

    run = ZooRun(_run_path(args.run))
    kw = dict(run.env_kwargs)
    if args.case:
        kw = {k: v for k, v in kw.items() if k not in ("case", "plant", "path")}
        kw["case"] = args.case
    agent = load_agent(run.model_path)
    if args.against is not None:
        against = [c for c in args.against.split(",") if c]
    elif run.residual:
        base = run.wrapper_kwargs.get("base", "pd")
        against = [base] + (["pd"] if base != "pd" else [])
    else:
        against = ["pd", "ccc"]
    label = f"zoo {run.algo}" + (f" residual on {agent.base_name}" if run.residual else " plain")
    rows = []
    t0 = time.perf_counter()
    rows.append((label, evaluate(gym.make(ENV_ID, **kw), agent, seed=args.seed)))
    for name in against:
        rows.append((name, evaluate(gym.make(ENV_ID, **kw), make_controller(name), seed=args.seed)))
    env_desc = ", ".join(f"{k}={v}" for k, v in kw.items()) or "default case"
    print(f"{run.model_path} on {env_desc} (seed {args.seed}, {time.perf_counter() - t0:.1f} s)")
    print(f"{'controller':34s} {'RMS ε µm':>10s} {'max ε µm':>10s}  RMS effort per axis  completed")
    for name, m in rows:
        rms, mx = (_num(m[k], ".3f") for k in ("rms_contour_error_um", "max_contour_error_um"))
        effort = ", ".join(_num(e, ".4g") for e in m["rms_effort"])
        print(f"{name:34s} {rms:>10s} {mx:>10s}  [{effort}]  {m['completed']}")
    if args.json:
        atomic_write_json(
            args.json,
            {
                "run": str(run.folder),
                "model": str(run.model_path),
                "env_kwargs": kw,
                "seed": args.seed,
                "rows": [{"controller": n, "metrics": m} for n, m in rows],
            },
        )
        print(f"wrote {args.json}")
    return 0


def cmd_export(args) -> int:
    from . import export_agent

    out = export_agent(_run_path(args.run), args.out)
    print(f"wrote {out} (agent.json, model.zip, normalization.json)")
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m agents.zoo", description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("evaluate", help="score a zoo run and its comparison controllers")
    e.add_argument("run", help="run folder, model .zip, or LOG_FOLDER:ALGO:ENV_ID (newest)")
    e.add_argument("--case", help="named case (default: the run's env_kwargs)")
    e.add_argument(
        "--against",
        help="comma-separated controllers to score too (default: the residual run's base and "
        "pd; pd,ccc for a plain run)",
    )
    e.add_argument("--seed", type=int, default=0)
    e.add_argument("--json", help="write the metrics here")
    e.set_defaults(func=cmd_evaluate)
    x = sub.add_parser("export", help="a residual zoo run as a contour-env model DIR")
    x.add_argument("run", help="run folder, model .zip, or LOG_FOLDER:ALGO:ENV_ID (newest)")
    x.add_argument("out", help="model DIR to write")
    x.set_defaults(func=cmd_export)
    args = p.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
