"""One run of a suite: a pure function of its spec (same spec, same figures, in any process).

:func:`execute` takes the spec as a plain dict (what crosses a process or a Ray task) and
returns ``{"spec", "plant", "metrics", "trace", "wall_s"}`` (the kinds: nominal, robustness,
ilc, design (:mod:`.design`), residual (:mod:`.residual`), circular (:mod:`.circular`)):
``metrics`` JSON-ready, ``trace`` arrays as lists for the figures (kept out of results.json);
a run that raised has ``error`` (the exception's type and message) and no metrics.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from .suite import CIRCULAR, DESIGN, ILC, NOMINAL, RESIDUAL_RUN, ROBUSTNESS, RunSpec

# points kept of a time trace for the figures
TRACE_POINTS = 1500


def _downsample(t, y, n: int = TRACE_POINTS):
    """Every k-th sample, keeping each block's largest |y| so that peaks survive."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    k = max(1, int(np.ceil(len(t) / n)))
    if k == 1:
        return t.tolist(), y.tolist()
    m = (len(t) // k) * k
    tb, yb = t[:m].reshape(-1, k), y[:m].reshape(-1, k)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        idx = np.nanargmax(np.where(np.isfinite(yb), np.abs(yb), -1.0), axis=1)
    rows = np.arange(tb.shape[0])
    return tb[rows, idx].tolist(), yb[rows, idx].tolist()


def _finite(x):
    x = float(x)
    return x if np.isfinite(x) else None


def _derived(plant: str, m: dict) -> dict:
    """Figures in the papers' own units: hsm2's x effort as a torque through the lead ℓ and its
    y force (Lee 2012 Table 3)."""
    if plant == "hsm2" and m.get("rms_effort"):
        from contour_env.plants.catalog import HSM2_LEAD_M_PER_RAD

        ex, ey = m["rms_effort"][:2]
        return {
            "rms_x_torque_Nm": None if ex is None else ex * HSM2_LEAD_M_PER_RAD,
            "rms_y_force_N": ey,
        }
    return {}


def _nominal(spec: RunSpec) -> dict:
    from agents.compare import compare

    metrics = tuple(spec.settings.get("metrics", ()))
    result = compare([spec.controller], seed=spec.seed, metrics=metrics, case=spec.case)
    row = dict(result["results"][0])
    row.pop("controller")
    row.update(_derived(result["plant"], row))
    record = result["records"][spec.controller]
    t, eps = _downsample(record.time, np.asarray(record.contour_error) * 1e6)
    return {
        "plant": result["plant"],
        "metrics": row,
        "trace": {"time_s": t, "contour_error_um": eps},
    }


def _robustness(spec: RunSpec) -> dict:
    import gymnasium as gym

    from agents.compare import robustness
    from contour_env import ENV_ID

    s = spec.settings
    row = robustness(
        [spec.controller],
        float(s["fraction"]),
        int(s["episodes"]),
        seed=spec.seed,
        traces=True,
        case=spec.case,
    )[0]
    traces = row.pop("traces")
    row.pop("controller")
    t = np.asarray(traces["time_s"])
    eps = np.asarray(traces["contour_error_m"]) * 1e6  # (n, episodes), NaN once stopped
    k = max(1, int(np.ceil(len(t) / 400)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        q = np.nanpercentile(eps[::k], [10, 50, 90], axis=1) if len(t) else np.zeros((3, 0))
        top = np.nanmax(eps[::k], axis=1) if len(t) else np.zeros(0)
    band = {
        "time_s": t[::k].tolist(),
        "p10_um": [_finite(v) for v in q[0]],
        "p50_um": [_finite(v) for v in q[1]],
        "p90_um": [_finite(v) for v in q[2]],
        "max_um": [_finite(v) for v in top],
    }
    plant = gym.make(ENV_ID, case=spec.case).unwrapped.setup.plant.name
    return {"plant": plant, "metrics": row, "trace": band}


def _ilc(spec: RunSpec) -> dict:
    import gymnasium as gym

    from agents import make_controller
    from agents.repeated_batch import run_batch
    from contour_env import ENV_ID
    from contour_env.metrics import encoder_resolution_um

    s = spec.settings
    kw = {}
    if s.get("condition") == "random":
        kw = {"disturbance_phase": "random", "measurement_noise_std_m": float(s["noise_m"])}
    env = gym.make(ENV_ID, case=spec.case, **kw)
    controller = make_controller(spec.controller, env=env).bind(env)
    result = run_batch(env, controller, int(s["iterations"]), seed=spec.seed, keep_trials=())
    rows = result["iterations"]
    first, last = rows[0], rows[-1]
    metrics = {
        "iterations": len(rows),
        "first_max_contour_error_um": first["max_contour_error_um"],
        "first_rms_contour_error_um": first["rms_contour_error_um"],
        "max_contour_error_um": last["max_contour_error_um"],
        "rms_contour_error_um": last["rms_contour_error_um"],
        # the trial rows do not carry it: the true plant's encoder count (as ilc_benchmark.py)
        "encoder_resolution_um": last.get("encoder_resolution_um")
        or encoder_resolution_um(env.unwrapped.plant.params.encoder_resolution_m),
        "diverged": result["diverged"],
        "completed": all(r["completed"] for r in rows),
        "max_contour_error_um_per_iteration": [r["max_contour_error_um"] for r in rows],
        "rms_contour_error_um_per_iteration": [r["rms_contour_error_um"] for r in rows],
    }
    return {"plant": result["plant"], "metrics": metrics, "trace": {}}


def _design(spec: RunSpec) -> dict:
    from .design import design

    s = spec.settings
    metrics = design(spec.case, spec.controller, float(s.get("mass_variation", 0.2)))
    return {"plant": spec.case, "metrics": metrics, "trace": {}}


def _residual(spec: RunSpec) -> dict:
    from .residual import residual_run

    plant, metrics = residual_run(spec.settings["model"], spec.settings["target"])
    return {"plant": plant, "metrics": metrics, "trace": {}}


def _circular(spec: RunSpec) -> dict:
    from .circular import run

    return run(spec.case, spec.controller, spec.settings, spec.seed)


_KINDS = {
    NOMINAL: _nominal,
    ROBUSTNESS: _robustness,
    ILC: _ilc,
    DESIGN: _design,
    RESIDUAL_RUN: _residual,
    CIRCULAR: _circular,
}


def execute(spec: dict) -> dict:
    """Run one spec (a :meth:`RunSpec.to_dict`); the result carries the spec back."""
    import contour_env  # noqa: F401  (registers the env in a fresh process)

    run = RunSpec.from_dict(spec)
    t0 = time.perf_counter()
    try:
        out = _KINDS[run.kind](run)
    except Exception as exc:  # a failed run is reported (and fails the command), not raised
        out = {"plant": None, "metrics": {}, "trace": {}, "error": f"{type(exc).__name__}: {exc}"}
    out["spec"] = run.to_dict()
    out["wall_s"] = time.perf_counter() - t0
    return out
