"""The held-out evaluation suite (``tests/data/heldout/``) is never training data: the training
code refuses it before opening it.

:func:`refuse_heldout` raises ``ValueError`` for a G-code file that lies under
:data:`HELDOUT_DIR` (the path resolved, symbolic links followed, so ``..`` and links do not get
around it) or whose bytes equal one of the suite's programs (a copy elsewhere). The suite
measures whether an agent helps on parts it never saw (docs/RESIDUAL_TRAINING.md); a program
of it in training or validation would make that figure meaningless.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

HELDOUT_DIR = Path(__file__).resolve().parents[2] / "tests" / "data" / "heldout"


def _heldout_digests(folder: Path) -> set:
    # read each time (ten small files): an edited program is never missed
    return {hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.rglob("*") if p.is_file()}


def _is_under(path: Path, folder: Path) -> bool:
    try:
        path.relative_to(folder)
    except ValueError:
        return False
    return True


def refuse_heldout(path, what: str = "gcode") -> None:
    """``ValueError`` naming ``what`` if ``path`` is (a copy of) a held-out program."""
    given = os.fspath(path)
    resolved = Path(given).expanduser().resolve()
    folder = HELDOUT_DIR.resolve()
    if _is_under(resolved, folder):
        raise ValueError(
            f"{what}: {given!r} is in the held-out evaluation suite ({folder}); training and "
            "validation never read it (docs/RESIDUAL_TRAINING.md)"
        )
    if folder.is_dir() and resolved.is_file():
        digests = _heldout_digests(folder)
        if hashlib.sha256(resolved.read_bytes()).hexdigest() in digests:
            raise ValueError(
                f"{what}: {given!r} is a copy of a program of the held-out evaluation suite "
                f"({folder}); training and validation never read it "
                "(docs/RESIDUAL_TRAINING.md)"
            )
