"""Is a ``path=`` argument of the Python API a G-code file or G-code program text?

The command line's ``--gcode`` always names a file (``contour-env run --gcode FILE``); the
Python API (``gym.make(..., path=...)``, ``build_setup(path=...)``) takes either, and tells
them apart by `is_program_text`:

1. an ``os.PathLike`` (``pathlib.Path``) is a file;
2. a string naming an existing file is that file, whatever its name;
3. a string ending in a usual G-code extension (`COMMON_EXTENSIONS`, any case) is a file
   (missing: ``FileNotFoundError``);
4. a string with a line break, or with ``G0``, ``G1``, ``G2`` or ``G3`` in it (any case, so
   ``G01``, ``g2`` too) is program text (``path="G1 X5 F600"``);
5. any other string is a file name (missing: ``FileNotFoundError``).
"""

from __future__ import annotations

import os

from .gcode import COMMON_EXTENSIONS

__all__ = ["is_program_text"]

_MOTION_WORDS = ("G0", "G1", "G2", "G3")


def is_program_text(path) -> bool:
    """True when ``path`` (a str or os.PathLike) is G-code program text, False when it names a
    file (rules in the module docstring)."""
    if isinstance(path, os.PathLike) or not isinstance(path, str):
        return False
    if "\n" not in path and "\r" not in path:
        try:
            if os.path.isfile(path):
                return False
        except (OSError, ValueError):  # a name the OS cannot take (NUL byte, too long)
            pass
        if path.strip().lower().endswith(COMMON_EXTENSIONS):
            return False
    else:
        return True
    up = path.upper()
    return any(word in up for word in _MOTION_WORDS)
