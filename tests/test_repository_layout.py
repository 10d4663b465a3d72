"""The product and the lab notebook apart (issue 51): ``scripts/`` holds what reproduces a
shipped artefact or is a release step, each cited by a doc or a test; ``research/`` holds the
investigations, each opening with its question, its answer and the doc that cites it; no test
loads a research file."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
TESTS = sorted((ROOT / "tests").rglob("*.py"))


def _text(paths):
    return "\n".join(p.read_text(encoding="utf-8") for p in paths)


@pytest.mark.parametrize("script", sorted(p.name for p in (ROOT / "scripts").glob("*.py")))
def test_every_script_is_cited_by_a_doc_or_a_test(script):
    stem = script[: -len(".py")]
    in_docs = f"scripts/{script}" in _text(DOCS)
    in_tests = re.search(rf"\b{stem}\b", _text(p for p in TESTS if p.name != Path(__file__).name))
    assert in_docs or in_tests, f"scripts/{script} is cited by no doc and no test"


RESEARCH = sorted((ROOT / "research").glob("*.py"))


@pytest.mark.parametrize("path", RESEARCH, ids=lambda p: p.name)
def test_every_research_file_opens_with_its_question_answer_and_citing_doc(path):
    text = path.read_text(encoding="utf-8")
    m = re.match(r'"""Question: (.+?)\n\nAnswer: (.+?)\n\nCited by: (\S+)', text, re.S)
    assert m, f"{path.name} must open with Question:, Answer:, Cited by:"
    doc = ROOT / m.group(3).rstrip(".,")
    assert doc.is_file(), f"{path.name} cites {doc}, which does not exist"
    assert f"research/{path.name}" in doc.read_text(encoding="utf-8"), (
        f"{doc.name} does not name research/{path.name}"
    )


def test_research_exists_and_no_test_loads_a_research_file():
    assert RESEARCH, "research/ is empty"
    for p in TESTS:
        if p.name == Path(__file__).name:
            continue
        text = p.read_text(encoding="utf-8")
        assert not re.search(r"""["'/]research\b""", text), f"{p} loads from research/"
