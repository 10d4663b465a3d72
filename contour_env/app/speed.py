"""Throughput benchmark: single-env steps/s and vectorised env-steps/s, with Gymnasium's
CartPole-v1 measured in the same run as the yardstick.

A shared machine's speed drifts by tens of per cent from second to second. So each figure is
the median of ``repeats`` timing windows, and the windows of contour_env and of CartPole
alternate: both see the same machine. Every window of contour_env covers whole episodes
(start-up, cruise, reversals, stop), so no phase of the motion is over- or under-sampled. The
JSON report keeps every window's rate, and each figure's ratio to CartPole
(``single_ratio_to_cartpole``; ``ratio_to_cartpole`` in a vector or the contended row): the
median of the ratios of the window pairs, so a drift of the machine between pairs cancels.
``scripts/check_speed_regression.py`` compares these ratios with the figures recorded in
``docs/bench_reference.json``.

A window lasts ``seconds / repeats`` or one whole episode, whichever is longer: at 4096 envs
one episode of the default case is 8 M env-steps, so the full benchmark takes a minute or
more whatever ``seconds`` says. ``quick=True`` (``contour-env bench --quick``) is a first
look in well under 30 s: one window per figure, 0.3 s, 1, 64 and 1024 envs.

After the tracking rows come three more (at 4096 envs; 1024 with ``quick``):

- exploration: the same envs driven by uniform random actions in [-1, 1] (what an RL agent
  sends early in training: guard terminations and resets) and by small random actions
  (±0.01, a random walk around standstill), each with its ratio to tracking: every
  exploration window follows a tracking window on the same envs and the ratio is the median
  of the pairs' ratios (the machine's drift between the rows cancels);
- contended: the tracking row again while a second process spins on the CPU (the benchmark
  starts ``python -c "while True: pass"`` itself and kills it afterwards, whatever happens),
  CartPole alternating as before, with the ratio to the quiet row;
- controller in the loop: the rows of ``contour_env.app.speed_controllers.controller_rates`` (a
  controller computing each action from the env's signals, single env and 4096 envs) with the
  ratio to the env's own single-env rate; skipped with a note where that module is missing.
"""

from __future__ import annotations

import os
import platform
import statistics
import subprocess
import sys
import time

import gymnasium as gym
import numpy as np

from .. import DEFAULT_CASE, ENV_ID

VECTOR_SIZES = (1, 64, 1024, 4096)
DEFAULT_REPEATS = 5
DEFAULT_SECONDS = 2.0
# --quick: one short window per figure, no 4096-env figure (its one episode alone is 8 M steps)
QUICK_SIZES = (1, 64, 1024)
QUICK_REPEATS = 1
QUICK_SECONDS = 0.3
# the exploration and contended rows: at this many envs (quick: the largest quick size)
EXTRA_ENVS = 4096
QUICK_EXTRA_ENVS = 1024
SMALL_ACTION = 0.01


def _time_single(env, actions: np.ndarray, min_seconds: float) -> float:
    # whole passes over ``actions`` (an episode for contour_env) until min_seconds have passed
    env.reset(seed=0)

    def one_pass():
        for a in actions:
            _, _, term, trunc, _ = env.step(a)
            if term or trunc:
                env.reset()

    n_done, elapsed = _timed_passes(one_pass, len(actions), min_seconds)
    return n_done / elapsed


def _time_vector(venv, actions: np.ndarray, min_seconds: float) -> float:
    venv.reset(seed=0)

    def one_pass():
        for a in actions:
            venv.step(a)

    n_done, elapsed = _timed_passes(one_pass, len(actions), min_seconds)
    return n_done * venv.num_envs / elapsed


def _timed_passes(one_pass, steps_per_pass: int, min_seconds: float) -> tuple[int, float]:
    # ``one_pass()`` again and again until min_seconds have passed: (steps done, seconds taken)
    n_done = 0
    t0 = time.perf_counter()
    while True:
        one_pass()
        n_done += steps_per_pass
        elapsed = time.perf_counter() - t0
        if elapsed >= min_seconds:
            return n_done, elapsed


