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
configuration. Installing applies the release gate (:func:`release_gate`): the kept agent is
scored on the held-out suite and its plant's named cases, and one worse than its base in RMS
anywhere, in max beyond 1.05x, or in max at all on the plant's own parts is installed as its
base (``"kept": "base"``, the refusal and the refused agent's figures in ``agent.json``
``"release"``). ``scripts/residual_scorecard.py`` then scores them against their bases.

The shipped recipes stop on a training-time budget and validate every 30 s of training time, so
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
# unless given). Every agent is taught, then fine-tuned (issue 48): the teacher (ILC on top of
# the base in the agent's action space, agents/teacher.py) learns a correction on 120 training
# parts of the path families, the actor is fitted to it, the critic warmed and the replay
# buffer filled with its transitions, then SAC on 4 envs (the sac-4 preset) fine-tunes with a
# learning rate annealed 3e-4 -> 3e-5 over the time budget. The budget (10 minutes of
# training time, the teacher included) keeps a run within 15 minutes of wall time with its
# validations. The model kept is the checkpoint — the pretrained student at 0 timesteps
# first — no worse than the base on any validation part in RMS and in max, at least 10 %
# better on average, with the lowest mean ratio, or the base itself. The agent fades its gate
# outside the ranges it was trained on (agents/envelope.py). None trains on a named case or a
# held-out program: both are what the scorecard scores.
_RECIPE = dict(
    path_variety=("families",),
    algo="sac",
    n_envs=4,
    gradient_steps=2,
    timesteps=100_000_000,  # the time budget ends the run
    time_budget_s=600.0,
    eval_every_s=30.0,
    gate=True,
    learning_rate_final=3e-5,
    teacher="ilc-contour",
    teacher_parts=120,
    validation_paths=16,
)
SHIPPED = {
    # stiction, Coulomb friction and a random-phase disturbance; base: CCC, the best classical
    # controller on sharp-corner and corner-blend with the margin-checked defaults
    "friction-table": dict(_RECIPE, plant="friction-table", base="ccc", validation_paths=24),
    # Stribeck friction and force ripple; base: CCC, the best classical controller on
    # lm-circle3d (which it never trains on); authority 10 % of the force limit (the plant's
    # default: its static friction is 6.7 % of the limit)
    "linear-motor": dict(_RECIPE, plant="linear-motor", base="ccc"),
    # Lee 2012's HSM2; base: adaptive CCC, the best there
    "hsm2": dict(_RECIPE, plant="hsm2", base="adaptive-ccc"),
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


# the release criteria of a shipped agent (issue 48), on the held-out suite and the named cases
# of its plant: RMS at most the base's everywhere, max at most 1.05x (a tolerance is a max),
# and on the plant's own parts (5x its top training feed, corners off the axes) max at most 1.00x
RELEASE_MAX_RATIO = 1.05
RELEASE_OWN_MAX_RATIO = 1.0


def release_failures(card: dict) -> list[str]:
    """The rows of a scorecard (:func:`agents.rl.scorecard.scorecard`) that break the release
    criteria, as 'target: RMS r, max m' lines (empty: releasable)."""
    out = []
    plant = card["plant"]
    for r in card["rows"]:
        own = r["target"].startswith(f"{plant}/")
        limit = RELEASE_OWN_MAX_RATIO if own else RELEASE_MAX_RATIO
        rms, mx = r["rms_ratio"], r["max_ratio"]
        if rms is None or mx is None or rms > 1.0 or mx > limit:
            out.append(f"{r['target']}: RMS {rms}, max {mx} (limits 1.0, {limit})")
    return out


def release_gate(run_dir: Path, workers: int = 2) -> dict:
    """Score the run's kept agent on the held-out suite and its plant's named cases and apply
    the release criteria. An agent that breaks them is not released: the run's files are
    installed with ``"kept": "base"`` (its base runs alone, as when no checkpoint passes
    keep-best) and the refusal, with the refused agent's figures, in ``agent.json``
    (``"release"``). Returns the release record. The held-out suite decides only this yes or
    no, never which checkpoint or run is kept."""
    import json

    from agents.rl.scorecard import scorecard
    from contour_env.io import atomic_write_json

    meta_path = run_dir / "agent.json"
    meta = json.loads(meta_path.read_text())
    if meta.get("kept") == "base":
        return {"released": False, "reason": "keep-best kept the base"}
    card = scorecard(run_dir, workers=workers)
    failures = release_failures(card)
    record = {
        "released": not failures,
        "failures": failures,
        "heldout_mean_ratio": card["heldout_mean_ratio"],
        "heldout_max_mean_ratio": card["heldout_max_mean_ratio"],
        "heldout_worst_ratio": card["heldout_worst_ratio"],
        "heldout_max_worst_ratio": card["heldout_max_worst_ratio"],
    }
    if failures:
        record["refused_kept"] = meta.get("kept")
        record["refused_timesteps"] = meta.get("timesteps")
        meta["kept"] = "base"
    meta["release"] = record
    atomic_write_json(meta_path, meta)
    return record


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
        dest = install(Path(args.from_run), names[0])
        _say_release(release_gate(dest), names[0])
        print(f"installed {dest}")
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
            dest = install(out, name)
            _say_release(release_gate(dest), name)
            print(f"installed {dest}")
    return 0


def _say_release(record: dict, name: str) -> None:
    if record.get("released"):
        print(f"{name}: released (no held-out program or named case worse than the base)")
    elif record.get("failures"):
        print(f"{name}: NOT released, installed as its base; the agent broke:")
        for line in record["failures"]:
            print(f"  {line}")
    else:
        print(f"{name}: installed as its base ({record.get('reason')})")


if __name__ == "__main__":
    raise SystemExit(main())
