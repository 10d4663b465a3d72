"""The test tiers (tests/conftest.py): every entry of tests/full_tier.txt names a test module or
a test function that exists, so the list cannot silently rot; the full tier is marked."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.conftest import FULL_TIER, full_tier_entries

ROOT = Path(__file__).resolve().parents[1]


def _functions(module: Path) -> set:
    tree = ast.parse(module.read_text(encoding="utf-8"))
    return {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}


@pytest.mark.parametrize("entry", sorted(full_tier_entries()))
def test_every_entry_names_an_existing_test(entry):
    module, _, function = entry.partition("::")
    path = ROOT / module
    assert path.is_file(), f"{FULL_TIER.name}: {entry}: no module {module}"
    if function:
        assert function.startswith("test_") and function in _functions(path), (
            f"{FULL_TIER.name}: {entry}: no test {function} in {module}"
        )


def test_the_full_tier_is_marked(request):
    # this module is not in the list: its own items are unit tests
    assert request.node.get_closest_marker("full") is None
    assert "tests/test_identify.py" in full_tier_entries()
    listed = [i for i in request.session.items if i.nodeid.startswith("tests/test_identify.py::")]
    assert all(i.get_closest_marker("full") is not None for i in listed)
