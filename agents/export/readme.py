"""The ``README.md`` written beside an exported law: what to feed it each servo period (name,
unit, shape), what it carries, what it returns, its servo period, and how to call it."""

from __future__ import annotations

from pathlib import Path


def _table(rows) -> str:
    out = ["| name | unit | shape | meaning |", "|---|---|---|---|"]
    for r in rows:
        shape = "×".join(str(d) for d in r["shape"]) or "scalar"
        out.append(f"| `{r['name']}` | {r['unit']} | {shape} | {r['description']} |")
    return "\n".join(out) + "\n"


def readme_text(iface: dict, files: list, bench: dict | None = None) -> str:
    """The README of an export (``iface``: :func:`agents.export.c_law.write_c`'s result)."""
    law = iface["law"]
    zero = iface.get("zero_law")
    what = (
        '**Zero law**: this agent was kept as its base controller (`"kept": "base"` in '
        "agent.json): the residual is always 0 and `applied` = clip(base_command, −1, 1)."
        if zero
        else f"A `{iface.get('algo', 'sac')}` actor; observation `{law['observation']}`, residual "
        f"frame `{law['residual_frame']}`, gate {law['gate']}, envelope {law['envelope']}, "
        f"fade at rest {law['fade_at_rest']}, bound {law['scale']:g} of the force limit per axis."
    )
    lines = [
        f"# Residual law of the agent `{iface['plant']}` ({iface['n_axes']} axes)",
        "",
        f"Exported from `{iface['model_dir']}` by `contour-env export`. {what}",
        "",
        f"- **Servo period**: {iface['servo_period_s']:g} s (the agent was trained at it: call "
        "the law once per period of this length, and nowhere else).",
        f"- **Decisions**: every {iface['action_repeat']} periods the network runs; between "
        "decisions the action is held and only the frame, the gate and the fades are applied.",
        f"- **Preview**: look-ahead positions at τ = "
        f"{', '.join(f'{t:g}' for t in iface['preview_times_s'])} s "
        f"({', '.join(str(k) for k in iface['preview_steps'])} periods).",
        "- **Commands** are fractions of each axis' force limit (the env's action): multiply by "
        "the drive's force limit for newtons.",
        "- **Bad input** (any NaN or infinity, a programmed feed or acceleration limit ≤ 0) "
        "closes the gate for that period: residual 0, applied = clip(base), `bad_input` 1.",
        "",
        "## Files",
        "",
        *[f"- `{Path(f).name}`" for f in files],
        "",
        "C: `cc -O2 -std=c99 -c residual.c` (link with `-lm`); call `residual_reset(&st)` at "
        "the start of every part and `residual_step(&in, &st, &out)` every servo period. "
        "ONNX (opset 17): the same inputs and state as named float64 tensors (the C scalars "
        "are tensors of shape [1]); the outputs `next_<state>` are the state to pass at the "
        "next call.",
        "",
        "## Inputs (each servo period)",
        "",
        _table(iface["inputs"]),
        "## State (carried between periods)",
        "",
        _table(iface["state"]),
        "## Outputs",
        "",
        _table(iface["outputs"]),
    ]
    if bench:
        lines += ["## Latency on the exporting machine", ""]
        for form, b in bench.items():
            lines.append(
                f"- {form}: median {b['median_us']:.2f} µs, p99 {b['p99_us']:.2f} µs per call "
                f"(deciding calls: median {b['deciding_median_us']:.2f} µs, p99 "
                f"{b['deciding_p99_us']:.2f} µs; {b['calls']} calls)"
            )
        lines.append("")
    return "\n".join(lines)
