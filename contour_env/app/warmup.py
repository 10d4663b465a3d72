"""Compile the numba kernels ahead of their first use, in parallel processes.

On a fresh install (or after a kernel source changed, see :mod:`contour_env.kernel_cache`) the
first command compiles the plant, env and controller kernels, which takes minutes on a 2-core
machine; afterwards they load from numba's on-disk cache in seconds. Two processes that start
cold at the same moment (the two workers of ``pytest -n 2``, two training runs) would each
compile everything. :func:`warm` compiles every kernel exactly once, split over ``workers``
processes, in two stages: the friction slow path that every other kernel calls (with the
five-axis kernels alongside), then the env step (the serial and the parallel driver, one part
each) and the compiled controller runners, which load the slow path from the cache.

``contour-env warm [--workers N]`` runs it; the test suite's ``conftest.py`` runs it before the
xdist workers start when the cache is cold.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# the parts, each a function compiling a group of kernels by running them briefly; in each
# stage the longest first (the residual runner alone compiles for about 3 minutes on 2 cores:
# started last, the stage would wait on it with one process idle)
STAGES = (("plant", "five-axis"), ("residual", "batch", "controllers", "env-parallel", "env"))


def _plant() -> None:
    # the plant step (friction slow path included) of a plant with stick–slip and of one with
    # a structural mode, through the batch step the env and the tests use
    from ..plants import Plant

    for name in ("hsm2", "linear-motor"):
        plant = Plant(name)
        state = plant.initial_state(np.zeros(plant.n_axes))
        for _ in range(3):
            plant.step(state, np.zeros(plant.n_axes), 0.0)


def _five_axis() -> None:
    import gymnasium as gym

    from .. import ENV_ID

    env = gym.make(ENV_ID, case="five-axis-line")
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.zeros(env.action_space.shape, np.float32))
    venv = gym.make_vec(
        ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", case="five-axis-line"
    )
    venv.reset(seed=0)
    venv.step(np.zeros(venv.action_space.shape, np.float32))


def _env() -> None:
    # the serial driver (single env, small batches)
    import gymnasium as gym

    from .. import ENV_ID

    env = gym.make(ENV_ID, case="hsm2-circle-II")
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.zeros(env.action_space.shape, np.float32))
    _vector_steps(2, num_threads=1)


def _env_parallel() -> None:
    # the parallel driver (>= 256 envs on more than one thread): a part of its own, as each
    # driver compiles the whole env step inline (about as long as the serial one)
    from ..env.core import PARALLEL_MIN_ENVS

    _vector_steps(PARALLEL_MIN_ENVS, num_threads=2)


def _vector_steps(n: int, num_threads: int) -> None:
    import gymnasium as gym

    from .. import ENV_ID

    venv = gym.make_vec(
        ENV_ID,
        num_envs=n,
        vectorization_mode="vector_entry_point",
        case="lm-circle3d",
        num_threads=num_threads,
    )
    venv.reset(seed=0)
    for _ in range(3):
        venv.step(np.zeros(venv.action_space.shape, np.float32))
    venv.close()


def _controllers() -> None:
    # the compiled controller runner, single env (compare, evaluate) and batched
    from agents.compare import compare

    compare(["pd", "ccc", "adaptive-ccc"], case="hsm2-circle-I")


def _batch() -> None:
    # the batched (parallel) controller runner: robustness bands, repeated-batch learning
    from agents.compare import robustness_compiled_steps

    robustness_compiled_steps("pd", 2, case="hsm2-circle-III")


def _residual() -> None:
    # a residual agent's compiled servo loop between its decisions (evaluation, validation)
    from agents.compiled.residual_runner import warm_up

    warm_up()


PARTS = {
    "plant": _plant,
    "five-axis": _five_axis,
    "env": _env,
    "env-parallel": _env_parallel,
    "controllers": _controllers,
    "batch": _batch,
    "residual": _residual,
}


def warm_part(name: str) -> None:
    """Compile one part's kernels in this process (see :data:`PARTS`)."""
    if name not in PARTS:
        raise ValueError(f"part: unknown {name!r}; known: {', '.join(PARTS)}")
    PARTS[name]()


def _start(name: str, root: str) -> subprocess.Popen:
    # stderr to a temporary file (a pipe read only at the end could fill and block the part)
    code = f"from contour_env.app.warmup import warm_part; warm_part({name!r})"
    err = tempfile.TemporaryFile("w+")
    proc = subprocess.Popen(
        [sys.executable, "-c", code], cwd=root, stdout=subprocess.DEVNULL, stderr=err, text=True
    )
    proc.err_file = err
    return proc


def warm(workers: int = 2, progress=None, skip=()) -> float:
    """Compile every kernel once, ``workers`` processes at a time (1: in turn, in this
    process's children), leaving out the parts named in ``skip``. Returns the wall time in
    seconds; raises RuntimeError naming the part whose process failed."""
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ValueError(f"workers: a positive integer, got {workers!r}")
    t0 = time.perf_counter()
    root = str(Path(__file__).resolve().parent.parent)
    for stage in STAGES:
        # a pool of ``workers`` processes over the stage's parts, the next part starting as
        # soon as one finishes
        waiting, running = [name for name in stage if name not in skip], []
        while waiting or running:
            while waiting and len(running) < workers:
                name = waiting.pop(0)
                running.append((name, _start(name, root)))
            time.sleep(0.2)
            for name, proc in list(running):
                if proc.poll() is None:
                    continue
                running.remove((name, proc))
                proc.err_file.seek(0)
                err = proc.err_file.read()
                proc.err_file.close()
                if proc.returncode != 0:
                    for _, other in running:
                        other.kill()
                    last = (err or "").strip().splitlines()[-1:] or ["no message"]
                    raise RuntimeError(f"warm-up of {name!r} failed: {last[0]}")
                if progress:
                    progress(f"compiled: {name} ({time.perf_counter() - t0:.0f} s)")
    return time.perf_counter() - t0


def cache_is_cold() -> bool:
    """True when the friction slow path (which every kernel calls) has no cache entry yet."""
    from .. import kernel_cache

    if kernel_cache.locator_installed():
        folder = kernel_cache.digest_folders()[0] / "plants"
    else:
        folder = kernel_cache.PACKAGE / "plants" / "__pycache__"
    return not any(folder.glob("kernel._axis_step_slow-*.nbi"))
