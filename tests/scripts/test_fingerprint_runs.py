"""scripts/fingerprint_runs.py: the bit-for-bit check of a refactoring (issue 37)."""

from __future__ import annotations

import json


def test_same_code_matches_and_a_changed_run_is_reported(load_script, tmp_path, capsys):
    fp = load_script("fingerprint_runs")
    only = "('nominal', 'sharp-corner', 'pd', 'nominal', 0)"
    first, second = tmp_path / "a.json", tmp_path / "b.json"
    assert fp.main(["--out", str(first), "--only", only]) == 0
    runs = json.loads(first.read_text())
    assert list(runs) == [only]
    assert runs[only]["error"] is None and runs[only]["rms_contour_error_um"] > 0
    # the same code twice: the same sha256, exit 0
    assert fp.main(["--out", str(second), "--against", str(first), "--only", only]) == 0
    assert "differ: 0 of 1 runs in both files" in capsys.readouterr().out
    # a run whose fingerprint differs from the earlier file is named, exit 1
    runs[only]["sha256"] = "0" * 64
    first.write_text(json.dumps(runs))
    assert fp.main(["--out", str(second), "--against", str(first), "--only", only]) == 1
    assert only in capsys.readouterr().out.split("differ: 1 of 1")[1]
    # a run added since the earlier file is new, not a difference; a run gone is a change
    first.write_text(json.dumps({}))
    assert fp.main(["--out", str(second), "--against", str(first), "--only", only]) == 0
    out = capsys.readouterr().out
    assert "differ: 0 of 0" in out and "new: 1" in out and only in out.split("new: 1")[1]
    gone = "('nominal', 'sharp-corner', 'pd', 'nominal', 99)"
    first.write_text(json.dumps({**json.loads(second.read_text()), gone: runs[only]}))
    assert fp.main(["--out", str(second), "--against", str(first), "--only", "sharp-corner"]) == 1
    assert gone in capsys.readouterr().out.split("missing: 1")[1]
