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


class OutputPathError(ValueError):
    """An output path that cannot be written (its folder is a file, it names a folder, no
    permission, ...). ``path`` is the path as given; the message names the path and why;
    ``contour_env.app.cli.main`` adds the option that gave it."""

    def __init__(self, path, reason: str):
        self.path = path
        self.reason = reason
        super().__init__(f"cannot write {os.fspath(path)}: {reason}")


def _existing_ancestor(path: Path) -> Path:
    parent = path.parent
    while not os.path.lexists(parent) and parent != parent.parent:
        parent = parent.parent
    return parent


def check_output_file(path) -> Path:
    """``path`` as a Path if a file can be written there (folders made as needed), else
    :class:`OutputPathError` saying why. Nothing is created."""
    p = Path(path)
    if str(path) == "" or p.name in ("", ".", ".."):
        raise OutputPathError(path, "not a file name")
    if p.is_dir():
        raise OutputPathError(path, "it is a directory")
    _check_parent(path, p.parent)
    return p


def check_output_dir(path) -> Path:
    """``path`` as a Path if it is, or can be made as, a writable folder, else
    :class:`OutputPathError`. Nothing is created."""
    p = Path(path)
    if str(path) == "":
        raise OutputPathError(path, "not a folder name")
    if os.path.lexists(p):
        if not p.is_dir():
            raise OutputPathError(path, "it exists and is not a directory")
        if not os.access(p, os.W_OK | os.X_OK):
            raise OutputPathError(path, "no permission to write in it")
        return p
    _check_parent(path, p)
    return p


def _check_parent(given, p: Path) -> None:
    # the folder p (to be made if missing): its nearest existing ancestor must be a writable
    # directory
    anc = p if os.path.lexists(p) else _existing_ancestor(p)
    if not anc.is_dir():
        raise OutputPathError(given, f"{anc} is not a directory")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise OutputPathError(given, f"no permission to write in {anc}")


def _tmp_for(path: Path, suffix: str) -> tuple[int, str]:
    check_output_file(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    except OSError as exc:
        raise OutputPathError(path, exc.strerror or str(exc)) from exc


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
    def save(tmp: str) -> None:
        with open(tmp, mode, encoding=encoding) as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())

    return atomic_save(path, save, ".tmp")


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
