"""The README as documentation that runs, and its generated tables.

Conventions this test holds the README to:

- Every ```python block runs as written, on its own, in a fresh interpreter
  (``python BLOCK.py`` in a subprocess, from the repository root, ``MPLBACKEND=Agg``, with a
  timeout of ``PYTHON_BLOCK_TIMEOUT_S``): so each block has its own imports and needs no earlier
  block, and its budgets are small. A block that writes files writes under ``out/``
  (git-ignored). A block that must not run here (say, a long training) is marked by the HTML
  comment ``<!-- readme-test: no-run (reason) -->`` on the line right before its fence; keep
  such blocks to the bare minimum (there are none now).
- Every ``contour-env`` command of a ```bash block parses: the subcommand exists
  (``contour-env SUB -h`` exits 0) and the whole command line is accepted by the parser; the
  commands are not run.
- The generated tables sit between ``<!-- BEGIN generated: NAME ... -->`` and
  ``<!-- END generated: NAME -->``, one generator of ``scripts/readme_figures.py`` each. The
  generators themselves are slow and are not run here; the replacement logic is tested with
  fake generators on a copy.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PYTHON_BLOCK_TIMEOUT_S = 300
NO_RUN = re.compile(r"<!--\s*readme-test:\s*no-run\b")


def fenced_blocks(text: str, language: str) -> list[tuple[int, str, bool]]:
    """``(line number, code, marked no-run)`` of every ```language block of ``text``."""
    lines = text.splitlines()
    out, i = [], 0
    while i < len(lines):
        if lines[i].strip() == f"```{language}":
            start = i
            previous = next((ln for ln in reversed(lines[:i]) if ln.strip()), "")
            i += 1
            body = []
            while i < len(lines) and lines[i].strip() != "```":
                body.append(lines[i])
                i += 1
            out.append((start + 1, "\n".join(body) + "\n", bool(NO_RUN.search(previous))))
        i += 1
    return out


README_TEXT = README.read_text(encoding="utf-8")
PYTHON_BLOCKS = fenced_blocks(README_TEXT, "python")
BASH_BLOCKS = fenced_blocks(README_TEXT, "bash")


def test_the_readme_has_python_and_bash_blocks_and_no_run_exceptions_are_rare():
    assert len(PYTHON_BLOCKS) >= 3 and len(BASH_BLOCKS) >= 3
    assert sum(skip for _, _, skip in PYTHON_BLOCKS) <= 1


@pytest.mark.parametrize(
    "line, code, skip", PYTHON_BLOCKS, ids=[f"README.md:{n}" for n, _, _ in PYTHON_BLOCKS]
)
def test_python_block_runs_as_written_in_a_fresh_interpreter(tmp_path, line, code, skip):
    if skip:
        pytest.skip(f"README.md:{line} is marked readme-test: no-run")
    script = tmp_path / f"readme_line_{line}.py"
    script.write_text(code, encoding="utf-8")
    env = {**os.environ, "MPLBACKEND": "Agg"}
    env.pop("PYTHONPATH", None)  # as a user's shell: the installed package, nothing else
    try:
        proc = subprocess.run(
            [sys.executable, str(script)],
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
            timeout=PYTHON_BLOCK_TIMEOUT_S,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"README.md:{line}: the block ran over {PYTHON_BLOCK_TIMEOUT_S} s")
    assert proc.returncode == 0, f"README.md:{line} failed:\n{code}\n{proc.stderr[-4000:]}"


def contour_env_commands(code: str) -> list[list[str]]:
    """The argument lists of every ``contour-env`` command in a bash block (continuation
    lines joined, comments dropped, split at ``&&``, ``||``, ``;`` and ``|``)."""
    commands = []
    for line in code.replace("\\\n", " ").splitlines():
        tokens = shlex.split(line, comments=True)
        current: list[str] = []
        for tok in [*tokens, "&&"]:
            if tok in ("&&", "||", ";", "|"):
                if current and current[0] == "contour-env":
                    commands.append(current[1:])
                current = []
            else:
                current.append(tok)
    return commands


BASH_COMMANDS = [cmd for _, code, _ in BASH_BLOCKS for cmd in contour_env_commands(code)]


