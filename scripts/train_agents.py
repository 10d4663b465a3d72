"""Train the shipped residual agents (``agents/models/<plant>/``) exactly as they were made.

    python scripts/train_agents.py [--only linear-motor,friction-table,hsm2] [--work DIR]
        [--install] [--from-run DIR]

Each agent is one ``contour-env train`` run with the configuration in :data:`SHIPPED` (seed 0,
one torch thread, this 2-core CPU); the run goes to ``--work/<plant>`` (default
``out/agents``) and, with ``--install``, its model files (``model.zip``, ``agent.json``,
``config.json``, ``normalization.json``, and the learning and validation curves where the run
wrote them) are copied to ``agents/models/<plant>/`` — checkpoints, replay buffers and
TensorBoard logs are not shipped. ``--from-run DIR`` installs a run made elsewhere (e.g. in the
background with ``contour-env train``) after checking that its ``config.json`` is the shipped
configuration. ``scripts/residual_scorecard.py`` then scores them against their bases.

The shipped recipes stop on a training-time budget and validate every 60 s of training time, so
a run is reproducible in its configuration, not to the bit: how many steps fit in the budget,
and so which checkpoints are candidates, depends on the machine's speed at the time (sb3 and
torch are seeded by ``seed``).
"""

from __future__ import annotations

import argparse
import shutil
import time
from pathlib import Path

from agents.rl import TrainConfig, train

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "agents" / "models"
SHIPPED_FILES = (
    "model.zip",
    "agent.json",
    "config.json",
    "normalization.json",
)
# shipped too when the run wrote them: the learning curve (runs with training cases, scored on
# them) and the keep-best record of each checkpoint (runs with a validation set)
OPTIONAL_FILES = (
    "learning_curve.json",
    "learning_curve.png",
    "validation_curve.json",
    "validation_curve.png",
)

# one entry per shipped agent: TrainConfig keywords (everything else at its default, seed 0
# unless given). Every agent trains on the path families (agents/rl/families.py) in the path
# frame with the axis observation, the fade at rest and the reward scaled by the base's error on
# each part (the defaults), with a learned gate and a learning rate annealed 3e-4 -> 3e-5 over
# 20 minutes of training time; the model kept is the checkpoint no worse than the base on any
# validation part and at least 10 % better on average, with the lowest mean ratio, or the base
# itself (issue 33).
_RECIPE = dict(
    path_variety=("families",),
    algo="sac",
    timesteps=10_000_000,  # the time budget ends the run
    time_budget_s=1200.0,
    eval_every_s=60.0,
    gate=True,
    learning_rate_final=3e-5,
)
SHIPPED = {
    # stiction and Coulomb friction of the friction table; base: CCC, the best classical
    # controller on sharp-corner and corner-blend with the margin-checked defaults
    # (trained before keep_min_gain existed, so with 0: its kept checkpoint is 0.59x the base
    # on average, and the 0.10 of the other recipes would have kept the same one)
    "friction-table": dict(
        _RECIPE, plant="friction-table", base="ccc", validation_paths=24, keep_min_gain=0.0
    ),  # fmt: skip
    # friction and force ripple of the linear motor; base: CCC, the best classical controller
    # on lm-circle3d, which is also a training source (one episode in two): the issue's
    # yardstick for this plant is that arc
    "linear-motor": dict(
        _RECIPE, cases=("lm-circle3d",), base="ccc", validation_paths=16
    ),  # fmt: skip
    # Lee 2012's HSM2; base: adaptive CCC (the best there), within one or two encoder counts
    # (2 / 1 um) on most parts: a smaller authority (2 % of the torque limit)
    "hsm2": dict(_RECIPE, plant="hsm2", base="adaptive-ccc", scale=0.02, validation_paths=16),
}


def check_run(run_dir: Path, name: str) -> None:
    """Refuse a run whose configuration is not the shipped one of ``name`` (or unfinished)."""
    from agents.rl.config import load_config

    if not (run_dir / "agent.json").is_file():
        raise SystemExit(f"--from-run: {run_dir} has no agent.json (not a finished run)")
    got = load_config(run_dir / "config.json").to_dict()
    want = TrainConfig(**{"seed": 0, **SHIPPED[name]}).to_dict()
    diff = sorted(k for k in set(got) | set(want) if got.get(k) != want.get(k))
    if diff:
        raise SystemExit(f"--from-run: {run_dir} differs from SHIPPED[{name!r}] in {diff}")


def install(run_dir: Path, name: str) -> Path:
    """Copy the model files of ``run_dir`` to ``agents/models/<name>`` (replacing it whole:
    written to a sibling folder first, then renamed)."""
    dest = MODELS / name
    tmp = MODELS / f".{name}.tmp"
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir(parents=True)
    for f in SHIPPED_FILES:
        shutil.copy2(run_dir / f, tmp / f)
    for f in OPTIONAL_FILES:
        if (run_dir / f).is_file():
            shutil.copy2(run_dir / f, tmp / f)
    if dest.exists():
        shutil.rmtree(dest)
    tmp.rename(dest)
    return dest


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default=",".join(SHIPPED), help="comma-separated agent names")
    ap.add_argument("--work", default="out/agents", help="folder for the training runs")
    ap.add_argument("--install", action="store_true", help="copy the models to agents/models")
    ap.add_argument("--no-progress", action="store_true")
    ap.add_argument(
        "--from-run",
        metavar="DIR",
        help="with --only NAME --install: install a finished run (e.g. a `contour-env train` "
        "run in the background) instead of training, after checking that its config.json is "
        "the shipped configuration",
    )
    args = ap.parse_args(argv)
    names = [n for n in args.only.split(",") if n]
    unknown = [n for n in names if n not in SHIPPED]
    if unknown:
        raise SystemExit(f"--only: unknown {unknown}; known: {', '.join(SHIPPED)}")
    if args.from_run:
        if len(names) != 1 or not args.install:
            raise SystemExit("--from-run: give one agent with --only NAME, and --install")
        check_run(Path(args.from_run), names[0])
        print(f"installed {install(Path(args.from_run), names[0])}")
        return 0
    for name in names:
        out = Path(args.work) / name
        if out.exists():
            shutil.rmtree(out)
        t0 = time.perf_counter()
        cfg = TrainConfig(**{"seed": 0, **SHIPPED[name]})
        res = train(cfg, out, progress=not args.no_progress)
        print(
            f"{name}: {res['timesteps']} timesteps, {time.perf_counter() - t0:.0f} s wall "
            f"(training and validation), kept: {res.get('kept')}",
            flush=True,
        )
        if args.install:
            print(f"installed {install(out, name)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
