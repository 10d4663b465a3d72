"""Regenerate the generated tables of the README and the docs pages in place, from a benchmark
report.

    python scripts/readme_figures.py [--only NAME[,NAME...]] [--check] [--readme FILE ...]
        [--report DIR | --out DIR [--workers N]]

The tables live where their topic is (``docs/controllers.md``, ``docs/ilc.md``,
``docs/paths.md``, ``docs/training.md``): each generated section is found in whichever of
README.md and ``docs/*.md`` holds it (:data:`DOCS`; ``--readme FILE``, repeatable, names the
files instead). A section in two files is an error; a section stamped by another script
(``(scripts/files_doc.py)`` in docs/FILES.md) is that script's and is left alone.

The tables come from the records of ``contour-env benchmark --suite readme`` (the ``readme``
suite runs exactly what the tables need, :data:`contour_env.app.benchmark.suite.README_TABLES`):
without ``--report`` the script runs ``contour-env benchmark --suite readme --out DIR
[--workers N]`` first (``DIR`` default ``out/readme-report``; with ``--only``, the suite
``readme:NAME[,NAME...]`` of those tables' runs only), with ``--report DIR`` it reads the
``results.json`` of an earlier run. Each table is rendered from the records
(:mod:`contour_env.app.benchmark.readme_tables`; a run the report lacks, or one that failed, is an
error). Each generated table sits between two HTML comments (invisible on GitHub)::

    <!-- BEGIN generated: NAME (scripts/readme_figures.py; DATE, commit HASH) -->
    | ... the table ... |
    <!-- END generated: NAME -->

and is replaced by its rendering; the BEGIN line is stamped with the date and the commit of
the report (its ``meta``: the UTC date of its timestamp, ``code_version``'s commit, short,
``-dirty`` when tracked files had uncommitted changes). Text outside the markers is never
touched, and each file is written atomically.

Tables (runs of the ``readme`` suite; times on a 2-core machine, serial):

- ``controller_table``: default gains and loop margins (``design`` runs, ~1 min;
  ``scripts/controller_table.py`` prints it alone);
- ``lee2012_table``: the defaults on Lee 2012's circles beside Tables 2–3 (~10 s;
  ``scripts/lee2012_table.py``);
- ``residual_table``: the shipped residual agents against their bases (``residual`` runs,
  several minutes: lm-circle3d is 159 000 steps; ``scripts/residual_benchmark.py --markdown``);
- ``ilc_table``: the repeated-batch ILC benchmark, 10 trials, seed 0 (~40 s;
  ``scripts/ilc_benchmark.py --markdown``);
- ``corner_blend_table``: pd, ccc and adaptive-ccc on ``corner-blend`` over seeds 0–4
  (~20 s; ``scripts/corner_blend_table.py``).

``--only`` renders the named ones; ``--check`` writes nothing and exits 1 when a table would
change (the stamps are ignored: a table is stale when its content differs, not its date).
A table that did not change keeps its stamp. A marker without a generator, or a table named in
``--only`` without its markers, is an error.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import functools
import json
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
# the files searched for generated sections: the README and every docs page
DOCS = [README, *sorted((ROOT / "docs").glob("*.md"))]
REPORT_DIR = ROOT / "out" / "readme-report"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from contour_env.app.benchmark import readme_tables  # noqa: E402
from contour_env.app.benchmark.suite import README_TABLES  # noqa: E402

MARKER = re.compile(
    r"(?P<begin><!-- BEGIN generated: (?P<name>[\w-]+)(?P<stamp>[^\n]*?)-->\n)"
    r"(?P<body>.*?)"
    r"(?P<end><!-- END generated: (?P=name) -->)",
    re.DOTALL,
)

# a section stamped by another script is that script's (docs/FILES.md: scripts/files_doc.py)
OTHER_SCRIPT = re.compile(r"\(scripts/(?!readme_figures\.py)")


def _own(m: re.Match) -> bool:
    return not OTHER_SCRIPT.match(m["stamp"].strip())


# where the report comes from (set by main) and, once read, its results.json
SOURCE: dict = {"report": None, "out": REPORT_DIR, "workers": 1, "only": None, "data": None}


def run_benchmark(out, tables=None, workers=1) -> dict:
    """``contour-env benchmark --suite readme[:TABLES] --out OUT --workers N``; its
    results.json. A failed run is a ``RuntimeError``."""
    from contour_env.app import cli_benchmark

    suite = "readme" if tables is None else "readme:" + ",".join(tables)
    argv = ["--suite", suite, "--out", str(out), "--workers", str(workers)]
    print(f"contour-env benchmark {' '.join(argv)}", flush=True)
    if cli_benchmark.main(argv) != 0:
        raise RuntimeError(f"contour-env benchmark --suite {suite} failed (see {out}/report.md)")
    return read_report(out)


def read_report(path) -> dict:
    """A report's results.json (``path``: the file or its folder)."""
    path = Path(path)
    file = path / "results.json" if path.is_dir() else path
    if not file.is_file():
        raise ValueError(f"--report: {file}: no such file (run contour-env benchmark first)")
    return json.loads(file.read_text(encoding="utf-8"))


