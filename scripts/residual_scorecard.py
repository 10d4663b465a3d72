"""The shipped residual agents against their bases on the held-out suite and the named cases.

    python scripts/residual_scorecard.py [--models DIR[,DIR...]] [--out FILE] [--workers N]
        [--markdown]

For every model DIR (default: the shipped agents, ``agents/models/*``) every program of
``tests/data/heldout/`` the plant takes and every named case of its plant is run with the agent
and with its base controller (:mod:`agents.rl.scorecard`, seed 0). Writes ``--out`` (default
``agents/models/scorecard.json``, atomically): one card per agent with its rows, the digest of
its ``agent.json`` + ``model.zip`` (so a stale card is detected by
``tests/agents/test_scorecard.py``) and the summary the acceptance reads: the worst ratio
agent / base over every target, the mean ratio over the held-out programs, of the RMS and of
the max contour error (issue 48). The held-out programs are the shared ones and the plant's own
(``tests/data/heldout/<plant>/``: a part at 5x its top training feed, corners turned off the
axes). ``--markdown`` prints the README's table.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from agents.rl.models import MODELS_DIR, list_models
from agents.rl.scorecard import scorecard
from contour_env.io import atomic_write_json

SCORECARD = MODELS_DIR / "scorecard.json"


def add_models_option(ap: argparse.ArgumentParser) -> None:
    """``--models DIR[,DIR...]`` (read by :func:`model_dirs`); also residual_benchmark.py's."""
    ap.add_argument("--models", help="comma-separated model DIRs (default: the shipped agents)")


def model_dirs(models: str | None) -> list[Path]:
    """The DIRs of ``--models``, or the shipped agents' (those that load)."""
    if models:
        return [Path(d) for d in models.split(",") if d]
    return [Path(r["path"]) for r in list_models() if "error" not in r]


def _r(x) -> str:
    return "—" if x is None else f"{x:.3f}"


def markdown(cards: list[dict]) -> str:
    """The README's summary: per agent, what keep-best kept and the agent / base RMS ratios
    (held-out mean and worst, named cases' worst, worst of all); the per-target figures are the
    README's generated ``residual_table``."""
    lines = [
        "| agent (base) | kept | held-out programs: mean RMS / max | held-out: worst RMS / max "
        "| named cases: worst RMS / max | worst of all: RMS / max |",
        "|---|---|---|---|---|---|",
    ]
    for c in cards:
        kept = {"base": "the base (no checkpoint passed)", "best-validation": "best checkpoint"}
        what = kept.get(c["kept"], c["kept"])
        if (c.get("release") or {}).get("failures"):
            what = "the base (the release gate refused the agent)"
        lines.append(
            f"| `{c['model']}` ({c['base']}) | {what} | "
            f"{_r(c['heldout_mean_ratio'])} / {_r(c.get('heldout_max_mean_ratio'))} | "
            f"{_r(c['heldout_worst_ratio'])} / {_r(c.get('heldout_max_worst_ratio'))} | "
            f"{_r(c['cases_worst_ratio'])} / {_r(c.get('cases_max_worst_ratio'))} | "
            f"{_r(c['worst_ratio'])} / {_r(c.get('max_worst_ratio'))} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_models_option(ap)
    ap.add_argument("--out", default=str(SCORECARD), help="JSON file to write")
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--markdown", action="store_true", help="print the README table")
    args = ap.parse_args(argv)
    cards = []
    for d in model_dirs(args.models):
        t0 = time.perf_counter()

        def show(row):
            print(
                f"  {row['target']:34s} base {row['base_rms_contour_error_um']:8.3f} / "
                f"{row['base_max_contour_error_um']:8.2f} µm  agent "
                f"{row['agent_rms_contour_error_um']:8.3f} / "
                f"{row['agent_max_contour_error_um']:8.2f} µm  RMS ratio {_r(row['rms_ratio'])}"
                f"  max ratio {_r(row.get('max_ratio'))}",
                flush=True,
            )

        print(f"{d}:", flush=True)
        card = scorecard(d, workers=args.workers, progress=show)
        card["score_wall_s"] = time.perf_counter() - t0
        print(
            f"  held-out mean RMS / max ratio {_r(card['heldout_mean_ratio'])} / "
            f"{_r(card['heldout_max_mean_ratio'])}, held-out worst "
            f"{_r(card['heldout_worst_ratio'])} / {_r(card['heldout_max_worst_ratio'])}, named "
            f"cases worst {_r(card['cases_worst_ratio'])} / {_r(card['cases_max_worst_ratio'])}"
            f" ({card['score_wall_s']:.0f} s)",
            flush=True,
        )
        cards.append(card)
    atomic_write_json(args.out, {"cards": cards})
    print(f"wrote {args.out}")
    if args.markdown:
        print(markdown(cards))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
