"""The README and the docs pages as documentation that runs, and their generated tables.

Conventions this test holds README.md and every ``docs/*.md`` page to (:data:`DOC_FILES`;
test ids name the file and the line, e.g. ``docs/env.md:12``):

- Every ```python block runs as written, on its own, in a fresh interpreter
  (``python BLOCK.py`` in a subprocess, from the repository root, ``MPLBACKEND=Agg``, with a
  timeout of ``PYTHON_BLOCK_TIMEOUT_S``): so each block has its own imports and needs no earlier
  block, and its budgets are small. A block that writes files writes under ``out/``
  (git-ignored). A block that must not run here (say, a signature that is not a program) is
  marked by the HTML comment ``<!-- readme-test: no-run (reason) -->`` on the line right
  before its fence; keep such blocks to the bare minimum (one now: the signature of
  ``FeedProfile.build`` in docs/FEED_PLANNER.md).
- Every ``contour-env`` command of a ```bash block parses: the subcommand exists
  (``contour-env SUB -h`` exits 0) and the whole command line is accepted by the parser; the
  commands are not run.
- The generated tables sit between ``<!-- BEGIN generated: NAME ... -->`` and
  ``<!-- END generated: NAME -->``, one generator of ``scripts/readme_figures.py`` each, each
  in the page of its topic. The generators themselves are slow and are not run here; the
  replacement logic is tested with fake generators on a copy.
- docs/cli.md is what ``scripts/cli_doc.py`` makes of the parsers (``--check``), and the
  README's relative links lead to files under docs/.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
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
DOC_FILES = [README, *sorted((ROOT / "docs").glob("*.md"))]
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


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


README_TEXT = README.read_text(encoding="utf-8")
TEXTS = {_rel(p): p.read_text(encoding="utf-8") for p in DOC_FILES}
# (file, line, code, no-run) of every block of every file
PYTHON_BLOCKS = [(f, *b) for f, t in TEXTS.items() for b in fenced_blocks(t, "python")]
BASH_BLOCKS = [(f, *b) for f, t in TEXTS.items() for b in fenced_blocks(t, "bash")]


def test_the_docs_have_python_and_bash_blocks_and_no_run_exceptions_are_rare():
    in_readme = [b for b in PYTHON_BLOCKS if b[0] == "README.md"]
    assert len(in_readme) >= 2 and sum(b[0] == "README.md" for b in BASH_BLOCKS) >= 3
    assert len(PYTHON_BLOCKS) >= 6 and len(BASH_BLOCKS) >= 10
    assert not any(skip for *_, skip in in_readme)
    assert sum(skip for *_, skip in PYTHON_BLOCKS) <= 1


@pytest.mark.parametrize(
    "file, line, code, skip", PYTHON_BLOCKS, ids=[f"{f}:{n}" for f, n, _, _ in PYTHON_BLOCKS]
)
def test_python_block_runs_as_written_in_a_fresh_interpreter(tmp_path, file, line, code, skip):
    where = f"{file}:{line}"
    if skip:
        pytest.skip(f"{where} is marked readme-test: no-run")
    script = tmp_path / f"block_line_{line}.py"
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
        pytest.fail(f"{where}: the block ran over {PYTHON_BLOCK_TIMEOUT_S} s")
    assert proc.returncode == 0, f"{where} failed:\n{code}\n{proc.stderr[-4000:]}"


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


# (where, arguments) of every contour-env command of every bash block
BASH_COMMANDS = [
    (f"{f}:{n}", cmd) for f, n, code, _ in BASH_BLOCKS for cmd in contour_env_commands(code)
]


def test_the_bash_blocks_use_contour_env():
    assert {"compare", "ilc", "train", "evaluate", "models"} <= {c[0] for _, c in BASH_COMMANDS}
    readme = {c[0] for w, c in BASH_COMMANDS if w.startswith("README.md:")}
    assert {"compare", "ilc", "train", "identify", "benchmark"} <= readme


@pytest.mark.parametrize("sub", sorted({c[0] for _, c in BASH_COMMANDS}))
def test_every_subcommand_of_the_bash_blocks_has_help(sub):
    from contour_env.app.cli import build_parser

    with contextlib.redirect_stdout(io.StringIO()), pytest.raises(SystemExit) as exc:
        build_parser().parse_args([sub, "-h"])
    assert exc.value.code == 0


@pytest.mark.parametrize(
    "where, args", BASH_COMMANDS, ids=[f"{w} {' '.join(c)[:50]}" for w, c in BASH_COMMANDS]
)
def test_every_contour_env_command_of_the_bash_blocks_parses(where, args):
    from contour_env.app.cli import build_parser

    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            ns = build_parser().parse_args(args)
    except SystemExit as exc:  # argparse: exit 2 with the message on stderr
        pytest.fail(f"{where}: contour-env {' '.join(args)}: {err.getvalue()} (exit {exc.code})")
    assert callable(ns.func)


def test_the_quick_bench_of_the_readme_parses_with_its_short_settings():
    from contour_env.app.cli import build_parser

    ns = build_parser().parse_args(["bench", "--quick"])
    assert ns.quick and ns.seconds is None and ns.repeats is None


# ------------------------------------------------------------------ the README as a landing page

README_MAX_LINES = 250


def test_the_readme_is_a_landing_page_whose_links_lead_into_docs():
    assert len(README_TEXT.splitlines()) <= README_MAX_LINES
    links = re.findall(r"(!?)\[[^\]]*\]\(([^)\s]+)\)", README_TEXT)
    relative = [(img, t) for img, t in links if not re.match(r"[a-z]+:|#", t)]
    assert relative
    for img, target in relative:
        path = ROOT / target.split("#")[0]
        assert path.exists(), f"README links to {target}, which does not exist"
        if not img:
            assert target.startswith("docs/"), f"README link {target} is not under docs/"
    # every topic page is one click away
    for page in ("env", "plants", "paths", "controllers", "ilc", "training", "machine", "speed"):
        assert f"](docs/{page}.md)" in README_TEXT, page


def test_every_page_of_the_docs_folder_is_in_the_site_nav():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for page in sorted((ROOT / "docs").glob("*.md")):
        assert re.search(rf":\s+{re.escape(page.name)}\s*$", nav, re.M), page.name


def test_the_shipped_agents_card_of_the_readme_is_the_one_on_the_training_page(load_script):
    mod = load_script("residual_scorecard")
    from agents.rl.models import MODELS_DIR

    table = mod.markdown(json.loads((MODELS_DIR / "scorecard.json").read_text())["cards"])
    assert table in README_TEXT and table in TEXTS["docs/training.md"]


# ------------------------------------------------------------------ the command-line reference


def test_the_cli_reference_is_current_whatever_the_terminal_width():
    for columns in ("40", "250"):
        env = {**os.environ, "COLUMNS": columns}
        proc = subprocess.run(
            [sys.executable, str(ROOT / "scripts" / "cli_doc.py"), "--check"],
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert proc.returncode == 0, f"COLUMNS={columns}: {proc.stderr}"


def test_the_cli_reference_has_a_section_and_every_option_of_every_subcommand(load_script):
    from contour_env.app.cli import build_parser

    text = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, parser in sub.choices.items():
        section = text.split(f"\n## {name}\n", 1)[1].split("\n## ", 1)[0]
        for action in parser._actions:
            for flag in action.option_strings:
                if flag not in ("-h", "--help"):
                    assert flag in section, f"{name}: {flag}"
    # written atomically: the file is replaced whole, and a fresh render is the same text
    assert load_script("cli_doc").render() == text


# ------------------------------------------------------------------ generated tables


# each generated table on the page of its topic
TABLE_PAGES = {
    "controller_table": "docs/controllers.md",
    "lee2012_table": "docs/controllers.md",
    "ilc_table": "docs/ilc.md",
    "residual_table": "docs/training.md",
    "corner_blend_table": "docs/paths.md",
}


def test_every_generated_section_has_its_generator_a_table_and_its_page(readme_figures):
    mod = readme_figures
    where = mod.locate()  # README.md and docs/*.md; a section in two files is an error
    assert set(where) == set(mod.GENERATORS) == set(TABLE_PAGES)
    assert {n: _rel(p) for n, p in where.items()} == TABLE_PAGES
    for name, path in where.items():
        body = mod.sections(path.read_text(encoding="utf-8"))[name]
        assert body.startswith("| ") and body.endswith("|\n"), name


def test_readme_figures_check_passes_on_the_docs_as_they_are(readme_figures):
    # the stored tables against themselves: the search over the files, nothing rendered
    mod = readme_figures
    where = mod.locate()
    current = {n: mod.sections(p.read_text(encoding="utf-8"))[n] for n, p in where.items()}
    gens = {n: (lambda t=t: t) for n, t in current.items()}
    assert mod.update_files(check=True, generators=gens, log=lambda s: None) == 0


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


def test_sections_are_found_in_whichever_file_holds_them_and_duplicates_are_errors(
    tmp_path, readme_figures
):
    mod = readme_figures
    first, second = tmp_path / "README.md", tmp_path / "page.md"
    first.write_text(SAMPLE.split("Between the tables.")[0])
    # another script's table (docs/FILES.md: scripts/files_doc.py) is left to that script
    other = (
        "<!-- BEGIN generated: gamma (scripts/files_doc.py) -->\n| g |\n"
        "<!-- END generated: gamma -->\n"
    )
    second.write_text("# page\n" + other + SAMPLE.split("Between the tables.")[1])
    assert {n: p.name for n, p in mod.locate([first, second]).items()} == {
        "alpha": "README.md",
        "beta": "page.md",
    }
    calls = []
    gens = _fake({"alpha": "| a |\n|---|\n| 1 |", "beta": "| b |\n|---|\n| 9 |"}, calls)
    quiet = dict(generators=gens, stamp_text=" (S) ", log=lambda s: None)
    assert mod.update_files([first, second], check=True, **quiet) == 1
    assert mod.update_files([first, second], **quiet) == 0
    assert "| 9 |" in second.read_text() and "| 9 |" not in first.read_text()
    assert other in second.read_text()
    assert "(typed; not stamped yet)" not in first.read_text()  # never stamped: stamped now
    assert mod.update_files([first, second], check=True, **quiet) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["README.md", "page.md"]
    second.write_text(first.read_text())
    with pytest.raises(ValueError, match="alpha is in .*README.md and in .*page.md"):
        mod.locate([first, second])


def test_main_regenerates_a_copy_of_the_page_with_a_fake_generator(
    tmp_path, monkeypatch, readme_figures
):
    mod = readme_figures
    page = mod.locate()["controller_table"]
    page_text = page.read_text(encoding="utf-8")
    copy = tmp_path / page.name
    shutil.copy(page, copy)
    table = "| plant | controller |\n|---|---|\n| `x` | `pd` |"
    monkeypatch.setitem(mod.GENERATORS, "controller_table", lambda: table)
    monkeypatch.setattr(mod, "git_commit", lambda root=mod.ROOT: "abc1234-dirty")
    assert mod.main(["--only", "controller_table", "--readme", str(copy), "--check"]) == 1
    assert copy.read_text() == page_text
    assert mod.main(["--only", "controller_table", "--readme", str(copy)]) == 0
    new = copy.read_text()
    assert mod.sections(new)["controller_table"] == table + "\n"
    stamp = mod.stamps(new)["controller_table"]
    assert re.fullmatch(
        r"\(scripts/readme_figures.py; \d{4}-\d\d-\d\d, commit abc1234-dirty\)", stamp
    )
    for name in mod.sections(page_text):
        if name != "controller_table":
            assert mod.sections(new)[name] == mod.sections(page_text)[name]


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