def _alternate(ours, yardstick, repeats: int) -> tuple[list[float], list[float]]:
    # the two timings in turns, so that a slow spell of the machine hits both
    a, b = [], []
    for _ in range(repeats):
        a.append(ours())
        b.append(yardstick())
    return a, b


def pair_ratios(ours: list[float], theirs: list[float]) -> list[float]:
    """The ratio of each window to the yardstick's window timed right after it."""
    return [a / b for a, b in zip(ours, theirs, strict=True)]


def machine_description() -> dict:
    """What the figures were measured on: processor, cores, OS, Python and the libraries that
    set the speed."""
    import numba

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cpu_count": os.cpu_count(),
        "system": f"{platform.system()} {platform.release()} {platform.machine()}",
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "gymnasium": gym.__version__,
    }


def _code_version() -> dict:
    from .benchmark.report import code_version

    return code_version()


def _load_average() -> list[float] | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):  # not on every platform
        return None


def start_busy_process() -> subprocess.Popen:
    """A second process that keeps one core busy (a spinning Python loop), for the contended
    row; the caller kills it (:func:`stop_busy_process`)."""
    return subprocess.Popen(
        [sys.executable, "-c", "while True: pass"],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def stop_busy_process(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.kill()
    proc.wait()


def _vector_rows(case, n, actions, rng, window, repeats):
    # the envs and action arrays of one vector size: tracking (the servo's commands with a
    # small seeded perturbation per env), CartPole's random actions
    dim = actions.shape[1]
    steps = len(actions)  # whole episodes: start-up, cruise, reversals, stop
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", case=case)
    acts = (actions[:steps, None, :] * (1.0 + 0.01 * rng.standard_normal((steps, n, dim)))).astype(
        np.float32
    )
    _time_vector(venv, acts[:5], 0.0)
    cvenv = gym.make_vec("CartPole-v1", num_envs=n, vectorization_mode="vector_entry_point")
    cacts = rng.integers(0, 2, (min(steps, 500), n))

    def track():
        return _time_vector(venv, acts, window)

    def measure():
        ours, theirs = _alternate(
            track,
            lambda: _time_vector(cvenv, cacts, window),
            repeats,
        )
        ratios = pair_ratios(ours, theirs)
        return {
            "num_envs": n,
            "env_steps_per_s": statistics.median(ours),
            "cartpole_env_steps_per_s": statistics.median(theirs),
            "ratio_to_cartpole": statistics.median(ratios),
            "env_steps_per_s_runs": ours,
            "cartpole_env_steps_per_s_runs": theirs,
            "ratio_to_cartpole_runs": ratios,
        }

    return venv, cvenv, measure, track


def tracking_actions(case: str, n_steps: int, bandwidth_rad_s: float = 60.0) -> np.ndarray:
    """Actions of a simple tracking servo (nominal-model feedforward + PD on the measured
    position, critically damped at ``bandwidth_rad_s``) recorded on one episode of ``case``:
    the command sequence a controller actually sends, so the benchmark exercises the plant as
    it runs in use (moving along the path, reversals at the quadrants), not a random walk
    around standstill."""
    env = gym.make(ENV_ID, case=case).unwrapped
    env.reset(seed=0)
    nominal = env.plant.nominal
    m, b = nominal.mass_kg, nominal.viscous_Ns_m
    limit = env.plant.params.force_limit_N
    kp, kd = bandwidth_rad_s**2, 2.0 * bandwidth_rad_s
    out = np.zeros((n_steps, env.core.dim), dtype=np.float32)
    for k in range(n_steps):
        s = env.signals()
        e = s["reference_position"] - s["measured_position"]
        de = s["reference_velocity"] - s["measured_velocity"]
        u = m * (s["reference_acceleration"] + kp * e + kd * de) + b * s["reference_velocity"]
        out[k] = np.clip(u / limit, -1.0, 1.0)
        _, _, term, trunc, _ = env.step(out[k])
        if term or trunc:
            env.reset(seed=0)
    return out


def run_bench(
    case: str = DEFAULT_CASE,
    *,
    seconds: float | None = None,
    sizes=None,
    repeats: int | None = None,
    quick: bool = False,
    extra_envs: int | None = None,
    controllers: bool = True,
    progress=None,
) -> dict:
    """Measure throughput with the actions of :func:`tracking_actions` replayed (the policy's
    own cost is not part of the measurement, as for CartPole's random actions).

    ``seconds``: measuring time per figure, split into ``repeats`` alternating windows (each
    at least one whole episode); the figure is the median window rate. ``sizes``: the vector
    env sizes. Defaults: 2 s, 5 windows, 1/64/1024/4096 envs; with ``quick`` 0.3 s, one
    window, 1/64/1024 envs (an explicit argument still wins). ``extra_envs``: the vector size
    of the exploration and contended rows (default 4096; 1024 with ``quick``; 0: no such rows).
    ``controllers``: add the controller-in-the-loop rows (where contour_env.app.speed_controllers
    exists).
    """
    import contour_env  # noqa: F401  (registers the env)

    seconds, repeats, sizes = _settings(quick, seconds, repeats, sizes)
    window = seconds / repeats
    rng = np.random.default_rng(0)
    out = _bench_header(case, seconds, repeats, quick)
    env = gym.make(ENV_ID, case=case)
    actions = tracking_actions(case, env.unwrapped.core.n_steps - 1)
    out.update(_single_rows(env, actions, rng, window, repeats))
    if progress:
        progress(
            f"single env: {out['single_env_steps_per_s']:,.0f} steps/s "
            f"(CartPole {out['cartpole_single_steps_per_s']:,.0f}; "
            f"ratio {out['single_ratio_to_cartpole']:.2f})"
        )
    if extra_envs is None:
        extra_envs = QUICK_EXTRA_ENVS if quick else EXTRA_ENVS
    _vector_figures(
        out, case, actions, rng, window, repeats, list(sizes), int(extra_envs), progress
    )
    if controllers:
        out["controllers"], out["controllers_note"] = _controller_rows(
            quick, out["single_env_steps_per_s"]
        )
    else:
        out["controllers"], out["controllers_note"] = (
            [],
            "controller-in-the-loop rows not asked for",
        )
    # the commit measured (taken last: ``git`` in a child process, nothing the timing needs)
    out["code"] = _code_version()
    if progress:
        _report_controllers(out, progress)
    return out


def _settings(quick: bool, seconds, repeats, sizes) -> tuple:
    # (seconds, repeats, sizes): the defaults (quick's with ``quick``) where None, checked
    if seconds is None:
        seconds = QUICK_SECONDS if quick else DEFAULT_SECONDS
    if repeats is None:
        repeats = QUICK_REPEATS if quick else DEFAULT_REPEATS
    if sizes is None:
        sizes = QUICK_SIZES if quick else VECTOR_SIZES

    if not (isinstance(repeats, int) and repeats >= 1):
        raise ValueError(f"repeats: must be an integer >= 1, got {repeats!r}")
    if not seconds > 0:
        raise ValueError(f"seconds: must be > 0, got {seconds!r}")
    return seconds, repeats, sizes


def _bench_header(case: str, seconds: float, repeats: int, quick: bool) -> dict:
    # what was measured, how, and on what machine (the report's first keys)
    return {
        "case": case,
        "action": "recorded commands of a feedforward + PD tracking servo, replayed",
        "statistic": f"median of {repeats} windows alternating with CartPole-v1's",
        "repeats": repeats,
        "seconds": seconds,
        "quick": bool(quick),
        "python": platform.python_version(),
        "cpu_count": os.cpu_count(),
        "machine": machine_description(),
        "started": time.strftime("%Y-%m-%d %H:%M:%S %z"),
        # the machine's load when the run started (1, 5, 15 min): a figure taken on a busy
        # machine is not a reference (scripts/check_speed_regression.py --update refuses it)
        "load_average_at_start": _load_average(),
    }


def _single_rows(env, actions, rng, window, repeats) -> dict:
    # the single-env figure, its windows alternating with CartPole's random actions
    _time_single(env, actions[:200], 0.0)  # compile / warm up
    cp = gym.make("CartPole-v1")
    cp_actions = rng.integers(0, 2, 2000)
    ours, theirs = _alternate(
        lambda: _time_single(env, actions, window),
        lambda: _time_single(cp, cp_actions, window),
        repeats,
    )
    ratios = pair_ratios(ours, theirs)
    return {
        "single_env_steps_per_s": statistics.median(ours),
        "cartpole_single_steps_per_s": statistics.median(theirs),
        "single_ratio_to_cartpole": statistics.median(ratios),
        "single_env_steps_per_s_runs": ours,
        "cartpole_single_steps_per_s_runs": theirs,
        "single_ratio_to_cartpole_runs": ratios,
    }


def _vector_figures(out, case, actions, rng, window, repeats, sizes, extra_n, progress) -> None:
    # out["vector"]: a row per size of ``sizes``; at ``extra_n`` envs (< 1: none) also
    # out["exploration"] and out["contended"]
    out["vector"] = []
    for n in sizes + ([] if extra_n in sizes or extra_n < 1 else [extra_n]):
        venv, cvenv, measure, track = _vector_rows(case, n, actions, rng, window, repeats)
        try:
            row = measure()
            if n in sizes:
                out["vector"].append(row)
                if progress:
                    progress(_vector_line(f"vector {n:5d} envs", row))
            if n != extra_n:
                continue
            out["exploration"] = _exploration(venv, track, len(actions), rng, window, repeats)
            if progress:
                for r in out["exploration"]:
                    progress(
                        f"{r['label']} {n} envs: {r['env_steps_per_s']:,.0f} env-steps/s "
                        f"(ratio to tracking {r['ratio_to_tracking']:.2f})"
                    )
            out["contended"] = _contended(measure, quiet=row)
            if progress:
                progress(
                    _vector_line(f"contended {n} envs", out["contended"])
                    + f"; ratio to quiet {out['contended']['ratio_to_quiet']:.2f}"
                )
        finally:
            venv.close()
            cvenv.close()


def _contended(measure, quiet: dict) -> dict:
    # ``measure()`` again while a second process spins on the CPU, with its ratio to ``quiet``
    busy = start_busy_process()
    try:
        time.sleep(0.1)
        row = measure()
    finally:
        stop_busy_process(busy)
    row["ratio_to_quiet"] = row["env_steps_per_s"] / quiet["env_steps_per_s"]
    row["cartpole_ratio_to_quiet"] = (
        row["cartpole_env_steps_per_s"] / quiet["cartpole_env_steps_per_s"]
    )
    row["contention"] = "a second process spinning on the CPU"
    return row


def _report_controllers(out: dict, progress) -> None:
    if out["controllers"]:
        for r in out["controllers"]:
            progress(
                f"{r['name']}: {r['steps_per_s']:,.0f} "
                f"(ratio to the env's single-env rate {r['ratio_to_env']:.2f})"
            )
    else:
        progress(out["controllers_note"])


def _vector_line(label: str, row: dict) -> str:
    runs = row["env_steps_per_s_runs"]
    return (
        f"{label}: {row['env_steps_per_s']:,.0f} env-steps/s "
        f"(windows {min(runs):,.0f}–{max(runs):,.0f}; "
        f"CartPole {row['cartpole_env_steps_per_s']:,.0f}; "
        f"ratio {row['ratio_to_cartpole']:.2f})"
    )


def _exploration(venv, track, steps, rng, window, repeats) -> list:
    # random actions instead of the servo's: uniform over the whole range (guard terminations
    # and autoresets), and small (a random walk around standstill). No phase of the episode to
    # cover here, so a window is ``window`` seconds of passes over 500 steps. Each window comes
    # right after a tracking window (whole episodes, as the tracking row) on the same envs, and
    # the ratio is the median of the window pairs' ratios: a slow spell of the machine hits both
    # sides of a pair, where the tracking row itself was timed a minute earlier.
    steps = min(steps, 500)
    n = venv.num_envs
    dim = venv.single_action_space.shape[0]
    rows = []
    for label, amp in (("uniform random actions", 1.0), ("small random actions", SMALL_ACTION)):
        acts = rng.uniform(-amp, amp, (steps, n, dim)).astype(np.float32)
        tracked, runs = _alternate(
            track, lambda acts=acts: _time_vector(venv, acts, window), repeats
        )
        rows.append(
            {
                "label": label,
                "amplitude": amp,
                "num_envs": n,
                "env_steps_per_s": statistics.median(runs),
                "env_steps_per_s_runs": runs,
                "tracking_env_steps_per_s_runs": tracked,
                "ratio_to_tracking": statistics.median(
                    r / t for r, t in zip(runs, tracked, strict=True)
                ),
            }
        )
    return rows


def _controller_rows(quick: bool, single_rate: float) -> tuple[list, str]:
    # controller-in-the-loop figures from contour_env.app.speed_controllers, where present
    try:
        from .speed_controllers import controller_rates
    except ImportError as e:
        return [], f"controller-in-the-loop rows skipped ({e})"
    rows = [
        {"name": name, "steps_per_s": float(rate), "ratio_to_env": float(rate) / single_rate}
        for name, rate in controller_rates(quick)
    ]
    return rows, "ratio: to the env's own single-env steps/s"


def format_bench(res: dict) -> str:
    def spread(runs):
        return f"{min(runs) / 1e6:.2f}–{max(runs) / 1e6:.2f} M" if runs else ""

    def ratio(value):
        # the median of the windows' ratios to CartPole's (absent from older reports)
        return f"{value:8.2f}" if value is not None else f"{'':8s}"

    lines = [
        f"case {res['case']}; actions: {res['action']}",
        f"figures: {res.get('statistic', 'one window')} (window range in brackets); ratio: "
        "the median of each window's ratio to the CartPole window timed after it",
        f"{'':28s}{'contour_env':>16s}{'':>16s}{'CartPole-v1':>16s}{'ratio':>8s}",
        f"{'single env, steps/s':28s}{res['single_env_steps_per_s']:16,.0f}"
        f"{'(' + spread(res.get('single_env_steps_per_s_runs', [])) + ')':>16s}"
        f"{res['cartpole_single_steps_per_s']:16,.0f}"
        f"{ratio(res.get('single_ratio_to_cartpole'))}",
    ]
    for row in res["vector"]:
        lines.append(
            f"{'vector ' + str(row['num_envs']) + ' envs, env-steps/s':28s}"
            f"{row['env_steps_per_s']:16,.0f}"
            f"{'(' + spread(row.get('env_steps_per_s_runs', [])) + ')':>16s}"
            f"{row['cartpole_env_steps_per_s']:16,.0f}"
            f"{ratio(row.get('ratio_to_cartpole'))}"
        )
    for row in res.get("exploration", []):
        lines.append(
            f"{row['label'] + ', ' + str(row['num_envs']) + ' envs':28s}"
            f"{row['env_steps_per_s']:16,.0f}"
            f"{'(' + spread(row['env_steps_per_s_runs']) + ')':>16s}"
            f"{'':16s}  ratio to tracking {row['ratio_to_tracking']:.2f}"
        )
    row = res.get("contended")
    if row:
        lines.append(
            f"{'contended ' + str(row['num_envs']) + ' envs':28s}"
            f"{row['env_steps_per_s']:16,.0f}"
            f"{'(' + spread(row['env_steps_per_s_runs']) + ')':>16s}"
            f"{row['cartpole_env_steps_per_s']:16,.0f}"
            f"{ratio(row.get('ratio_to_cartpole'))}"
            f"  ratio to quiet {row['ratio_to_quiet']:.2f} "
            f"(CartPole {row['cartpole_ratio_to_quiet']:.2f})"
        )
    for row in res.get("controllers", []):
        lines.append(
            f"{row['name']}: {row['steps_per_s']:,.0f}; ratio to the env's single-env rate "
            f"{row['ratio_to_env']:.2f}"
        )
    if not res.get("controllers") and res.get("controllers_note"):
        lines.append(res["controllers_note"])
    return "\n".join(lines)
