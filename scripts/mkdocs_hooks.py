"""MkDocs hook (``hooks:`` in mkdocs.yml): the files outside ``docs/`` that a page links to
with a repository-relative link, ``](../agents/models/friction-table/validation_curve.png)``,
are copied into the site under ``_repo/`` and the link is pointed there, so one link works on
GitHub (the Markdown as written) and in the built site. Only links to existing files are
rewritten; a link to a missing file is left for MkDocs to report (``--strict`` fails on it)."""

from __future__ import annotations

import re
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]
PREFIX = "_repo/"
LINK = re.compile(r"\]\(\.\./(?P<path>[^)\s#]+)(?P<rest>[^)]*)\)")


def _outside_targets(docs_dir: Path) -> set[str]:
    """Repository-relative paths of the existing files outside docs/ linked from a page."""
    found = set()
    for page in docs_dir.glob("*.md"):
        for m in LINK.finditer(page.read_text(encoding="utf-8")):
            target = (ROOT / m["path"]).resolve()
            if target.is_file() and docs_dir.resolve() not in target.parents:
                found.add(target.relative_to(ROOT).as_posix())
    return found


def on_files(files, config):
    docs_dir = Path(config["docs_dir"])
    for rel in sorted(_outside_targets(docs_dir)):
        files.append(File.generated(config, PREFIX + rel, abs_src_path=str(ROOT / rel)))
    return files


def on_page_markdown(markdown, page, config, files):
    def sub(m: re.Match) -> str:
        if files.get_file_from_path(PREFIX + m["path"]) is None:
            return m.group(0)
        return f"]({PREFIX}{m['path']}{m['rest']})"

    return LINK.sub(sub, markdown)