def test_the_bash_blocks_use_contour_env():
    assert {"compare", "ilc", "train", "evaluate", "models"} <= {c[0] for c in BASH_COMMANDS}


@pytest.mark.parametrize("sub", sorted({c[0] for c in BASH_COMMANDS}))
def test_every_subcommand_of_the_bash_blocks_has_help(sub):
    from contour_env.app.cli import build_parser

    with contextlib.redirect_stdout(io.StringIO()), pytest.raises(SystemExit) as exc:
        build_parser().parse_args([sub, "-h"])
    assert exc.value.code == 0


@pytest.mark.parametrize("args", BASH_COMMANDS, ids=[" ".join(c)[:60] for c in BASH_COMMANDS])
def test_every_contour_env_command_of_the_bash_blocks_parses(args):
    from contour_env.app.cli import build_parser

    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            ns = build_parser().parse_args(args)
    except SystemExit as exc:  # argparse: exit 2 with the message on stderr
        pytest.fail(f"contour-env {' '.join(args)}: {err.getvalue()} (exit {exc.code})")
    assert callable(ns.func)


def test_the_quick_bench_of_the_readme_parses_with_its_short_settings():
    from contour_env.app.cli import build_parser

    ns = build_parser().parse_args(["bench", "--quick"])
    assert ns.quick and ns.seconds is None and ns.repeats is None


# ------------------------------------------------------------------ generated tables


def test_every_generated_section_of_the_readme_has_its_generator_and_a_table(readme_figures):
    mod = readme_figures
    found = mod.sections(README_TEXT)
    assert set(found) == set(mod.GENERATORS)
    for name, body in found.items():
        assert body.startswith("| ") and body.endswith("|\n"), name


SAMPLE = """# title

Some text.

<!-- BEGIN generated: alpha (typed; not stamped yet) -->
| a |
|---|
| 1 |
<!-- END generated: alpha -->

Between the tables.

<!-- BEGIN generated: beta (scripts/readme_figures.py; 2026-01-01, commit abc1234) -->
| b |
|---|
| 2 |
<!-- END generated: beta -->

The end.
"""


def _fake(tables: dict, calls: list):
    def make(name):
        def gen():
            calls.append(name)
            return tables[name]

        return gen

    return {name: make(name) for name in tables}


def test_sections_are_replaced_in_place_and_the_rest_is_untouched(tmp_path, readme_figures):
    mod = readme_figures
    readme = tmp_path / "README.md"
    readme.write_text(SAMPLE)
    calls = []
    gens = _fake({"alpha": "| a |\n|---|\n| 10 |", "beta": "| b |\n|---|\n| 2 |\n"}, calls)
    log = []
    assert mod.update_readme(readme, generators=gens, stamp_text=" (S) ", log=log.append) == 0
    new = readme.read_text()
    assert calls == ["alpha", "beta"]
    assert (
        "<!-- BEGIN generated: alpha (S) -->\n| a |\n|---|\n| 10 |\n<!-- END generated: alpha"
        in new
    )
    # beta did not change: its stamp (the commit it was made at) is kept
    assert (
        "<!-- BEGIN generated: beta (scripts/readme_figures.py; 2026-01-01, commit abc1234)" in new
    )
    outside = re.sub(r"<!-- BEGIN.*?<!-- END generated: \w+ -->", "", SAMPLE, flags=re.S)
    assert re.sub(r"<!-- BEGIN.*?<!-- END generated: \w+ -->", "", new, flags=re.S) == outside
    assert any("changed: alpha" in s for s in log)
    assert [p.name for p in tmp_path.iterdir()] == ["README.md"]  # atomic: no temporary left


