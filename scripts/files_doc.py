"""Regenerate the key tables of docs/FILES.md from the schemas the package checks files with.

    python scripts/files_doc.py [--check]

Each table sits between ``<!-- BEGIN generated: NAME (scripts/files_doc.py) -->`` and
``<!-- END generated: NAME -->`` and is replaced by :func:`contour_env.schema.markdown_table`
of its schema, so the keys, units and ranges the docs list are the ones checked on load:

- ``plant_keys``: :data:`contour_env.plants.file_schema.PLANT_KEYS` (``plant.json``);
- ``trace_columns``: :data:`contour_env.identify.trace.TRACE_KEYS` (the trace CSV);
- ``agent_keys``: :data:`agents.model_files.AGENT_KEYS` (``agent.json``);
- ``normalization_keys``: :data:`agents.model_files.NORMALIZATION_KEYS`.

``--check`` writes nothing and exits 1 when a table would change (a release step: the test
suite runs it). The file is written atomically.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "FILES.md"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def tables() -> dict:
    from agents.model_files import AGENT_KEYS, NORMALIZATION_KEYS
    from contour_env.identify.trace import TRACE_KEYS
    from contour_env.plants.file_schema import PLANT_KEYS
    from contour_env.schema import markdown_table

    return {
        "plant_keys": markdown_table(PLANT_KEYS),
        "trace_columns": markdown_table(TRACE_KEYS),
        "agent_keys": markdown_table(AGENT_KEYS),
        "normalization_keys": markdown_table(NORMALIZATION_KEYS),
    }


def render(text: str, generated: dict) -> str:
    """``text`` with each generated table replaced; ValueError for a table without markers."""
    for name, table in generated.items():
        pattern = re.compile(
            rf"(<!-- BEGIN generated: {name} [^\n]*-->\n)(.*?)(<!-- END generated: {name} -->)",
            re.S,
        )
        if not pattern.search(text):
            raise ValueError(f"{DOC.name}: no markers for the table {name!r}")
        text = pattern.sub(lambda m, t=table: m.group(1) + t + m.group(3), text)
    return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if a table is stale")
    ap.add_argument("--doc", default=str(DOC), help="the file (default docs/FILES.md)")
    args = ap.parse_args(argv)
    path = Path(args.doc)
    old = path.read_text(encoding="utf-8")
    new = render(old, tables())
    if args.check:
        if new != old:
            print(f"{path}: generated tables are stale; run python scripts/files_doc.py")
            return 1
        print(f"{path}: generated tables up to date")
        return 0
    from contour_env.io import atomic_write_text

    atomic_write_text(path, new)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