def report() -> dict:
    """The report the tables come from: read once (``--report``) or run once."""
    if SOURCE["data"] is None:
        if SOURCE["report"] is not None:
            SOURCE["data"] = read_report(SOURCE["report"])
        else:
            SOURCE["data"] = run_benchmark(SOURCE["out"], SOURCE["only"], SOURCE["workers"])
    return SOURCE["data"]


def render(name: str) -> str:
    """The README table ``name`` from the report's records."""
    return readme_tables.render(name, report()["records"])


GENERATORS: dict[str, Callable[[], str]] = {
    name: functools.partial(render, name) for name in README_TABLES
}


def git_commit(root: Path = ROOT) -> str:
    """``git rev-parse --short HEAD``, with ``-dirty`` when tracked files are modified;
    ``unknown`` outside a git checkout."""

    def git(*args) -> str:
        return subprocess.run(
            ["git", *args], cwd=root, capture_output=True, text=True, check=True, timeout=30
        ).stdout.strip()

    try:
        commit = git("rev-parse", "--short", "HEAD")
        dirty = bool(git("status", "--porcelain", "--untracked-files=no"))
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return f"{commit}-dirty" if dirty else commit


def stamp(date: str | None = None, commit: str | None = None) -> str:
    """The BEGIN line's stamp: the date and commit of the report the tables came from (when
    one was read), else today and the checkout's commit."""
    if SOURCE["data"] is not None and (date is None or commit is None):
        rdate, rcommit = readme_tables.report_stamp(SOURCE["data"])
        date, commit = date or rdate, commit or rcommit
    date = date or _dt.date.today().isoformat()
    commit = commit or git_commit()
    return f" (scripts/readme_figures.py; {date}, commit {commit}) "


def sections(text: str) -> dict[str, str]:
    """The body (table) of every generated section, by name."""
    return {m["name"]: m["body"] for m in MARKER.finditer(text) if _own(m)}


def stamps(text: str) -> dict[str, str]:
    """The stamp of every generated section's BEGIN line, by name."""
    return {m["name"]: m["stamp"].strip() for m in MARKER.finditer(text) if _own(m)}


def replace_sections(text: str, tables: dict[str, str], stamp_text: str) -> str:
    """``text`` with the body of each section named in ``tables`` replaced (and its BEGIN
    line re-stamped); other sections and all text outside the markers unchanged."""
    found = sections(text)
    missing = sorted(set(tables) - set(found))
    if missing:
        raise ValueError(f"no generated section for {', '.join(missing)}")

    def sub(m: re.Match) -> str:
        name = m["name"]
        if name not in tables or not _own(m):
            return m.group(0)
        body = tables[name].rstrip("\n") + "\n"
        return f"<!-- BEGIN generated: {name}{stamp_text}-->\n{body}{m['end']}"

    return MARKER.sub(sub, text)


