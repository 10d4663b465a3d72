"""Trained agents on disk: the shipped ones (``agents/models/<name>/``) and any model DIR.

A shipped agent is a model DIR written by ``contour-env train`` (``agent.json``, ``model.zip``,
``normalization.json``, …) copied to ``agents/models/<name>``; ``contour-env models`` lists
them with their plant, base, training cases and budget, and :func:`shipped_model_for` picks
the one for a plant (``--controllers residual`` without ``--model``).
"""

from __future__ import annotations

from pathlib import Path

from ..residual import read_model_metadata

MODELS_DIR = Path(__file__).resolve().parent.parent / "models"


def list_models(root=None) -> list[dict]:
    """One row per model DIR directly under ``root`` (default: the shipped agents): name,
    path, plant, axes, algo, base, cases, timesteps, scale. Unreadable folders are reported
    with an ``error`` key instead of being skipped silently; folders whose name starts with
    ``.`` or ``_`` (a sweep's ``_ray`` and ``_logs``) are not models and are skipped."""
    if root is not None and not Path(root).is_dir():
        what = "not a directory" if Path(root).exists() else "no such directory"
        raise ValueError(f"--dir: {root}: {what}")
    root = Path(root) if root is not None else MODELS_DIR
    if not root.is_dir():
        return []
    rows = []
    for d in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith((".", "_"))):
        try:
            m = read_model_metadata(d)
        except (ValueError, FileNotFoundError) as exc:
            rows.append({"name": d.name, "path": str(d), "error": str(exc)})
            continue
        rows.append(
            {
                "name": d.name,
                "path": str(d),
                "plant": m["plant"],
                "n_axes": m["n_axes"],
                "algo": m["algo"],
                "base": m["base"],
                "cases": m.get("cases", []) + m.get("gcode", []),
                "timesteps": m.get("timesteps"),
                "scale": m["scale"],
                "train_wall_s": m.get("train_wall_s"),
                "kept": m.get("kept"),
                "teacher": m.get("teacher", "none"),
                "envelope": m.get("envelope") is not None,
            }
        )
    return rows


def shipped_model_for(plant: str, root=None) -> Path:
    """The shipped model DIR for ``plant``; none → ``ValueError`` listing what exists."""
    rows = [r for r in list_models(root) if "error" not in r]
    for r in rows:
        if r["plant"] == plant:
            return Path(r["path"])
    have = ", ".join(sorted({r["plant"] for r in rows})) or "none"
    raise ValueError(
        f"plant: no shipped residual agent for plant {plant!r} (shipped for: {have}); train one "
        "with `contour-env train` and pass --model DIR"
    )


def _kept(kept) -> str:
    """What keep-best kept, for the table: the base itself (the agent is its base), the best
    checkpoint by validation, the final model, or '-' for agents from before keep-best."""
    return {"base": "the base itself", "best-validation": "best checkpoint"}.get(kept, kept or "-")


def format_models(rows: list[dict]) -> str:
    if not rows:
        return "no trained agents found"
    lines = [
        f"{'name':22s} {'plant':15s} {'algo':7s} {'base':13s} {'teacher':12s} {'envelope':8s} "
        f"{'timesteps':>10s}  {'kept':16s} cases"
    ]
    for r in rows:
        if "error" in r:
            lines.append(f"{r['name']:22s} unreadable: {r['error']}")
            continue
        env = "yes" if r.get("envelope") else "no"
        lines.append(
            f"{r['name']:22s} {r['plant']:15s} {r['algo']:7s} {r['base']:13s} "
            f"{r.get('teacher', 'none'):12s} {env:8s} "
            f"{r['timesteps'] or 0:>10d}  {_kept(r.get('kept')):16s} {', '.join(r['cases'])}"
        )
    return "\n".join(lines)
