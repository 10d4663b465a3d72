"""The tables of the observation and of ``info`` in :class:`ContouringEnv`'s docstring, made
from the declared layout (:data:`contour_env.env.layout.OBS_FIELDS`,
:data:`contour_env.env.layout.INFO_KEYS`); ``tests/env/test_layout.py`` holds the docstring
to them. ``python -m contour_env.env.layout_doc`` prints both."""

from __future__ import annotations

from .layout import INFO_KEYS, OBS_FIELDS


def _offset(n: int, c: int) -> str:
    # a·n + c in words ("0", "n", "2n", "2n+1")
    text = "" if n == 0 else ("n" if n == 1 else f"{n}n")
    if c or not text:
        text = f"{text}+{c}" if text else f"{c}"
    return text


def observation_table() -> str:
    """The observation as a Markdown table: index (n axes), field and unit, scale."""
    rows = ["| index | field (unit before scaling) | scale |", "|---|---|---|"]
    n_coef, const, open_end = 0, 0, False
    last = len(OBS_FIELDS) - 1
    for i, f in enumerate(OBS_FIELDS):
        what, _, scale = f.doc.partition("; ")
        unit = "" if f.unit == "1" else f" ({f.unit})"
        if open_end and i == last and f.shape == "A":
            index = "last n"
        elif f.shape == "A":
            start = _offset(n_coef, const)
            stop = (
                f"{_offset(n_coef + 1, const)}−1".replace("+0", "")
                if const == 0
                else f"{_offset(n_coef + 1, const - 1)}"
            )
            index = f"{start} .. {stop}"
        elif f.shape == "p·A":
            index = f"{_offset(n_coef, const)} .."
        else:
            index = _offset(n_coef, const)
        rows.append(f"| {index} | {what}{unit} | {scale or '–'} |")
        if f.shape == "A":
            n_coef += 1
        elif f.shape == "p·A":
            open_end = True
        else:
            const += 1
    return "\n".join(rows)


def info_table() -> str:
    """The ``info`` keys as a Markdown table: key, unit, per axis or not, meaning."""
    rows = ["| key | unit | shape | meaning |", "|---|---|---|---|"]
    for f, _ in INFO_KEYS:
        shape = "(n,)" if f.shape == "A" else "scalar"
        rows.append(f"| `{f.name}` | {f.unit} | {shape} | {f.doc} |")
    return "\n".join(rows)


if __name__ == "__main__":
    print(observation_table())
    print()
    print(info_table())
