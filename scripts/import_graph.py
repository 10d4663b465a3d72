"""The module import graph of ``contour_env`` and ``agents``, read from the source with ``ast``
(imports inside functions included), its layers and its circles.

    python scripts/import_graph.py            # the floor plan, top floor first
    python scripts/import_graph.py --json F   # the graph as {module: [imported modules]}

The layers the package holds (``tests/test_architecture.py``):

- the **library**: every ``contour_env`` module outside ``contour_env.app`` (plants, paths,
  contour error, metrics, cases, the env); it imports neither ``agents`` nor the application;
- **agents** (controllers, residual RL): imports the library only;
- the **application** ``contour_env.app`` (CLI, speed bench, benchmark and report, charts,
  sweeps): may import both.

No module reaches itself through its imports (no circle). A floor is the length of the longest
chain of imports below a module (floor 1 imports nothing of the package).
"""

from __future__ import annotations

import argparse
import ast
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("contour_env", "agents")


def module_files(root: Path = ROOT) -> dict[str, Path]:
    """Every module of the packages: dotted name → file (a package is its ``__init__``)."""
    out = {}
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


def _resolve(name: str, modules: dict) -> str | None:
    """The module a dotted import name lands in (the longest known prefix)."""
    parts = name.split(".")
    while parts:
        dotted = ".".join(parts)
        if dotted in modules:
            return dotted
        parts.pop()
    return None


def imports_of(module: str, path: Path, modules: dict) -> set[str]:
    """The package modules ``module`` imports, at the top or inside functions. ``from P import
    n`` imports the submodule ``P.n`` where there is one, else P (a name its ``__init__``
    defines). A module's parent packages are imported before it in any case: not arrows."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_pkg = path.name == "__init__.py"
    here = module.split(".") if is_pkg else module.split(".")[:-1]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                target = _resolve(alias.name, modules)
                if target:
                    found.add(target)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - (node.level - 1)]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module or ""
            target = _resolve(name, modules)
            if target is None:
                continue
            for alias in node.names:
                sub = f"{name}.{alias.name}"
                found.add(sub if sub in modules else target)
    found.discard(module)
    return found


def build_graph(root: Path = ROOT) -> dict[str, set[str]]:
    modules = module_files(root)
    return {m: imports_of(m, p, modules) for m, p in modules.items()}


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def layer(module: str) -> str:
    """``library``, ``agents`` or ``app``."""
    if module == "contour_env.app" or module.startswith("contour_env.app."):
        return "app"
    if module.split(".")[0] == "agents":
        return "agents"
    return "library"


ALLOWED = {
    "library": {"library"},
    "agents": {"library", "agents"},
    "app": {"library", "agents", "app"},
}


def layer_violations(graph: dict[str, set[str]]) -> list[str]:
    """Every import that points up a layer: ``'a -> b (library imports app)'``."""
    return [
        f"{m} -> {t} ({layer(m)} imports {layer(t)})"
        for m in sorted(graph)
        for t in sorted(graph[m])
        if layer(t) not in ALLOWED[layer(m)]
    ]


def floors(graph: dict[str, set[str]]) -> dict[str, int]:
    """Floor of each module: 1 + the highest floor it imports (a circle shares one floor)."""
    memo: dict[str, int] = {}

    def floor(m, seen=()):
        if m in memo:
            return memo[m]
        below = [floor(t, seen + (m,)) for t in graph[m] if t not in seen]
        memo[m] = 1 + max(below, default=0)
        return memo[m]

    for m in graph:
        floor(m)
    return memo


def floor_plan(graph: dict[str, set[str]]) -> str:
    fl = floors(graph)
    lines = []
    for f in sorted(set(fl.values()), reverse=True):
        mods = sorted(m for m in fl if fl[m] == f)
        lines.append(f"floor {f:2d}: " + ", ".join(f"{m} [{layer(m)}]" for m in mods))
    circ = circles(graph)
    lines.append(f"circles: {len(circ)}" + "".join(f"\n  {' <-> '.join(c)}" for c in circ))
    up = layer_violations(graph)
    lines.append(f"imports up a layer: {len(up)}" + "".join(f"\n  {u}" for u in up))
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", help="write the graph as JSON to this file")
    args = ap.parse_args(argv)
    graph = build_graph()
    if args.json:
        Path(args.json).write_text(json.dumps({m: sorted(t) for m, t in graph.items()}, indent=1))
    print(floor_plan(graph))
    return 0


if __name__ == "__main__":
    sys.exit(main())
