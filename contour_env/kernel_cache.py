"""Where numba's compiled kernels are cached: one folder per digest of the kernel sources,
shared by every checkout of the same code on this machine.

numba (``cache=True``) keys a cached function on its own source file only, so a kernel that
inlines functions of another module (``contour_env.env.kernel`` inlines the plant step, the
noise streams and the path distance) would keep running stale code after those change, and
its default folder (``__pycache__`` beside the source) is new in every clean checkout, so a
fresh clone compiled every kernel again (minutes on 2 cores).

Here the package's compiled functions are cached under
``CACHE_ROOT/<group>-<digest>/<module folder>``:

- ``CACHE_ROOT`` is ``$CONTOUR_ENV_KERNEL_CACHE``, else ``$XDG_CACHE_HOME/contour_env/kernels``,
  else ``~/.cache/contour_env/kernels``;
- the group ``env`` (``contour_env``'s kernels) is keyed by the digest of
  :data:`KERNEL_SOURCES`; the group ``compiled`` (``agents/compiled``: the laws and the fused
  episode loops, which inline the env kernel) by the digest of those sources and of every
  module of ``agents/compiled``. The digests include the numba and Python versions.

An edit of any kernel source therefore gives a new folder (nothing stale is ever loaded), and a
second clone of the same commit finds the first one's kernels. Only the newest
:data:`KEEP_DIGESTS` folders of each group are kept. The folder is chosen by numba's public
locator hook (``numba.core.config.CACHE_LOCATOR_CLASSES``, the ``NUMBA_CACHE_LOCATOR_CLASSES``
variable, numba ≥ 0.68) ahead of numba's own locators; when the user set ``NUMBA_CACHE_DIR``
or ``NUMBA_CACHE_LOCATOR_CLASSES`` themselves, when the root is not writable (checked on
import), or on an older numba, numba's default applies and :func:`refresh_stale_caches` drops
in-tree caches made from other sources instead.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
AGENTS_COMPILED = PACKAGE.parent / "agents" / "compiled"

# the modules of the package that define compiled functions, or records and intrinsics that
# compiled code inlines, relative to the package; tests/test_kernel_cache.py holds it equal to
# kernel_sources() (reading every source on each import would cost ~0.1 s)
KERNEL_SOURCES = (
    "contour_error.py",
    "env/borrow.py",
    "env/five_axis_kernel.py",
    "env/kernel.py",
    "env/layout.py",
    "env/reward.py",
    "identify/kernel.py",
    "noise.py",
    "plants/five_axis/dynamics.py",
    "plants/five_axis/plant.py",
    "plants/kernel.py",
)

# how many digest folders of each group are kept under the cache root (other checkouts,
# other commits); older ones are deleted when a new one is made
KEEP_DIGESTS = 6

_COMPILED_MARKERS = ("@njit", "@jit", "@intrinsic", "@overload", "@vectorize", "register_record(")


def kernel_sources(root: Path = PACKAGE) -> tuple[str, ...]:
    """The modules of the package that define compiled functions (``@njit``, ``@intrinsic``…)
    or records registered for compiled code, read from the source: what :data:`KERNEL_SOURCES`
    must list. A module that only calls kernels (``env/core.py``) is not one: editing it
    recompiles nothing."""
    out = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel.parts[0] == "app" or rel.as_posix() == "kernel_cache.py":
            continue
        text = path.read_text(encoding="utf-8")
        if any(m in text for m in _COMPILED_MARKERS):
            out.append(rel.as_posix())
    return tuple(out)


STAMP = PACKAGE / "__pycache__" / "kernel_sources.sha256"


def _versions() -> bytes:
    numba_version = ".".join(map(str, _numba_version(parts=3))) or "?"
    return f"numba {numba_version} python {sys.version_info[:3]}".encode()


def sources_digest(root: Path = PACKAGE) -> str:
    """sha256 of every kernel source (names and bytes)."""
    h = hashlib.sha256()
    for rel in KERNEL_SOURCES:
        h.update(rel.encode())
        h.update((root / rel).read_bytes())
    return h.hexdigest()


def compiled_digest(root: Path = PACKAGE, compiled: Path = AGENTS_COMPILED) -> str:
    """sha256 of the kernel sources and of every module of ``agents/compiled``."""
    h = hashlib.sha256(sources_digest(root).encode())
    for path in sorted(compiled.glob("*.py")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def cache_root() -> Path:
    """The folder every digest folder lives in (see the module docstring)."""
    env = os.environ.get("CONTOUR_ENV_KERNEL_CACHE")
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "contour_env" / "kernels"


class _Folders:
    """The digest folders of this process (computed once, on first use)."""

    env: Path | None = None
    compiled: Path | None = None

    @classmethod
    def resolve(cls) -> None:
        if cls.env is not None:
            return
        v = hashlib.sha256(_versions()).hexdigest()[:8]
        root = cache_root()
        cls.env = root / f"env-{sources_digest()[:16]}-{v}"
        cls.compiled = root / f"compiled-{compiled_digest()[:16]}-{v}"


def digest_folders() -> tuple[Path, Path]:
    """(env kernels' folder, agents/compiled's folder) for the current sources."""
    _Folders.resolve()
    return _Folders.env, _Folders.compiled


def _numba_locators():
    from numba.core import caching

    class DigestCacheLocator(caching.InTreeCacheLocator):
        """numba locator: the package's compiled functions cache in their digest folder."""

        def __init__(self, py_func, py_file, folder):
            super().__init__(py_func, py_file)
            self._cache_path = str(folder)

        @classmethod
        def from_function(cls, py_func, py_file):
            try:
                path = Path(py_file).resolve()
            except (OSError, TypeError):
                return None
            env_dir, compiled_dir = digest_folders()
            if path.is_relative_to(AGENTS_COMPILED):
                folder = compiled_dir / path.parent.relative_to(AGENTS_COMPILED)
            elif path.is_relative_to(PACKAGE):
                folder = env_dir / path.parent.relative_to(PACKAGE)
            else:
                return None
            self = cls(py_func, py_file, folder)
            try:
                self.ensure_cache_path()
            except OSError:
                return None  # not writable: numba's own locators
            _prune(folder)
            return self

    return DigestCacheLocator


