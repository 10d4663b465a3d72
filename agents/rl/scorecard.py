"""An agent's scorecard: the agent against its base on every program of the held-out suite and
every named case of its plant — the figures that say whether an agent can be switched on in a
shop (docs/RESIDUAL_TRAINING.md, "The held-out suite").

Each target is scored with the project's one scoring function
(:func:`contour_env.evaluation.evaluate`, seed 0) for the agent and for its base controller;
a row holds both RMS and max contour errors, the ratios agent / base (both figures taken at
least at one encoder count of the plant's coarsest axis: below it a difference is
quantisation, not a property — hsm2's 2 µm; the friction table's and the linear motor's 0.1 µm
counts never bind) and the RMS effort per axis. :func:`summary` reduces the rows to what the
acceptance reads: the worst ratio over all targets and the mean ratio over the held-out
programs.

The held-out programs are the only place where this module reads ``tests/data/heldout/``;
training never does (:mod:`agents.rl.heldout`).
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

from .heldout import HELDOUT_DIR

# 3-D parts (simultaneous XYZ moves, arcs in the ZX plane): for 3-axis plants only
THREE_D_PROGRAMS = ("helical_bore_3d.ngc", "boss_crown_3d.nc")
EFFORT_FLOOR_N = 1e-6


def heldout_programs(n_axes: int, plant: str | None = None) -> list[Path]:
    """The held-out programs a plant of ``n_axes`` axes takes, sorted by name: the shared ones
    (``tests/data/heldout/*``), then with ``plant`` its own (``tests/data/heldout/<plant>/``:
    a part at 5x its top training feed and one with corners turned off the axes, issue 48)."""
    progs = sorted(p for p in HELDOUT_DIR.iterdir() if p.is_file())
    progs = [p for p in progs if n_axes == 3 or p.name not in THREE_D_PROGRAMS]
    own = HELDOUT_DIR / plant if plant else None
    if own is not None and own.is_dir():
        progs += sorted(p for p in own.iterdir() if p.is_file())
    return progs


def program_label(path: Path) -> str:
    """A held-out program's label: its name, ``<plant>/<name>`` for a plant's own."""
    return path.name if path.parent == HELDOUT_DIR else f"{path.parent.name}/{path.name}"


def targets_for(plant: str, n_axes: int) -> list[tuple[str, str, dict]]:
    """(kind, label, env kwargs) of every target of an agent of ``plant``: its named cases
    (kind ``"case"``), then the held-out programs (kind ``"heldout"``)."""
    from contour_env.cases import case_names, get_case

    out = [("case", c, {"case": c}) for c in case_names() if get_case(c).plant == plant]
    out += [
        ("heldout", program_label(p), {"plant": plant, "path": str(p)})
        for p in heldout_programs(n_axes, plant)
    ]
    return out


def model_digest(model_dir) -> str:
    """SHA-256 (first 16 hex digits) of a model DIR's ``agent.json`` and ``model.zip``: a
    scorecard names the exact agent it scored."""
    h = hashlib.sha256()
    for name in ("agent.json", "model.zip"):
        h.update((Path(model_dir) / name).read_bytes())
    return h.hexdigest()[:16]


def score_target(model_dir, kind: str, label: str, env_kwargs: dict) -> dict:
    """One row: the agent of ``model_dir`` and its base on one target."""
    import gymnasium as gym

    from contour_env import ENV_ID
    from contour_env.evaluation import evaluate

    from ..registry import make_controller
    from ..residual import ResidualAgent

    agent = ResidualAgent(model_dir)
    base = evaluate(gym.make(ENV_ID, **env_kwargs), make_controller(agent.base_name))
    mine = evaluate(gym.make(ENV_ID, **env_kwargs), agent)
    b, a = base["rms_contour_error_um"], mine["rms_contour_error_um"]
    bm, am = base["max_contour_error_um"], mine["max_contour_error_um"]
    ratio = floored_ratio(a, b, base, mine)
    max_ratio = floored_ratio(am, bm, base, mine)
    effort = [
        x / y if y > EFFORT_FLOOR_N else None
        for x, y in zip(mine["rms_effort"], base["rms_effort"], strict=True)
    ]
    return {
        "kind": kind,
        "target": label,
        "base_rms_contour_error_um": b,
        "agent_rms_contour_error_um": a,
        "base_max_contour_error_um": base["max_contour_error_um"],
        "agent_max_contour_error_um": mine["max_contour_error_um"],
        "rms_ratio": None if not math.isfinite(ratio) else ratio,
        "max_ratio": None if not math.isfinite(max_ratio) else max_ratio,
        "effort_ratio": effort,
        "agent_completed": bool(mine["completed"]),
        "encoder_resolution_um": base.get("encoder_resolution_um"),
        "outside_envelope_fraction": mine.get("outside_envelope_fraction"),
    }


def floored_ratio(a, b, base: dict, mine: dict) -> float:
    """agent / base with both at least one encoder count (``encoder_resolution_um``, the
    coarsest axis's): a difference below one count is quantisation, not a property (∞ when
    the agent did not complete the part)."""
    if a is None or not b or not mine["completed"]:
        return math.inf
    res = float(base.get("encoder_resolution_um") or 0.0)
    return max(a, res) / max(b, res)


def _score_job(job):
    return score_target(*job)


def scorecard(model_dir, *, workers: int = 1, progress=None) -> dict:
    """Every target's row for the agent of ``model_dir`` and the summary (see module doc);
    ``workers`` > 1 scores targets in that many processes (same figures)."""
    from ..residual import read_model_metadata

    meta = read_model_metadata(model_dir)
    jobs = [
        (str(model_dir), kind, label, kw)
        for kind, label, kw in targets_for(meta["plant"], int(meta["n_axes"]))
    ]
    rows = []
    if workers > 1:
        import multiprocessing as mp

        with mp.get_context("spawn").Pool(workers) as pool:
            for row in pool.imap(_score_job, jobs):
                rows.append(row)
                if progress:
                    progress(row)
    else:
        for job in jobs:
            rows.append(_score_job(job))
            if progress:
                progress(rows[-1])
    return {
        "model": Path(model_dir).name,
        "model_digest": model_digest(model_dir),
        "plant": meta["plant"],
        "base": meta["base"],
        "kept": meta.get("kept"),
        "release": meta.get("release"),
        "residual_frame": meta.get("residual_frame", "axes"),
        "gate": bool(meta.get("gate", False)),
        "rows": rows,
        **summary(rows),
    }


def summary(rows: list[dict]) -> dict:
    """worst_ratio (every target; ∞ as None when one was not completed), heldout_mean_ratio,
    heldout_worst_ratio, cases_worst_ratio — of the RMS contour error — and the same of the
    max contour error (``max_worst_ratio``, ``heldout_max_mean_ratio``,
    ``heldout_max_worst_ratio``, ``cases_max_worst_ratio``): a tolerance is a max."""

    def ratios(kind=None, key="rms_ratio"):
        return [
            math.inf if r.get(key) is None else r[key]
            for r in rows
            if kind is None or r["kind"] == kind
        ]

    def num(x):
        return None if not math.isfinite(x) else float(x)

    out = {}
    for key, prefix in (("rms_ratio", ""), ("max_ratio", "max_")):
        held = ratios("heldout", key)
        cases = ratios("case", key)
        out[f"{prefix}worst_ratio"] = num(max(ratios(None, key), default=math.nan))
        out[f"heldout_{prefix}mean_ratio"] = num(sum(held) / len(held)) if held else None
        out[f"heldout_{prefix}worst_ratio"] = num(max(held, default=math.nan))
        out[f"cases_{prefix}worst_ratio"] = num(max(cases, default=math.nan))
    return out