def test_only_runs_the_named_generators_and_check_writes_nothing(tmp_path, readme_figures):
    mod = readme_figures
    readme = tmp_path / "README.md"
    readme.write_text(SAMPLE)
    calls = []
    gens = _fake({"alpha": "| a |\n|---|\n| 1 |", "beta": "| b |\n|---|\n| 3 |"}, calls)
    quiet = dict(generators=gens, stamp_text=" (S) ", log=lambda s: None)
    # alpha is current (stamps are not content), beta would change
    assert mod.update_readme(readme, only=["alpha"], check=True, **quiet) == 0
    assert mod.update_readme(readme, only=["beta"], check=True, **quiet) == 1
    assert mod.update_readme(readme, check=True, **quiet) == 1
    assert readme.read_text() == SAMPLE and calls == ["alpha", "beta", "alpha", "beta"]
    assert mod.update_readme(readme, only=["beta"], **quiet) == 0
    new = readme.read_text()
    assert "| 3 |" in new and "| 1 |" in new and "(typed; not stamped yet)" in new
    assert mod.update_readme(readme, check=True, **quiet) == 0


def test_unknown_names_and_missing_markers_are_errors(tmp_path, readme_figures):
    mod = readme_figures
    readme = tmp_path / "README.md"
    readme.write_text(SAMPLE)
    quiet = dict(stamp_text=" (S) ", log=lambda s: None)
    only_alpha = _fake({"alpha": "| a |"}, [])
    with pytest.raises(ValueError, match="without a generator"):
        mod.update_readme(readme, generators=only_alpha, **quiet)
    both = _fake({"alpha": "| a |", "beta": "| b |", "gamma": "| c |"}, [])
    with pytest.raises(ValueError, match="no generated section for gamma"):
        mod.update_readme(readme, generators=both, only=["gamma"], **quiet)
    with pytest.raises(ValueError, match="unknown generator"):
        mod.update_readme(readme, generators=both, only=["delta"], **quiet)
    assert readme.read_text() == SAMPLE


def test_main_regenerates_a_copy_of_the_readme_with_a_fake_generator(
    tmp_path, monkeypatch, readme_figures
):
    mod = readme_figures
    copy = tmp_path / "README.md"
    shutil.copy(README, copy)
    table = "| plant | controller |\n|---|---|\n| `x` | `pd` |"
    monkeypatch.setitem(mod.GENERATORS, "controller_table", lambda: table)
    monkeypatch.setattr(mod, "git_commit", lambda root=mod.ROOT: "abc1234-dirty")
    assert mod.main(["--only", "controller_table", "--readme", str(copy), "--check"]) == 1
    assert copy.read_text() == README_TEXT
    assert mod.main(["--only", "controller_table", "--readme", str(copy)]) == 0
    new = copy.read_text()
    assert mod.sections(new)["controller_table"] == table + "\n"
    stamp = mod.stamps(new)["controller_table"]
    assert re.fullmatch(
        r"\(scripts/readme_figures.py; \d{4}-\d\d-\d\d, commit abc1234-dirty\)", stamp
    )
    for name in ("lee2012_table", "ilc_table", "residual_table"):
        assert mod.sections(new)[name] == mod.sections(README_TEXT)[name]


def test_git_commit_is_a_short_hash_possibly_dirty(readme_figures):
    commit = readme_figures.git_commit()
    assert commit == "unknown" or re.fullmatch(r"[0-9a-f]{4,40}(-dirty)?", commit)


def test_the_ilc_benchmark_prints_the_readme_table_layout():
    spec = importlib.util.spec_from_file_location(
        "ilc_benchmark", ROOT / "scripts" / "ilc_benchmark.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    row = dict(case="hsm2-circle-II", condition="random", encoder_resolution_um=2.0)
    rows = [
        {**row, "controller": "ilc-pd", "first_max_um": 254.41, "first_rms_um": 193.57,
         "last_max_um": 1.2, "last_rms_um": 0.5},
        {**row, "controller": "vilcfd", "first_max_um": 32.7, "first_rms_um": 5.4589,
         "last_max_um": 2.83, "last_rms_um": None},
    ]  # fmt: skip
    text = mod.format_markdown(rows, 10)
    assert text.splitlines() == [
        "| case | condition | law | trial 1 max / RMS | trial 10 max / RMS |",
        "|---|---|---|---|---|",
        "| hsm2-circle-II | random | ilc-pd | 254.4 / 193.6 | ≤2 (enc) / ≤2 (enc) |",
        "| | | vilcfd | 32.70 / 5.459 | 2.830 / failed |",
    ]
    assert mod.compare(1.0, 2.0) == "50.0 % lower" and mod.compare(2.642, 2.0).endswith("higher")