def locate(paths=None) -> dict[str, Path]:
    """The file that holds each generated section, by name (``paths`` default :data:`DOCS`); a
    section in two files is a ``ValueError``."""
    where: dict[str, Path] = {}
    for p in [Path(p) for p in (DOCS if paths is None else paths)]:
        for name in sections(p.read_text(encoding="utf-8")):
            if name in where:
                raise ValueError(f"generated section {name} is in {where[name]} and in {p}")
            where[name] = p
    return where


def update_readme(path=README, **kwargs) -> int:
    """Regenerate the sections of the one file at ``path`` (:func:`update_files`)."""
    return update_files([path], **kwargs)


def update_files(
    paths=None,
    *,
    only=None,
    check: bool = False,
    generators: dict[str, Callable[[], str]] | None = None,
    stamp_text: str | None = None,
    log=print,
) -> int:
    """Regenerate the generated sections of ``paths`` (default :data:`DOCS`), each in the file
    that holds it; returns the exit status (``check``: 1 when a table would change, nothing
    written)."""
    from contour_env.io import atomic_write_text

    generators = GENERATORS if generators is None else generators
    paths = [Path(p) for p in (DOCS if paths is None else paths)]
    texts = {p: p.read_text(encoding="utf-8") for p in paths}
    where = locate(paths)
    present = {n: sections(texts[p])[n] for n, p in where.items()}
    unknown = sorted(set(present) - set(generators))
    if unknown:
        raise ValueError(f"generated section(s) without a generator: {unknown}")
    names = list(present) if only is None else list(only)
    bad = sorted(set(names) - set(generators))
    if bad:
        raise ValueError(f"--only: unknown generator(s) {bad}; known: {', '.join(generators)}")
    missing = sorted(set(names) - set(present))
    if missing:
        raise ValueError(f"no generated section for {', '.join(missing)}")
    tables = {}
    for name in names:
        log(f"generating {name} ...")
        tables[name] = generators[name]().rstrip("\n") + "\n"
    stale = [n for n in names if tables[n] != present.get(n)]
    if check:
        for n in stale:
            log(f"{where[n].name}: {n} is out of date")
        return 1 if stale else 0
    # a table that did not change keeps its stamp (the commit it was made at still made it),
    # unless it was never stamped
    for p, text in texts.items():
        old_stamps = stamps(text)
        write = {
            n: t
            for n, t in tables.items()
            if where[n] == p and (n in stale or "commit" not in old_stamps[n])
        }
        if write:
            new = replace_sections(text, write, stamp_text if stamp_text is not None else stamp())
            atomic_write_text(p, new)
    for p in paths:
        mine = [n for n in names if where[n] == p]
        if mine:
            changed = [n for n in stale if where[n] == p]
            log(f"{p.name}: regenerated {', '.join(mine)}; changed: {', '.join(changed) or 'none'}")
    if not names:
        log("regenerated nothing")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help=f"comma-separated, of: {', '.join(GENERATORS)}")
    ap.add_argument(
        "--check", action="store_true", help="exit 1 if a table would change; write nothing"
    )
    ap.add_argument(
        "--readme",
        action="append",
        metavar="FILE",
        help="a file to update (repeatable; default README.md and docs/*.md, each table where it "
        "is)",
    )
    ap.add_argument(
        "--report",
        metavar="DIR",
        help="render from this contour-env benchmark --suite readme report (its results.json) "
        "instead of running the suite",
    )
    ap.add_argument(
        "--out",
        metavar="DIR",
        default=str(REPORT_DIR),
        help="where the suite's report is written when it is run (default out/readme-report)",
    )
    ap.add_argument("--workers", default="1", metavar="N", help="local processes for the runs")
    args = ap.parse_args(argv)
    only = [n.strip() for n in args.only.split(",") if n.strip()] if args.only else None
    SOURCE.update(report=args.report, out=args.out, workers=args.workers, only=only, data=None)
    try:
        return update_files(args.readme, only=only, check=args.check)
    except ValueError as exc:
        ap.error(str(exc))
    except RuntimeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    raise SystemExit(main())
