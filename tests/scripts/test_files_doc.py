"""scripts/files_doc.py: the key tables of docs/FILES.md are the schemas the package checks
files with (issue 49, acceptance 4)."""

from __future__ import annotations

import pytest


@pytest.fixture
def files_doc(load_script):
    return load_script("files_doc")


def test_the_docs_tables_are_up_to_date(files_doc, capsys):
    assert files_doc.main(["--check"]) == 0, capsys.readouterr().out


def test_a_stale_table_is_found_and_rewritten(files_doc, tmp_path):
    doc = tmp_path / "FILES.md"
    text = files_doc.DOC.read_text(encoding="utf-8")
    stale = text.replace("| `force_limit` | N |", "| `force_limit` | kN |")
    assert stale != text
    doc.write_text(stale, encoding="utf-8")
    assert files_doc.main(["--check", "--doc", str(doc)]) == 1
    assert files_doc.main(["--doc", str(doc)]) == 0
    assert doc.read_text(encoding="utf-8") == text


def test_every_schema_key_is_documented_with_its_unit(files_doc):
    from agents.model_files import AGENT_KEYS
    from contour_env.plants.file_schema import PLANT_KEYS

    text = files_doc.DOC.read_text(encoding="utf-8")
    for key in (*PLANT_KEYS, *AGENT_KEYS):
        assert f"| `{key.name}` | {key.unit or '–'} |" in text
    with pytest.raises(ValueError, match="no markers for the table 'plant_keys'"):
        files_doc.render("no markers here", {"plant_keys": "| a |\n"})
