"""Shared fixtures: the project's scripts (``scripts/*.py``, not a package) loaded as modules.

Before the xdist workers of ``pytest -n N`` (N >= 2) start on a cold numba cache (a fresh
clone, or kernels changed), the kernels are compiled once by :func:`contour_env.app.warmup.warm`,
split over N processes: otherwise every worker compiles all of them at the same time."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def pytest_configure(config):
    # the controlling process of an xdist run only (workers carry ``workerinput``)
    if hasattr(config, "workerinput"):
        return
    n = getattr(config.option, "numprocesses", None)
    if not isinstance(n, int) or n < 2:
        return
    # one worker per core: numpy's and scipy's OpenBLAS would start a thread per core in every
    # worker, and the workers' threads contend (the workers inherit this before numpy loads)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from contour_env.app import warmup

    if warmup.cache_is_cold():
        # not the batched controller runner: its parallel loop alone compiles for minutes
        # and the default suite does not run it
        dt = warmup.warm(n, skip=("batch",))
        config._warm_note = f"numba kernels compiled before the workers started: {dt:.0f} s"


def pytest_report_header(config):
    note = getattr(config, "_warm_note", None)
    return [note] if note else []


def _load_script(name: str):
    spec = importlib.util.spec_from_file_location(f"script_{name}", ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture
def load_script():
    """``load_script(NAME)``: ``scripts/NAME.py`` as a fresh module."""
    return _load_script


@pytest.fixture
def readme_figures():
    """``scripts/readme_figures.py`` as a fresh module."""
    return _load_script("readme_figures")


def once_per_run(tmp_path_factory, key: str, compute):
    """``compute()``, computed once per test run even when the xdist workers split a module's
    tests between them (a module-scoped fixture would run once per worker): the first worker
    to ask computes it under a file lock and pickles it into the run's shared temporary folder,
    the others load it. Without xdist it is simply computed."""
    import pickle

    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return compute()
    from filelock import FileLock

    path = tmp_path_factory.getbasetemp().parent / f"once-{key}.pkl"
    with FileLock(str(path) + ".lock"):
        if path.is_file():
            return pickle.loads(path.read_bytes())
        value = compute()
        tmp = path.with_suffix(".tmp")
        tmp.write_bytes(pickle.dumps(value))
        tmp.replace(path)
        return value


@pytest.fixture(scope="session")
def shared(tmp_path_factory):
    """``shared(KEY, compute)``: :func:`once_per_run` for this run."""
    return lambda key, compute: once_per_run(tmp_path_factory, key, compute)


# the full tier: tests that train, fit, or run long episodes, CLI commands or scripts end to end
# (about 1 s or more each, listed in tests/full_tier.txt by module or module::function); the
# default run (CI, the README's test command) runs them, the unit tier leaves them out:
#     pytest -m "not slow and not full" -n 2
FULL_TIER = Path(__file__).with_name("full_tier.txt")


def full_tier_entries() -> set:
    lines = FULL_TIER.read_text(encoding="utf-8").splitlines()
    return {s.strip() for s in lines if s.strip() and not s.startswith("#")}


def pytest_collection_modifyitems(config, items):
    entries = full_tier_entries()
    for item in items:
        module = item.nodeid.split("::")[0]
        function = getattr(item, "originalname", None) or item.name
        if module in entries or f"{module}::{function}" in entries:
            item.add_marker(pytest.mark.full)
