"""``contour-env benchmark``: the whole benchmark in one command, and a report people read.

- :mod:`.suite`: what the ``quick``, ``paper``, ``full`` and ``readme`` suites run
  (:class:`RunSpec`);
- :mod:`.design`, :mod:`.residual`: the ``design`` (gains, margins) and ``residual`` (shipped
  agent against its base) runs;
- :mod:`.readme_tables`: the README's generated tables, rendered from ``results.json``;
- :mod:`.published`: the seed papers' published figures, as data;
- :mod:`.circular`: the circular-test section (ISO 230-4 on every named 2- and 3-axis plant):
  its runs, tables, readings and polar plots;
- :mod:`.runs`: one run, a pure function of its spec;
- :mod:`.runner`: the runs serially, on local processes (``--workers N``) or as Ray tasks
  (``--ray auto|ADDRESS``), with identical figures;
- :mod:`.report`: ``results.json``, ``report.md``, ``report.html`` and the figures.
"""

from __future__ import annotations

from .suite import SUITES, RunSpec, get_suite

__all__ = ["SUITES", "RunSpec", "get_suite"]
