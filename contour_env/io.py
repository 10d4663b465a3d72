"""Atomic file output: write to a temporary file in the same folder, then rename.

The temporary file comes from :func:`tempfile.mkstemp`, which creates it with mode 0600 (so
that nobody else can read a half-written file). Before the rename it is given the mode a
plain ``open(path, "w")`` would have created: ``0o666 & ~umask`` (0644 under the usual umask
022, 0600 under 077), so the outputs are as readable as any other file the user writes.
"""

from __future__ import annotations

import json
import os
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

_UMASK_LOCK = threading.Lock()


def current_umask() -> int:
    """The process umask, read without changing it where the system allows.

    Linux reports it in ``/proc/self/status``; elsewhere it is read by setting and restoring
    it (``os.umask`` has no read-only form) under a lock, so that no two writers of this module
    race; a file created by another thread in that instant gets umask 0o077, never a more
    permissive one."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    with _UMASK_LOCK:
        old = os.umask(0o077)
        os.umask(old)
    return old


def default_mode(directory: bool = False) -> int:
    """The mode a new file (0o666) or directory (0o777) gets under the current umask."""
    return (0o777 if directory else 0o666) & ~current_umask()


def apply_default_mode(path, directory: bool | None = None) -> None:
    """Give ``path`` (made by mkstemp/mkdtemp, mode 0600/0700) the umask's default mode."""
    if directory is None:
        directory = os.path.isdir(path)
    os.chmod(path, default_mode(directory))


def _tmp_for(path: Path, suffix: str) -> tuple[int, str]:
    path.parent.mkdir(parents=True, exist_ok=True)
    return tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)


def atomic_save(path, save: Callable[[str], object], suffix: str | None = None) -> Path:
    """``save(tmp)`` writes the file under a temporary name in the same folder (any writer
    that takes a file name: matplotlib, stable-baselines3's ``model.save``, ...); the file is
    then given the umask's mode and renamed to ``path``. On any error the temporary file is
    removed and ``path`` is left as it was."""
    path = Path(path)
    fd, tmp = _tmp_for(path, path.suffix if suffix is None else suffix)
    os.close(fd)
    try:
        save(tmp)
        apply_default_mode(tmp, directory=False)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def _write(path, data, mode: str, encoding: str | None) -> Path:
    path = Path(path)
    fd, tmp = _tmp_for(path, ".tmp")
    try:
        with os.fdopen(fd, mode, encoding=encoding) as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        apply_default_mode(tmp, directory=False)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def atomic_write_text(path, text: str) -> Path:
    return _write(path, text, "w", "utf-8")


def atomic_write_json(path, data) -> Path:
    return atomic_write_text(path, json.dumps(data, indent=2, allow_nan=False) + "\n")


def atomic_save_figure(fig, path, **kwargs) -> Path:
    """Save a matplotlib figure atomically; the format comes from the file suffix."""
    path = Path(path)
    fmt = path.suffix.lstrip(".") or "png"
    return atomic_save(
        path, lambda tmp: fig.savefig(tmp, format=fmt, **kwargs), path.suffix or ".png"
    )


def atomic_write_bytes(path, data: bytes) -> Path:
    return _write(path, data, "wb", None)
