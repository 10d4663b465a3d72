"""What ``contour-env train`` tells while it runs: the expected time, and the time to target.

**Expected time.** Before training, :func:`expected_time_line` estimates the run's training
time from reference rates of agent steps per second (:data:`REFERENCE_STEPS_PER_S`, measured
on this 2-core machine kind on ``lm-circle3d`` by ``scripts/time_to_target.py``; the README's
"Time to target" table); at the first evaluation after :data:`EXPECT_AFTER_S` seconds of
training (or at the end of the budget) it says it again from the run's own rate, with the
evaluations' time from the one just made.

**Time to target.** :class:`TargetWatch` reads the curves as they grow and records, in wall
time (evaluations included, the time at which the run *knew*), training time and timesteps,
the first evaluation at which

- ``validation_base_level``: the policy is at the base's level on every validation path (no
  ratio to the base above 1) and below it on average (mean ratio < 1, strictly: an agent
  whose gate is still closed *is* the base and does not count) — parts training never draws;
- ``validation_eligible``: a checkpoint is eligible for keep-best (no validation path worse
  than the base, the mean at most 1 − ``keep_min_gain``: :mod:`agents.rl.validation`);
- ``training_tasks_target``: the mean RMS contour error on the training cases / G-code files
  is at most :data:`TARGET_RATIO` × the base's (issue 34's target, 0.70× CCC on
  ``lm-circle3d``).

Each is logged once when reached, shown in the progress bar (minutes of wall time, "—" not
yet) and stored in the summary and ``agent.json`` (``time_to_target``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

# a fraction of the base's RMS contour error on the training tasks
TARGET_RATIO = 0.70
# seconds of training after which the expected time is re-estimated from the run's own rate
EXPECT_AFTER_S = 30.0
# agent steps per second of training time (evaluations excluded) by (algo, n_envs), measured
# on this 2-core machine kind: a data file that says which command and commit measured them
# (agents/rl/data/reference_rates.json, from docs/time_to_target.json); another envs count
# takes the nearest measured one's rate; an algorithm not measured (td3) has none
RATES_FILE = Path(__file__).resolve().parent / "data" / "reference_rates.json"


def _load_rates(path: Path = RATES_FILE) -> dict:
    data = json.loads(path.read_text(encoding="utf-8"))
    return {(r["algo"], int(r["n_envs"])): float(r["steps_per_s"]) for r in data["rates"]}


REFERENCE_STEPS_PER_S = _load_rates()

KEYS = ("validation_base_level", "validation_eligible", "training_tasks_target")
LABELS = {
    "validation_base_level": "validation at the base's level",
    "validation_eligible": "a checkpoint eligible for keep-best",
    "training_tasks_target": f"training tasks at {TARGET_RATIO:.2f}x the base",
}
SHORT = {
    "validation_base_level": "to_base",
    "validation_eligible": "to_keep",
    "training_tasks_target": f"to_{TARGET_RATIO:.2f}x",
}


def reference_rate(algo: str, n_envs: int) -> float | None:
    """The reference agent steps/s of ``algo`` nearest ``n_envs`` (None: not measured)."""
    measured = [(n, r) for (a, n), r in REFERENCE_STEPS_PER_S.items() if a == algo]
    if not measured:
        return None
    n, r = min(measured, key=lambda nr: abs(math.log(nr[0]) - math.log(max(n_envs, 1))))
    return r


def budget_ends_first(cfg) -> bool:
    """Whether the time budget, not the timesteps, is expected to end the run (at the
    reference rate; unknown rate: whenever there is a budget)."""
    if cfg.time_budget_s is None:
        return False
    rate = reference_rate(cfg.algo, cfg.num_envs)
    return rate is None or cfg.time_budget_s * rate < cfg.timesteps


def _minutes(s: float) -> str:
    return f"{s / 60:.1f} min" if s >= 60 else f"{s:.0f} s"


def expected_time_line(
    cfg,
    rate: float | None,
    train_s: float,
    timesteps: int,
    *,
    measured: bool,
    eval_s: float | None = None,
) -> str:
    """One line: the expected training time of the run (``rate``: agent steps/s, measured by
    the run; None: the reference rate of :data:`REFERENCE_STEPS_PER_S`) and, when known, the
    evaluations' share (``eval_s``: the cost of one evaluation, s)."""
    if rate is None:
        rate = reference_rate(cfg.algo, cfg.num_envs)
    left = max(int(cfg.timesteps) - int(timesteps), 0)
    if rate is None or not rate > 0:
        by_steps = None
        src = "no reference rate for this configuration"
    else:
        by_steps = left / rate
        src = (
            f"{rate:,.0f} agent steps/s measured over this run's first {train_s:.0f} s of training"
            if measured
            else f"{rate:,.0f} agent steps/s, the reference rate of {cfg.algo} with "
            f"{cfg.num_envs} env(s) on this machine kind"
        )
    budget = None if cfg.time_budget_s is None else max(cfg.time_budget_s - train_s, 0.0)
    if by_steps is None and budget is None:
        return f"expected time: unknown ({src})"
    if budget is not None and (by_steps is None or budget < by_steps):
        what = f"{_minutes(budget)} of training (the time budget ends it first)"
    else:
        what = f"{_minutes(by_steps)} of training for {left:,} more timesteps"
    if eval_s is None:
        extra = ", plus the evaluations (timed at the first one)"
    else:
        train_time = (
            by_steps if budget is None or (by_steps is not None and by_steps < budget) else budget
        )
        # the steps the run will make: all that are left, or what the budget allows
        steps = left if train_time is by_steps else (rate or 0.0) * train_time
        n_eval = math.ceil(steps / cfg.eval_every()) if rate else 0
        if cfg.eval_every_s is not None:
            n_eval = max(n_eval, math.ceil(train_time / cfg.eval_every_s))
        n_eval += 1  # the final one
        extra = f", plus about {_minutes(n_eval * eval_s)} for {n_eval} evaluations"
    return f"expected time: {what}{extra} ({src})"


