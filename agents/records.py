"""The JSON-able records objects give of themselves (hyperparameters, keyword arguments,
counts): :func:`attributes` reads the fields that go into one under their own names."""

from __future__ import annotations


def attributes(obj, *names: str) -> dict:
    """``{name: obj.name}`` for each of ``names``, in their order."""
    return {name: getattr(obj, name) for name in names}
