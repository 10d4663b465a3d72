"""The manual as a MkDocs site (mkdocs.yml, docs/): ``mkdocs build --strict`` succeeds, so no
page links to a missing page or heading, every page is in the nav, and the API reference's
``::: module`` blocks resolve (mkdocstrings). Needs the ``[docs]`` (or ``[test]``) extra."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BUILD_TIMEOUT_S = 300

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("mkdocs") is None or importlib.util.find_spec("mkdocstrings") is None,
    reason='mkdocs or mkdocstrings is not installed (pip install -e ".[docs]")',
)


def test_the_site_builds_with_strict(tmp_path):
    site = tmp_path / "site"
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=BUILD_TIMEOUT_S,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert proc.returncode == 0, proc.stderr[-6000:]
    assert "WARNING" not in proc.stderr, proc.stderr[-6000:]
    for page in ("env", "paths", "controllers", "training", "machine", "cli", "api"):
        assert (site / page / "index.html").is_file(), page
    api = (site / "api" / "index.html").read_text(encoding="utf-8")
    assert "make_controller" in api and "ContouringEnv" in api
    # the figure a page links to outside docs/ is in the site (scripts/mkdocs_hooks.py)
    assert (site / "_repo/agents/models/friction-table/validation_curve.png").is_file()
