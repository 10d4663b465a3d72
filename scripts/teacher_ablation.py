"""The teacher ablation (issue 48): RL only, teacher only and teacher + RL, each with and without
the envelope, several seeds, the same training-time budget, scored on the held-out suite and the
plant's named cases.

    python scripts/teacher_ablation.py [--plant friction-table] [--base ccc]
        [--budget 240] [--seeds 0,1,2] [--variants rl,teacher,teacher+rl,...] [--parallel 2]
        [--work out/teacher_ablation] [--out docs/teacher_ablation_<plant>.json] [--markdown]

Variants (``contour-env train --plant P --paths families --base B --time-budget S --seed N``
and):

| variant | options |
|---|---|
| ``rl`` | ``--teacher none --envelope`` (SAC from scratch, the recipe before the teacher) |
| ``rl-noenv`` | ``--teacher none --no-envelope`` |
| ``teacher`` | ``--teacher ilc-contour --no-fine-tune --envelope`` (the pretrained student) |
| ``teacher-noenv`` | ``--teacher ilc-contour --no-fine-tune --no-envelope`` |
| ``teacher+rl`` | ``--teacher ilc-contour --envelope`` (the shipped recipe) |
| ``teacher+rl-noenv`` | ``--teacher ilc-contour --no-envelope`` |

Everything else is the trainer's default (SAC on 4 envs, the path frame, gate, axis
observation, fade at rest, keep-best with the base as a candidate and the max rule). The
budget is training time with the teacher in it (a teacher-only run ends when its student is
fitted). Each run is its own process, ``--parallel`` at a time; a run that exists in ``--work``
with its ``agent.json`` is not trained again. Each kept agent is scored by
:mod:`agents.rl.scorecard` (the card cached in the run's folder, so a second call with more
variants scores only the new runs). Writes ``--out`` (atomically): per run its card, per variant the
mean, min and max over the seeds of the held-out mean and worst RMS ratio, the held-out mean
and worst max ratio and how many seeds kept the base. ``--markdown`` prints the README's table.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

from residual_ablation import _stats, train_all  # noqa: E402

VARIANTS = {
    "rl": ["--teacher", "none", "--envelope"],
    "rl-noenv": ["--teacher", "none", "--no-envelope"],
    "teacher": ["--teacher", "ilc-contour", "--no-fine-tune", "--envelope"],
    "teacher-noenv": ["--teacher", "ilc-contour", "--no-fine-tune", "--no-envelope"],
    "teacher+rl": ["--teacher", "ilc-contour", "--envelope"],
    "teacher+rl-noenv": ["--teacher", "ilc-contour", "--no-envelope"],
}
KEYS = (
    "heldout_mean_ratio",
    "heldout_worst_ratio",
    "heldout_max_mean_ratio",
    "heldout_max_worst_ratio",
    "worst_ratio",
    "max_worst_ratio",
)


def command(plant, base, budget, seed, variant, out, extra=()) -> list[str]:
    return [
        sys.executable, "-m", "contour_env.app.cli", "train", "--plant", plant, "--paths",
        "families", "--base", base, "--time-budget", str(budget), "--eval-every-s", "60",
        "--learning-rate-final", "3e-5", "--seed", str(seed), *VARIANTS[variant],
        "--out", str(out), "--no-progress", *extra,
    ]  # fmt: skip


def summarise(cards_by_variant: dict) -> dict:
    out = {}
    for variant, cards in cards_by_variant.items():
        out[variant] = {key: _stats([c[key] for c in cards]) for key in KEYS}
        out[variant]["kept_base"] = sum(c["kept"] == "base" for c in cards)
        out[variant]["seeds"] = len(cards)
    return out


def markdown(result: dict) -> str:
    """Per variant, mean (min–max) over the seeds of the kept agent's ratios to its base."""

    def cell(s):
        if s["mean"] is None:
            return "not completed on every part"
        return f"{s['mean']:.2f} ({s['min']:.2f}–{s['max']:.2f})"

    lines = [
        "| variant | kept: held-out RMS mean | kept: RMS worst | kept: max mean | kept: max "
        "worst | kept as base | final policy: RMS mean | final: RMS worst | final: max worst "
        "| command |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    finals = result.get("summary_final", {})
    for variant, s in result["summary"].items():
        f = finals.get(variant)
        fin = (
            f"{cell(f['heldout_mean_ratio'])} | {cell(f['heldout_worst_ratio'])} | "
            f"{cell(f['heldout_max_worst_ratio'])}"
            if f
            else "– | – | –"
        )
        cmd = (
            f"`python scripts/teacher_ablation.py --plant {result['plant']} --variants "
            f"{variant} --budget {result['budget_s']:g} --seeds "
            f"{','.join(str(x) for x in result['seeds'])}`"
        )
        lines.append(
            f"| `{variant}` | {cell(s['heldout_mean_ratio'])} | {cell(s['heldout_worst_ratio'])}"
            f" | {cell(s['heldout_max_mean_ratio'])} | {cell(s['heldout_max_worst_ratio'])} | "
            f"{s['kept_base']} of {s['seeds']} | {fin} | {cmd} |"
        )
    return "\n".join(lines)


def _card(out: Path, workers: int) -> dict:
    """The run's scorecard, cached in its folder (``card.json``) for the agent it scored."""
    import json

    from agents.rl.scorecard import model_digest, scorecard
    from contour_env.io import atomic_write_json

    cached = out / "card.json"
    if cached.is_file():
        card = json.loads(cached.read_text())
        if card.get("model_digest") == model_digest(out):
            return card
    card = scorecard(out, workers=workers)
    atomic_write_json(cached, card)
    return card


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant", default="friction-table")
    ap.add_argument("--base", default="ccc")
    ap.add_argument("--budget", type=float, default=240.0, help="training time per run (s)")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--parallel", type=int, default=2)
    ap.add_argument("--work", default="out/teacher_ablation")
    ap.add_argument("--out", default=None, help="JSON (default docs/teacher_ablation_<plant>.json)")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--train-args", default="", help="more contour-env train options")
    args = ap.parse_args(argv)
    import json
    import shlex

    from contour_env.io import atomic_write_json

    seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
    variants = [v for v in args.variants.split(",") if v]
    bad = [v for v in variants if v not in VARIANTS]
    if bad:
        raise SystemExit(f"--variants: unknown {bad}; known: {', '.join(VARIANTS)}")
    extra = shlex.split(args.train_args)
    work = Path(args.work) / args.plant
    runs = {(v, s): work / f"{v.replace('+', '-')}-s{s}" for v in variants for s in seeds}
    jobs = [
        (out, command(args.plant, args.base, args.budget, s, v, out, extra))
        for (v, s), out in runs.items()
    ]
    t0 = time.perf_counter()
    train_all(jobs, args.parallel)
    out_json = Path(args.out or ROOT / "docs" / f"teacher_ablation_{args.plant}.json")
    previous = json.loads(out_json.read_text()) if out_json.is_file() else {}
    cards_by_variant = {v: [] for v in variants}
    finals_by_variant = {v: [] for v in variants}
    for (v, s), out in runs.items():
        card = _card(out, args.parallel)
        meta = json.loads((out / "agent.json").read_text())
        card.update(seed=s, variant=v, run_wall_s=meta.get("run_wall_s"))
        cards_by_variant[v].append(card)
        # what the variant learned, whatever keep-best decided: the policy at the end of the
        # run (a teacher-only run's is its pretrained student)
        final = _card(out / "final", args.parallel)
        final.update(seed=s, variant=v, kept="final")
        finals_by_variant[v].append(final)
        print(
            f"{v:18s} seed {s}: kept ({card['kept']}) held-out RMS mean "
            f"{card['heldout_mean_ratio']}, worst {card['heldout_worst_ratio']}; max mean "
            f"{card['heldout_max_mean_ratio']}, worst {card['heldout_max_worst_ratio']}",
            flush=True,
        )
    # variants run by an earlier call with the same settings are kept beside these
    same = previous.get("budget_s") == args.budget
    cards = dict(previous.get("cards", {})) if same else {}
    cards.update(cards_by_variant)
    finals = dict(previous.get("final_cards", {})) if same else {}
    finals.update(finals_by_variant)
    order = [v for v in VARIANTS if v in cards]
    result = {
        "plant": args.plant,
        "base": args.base,
        "budget_s": args.budget,
        "train_args": extra,
        "seeds": seeds,
        "wall_s": time.perf_counter() - t0,
        "summary": summarise({v: cards[v] for v in order}),
        "summary_final": summarise({v: finals[v] for v in order if v in finals}),
        "cards": {v: cards[v] for v in order},
        "final_cards": {v: finals[v] for v in order if v in finals},
    }
    atomic_write_json(out_json, result)
    print(f"wrote {out_json}")
    print(markdown(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
