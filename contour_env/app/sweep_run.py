"""Run a sweep's trials (:mod:`contour_env.app.sweep`): one after another in this process, or as
Ray Tune trials (``--ray auto|ADDRESS``, one CPU per torch thread). Each trial is
:func:`run_trial`, a pure function of its arguments that never raises: a failed trial is a
record with ``status`` ``error``, the others go on. ``OUT/sweep.json`` is rewritten after every
finished trial (``"complete": false`` until the end) and lists the trials in the file's order,
so the figures are the same whichever way the trials ran.
"""

from __future__ import annotations

import os
import time
from dataclasses import asdict
from pathlib import Path

SWEEP_FORMAT = "contour_env.sweep/1"
# the trainer's summary figures a trial record carries
RECORD = ("name", "status", "error", "model", "wall_s")
FIGURES = (
    "timesteps",
    "kept",
    "kept_timesteps",
    "base_rms_contour_error_um",
    "final_rms_contour_error_um",
    "validation_rms_contour_error_um",
    "validation_base_rms_contour_error_um",
)


def check_ray(address) -> str | None:
    """``--ray``'s ``address`` checked: ``ValueError`` naming ``--ray`` when it is empty or
    Ray Tune is not installed."""
    from contour_env.app.benchmark.runner import check_ray as _check

    return _check(address, "ray.tune")


def run_trial(trial: dict) -> dict:
    """One trial (a :class:`~contour_env.app.sweep.Trial` as a dict): ``contour-env train``'s own
    function on its arguments; the record of :data:`FIGURES`, status and wall time."""
    from contour_env.app.cli_rl import train_from_args

    from .cli_rl import train_parser

    rec = {"name": trial["name"], "status": "error", "error": None, "model": trial["out"]}
    t0 = time.perf_counter()
    try:
        args = train_parser().parse_args(list(trial["argv"]))
        Path(trial["log"]).parent.mkdir(parents=True, exist_ok=True)
        with open(trial["log"], "a", encoding="utf-8") as fh:
            _, res = train_from_args(args, log=lambda s: print(s, file=fh, flush=True))
        rec.update({k: res.get(k) for k in FIGURES}, status="ok")
    except Exception as exc:  # recorded: a failed trial must not end the sweep
        rec["error"] = " ".join(f"{type(exc).__name__}: {exc}".split())
    rec["wall_s"] = round(time.perf_counter() - t0, 3)
    return {k: rec.get(k) for k in (*RECORD, *FIGURES)}


def _tune_trainable(config: dict) -> None:
    from ray import tune

    tune.report(run_trial(config["trial"]))


def _init_ray(address: str) -> bool:
    """Connects to (or starts) Ray; True when this call did."""
    import logging

    import ray

    if ray.is_initialized():
        return False
    kw = dict(log_to_driver=False, logging_level=logging.ERROR)
    if address == "auto":
        try:
            ray.init(address="auto", **kw)
        except ConnectionError:
            ray.init(include_dashboard=False, **kw)
    elif address == "local":
        ray.init(include_dashboard=False, **kw)
    else:
        ray.init(address=address, **kw)
    return True


def _last_line(exc) -> str:
    lines = [line for line in str(exc).splitlines() if line.strip()]
    return " ".join(lines[-1].split()) if lines else type(exc).__name__


def run_ray(sweep, address: str, done) -> dict:
    """Runs the trials with Ray Tune, ``done(record)`` as each ends; the failed Ray trials'
    errors by name."""
    import ray
    from ray import tune

    specs = {t.name: asdict(t) for t in sweep.trials}

    class Progress(tune.Callback):
        def on_trial_result(self, iteration, trials, trial, result, **info):
            done({k: result.get(k) for k in (*RECORD, *FIGURES)})

        def on_trial_error(self, iteration, trials, trial, **info):
            name = trial.config["trial"]["name"]
            done({"name": name, "status": "error", "error": "the Ray trial failed"})

    # Tune's legacy console reporter, silent at verbose 0 (the new one prints tables)
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    started = _init_ray(address)
    try:
        trainable = tune.with_resources(
            _tune_trainable, lambda config: {"cpu": max(1, int(config["trial"]["cpus"]))}
        )
        tuner = tune.Tuner(
            trainable,
            param_space={"trial": tune.grid_search(list(specs.values()))},
            tune_config=tune.TuneConfig(
                max_concurrent_trials=sweep.max_concurrent,
                trial_name_creator=lambda t: t.config["trial"]["name"],
                trial_dirname_creator=lambda t: t.config["trial"]["name"],
            ),
            run_config=tune.RunConfig(
                name="sweep",
                storage_path=str((sweep.out / "_ray").resolve()),
                verbose=0,
                callbacks=[Progress()],
            ),
        )
        grid = tuner.fit()
        # the exception of a failed Ray trial is known once the run has ended
        return {r.config["trial"]["name"]: _last_line(r.error) for r in grid if r.error is not None}
    finally:
        if started:
            ray.shutdown()


def run_sweep(sweep, ray: str | None = None) -> int:
    """Runs every trial of ``sweep`` and writes ``OUT``; 0 when all trials trained, else 1."""
    from contour_env.io import atomic_write_json, atomic_write_text

    out = sweep.out
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "sweep.yaml", sweep.text)
    executor = f"ray {ray}" if ray else "serial"
    records = {
        t.name: {"name": t.name, "options": t.options, "status": "pending", "model": t.out}
        for t in sweep.trials
    }
    t0 = time.perf_counter()

    def write(complete: bool) -> None:
        doc = {
            "format": SWEEP_FORMAT,
            "sweep": str(sweep.file),
            "out": str(out),
            "executor": executor,
            "complete": complete,
            "wall_s": round(time.perf_counter() - t0, 3),
            "trials": list(records.values()),
        }
        atomic_write_json(out / "sweep.json", doc)

    def done(rec: dict) -> None:
        name = rec["name"]
        records[name].update(rec)
        n = sum(r["status"] != "pending" for r in records.values())
        print(f"[{n}/{len(records)}] {name}: {_outcome(records[name])}", flush=True)
        write(complete=False)

    write(complete=False)
    print(f"sweep: {len(records)} trials ({executor}) into {out}", flush=True)
    if ray:
        for name, err in run_ray(sweep, ray, done).items():
            if records[name]["status"] != "ok":
                records[name].update(status="error", error=f"Ray: {err}")
    else:
        for t in sweep.trials:
            done(run_trial(asdict(t)))
    for rec in records.values():  # a trial Ray never reported
        if rec["status"] == "pending":
            rec.update(status="error", error="no result (the Ray trial did not report)")
    write(complete=True)
    bad = [r for r in records.values() if r["status"] != "ok"]
    print(
        f"sweep: {len(records) - len(bad)} ok, {len(bad)} error in "
        f"{time.perf_counter() - t0:.1f} s; wrote {out / 'sweep.json'}"
    )
    return 1 if bad else 0


def _outcome(rec: dict) -> str:
    if rec["status"] != "ok":
        return f"error: {rec.get('error')}"
    text = f"ok in {rec.get('wall_s', 0):.1f} s"
    val = rec.get("validation_rms_contour_error_um")
    base = rec.get("validation_base_rms_contour_error_um")
    if val is not None:
        return f"{text}, validation RMS contour error {val:.4g} µm (base {base:.4g} µm)"
    fin, base = rec.get("final_rms_contour_error_um"), rec.get("base_rms_contour_error_um")
    if fin is not None:
        return f"{text}, final RMS contour error {fin:.4g} µm (base {base:.4g} µm)"
    return text
