"""Invalidation of numba's on-disk kernel caches when any kernel source changes.

numba (``cache=True``) keys a cached function on its own source file only, so a kernel that
inlines functions of another module (``contour_env.env.kernel`` inlines the plant step, the
noise streams and the path distance) keeps running stale code after those change. On import,
the package compares a digest of every kernel source with the one recorded beside the caches
and, when it differs, deletes the package's cache files (``__pycache__/*.nbi``, ``*.nbc``) so
that numba recompiles once. Nothing is raised when a folder is read-only (numba then caches in
its user-wide folder, which this does not manage).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent


# every module of the package that uses numba (compiled functions, or functions and records
# that compiled code inlines), relative to the package; tests/test_kernel_cache.py holds it
# equal to kernel_sources() (reading every source on each import would cost ~0.1 s)
KERNEL_SOURCES = (
    "contour_error.py",
    "env/borrow.py",
    "env/core.py",
    "env/five_axis_kernel.py",
    "env/kernel.py",
    "env/layout.py",
    "env/reward.py",
    "noise.py",
    "plants/five_axis/dynamics.py",
    "plants/five_axis/plant.py",
    "plants/kernel.py",
)


def kernel_sources(root: Path = PACKAGE) -> tuple[str, ...]:
    """The modules of the package that use numba, read from the source: what
    :data:`KERNEL_SOURCES` must list (the application, ``app/``, has none)."""
    out = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel.parts[0] == "app" or rel.as_posix() == "kernel_cache.py":
            continue
        text = path.read_text(encoding="utf-8")
        if "from numba" in text or "import numba" in text or "from .borrow import" in text:
            out.append(rel.as_posix())
    return tuple(out)


STAMP = PACKAGE / "__pycache__" / "kernel_sources.sha256"


def sources_digest(root: Path = PACKAGE) -> str:
    h = hashlib.sha256()
    for rel in KERNEL_SOURCES:
        h.update(rel.encode())
        h.update((root / rel).read_bytes())
    return h.hexdigest()


def cache_is_cold(root: Path = PACKAGE) -> bool:
    """Whether the env step's compiled kernels are not on disk yet (a fresh install, or kernel
    sources changed): the first command then spends minutes compiling them."""
    folder = root / "env" / "__pycache__"
    return not any(folder.glob("kernel.*.nbi"))


COLD_NOTE = (
    "note: first run here: numba is compiling the simulation kernels (2-5 minutes on 2 cores, "
    "once; later commands load them in seconds; `contour-env warm` does it up front)"
)


def refresh_stale_caches(root: Path = PACKAGE) -> list[Path]:
    """Delete the package's numba cache files if the kernel sources changed since they were
    written; return the files deleted (empty when the caches are current)."""
    stamp = root / "__pycache__" / STAMP.name
    digest = sources_digest(root)
    try:
        if stamp.read_text().strip() == digest:
            return []
    except OSError:
        pass
    removed = []
    for folder in {(root / rel).parent / "__pycache__" for rel in KERNEL_SOURCES}:
        for f in list(folder.glob("*.nbi")) + list(folder.glob("*.nbc")):
            try:
                f.unlink()
                removed.append(f)
            except OSError:
                pass
    try:
        stamp.parent.mkdir(exist_ok=True)
        tmp = stamp.with_suffix(".tmp")
        tmp.write_text(digest + "\n")
        tmp.replace(stamp)
    except OSError:
        pass
    return removed
