"""Compare controllers on one case with the project's one scoring function (Lee 2012 Tables 2
and 3 style), optionally over plant-parameter variations with the vectorised env."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from contour_env import ENV_ID
from contour_env.env.rollout import is_five_axis_env
from contour_env.evaluation import run_episode
from contour_env.metrics import check_metrics, format_um, score
from contour_env.plants.randomize import randomized

from .parameters import ControllerSpec
from .registry import make_controller, parse_spec

CVAR_FRACTION = 0.10
# the row name of a trained residual agent (``model``: a model DIR, or the shipped agent)
RESIDUAL = "residual"


def comparable_names() -> list[str]:
    """Names ``compare`` accepts: every fixed controller of the registry and ``residual``."""
    from .registry import all_controller_names

    return [*all_controller_names(), RESIDUAL]


def check_controllers(specs: list[str | ControllerSpec]) -> list[ControllerSpec]:
    """The parsed records (:func:`agents.registry.parse_spec`) of ``specs`` (names or variants
    such as ``ccc:wp=3e4``, or records), one each in order; ``ValueError`` for an unknown
    name, a malformed or unknown parameter, or a value the controller's constructor refuses,
    in any of them — before anything is run. ``residual`` takes no parameters."""
    if not specs:
        raise ValueError(f"controllers: none given; known: {', '.join(comparable_names())}")
    records = []
    for text in specs:
        spec = parse_spec(text, agent_names=(RESIDUAL,), parameter="controllers")
        if spec.name != RESIDUAL:
            make_controller(spec)  # the values its constructor refuses
        records.append(spec)
    return records


def bound_controller(name: str | ControllerSpec, env, model=None):
    """``name`` (a controller name or variant such as ``ccc:wp=3e4``, or its parsed record)
    bound to ``env``, the class of the env's plant family (``pd`` on the five-axis plant is
    Chen 2022's joint PD); ``residual`` is the agent in ``model`` (a model DIR written by
    ``contour-env train``) or, without one, the shipped agent for the env's plant
    (``ValueError`` when there is none, or when the agent was trained for another plant or
    number of axes)."""
    spec = name if isinstance(name, ControllerSpec) else check_controllers([name])[0]
    if spec.name != RESIDUAL:
        return make_controller(spec, env=env).bind(env)
    from contour_env.env.core import core_of

    from .residual import ResidualAgent
    from .rl.models import shipped_model_for

    _, core = core_of(env)
    model_dir = model if model is not None else shipped_model_for(core.setup.plant.name)
    return ResidualAgent(model_dir).bind(env)


def compare(
    controllers: list[str],
    *,
    seed: int = 0,
    progress=None,
    model=None,
    metrics=(),
    **env_kwargs,
) -> dict:
    """Run every controller on the same env; an unstable one is reported, not raised.
    ``controllers``: names or variants (``"ccc:wp=3e4:wd=20"``, :mod:`agents.parameters`);
    each row's ``controller`` is the string as given. Every spec is checked before anything
    runs. ``model``: the model DIR of the ``residual`` row (default: the shipped agent).
    ``metrics``: extra metrics of :func:`contour_env.metrics.score` (``("total",)``: Chen &
    Lee 2020's total contour error, ``total_contour_error_um``).

    Returns {"case": ..., "plant": ..., "results": [{"controller", "stable", metrics...}],
    "records": {name: EpisodeRecord}} (records are for plotting; not JSON).
    """
    specs = check_controllers(list(controllers))  # each string parsed here, once
    metrics = check_metrics(metrics)  # an unknown metric is an error before any run
    results, records = [], {}
    setup = None
    # bind every controller first: a gain or plant it cannot work with (jee-ccc on a force
    # drive, a per-axis value of the wrong length) is an error before any row has run
    bound = []
    # one env serves every fixed controller (each run resets it with the same seed; building
    # the env is a large part of a compiled run's time); a residual agent gets its own
    shared = None
    for spec in specs:
        if spec.name == RESIDUAL:
            env = gym.make(ENV_ID, **env_kwargs)
        else:
            shared = shared or gym.make(ENV_ID, **env_kwargs)
            env = shared
        bound.append((spec.label, env, bound_controller(spec, env, model)))
    for name, env, controller in bound:
        setup = env.unwrapped.setup
        record = run_episode(env, controller, seed=seed)  # five-axis: with orientation error
        m = score(record, metrics=metrics)
        row = {"controller": name, "stable": record.completed, **m}
        if getattr(controller, "is_base", False):
            # no checkpoint beat the base on validation: the agent is its base (zero residual)
            row["agent_is_base"] = True
            row["agent_base"] = controller.base_name
            row["agent_base_reason"] = controller.base_reason()
        share = getattr(controller, "outside_envelope_fraction", None)
        if callable(share) and share() is not None:
            # the share of the agent's decisions outside the ranges it was trained on
            row["outside_envelope_fraction"] = float(share())
        results.append(row)
        records[name] = record
        if progress:
            progress(name, row)
    return {"case": setup.name, "plant": setup.plant.name, "results": results, "records": records}


def check_randomizable(**env_kwargs):
    """The env of ``env_kwargs`` (unwrapped) if its plant takes plant variations (the feed-drive
    plants); ValueError saying why not for the five-axis plant."""
    probe = gym.make(ENV_ID, **env_kwargs).unwrapped
    if is_five_axis_env(probe):
        raise ValueError(
            "randomize: plant variations are not implemented for the five-axis plant (its "
            "parameters are masses, inertias and offsets of a coupled model, not per-axis "
            "drives); compare it on the nominal plant and with --ideal"
        )
    return probe


def robustness(
    controllers: list[str],
    fraction: float,
    episodes: int,
    *,
    seed: int = 0,
    progress=None,
    model=None,
    traces: bool = False,
    **env_kwargs,
) -> list[dict]:
    """Each controller over ``episodes`` true-plant variations (every per-axis parameter of
    :data:`contour_env.plants.randomize.RANDOMIZED_FIELDS` scaled by U[1 − f, 1 + f]), run as
    one vectorised env; the controllers keep the nominal model. Reports the mean and the
    CVaR of the worst 10 % of RMS contour error, the worst max contour error and the failure
    rate (episodes stopped by the crash guard). ``controllers``: names or variants, as
    :func:`compare`.

    Each row also has lists with one entry per variation, in episode order:
    ``rms_contour_error_um_per_episode``, ``max_contour_error_um_per_episode`` (both µm) and
    ``failed_per_episode``. With ``traces=True`` a row has ``traces`` too (for plots; numpy
    arrays, not JSON):
    ``{"time_s": (n,), "contour_error_m": (n, episodes)}``, ε after each step, NaN once a
    variation has stopped or where ε is not finite."""
    specs = check_controllers(list(controllers))  # each string parsed here, once
    probe = check_randomizable(**env_kwargs)
    variants = randomized(probe.plant.params, fraction, episodes, seed=seed)
    rows = []
    for spec in specs:
        name = spec.label
        venv = gym.make_vec(
            ENV_ID,
            num_envs=episodes,
            vectorization_mode="vector_entry_point",
            plant_params=variants,
            **env_kwargs,
        )
        controller = bound_controller(spec, venv, model)
        obs, _ = venv.reset(seed=seed)
        core = venv.core if hasattr(venv, "core") else venv.unwrapped.core
        n = core.n_steps - 1
        running = np.ones(episodes, dtype=bool)
        failed = np.zeros(episodes, dtype=bool)
        sq = np.zeros(episodes)
        peak = np.zeros(episodes)
        count = np.zeros(episodes)
        trace = np.full((n, episodes), np.nan) if traces else None
        steps = 0
        fast = _run_batch_compiled(venv, controller, sq, peak, count, failed, trace)
        if fast is not None:
            steps = fast
        for i in range(n if fast is None else 0):
            action, _ = controller.predict(obs)
            obs, _, term, trunc, info = venv.step(action)
            eps = np.where(np.isfinite(info["contour_error"]), info["contour_error"], np.inf)
            if trace is not None:
                trace[i] = np.where(running & np.isfinite(eps), eps, np.nan)
            steps = i + 1
            sq[running] += np.minimum(eps[running], 1e3) ** 2
            peak[running] = np.maximum(peak[running], eps[running])
            count[running] += 1
            failed |= running & term
            running &= ~(term | trunc)
            if not running.any():
                break
        rms = np.sqrt(sq / np.maximum(count, 1)) * 1e6
        worst = np.sort(rms)[::-1][: max(1, int(round(CVAR_FRACTION * episodes)))]
        row = {
            "controller": name,
            "episodes": episodes,
            "randomize": fraction,
            "mean_rms_contour_error_um": float(np.mean(rms)),
            "cvar10_rms_contour_error_um": float(np.mean(worst)),
            "worst_max_contour_error_um": float(np.max(np.minimum(peak, 1e3)) * 1e6),
            "failure_rate": float(np.mean(failed)),
            "rms_contour_error_um_per_episode": [float(x) for x in rms],
            "max_contour_error_um_per_episode": [float(x) for x in np.minimum(peak, 1e3) * 1e6],
            "failed_per_episode": [bool(x) for x in failed],
        }
        if trace is not None:
            row["traces"] = {
                "time_s": np.arange(1, steps + 1) * core.T,
                "contour_error_m": trace[:steps],
            }
        rows.append(row)
        if progress:
            progress(name, row)
    return rows


# opt in to the compiled robustness loop (see _run_batch_compiled)
BATCH_ENV_VAR = "CONTOUR_ENV_COMPILED_BATCH"


def _run_batch_compiled(venv, controller, sq, peak, count, failed, trace) -> int | None:
    """The robustness loop compiled (every variant's episode on its own thread; the same
    sums, to the bit, as the Python loop), from the reset state of ``venv``; returns the
    number of steps the longest episode ran, or None (nothing done) when the controller has no
    compiled form or the env is wrapped. ``CONTOUR_ENV_COMPILED=0`` keeps the Python loop.

    Opt-in (``CONTOUR_ENV_COMPILED_BATCH=1``): the parallel loop takes about two minutes to
    compile on a fresh checkout (then it is cached), longer than the Python loop needs for a
    typical ``--randomize`` run."""
    import os

    from contour_env.env import rollout

    if os.environ.get(BATCH_ENV_VAR, "0") != "1":
        return None
    if not rollout.compiled_allowed() or rollout.plain_vector_env(venv) is None:
        return None
    form = rollout.compiled_form_of(controller)
    if form is None:
        return None
    core = venv.core
    B = core.n_envs
    bad = np.zeros(B, dtype=np.int64)
    lengths = np.zeros(B, dtype=np.int64)
    trace_arr = trace if trace is not None else np.empty((0, B))
    form.run_batch(core, sq, peak, count, failed, bad, trace_arr, lengths)
    if bad.any():
        b = int(np.argmax(bad))
        raise ValueError(
            f"action: must be finite, got {core.action[b].tolist()} (env {b}); the action is "
            "the per-axis command in [-1, 1] of the force limit"
        )
    return int(lengths.max(initial=0))


def robustness_compiled_steps(spec: str, n_envs: int, **env_kwargs) -> tuple[int, float]:
    """(env-steps, seconds) of one compiled robustness batch of ``spec`` over ``n_envs``
    ±10 % plant variants (for the benchmark; the loop is compiled / loaded first)."""
    import time

    from contour_env.env import rollout

    probe = gym.make(ENV_ID, **env_kwargs).unwrapped
    variants = randomized(probe.plant.params, 0.1, n_envs, seed=0)
    venv = gym.make_vec(
        ENV_ID,
        num_envs=n_envs,
        vectorization_mode="vector_entry_point",
        plant_params=variants,
        **env_kwargs,
    )
    controller = make_controller(spec, env=venv).bind(venv)
    B = n_envs
    for timed in (False, True):
        venv.reset(seed=0)
        controller.reset()
        form = rollout.compiled_form_of(controller)
        args = (np.zeros(B), np.zeros(B), np.zeros(B), np.zeros(B, dtype=bool))
        lengths = np.zeros(B, dtype=np.int64)
        t0 = time.perf_counter()
        form.run_batch(venv.core, *args, np.zeros(B, dtype=np.int64), np.empty((0, B)), lengths)
        dt = time.perf_counter() - t0
        if timed:
            return int(lengths.sum()), dt
    raise AssertionError("unreachable")


def significant(x: float, digits: int = 3) -> str:
    """``x`` with ``digits`` significant digits in plain notation (``0.00100``, ``1.23``,
    ``1000``); scientific below 10⁻³ and from 10⁵ on."""
    if x == 0 or not np.isfinite(x):
        return f"{x:g}"
    if not 1e-3 <= abs(x) < 1e5:
        return f"{x:.{digits - 1}e}"
    r = float(f"{x:.{digits}g}")  # rounded first: 9.996 → 10.0, not 10.00
    decimals = digits - 1 - int(np.floor(np.log10(abs(r))))
    return f"{r:.{max(decimals, 0)}f}"


def _reference_row(rows: list[dict]) -> dict | None:
    """The row the RMS ratio is taken to: ``pd`` when it is among the rows, else the first."""
    return next((r for r in rows if r["controller"] == "pd"), rows[0] if rows else None)


def format_table(comparison: dict, robust: list[dict] | None = None) -> str:
    """Lee 2012 Tables 2 and 3 layout: max/RMS contour error (µm), the RMS ratio to PD (or, with
    no ``pd`` row, to the first row; 3 significant digits), Chen & Lee 2020's total contour
    error (mm, their unit) where the rows have it, RMS effort per axis. An error
    below one encoder count prints as ``≤R (enc)`` (R the coarsest axis's count, µm)."""
    rows = comparison["results"]
    ref = _reference_row(rows)
    ref_rms = (
        ref.get("rms_contour_error_um")
        if ref is not None and (ref["stable"] or ref.get("termination_reason") is None)
        else None
    )
    ref_name = "pd" if ref is None else ref["controller"]
    ref_label = "RMS/PD" if ref_name == "pd" else f"RMS/{ref_name}"
    names = [r["controller"] for r in rows] + [r["controller"] for r in robust or []]
    w = max([14, *(len(n) + 2 for n in names)])
    rw = max(10, len(ref_label) + 2)
    # Chen & Lee 2020's total contour error, in their unit (mm), where the run asked for it
    total = any("total_contour_error_um" in r for r in rows)
    # five-axis runs: ε is the tool-tip contour error, and the orientation error θ follows
    orient = any("rms_orientation_error_arcsec" in r for r in rows)
    head_o = f"{'max θ ″':>11s}{'RMS θ ″':>11s}" if orient else ""
    lines = [
        f"case {comparison['case']} (plant {comparison['plant']})",
        f"{'controller':{w}s}{'max ε µm':>12s}{'RMS ε µm':>12s}{ref_label:>{rw}s}"
        f"{'total ε mm' if total else '':>{14 if total else 0}s}{head_o}"
        f"{'  RMS effort per axis':s}",
    ]
    for r in rows:
        # a run that was not stopped but did not follow the program (e.g. it ended more than
        # 1 mm from the end point) keeps its figures, flagged; a stopped one has none
        incomplete = not r["stable"] and r.get("termination_reason") is None
        if not r["stable"] and not (incomplete and r.get("rms_contour_error_um") is not None):
            lines.append(
                f"{r['controller']:{w}s}  UNSTABLE ({r['termination_reason']} after "
                f"{r['n_steps']} steps)"
            )
            continue
        rms = r["rms_contour_error_um"]
        ratio = significant(rms / ref_rms) if ref_rms and rms is not None else ""
        effort = ", ".join(f"{e:.4g}" for e in r["rms_effort"])
        res = r.get("encoder_resolution_um")
        tot = ""
        if total:
            t = r.get("total_contour_error_um")
            tot = f"{t * 1e-3:14.4g}" if t is not None else f"{'n/a':>14s}"
        ori = ""
        if orient:
            ori = "".join(
                f"{v:11.2f}" if v is not None else f"{'n/a':>11s}"
                for v in (
                    r.get("max_orientation_error_arcsec"),
                    r.get("rms_orientation_error_arcsec"),
                )
            )
        lines.append(
            f"{r['controller']:{w}s}{format_um(r['max_contour_error_um'], res, '.1f'):>12s}"
            f"{format_um(rms, res, '.2f'):>12s}{ratio:>{rw}s}{tot}{ori}  [{effort}]"
            + (f"  (incomplete: {r.get('incomplete_reason')})" if incomplete else "")
        )
    if robust:
        lines.append("")
        lines.append(
            f"robustness: {robust[0]['episodes']} plant variations, "
            f"±{robust[0]['randomize'] * 100:.0f} %"
        )
        lines.append(
            f"{'controller':{w}s}{'mean RMS ε':>12s}{'CVaR10 RMS ε':>14s}"
            f"{'worst max ε':>13s}{'failures':>10s}"
        )
        for r in robust:
            lines.append(
                f"{r['controller']:{w}s}{r['mean_rms_contour_error_um']:12.2f}"
                f"{r['cvar10_rms_contour_error_um']:14.2f}"
                f"{r['worst_max_contour_error_um']:13.1f}{r['failure_rate']:10.1%}"
            )
    return "\n".join(lines)
