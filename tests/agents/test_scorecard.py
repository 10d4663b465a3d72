"""The shipped agents' scorecard (agents/models/scorecard.json, written by
scripts/residual_scorecard.py): it is the card of the agents that are shipped (their digests),
covers every held-out program and named case of each plant, its summary follows from its rows,
a re-scored row agrees, and every shipped agent is never worse than its base there and — unless
keep-best kept the base itself, which then scores 1 exactly everywhere — better by 10 % on the
held-out programs on average (issue 33's acceptance)."""

from __future__ import annotations

import json
import math

import pytest

from agents.rl.models import MODELS_DIR, list_models
from agents.rl.scorecard import model_digest, score_target, summary, targets_for

CARD = MODELS_DIR / "scorecard.json"
README = MODELS_DIR.parents[1] / "README.md"
SHIPPED = [r for r in list_models() if "error" not in r]


@pytest.fixture(scope="module")
def cards():
    assert CARD.is_file(), "run python scripts/residual_scorecard.py"
    return {c["model"]: c for c in json.loads(CARD.read_text())["cards"]}


def test_the_card_is_of_the_shipped_agents(cards):
    assert {r["name"] for r in SHIPPED} == set(cards)
    for r in SHIPPED:
        assert cards[r["name"]]["model_digest"] == model_digest(r["path"]), (
            f"{r['name']}: the scorecard is stale; run python scripts/residual_scorecard.py"
        )


@pytest.mark.parametrize("row", SHIPPED, ids=lambda r: r["name"])
def test_every_target_is_scored_and_the_summary_follows(cards, row):
    card = cards[row["name"]]
    want = [(k, label) for k, label, _ in targets_for(row["plant"], row["n_axes"])]
    assert [(r["kind"], r["target"]) for r in card["rows"]] == want
    assert sum(k == "heldout" for k, _ in want) >= 8
    for r in card["rows"]:
        if r["rms_ratio"] is not None:
            ratio = r["agent_rms_contour_error_um"] / r["base_rms_contour_error_um"]
            assert r["rms_ratio"] == pytest.approx(ratio, rel=1e-12)
    assert summary(card["rows"]) == {k: card[k] for k in summary(card["rows"])}


@pytest.mark.parametrize("row", SHIPPED, ids=lambda r: r["name"])
def test_a_rescored_row_agrees(cards, row):
    card = cards[row["name"]]
    kind, label, kw = targets_for(row["plant"], row["n_axes"])[0]
    again = score_target(row["path"], kind, label, kw)
    first = card["rows"][0]
    for key in ("base_rms_contour_error_um", "agent_rms_contour_error_um"):
        assert again[key] == pytest.approx(first[key], rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("row", SHIPPED, ids=lambda r: r["name"])
def test_never_worse_than_the_base_and_better_on_average(cards, row):
    card = cards[row["name"]]
    worse = [
        (r["target"], r["rms_ratio"])
        for r in card["rows"]
        if r["rms_ratio"] is None or r["rms_ratio"] > 1.0
    ]
    assert not worse, f"{row['name']}: worse than its base on {worse}"
    assert math.isfinite(card["worst_ratio"]) and card["worst_ratio"] <= 1.0
    if card["kept"] == "base":
        # no checkpoint passed keep-best: the shipped agent is its base, exactly, everywhere
        # (issue 33's 10 % target is then not met for this plant: the README says so)
        assert all(r["rms_ratio"] == 1.0 for r in card["rows"])
        assert f"`{row['name']}` ({card['base']}) | the base (no checkpoint passed)" in (
            README.read_text()
        )
    else:
        assert card["heldout_mean_ratio"] is not None and card["heldout_mean_ratio"] <= 0.90


def test_the_readme_shows_the_card():
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "residual_scorecard", MODELS_DIR.parents[1] / "scripts" / "residual_scorecard.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    table = mod.markdown(json.loads(CARD.read_text())["cards"])
    assert table in README.read_text(), "paste python scripts/residual_scorecard.py --markdown"
