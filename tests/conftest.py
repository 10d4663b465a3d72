"""Shared fixtures: the project's scripts (``scripts/*.py``, not a package) loaded as modules."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


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
