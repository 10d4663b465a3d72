"""Run a suite's independent runs: serially, on ``workers`` local processes, or as Ray tasks.

Every run is a pure function of its spec (:func:`.runs.execute`), and the results are
returned in the suite's order whatever the executor, so the figures are identical.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence

from .runs import execute
from .suite import RunSpec

RAY_HINT = 'pip install -e ".[ray]"'


def check_workers(workers) -> int:
    """``workers`` as an int >= 1; ``ValueError`` naming ``--workers`` otherwise."""
    try:
        n = int(str(workers).strip())
    except ValueError:
        raise ValueError(
            f"--workers: must be an integer >= 1 (local processes), got {workers!r}"
        ) from None
    if n < 1:
        raise ValueError(f"--workers: must be an integer >= 1 (local processes), got {workers!r}")
    return n


def check_ray(address, module: str = "ray") -> str | None:
    """``address`` (``auto``, ``local`` or a cluster ADDRESS such as ``ray://host:10001`` or
    ``host:6379``) checked; ``ValueError`` naming ``--ray`` when it is empty or ``module``
    (``ray``; ``ray.tune`` for training sweeps) is not installed."""
    if address is None:
        return None
    text = str(address).strip()
    if not text:
        raise ValueError("--ray: give auto (a local Ray instance) or a cluster ADDRESS")
    try:
        importlib.import_module(module)
    except ImportError:
        what = "Ray Tune" if module == "ray.tune" else "Ray"
        raise ValueError(f"--ray: {what} is not installed; install it with {RAY_HINT}") from None
    return text


def run_serial(specs: Sequence[RunSpec], progress: Callable | None = None) -> list[dict]:
    out = []
    for spec in specs:
        out.append(execute(spec.to_dict()))
        if progress:
            progress(out[-1])
    return out


def run_processes(
    specs: Sequence[RunSpec], workers: int, progress: Callable | None = None
) -> list[dict]:
    """The runs on ``workers`` fresh (spawned) processes; results in the specs' order."""
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    results: list = [None] * len(specs)
    ctx = mp.get_context("spawn")  # no fork of a process holding numba/torch threads
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        futures = {pool.submit(execute, s.to_dict()): i for i, s in enumerate(specs)}
        for fut in as_completed(futures):
            results[futures[fut]] = fut.result()
            if progress:
                progress(results[futures[fut]])
    return results


def run_ray(specs: Sequence[RunSpec], address: str, progress: Callable | None = None) -> list[dict]:
    """The runs as Ray tasks: ``address`` ``auto`` joins a running cluster or starts a local
    instance, ``local`` always starts one, anything else is a cluster address."""
    import ray

    started = False
    if not ray.is_initialized():
        if address == "local":
            ray.init(include_dashboard=False, log_to_driver=False)
        elif address == "auto":
            try:
                ray.init(address="auto", log_to_driver=False)
            except ConnectionError:
                ray.init(include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
        started = True
    try:
        task = ray.remote(num_cpus=1)(execute)
        refs = [task.remote(s.to_dict()) for s in specs]
        index = {ref: i for i, ref in enumerate(refs)}
        results: list = [None] * len(specs)
        pending = list(refs)
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                results[index[ref]] = ray.get(ref)
                if progress:
                    progress(results[index[ref]])
        return results
    finally:
        if started:
            ray.shutdown()


def run_all(
    specs: Sequence[RunSpec],
    *,
    workers: int = 1,
    ray: str | None = None,
    progress: Callable | None = None,
) -> list[dict]:
    """Every spec's result, in order: Ray tasks with ``ray``, else ``workers`` processes
    (1: in this process)."""
    workers = check_workers(workers)
    address = check_ray(ray)
    if address is not None:
        if workers != 1:
            raise ValueError("--workers: give --workers N or --ray ADDRESS, not both")
        return run_ray(specs, address, progress)
    if workers == 1 or len(specs) <= 1:
        return run_serial(specs, progress)
    return run_processes(specs, workers, progress)