class TargetWatch:
    """The first evaluation at which each target of the module doc is reached (see there)."""

    def __init__(self, base_rms: float | None, curve: list, val_curve: list):
        self.base_rms = base_rms
        self.curve = curve
        self.val_curve = val_curve
        self.reached: dict = {k: None for k in KEYS}
        self._seen = {"curve": 0, "val": 0}
        self.update(quiet=True)  # points of a resumed run

    @staticmethod
    def _stamp(point: dict) -> dict:
        return {
            "wall_s": point.get("wall_s"),
            "train_s": point.get("train_s"),
            "timesteps": int(point["timesteps"]),
        }

    def update(self, quiet: bool = False) -> list[str]:
        """Read the new points; returns a log line for each target first reached."""
        msgs = []

        def hit(key, point, detail):
            if self.reached[key] is None:
                self.reached[key] = self._stamp(point)
                w = point.get("wall_s")
                when = f"after {_minutes(w)} of wall time, " if w is not None else ""
                msgs.append(
                    f"time to target: {LABELS[key]} ({detail}) {when}"
                    f"{_minutes(point.get('train_s') or 0.0)} of training, "
                    f"{int(point['timesteps']):,} timesteps"
                )

        for p in self.val_curve[self._seen["val"] :]:
            score = p.get("score")
            ratios = p.get("ratio_to_base") or []
            at_base = (
                score is not None
                and score < 1.0
                and bool(ratios)
                and all(r is not None and r <= 1.0 for r in ratios)
            )
            if at_base:
                hit("validation_base_level", p, f"mean ratio {score:.3f}, no part worse")
            if p.get("eligible"):
                hit("validation_eligible", p, f"mean ratio {score:.3f}")
        self._seen["val"] = len(self.val_curve)
        if self.base_rms is not None and self.base_rms > 0:
            for p in self.curve[self._seen["curve"] :]:
                rms = p.get("rms_contour_error_um")
                if rms is not None and rms <= TARGET_RATIO * self.base_rms:
                    hit("training_tasks_target", p, f"{rms:.4g} µm, {rms / self.base_rms:.3f}x")
            self._seen["curve"] = len(self.curve)
        return [] if quiet else msgs

    def postfix(self) -> dict:
        """The progress bar's fields: minutes of wall time to each target so far ("—": not
        yet; targets that do not apply to the run are left out)."""
        out = {}
        for key in KEYS:
            if key == "training_tasks_target" and self.base_rms is None:
                continue
            if key != "training_tasks_target" and not self.val_curve:
                continue
            r = self.reached[key]
            done = r is not None and r["wall_s"] is not None
            out[SHORT[key]] = f"{r['wall_s'] / 60:.1f}m" if done else "—"
        return out

    def record(self) -> dict:
        """JSON: each target's first stamp (None: not reached), and the ratio."""
        return {"target_ratio": TARGET_RATIO, **{k: self.reached[k] for k in KEYS}}
