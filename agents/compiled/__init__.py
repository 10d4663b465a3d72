"""Compiled (numba) forms of the classical controllers' per-step laws and the fused episode
loops that run them with the env kernel (``contour_env.evaluation.run_episode`` takes this
path for ``pd``, ``ccc``, ``adaptive-ccc``, ``jee-ccc``, ``rfnn`` and ``fnn``;
``compiled=False`` or ``CONTOUR_ENV_COMPILED=0`` keeps the Python ``act``).

The loops inline the env kernel, whose sources numba's cache does not track: their caches live
in a folder keyed by the digest of those sources and of this package's modules
(:mod:`contour_env.kernel_cache`). When numba's default in-tree folders are in use instead, the
caches of this package are deleted on import when any of those sources changed."""

from __future__ import annotations

import hashlib
from pathlib import Path

from contour_env.kernel_cache import KERNEL_SOURCES, PACKAGE, locator_installed


def _refresh_caches() -> None:
    if locator_installed():
        return  # the digest folders: nothing stale can be found
    here = Path(__file__).resolve().parent
    h = hashlib.sha256()
    # the env's kernel sources and every module of this package (the laws, the loops)
    for path in [PACKAGE / rel for rel in KERNEL_SOURCES] + sorted(here.glob("*.py")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    digest = h.hexdigest()
    stamp = here / "__pycache__" / "compiled_sources.sha256"
    try:
        if stamp.read_text().strip() == digest:
            return
    except OSError:
        pass
    for f in list(stamp.parent.glob("*.nbi")) + list(stamp.parent.glob("*.nbc")):
        try:
            f.unlink()
        except OSError:
            pass
    try:
        stamp.parent.mkdir(exist_ok=True)
        stamp.write_text(digest + "\n")
    except OSError:
        pass


_refresh_caches()

from .forms import CompiledForm, compiled_form  # noqa: E402

__all__ = ["CompiledForm", "compiled_form"]
