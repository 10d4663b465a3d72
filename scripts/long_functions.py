"""Functions longer than a limit in ``contour_env``, ``agents`` and ``scripts`` (lines from the
``def`` to the last line of the body, decorators and docstring included).

    python scripts/long_functions.py [--limit 120]     # exit 1 when any is longer
"""

from __future__ import annotations

import argparse
import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("contour_env", "agents", "scripts", "research")


def function_lengths(root: Path = ROOT) -> list[tuple[int, str]]:
    """(lines, 'path:line name') of every function and method, longest first."""
    out = []
    for folder in FOLDERS:
        for path in sorted((root / folder).rglob("*.py")):
            tree = ast.parse(path.read_text(), filename=str(path))
            for node in ast.walk(tree):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    n = node.end_lineno - node.lineno + 1
                    rel = path.relative_to(root)
                    out.append((n, f"{rel}:{node.lineno} {node.name}"))
    return sorted(out, reverse=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--limit", type=int, default=120, help="longest allowed, lines (default 120)")
    args = ap.parse_args(argv)
    long = [(n, where) for n, where in function_lengths() if n > args.limit]
    for n, where in long:
        print(f"{n:4d}  {where}")
    print(f"{len(long)} functions over {args.limit} lines")
    return 1 if long else 0


if __name__ == "__main__":
    sys.exit(main())