_PRUNED: set = set()


def _prune(folder: Path) -> None:
    """Keep the newest KEEP_DIGESTS digest folders of the group ``folder`` belongs to (once
    per group and process)."""
    root = cache_root()
    group_dir = next((p for p in [folder, *folder.parents] if p.parent == root), None)
    if group_dir is None or group_dir in _PRUNED:
        return
    _PRUNED.add(group_dir)
    group = group_dir.name.split("-", 1)[0]
    try:
        dirs = sorted(root.glob(f"{group}-*"), key=lambda p: p.stat().st_mtime, reverse=True)
    except OSError:
        return
    for old in [d for d in dirs if d != group_dir][KEEP_DIGESTS - 1 :]:
        shutil.rmtree(old, ignore_errors=True)


LOCATOR = "contour_env.kernel_cache.DigestCacheLocator"
# numba's own locators, after ours (the names numba's config hook accepts without a module)
_NUMBA_DEFAULT = "InTreeCacheLocator,UserWideCacheLocator,IPythonCacheLocator,ZipCacheLocator"


# the numba that reads NUMBA_CACHE_LOCATOR_CLASSES and stamps sources by content (tested here);
# an older one keeps its default folders
MIN_NUMBA = (0, 68)


def _numba_version(parts: int = 2) -> tuple[int, ...]:
    """The installed numba's version, its first ``parts`` numbers; (0, 0) when unreadable."""
    try:
        from importlib.metadata import version

        return tuple(int(x) for x in version("numba").split(".")[:parts])
    except Exception:  # noqa: BLE001 - no distribution record, or a local version string
        return (0, 0)


def _writable(root: Path) -> bool:
    try:
        root.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=root).close()
        return True
    except OSError:
        return False


def locator_setting() -> str:
    """The value of ``NUMBA_CACHE_LOCATOR_CLASSES`` that puts the digest locator first."""
    return f"{LOCATOR},{_NUMBA_DEFAULT}"


def install_locator() -> bool:
    """Put the digest locator ahead of numba's own (through ``NUMBA_CACHE_LOCATOR_CLASSES``, so
    that importing the package does not import numba, and subprocesses inherit it); False, and
    numba's default kept, when the user chose numba's cache folder or locators."""
    mine = locator_setting()
    if os.environ.get("NUMBA_CACHE_DIR") or _numba_version() < MIN_NUMBA:
        return False
    if os.environ.get("NUMBA_CACHE_LOCATOR_CLASSES", mine) != mine:
        return False
    if not _writable(cache_root()):
        return False  # numba's own folders, and the in-tree invalidation with them
    os.environ["NUMBA_CACHE_LOCATOR_CLASSES"] = mine
    numba_config = sys.modules.get("numba.core.config")
    if numba_config is not None:  # numba read the variable already: set what it read
        if not hasattr(numba_config, "CACHE_LOCATOR_CLASSES"):
            return False
        numba_config.CACHE_LOCATOR_CLASSES = mine
    return True


def locator_installed() -> bool:
    """Whether the package's kernels cache in their digest folders in this process."""
    if os.environ.get("NUMBA_CACHE_LOCATOR_CLASSES") != locator_setting():
        return False
    numba_config = sys.modules.get("numba.core.config")
    return numba_config is None or getattr(numba_config, "CACHE_LOCATOR_CLASSES", "") == (
        locator_setting()
    )


def __getattr__(name):
    # numba imports the locator by its dotted name; it is built on first use so that importing
    # the package does not import numba
    if name == "DigestCacheLocator":
        cls = _numba_locators()
        globals()[name] = cls
        return cls
    raise AttributeError(name)


def cache_is_cold(root: Path = PACKAGE) -> bool:
    """Whether the env step's compiled kernels are not on disk yet (a fresh machine, or kernel
    sources changed): the first command then spends minutes compiling them."""
    if root == PACKAGE and locator_installed():
        folder = digest_folders()[0] / "env"
    else:
        folder = root / "env" / "__pycache__"
    return not any(folder.glob("kernel.*.nbi"))


COLD_NOTE = (
    "note: first run here: numba is compiling the simulation kernels (2-5 minutes on 2 cores, "
    "once per version of the kernels on this machine; later commands and other checkouts load "
    "them in seconds; `contour-env warm` does it up front)"
)


def refresh_stale_caches(root: Path = PACKAGE) -> list[Path]:
    """Delete the package's in-tree numba cache files if the kernel sources changed since they
    were written (numba's default folders, used when the digest locator is not installed);
    return the files deleted (empty when the caches are current)."""
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
