"""Argument checks shared by the path constructors: a finite real number, with the caller's
words for what went wrong."""

from __future__ import annotations

import math


def finite_number(
    name: str, value, *, bools: bool = False, expected: str = "expected a number", bad: str = ""
) -> float:
    """``float(value)``, which must be finite; else ``ValueError(f"{name}: {expected}, got
    {value!r}")`` where it is no number (a bool counts as none unless ``bools``) and
    ``f"{name}: {bad}, got {value!r}"`` where it is not finite (``bad`` defaults to
    "must be finite")."""
    if not bools and isinstance(value, bool):
        raise ValueError(f"{name}: {expected}, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: {expected}, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name}: {bad or 'must be finite'}, got {value!r}")
    return v
