"""The package's floor plan, held: the import graph of ``contour_env`` and ``agents`` read from
the source (imports inside functions included) has no circle, and its layers point down only —
the library imports neither ``agents`` nor the application ``contour_env.app``; ``agents``
imports the library only (scripts/import_graph.py builds the graph; docs/ARCHITECTURE.md
draws it)."""

from __future__ import annotations

import importlib.util
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _graph_module():
    spec = importlib.util.spec_from_file_location(
        "import_graph", ROOT / "scripts" / "import_graph.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


G = _graph_module()


@pytest.fixture(scope="module")
def graph():
    return G.build_graph(ROOT)


def test_graph_reads_every_module_and_known_arrows(graph):
    # a sanity check of the reader on arrows that exist today
    assert "contour_env.env.core" in graph and "agents.base" in graph
    assert "contour_env.env.core" in graph["agents.base"]
    assert "contour_env.env.kernel" in graph["contour_env.env.core"]  # `from . import kernel as K`
    assert "agents.compiled" in graph["agents.base"]  # an import inside a method counts


def test_no_import_circle(graph):
    assert G.circles(graph) == []


def test_layers_point_down(graph):
    assert G.layer_violations(graph) == []


def test_reader_finds_a_circle_and_an_upward_import(tmp_path):
    # the checks above can fail: a made-up tree with a circle and an upward import
    for rel, text in {
        "contour_env/__init__.py": "",
        "contour_env/a.py": "from . import b\n",
        "contour_env/b.py": "def f():\n    from .a import x\n",
        "contour_env/app/__init__.py": "",
        "contour_env/app/cli.py": "import agents.x\n",
        "agents/x.py": "",
        "contour_env/c.py": "from contour_env.app.cli import main\n",
        "agents/__init__.py": "",
        "agents/y.py": "from contour_env.app import cli\n",
    }.items():
        p = tmp_path / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(textwrap.dedent(text))
    g = G.build_graph(tmp_path)
    assert G.circles(g) == [["contour_env.a", "contour_env.b"]]
    assert G.layer_violations(g) == [
        "agents.y -> contour_env.app.cli (agents imports app)",
        "contour_env.c -> contour_env.app.cli (library imports app)",
    ]
