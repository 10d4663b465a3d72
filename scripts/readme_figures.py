"""Regenerate the README's generated tables in place, from the scripts that compute them.

    python scripts/readme_figures.py [--only NAME[,NAME...]] [--check] [--readme README.md]

Each generated table sits between two HTML comments (invisible on GitHub)::

    <!-- BEGIN generated: NAME (scripts/readme_figures.py; DATE, commit HASH) -->
    | ... the table ... |
    <!-- END generated: NAME -->

and is replaced by what its generator prints now; the BEGIN line is stamped with the date and
the commit (``git rev-parse --short HEAD``, ``-dirty`` when tracked files have uncommitted
changes). Text outside the markers is never touched, and the README is written atomically.

Generators (all run the project's own scoring; times on a 2-core machine):

- ``controller_table``: default gains and loop margins (``scripts/controller_table.py``, ~1 min);
- ``lee2012_table``: the defaults on Lee 2012's circles beside Tables 2–3
  (``scripts/lee2012_table.py``, ~10 s);
- ``residual_table``: the shipped residual agents against their bases
  (``scripts/residual_benchmark.py --markdown``, several minutes: lm-circle3d is 159 000 steps);
- ``ilc_table``: the repeated-batch ILC benchmark (``scripts/ilc_benchmark.py --markdown``,
  ~40 s);
- ``corner_blend_table``: pd, ccc and adaptive-ccc on ``corner-blend`` over seeds 0–4
  (``scripts/corner_blend_table.py``, ~20 s).

``--only`` runs the named ones; ``--check`` writes nothing and exits 1 when a table would
change (the stamps are ignored: a table is stale when its content differs, not its date).
A marker in the README without a generator, or a generator named in ``--only`` without its
markers, is an error.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import importlib.util
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

MARKER = re.compile(
    r"(?P<begin><!-- BEGIN generated: (?P<name>[\w-]+)(?P<stamp>[^\n]*?)-->\n)"
    r"(?P<body>.*?)"
    r"(?P<end><!-- END generated: (?P=name) -->)",
    re.DOTALL,
)


def _script(name: str):
    """A module of scripts/ (not a package) loaded from its file."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    file = ROOT / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"_readme_{name}", file)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def controller_table() -> str:
    return "\n".join(_script("controller_table").rows())


def lee2012_table() -> str:
    mod = _script("lee2012_table")
    return "\n".join(mod.table(list(mod.LEE)))


def residual_table() -> str:
    from agents.rl.models import list_models

    mod = _script("residual_benchmark")
    rows = []
    for r in list_models():
        if "error" not in r:
            rows += mod.benchmark_model(Path(r["path"]))
    return mod.format_markdown(rows)


def ilc_table() -> str:
    mod = _script("ilc_benchmark")
    n = 10
    rows, _ = mod.run_benchmark(
        ["sharp-corner", "hsm2-circle-II"],
        list(mod.CONDITIONS),
        list(mod.LEARNING_CONTROLLERS),
        n,
        1,
        mod.DEFAULT_NOISE_M,
        log=lambda s: None,
    )
    return mod.format_markdown(rows, n)


def corner_blend_table() -> str:
    mod = _script("corner_blend_table")
    return mod.format_markdown(mod.measure(["pd", "ccc", "adaptive-ccc"], 5), 5)


GENERATORS: dict[str, Callable[[], str]] = {
    "controller_table": controller_table,
    "lee2012_table": lee2012_table,
    "residual_table": residual_table,
    "ilc_table": ilc_table,
    "corner_blend_table": corner_blend_table,
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
    date = date or _dt.date.today().isoformat()
    commit = commit or git_commit()
    return f" (scripts/readme_figures.py; {date}, commit {commit}) "


def sections(text: str) -> dict[str, str]:
    """The body (table) of every generated section, by name."""
    return {m["name"]: m["body"] for m in MARKER.finditer(text)}


def stamps(text: str) -> dict[str, str]:
    """The stamp of every generated section's BEGIN line, by name."""
    return {m["name"]: m["stamp"].strip() for m in MARKER.finditer(text)}


def replace_sections(text: str, tables: dict[str, str], stamp_text: str) -> str:
    """``text`` with the body of each section named in ``tables`` replaced (and its BEGIN
    line re-stamped); other sections and all text outside the markers unchanged."""
    found = sections(text)
    missing = sorted(set(tables) - set(found))
    if missing:
        raise ValueError(f"README: no generated section for {', '.join(missing)}")

    def sub(m: re.Match) -> str:
        name = m["name"]
        if name not in tables:
            return m.group(0)
        body = tables[name].rstrip("\n") + "\n"
        return f"<!-- BEGIN generated: {name}{stamp_text}-->\n{body}{m['end']}"

    return MARKER.sub(sub, text)


def update_readme(
    path=README,
    *,
    only=None,
    check: bool = False,
    generators: dict[str, Callable[[], str]] | None = None,
    stamp_text: str | None = None,
    log=print,
) -> int:
    """Regenerate the sections of the README at ``path``; returns the exit status (``check``:
    1 when a table would change, nothing written)."""
    from contour_env.io import atomic_write_text

    generators = GENERATORS if generators is None else generators
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    present = sections(text)
    unknown = sorted(set(present) - set(generators))
    if unknown:
        raise ValueError(f"README: generated section(s) without a generator: {unknown}")
    names = list(present) if only is None else list(only)
    bad = sorted(set(names) - set(generators))
    if bad:
        raise ValueError(f"--only: unknown generator(s) {bad}; known: {', '.join(generators)}")
    tables = {}
    for name in names:
        log(f"generating {name} ...")
        tables[name] = generators[name]().rstrip("\n") + "\n"
    stale = [n for n in names if tables[n] != present.get(n)]
    if check:
        for n in stale:
            log(f"{path.name}: {n} is out of date")
        return 1 if stale else 0
    # a table that did not change keeps its stamp (the commit it was made at still made it),
    # unless it was never stamped
    old_stamps = stamps(text)
    write = {n: t for n, t in tables.items() if n in stale or "commit" not in old_stamps[n]}
    if write:
        new = replace_sections(text, write, stamp_text if stamp_text is not None else stamp())
        atomic_write_text(path, new)
    log(
        f"{path.name}: regenerated {', '.join(names) or 'nothing'}; "
        f"changed: {', '.join(stale) or 'none'}"
    )
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help=f"comma-separated, of: {', '.join(GENERATORS)}")
    ap.add_argument(
        "--check", action="store_true", help="exit 1 if a table would change; write nothing"
    )
    ap.add_argument("--readme", default=str(README), help="the README to update")
    args = ap.parse_args(argv)
    only = [n.strip() for n in args.only.split(",") if n.strip()] if args.only else None
    try:
        return update_readme(args.readme, only=only, check=args.check)
    except ValueError as exc:
        ap.error(str(exc))


if __name__ == "__main__":
    raise SystemExit(main())
