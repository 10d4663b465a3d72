"""Train the shipped residual agents (``agents/models/<plant>/``) exactly as they were made.

    python scripts/train_agents.py [--only linear-motor,friction-table,hsm2] [--work DIR]
        [--install]

Each agent is one ``contour-env train`` run with the configuration in :data:`SHIPPED` (seed 0,
one torch thread, this 2-core CPU); the run goes to ``--work/<plant>`` (default
``out/agents``) and, with ``--install``, its model files (``model.zip``, ``agent.json``,
``config.json``, ``normalization.json``, ``learning_curve.json``/``.png``) are copied to
``agents/models/<plant>/`` — checkpoints, replay buffers and TensorBoard logs are not
shipped. ``scripts/residual_benchmark.py`` then scores them against their bases.

Training is deterministic for the same machine, library versions and thread count (sb3 and
torch seeded by ``seed``); on another CPU the agent differs in its last digits and the figures
of the README move a little.
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
    "learning_curve.json",
    "learning_curve.png",
)
# shipped too when the run wrote them (validation runs): the keep-best record of each checkpoint
OPTIONAL_FILES = ("validation_curve.json", "validation_curve.png")

# one entry per shipped agent: TrainConfig keywords (everything else at its default)
SHIPPED = {
    # the friction and ripple of the linear motor across the x reversal of the inclined arc;
    # base: CCC, the best classical controller on lm-circle3d (contour-env compare)
    "linear-motor": dict(
        cases=("lm-circle3d",), base="ccc", algo="sac", timesteps=60_000, eval_freq=10_000
    ),
    # stiction at the exact-stop corner of the friction table; base: CCC, the best classical
    # controller on sharp-corner with the margin-checked defaults (contour-env compare). The
    # agent sees only the task-frame errors and also trains on random circles, so that it
    # does not spoil paths it was not trained on (README table)
    "friction-table": dict(
        cases=("sharp-corner",),
        path_variety=("circles",),
        observation="errors",
        residual_penalty=5.0,
        base="ccc",
        algo="sac",
        timesteps=60_000,
        eval_freq=20_000,
    ),
    # Lee 2012's circles on HSM2; base: adaptive CCC (the best there). Small authority and a
    # strong residual penalty: adaptive CCC is within a few encoder counts, and a larger
    # residual (scale 0.05, full observation: −19 to −25 % on the circles) made the 40 mm
    # square 14 times worse
    "hsm2": dict(
        cases=("hsm2-circle-I", "hsm2-circle-II", "hsm2-circle-III"),
        path_variety=("circles",),
        circle_radius_m=(0.02, 0.15),
        observation="errors",
        residual_penalty=10.0,
        scale=0.02,
        base="adaptive-ccc",
        algo="sac",
        timesteps=40_000,
        eval_freq=20_000,
    ),
}


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
    args = ap.parse_args(argv)
    names = [n for n in args.only.split(",") if n]
    unknown = [n for n in names if n not in SHIPPED]
    if unknown:
        raise SystemExit(f"--only: unknown {unknown}; known: {', '.join(SHIPPED)}")
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
