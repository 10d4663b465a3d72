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


# --- docs/ARCHITECTURE.md against the code (a newcomer's test) --------------------------------
DOC = (ROOT / "docs" / "ARCHITECTURE.md").read_text()


def _named_in_doc():
    import re

    paths = set(re.findall(r"`((?:contour_env|agents|scripts|tests)/[\w/.]*)`", DOC))
    dotted = set(re.findall(r"`((?:contour_env|agents)\.[\w.]+)", DOC))
    return paths, dotted


def test_every_path_the_architecture_doc_names_exists():
    paths, _ = _named_in_doc()
    assert len(paths) > 30
    missing = [p for p in sorted(paths) if not (ROOT / p.rstrip("/")).exists()]
    assert missing == []


def test_every_module_and_name_the_architecture_doc_names_exists():
    import importlib

    _, dotted = _named_in_doc()
    modules = G.module_files(ROOT)
    assert len(dotted) > 15
    missing = []
    for name in sorted(dotted):
        parts = name.split(".")
        # the longest prefix that is a module, then attributes
        for cut in range(len(parts), 0, -1):
            if ".".join(parts[:cut]) in modules:
                break
        else:
            missing.append(name)
            continue
        obj = importlib.import_module(".".join(parts[:cut]))
        for attr in parts[cut:]:
            if not hasattr(obj, attr):
                missing.append(name)
                break
            obj = getattr(obj, attr)
    assert missing == []


def test_the_architecture_doc_describes_every_package():
    packages = sorted(
        p.parent.relative_to(ROOT).as_posix() + "/"
        for pkg in G.PACKAGES
        for p in (ROOT / pkg).rglob("__init__.py")
        if p.parent != ROOT / pkg
    )
    assert "contour_env/app/" in packages
    assert [p for p in packages if f"`{p}`" not in DOC] == []
