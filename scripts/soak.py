"""Soak test: many env steps over every named case, action extremes and randomised plants.

    python scripts/soak.py --steps 1000000 [--seed 0] [--n-envs 8] [--json soak.json]

The steps are spread evenly over every named case (``cases.all_case_names``: the feed-drive
cases and the five-axis ones) × {single env, vector env of ``--n-envs``} × {nominal plant,
plant parameters varied ±20 % (``plants.randomize.randomized``, as ``agents/compare.py
--randomize``)}; the five-axis plant has no variations (``compare --randomize`` refuses it
too), so its cases run nominal only. A vector step counts ``n_envs`` steps. Each episode
drives one action pattern, in turn: 0, +1, −1, uniform random in [−1, 1], alternating sign
(±1), uniform random in [−5, 5] and ±1e300 (clipped to [−1, 1] by the env). Actions the env
documents as errors (NaN, ±inf: ``ValueError``) are probed a few times per block and must
raise ``ValueError``; the env is reset after each probe. In the vector env they are also
probed, a few times per block, in the row of an env whose episode has just ended, on the
step that autoresets it (the action is ignored there, and must be refused all the same); the
refused step changes nothing, so the soak goes on without a reset.

Counted, and any one is a failure (exit status 1): NaN/inf in an observation, a reward or a
floating-point info field, every one the env returns (the contour error of an env that ended
with ``non_finite_state`` is ``inf`` by design: counted apart, as a termination), a
non-finite action that does not raise ValueError, and any other exception. Prints a summary
(and writes it as JSON with --json).
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback

import numpy as np

from agents.records import attributes
from contour_env.cases import FIVE_AXIS_CASES, all_case_names
from contour_env.env.contouring_env import ContouringEnv
from contour_env.env.vector_env import ContouringVectorEnv
from contour_env.plants.randomize import randomized

PATTERNS = ("zero", "plus", "minus", "random", "alternate", "wide", "huge")
PROBES_PER_BLOCK = 3


def action_for(pattern: str, k: int, shape, rng) -> np.ndarray:
    if pattern == "zero":
        return np.zeros(shape)
    if pattern == "plus":
        return np.ones(shape)
    if pattern == "minus":
        return -np.ones(shape)
    if pattern == "random":
        return rng.uniform(-1.0, 1.0, shape)
    if pattern == "alternate":
        return np.full(shape, 1.0 if k % 2 == 0 else -1.0)
    if pattern == "wide":
        return rng.uniform(-5.0, 5.0, shape)
    if pattern == "huge":
        return np.where(rng.random(shape) < 0.5, -1e300, 1e300)
    raise ValueError(pattern)


class Counts:
    def __init__(self):
        self.steps = 0
        self.episodes = 0
        self.nonfinite_obs = 0
        self.nonfinite_reward = 0
        self.nonfinite_info = 0
        self.probes = 0
        self.autoreset_probes = 0
        self.probe_not_refused = 0
        self.exceptions = 0
        self.terminations: dict[str, int] = {}
        self.min_reward = np.inf
        self.first_problems: list[str] = []

    def problem(self, text: str) -> None:
        if len(self.first_problems) < 10:
            self.first_problems.append(text)

    @property
    def failures(self) -> int:
        return (
            self.nonfinite_obs
            + self.nonfinite_reward
            + self.nonfinite_info
            + self.probe_not_refused
            + self.exceptions
        )

    def to_dict(self) -> dict:
        return {
            **attributes(
                self, "steps", "episodes", "nonfinite_obs", "nonfinite_reward", "nonfinite_info"
            ),
            "nonfinite_action_probes": self.probes,
            "autoreset_action_probes": self.autoreset_probes,
            "nonfinite_action_not_refused": self.probe_not_refused,
            "exceptions": self.exceptions,
            "terminations": dict(sorted(self.terminations.items())),
            "min_reward": float(self.min_reward) if np.isfinite(self.min_reward) else None,
            "failures": self.failures,
            "first_problems": self.first_problems,
        }


def _check(c: Counts, where: str, obs, reward, info, ended_nonfinite) -> None:
    """Count NaN/inf in obs, reward and info (rows of envs with a non-finite state apart)."""
    obs = np.asarray(obs)
    reward = np.asarray(reward)
    if not np.all(np.isfinite(obs)):
        c.nonfinite_obs += 1
        c.problem(f"{where}: non-finite observation")
    if not np.all(np.isfinite(reward)):
        c.nonfinite_reward += 1
        c.problem(f"{where}: non-finite reward {reward}")
    else:
        c.min_reward = min(c.min_reward, float(reward.min()))
    keep = ~np.asarray(ended_nonfinite, dtype=bool)
    for key, value in info.items():
        v = np.asarray(value)
        if v.dtype.kind != "f":  # step counts, saturation flags, termination reasons
            continue
        if v.ndim and v.shape[0] == keep.shape[0] and keep.shape[0] > 1:
            v = v[keep]
        elif not keep.all():
            continue
        if not np.all(np.isfinite(v)):
            c.nonfinite_info += 1
            c.problem(f"{where}: non-finite info[{key!r}]")
            break


def _probe(c: Counts, step, shape, where: str, base=None, row: int = -1) -> None:
    """Step with NaN, +inf and -inf in turn, in the last axis of ``row`` of ``base`` (zeros if
    None); each must raise ValueError."""
    for bad in (np.nan, np.inf, -np.inf):
        a = np.zeros(shape) if base is None else np.array(base, dtype=np.float64)
        a.reshape(-1, shape[-1])[row, -1] = bad
        c.probes += 1
        try:
            step(a)
        except ValueError:
            continue
        c.probe_not_refused += 1
        c.problem(f"{where}: action with {bad} was accepted")


def soak_single(c: Counts, case: str, params, steps: int, rng, seed: int) -> None:
    kw = {} if params is None else {"plant_params": params}
    env = ContouringEnv(case=case, **kw)
    shape = (env.core.dim,)
    where = f"{case} single{' randomised' if params else ''}"
    probe_every = max(1, steps // PROBES_PER_BLOCK)
    env.reset(seed=seed)
    c.episodes += 1
    pattern = PATTERNS[c.episodes % len(PATTERNS)]
    k = 0
    for i in range(steps):
        if i % probe_every == probe_every - 1:
            _probe(c, env.step, shape, where)
            env.reset(seed=seed + i)
            c.episodes += 1
            k = 0
        obs, r, term, trunc, info = env.step(action_for(pattern, k, shape, rng))
        k += 1
        c.steps += 1
        reason = info["termination_reason"]
        _check(c, f"{where} {pattern} step {k}", obs, r, info, [reason == "non_finite_state"])
        if term or trunc:
            key = reason if term else "truncated"
            c.terminations[key] = c.terminations.get(key, 0) + 1
            env.reset(seed=seed + i + 1)
            c.episodes += 1
            pattern = PATTERNS[c.episodes % len(PATTERNS)]
            k = 0


def soak_vector(c: Counts, case: str, params, n_envs: int, steps: int, rng, seed: int) -> None:
    kw = {} if params is None else {"plant_params": params}
    venv = ContouringVectorEnv(num_envs=n_envs, case=case, **kw)
    shape = (n_envs, venv.core.dim)
    where = f"{case} vector{' randomised' if params else ''}"
    calls = max(1, steps // n_envs)
    probe_every = max(1, calls // PROBES_PER_BLOCK)
    venv.reset(seed=seed)
    c.episodes += n_envs
    # one pattern per env, rotating at each of its episodes
    patterns = np.arange(n_envs) % len(PATTERNS)
    k = np.zeros(n_envs, dtype=np.int64)
    autoreset_probes = 0
    ended = ()
    for i in range(calls):
        if i % probe_every == probe_every - 1:
            _probe(c, venv.step, shape, where)
            venv.reset(seed=seed + i)
            c.episodes += n_envs
            k[:] = 0
            ended = ()  # the reset cleared the autoresets due
        a = np.empty(shape)
        for b in range(n_envs):
            a[b] = action_for(PATTERNS[patterns[b]], int(k[b]), shape[1:], rng)
        if len(ended) and autoreset_probes < PROBES_PER_BLOCK:
            # an env being autoreset at this step: its (ignored) action must still be finite
            autoreset_probes += 1
            c.autoreset_probes += 3
            _probe(c, venv.step, shape, f"{where} autoreset of env {ended[0]}", a, ended[0])
        obs, r, term, trunc, info = venv.step(a)
        k += 1
        c.steps += n_envs
        reasons = np.asarray(info["termination_reason"])
        _check(c, f"{where} step {i}", obs, r, info, reasons == "non_finite_state")
        ended = np.flatnonzero(term | trunc)
        for b in ended:
            key = str(reasons[b]) if term[b] else "truncated"
            c.terminations[key] = c.terminations.get(key, 0) + 1
            patterns[b] = (patterns[b] + 1) % len(PATTERNS)
            k[b] = -1  # the next step resets it (NEXT_STEP autoreset)
            c.episodes += 1


def soak(steps: int, seed: int = 0, n_envs: int = 8, progress=print, cases=None) -> dict:
    """The soak over ``cases`` (default: every named case)."""
    rng = np.random.default_rng(seed)
    c = Counts()
    cases = all_case_names() if cases is None else list(cases)
    blocks = [
        (case, mode, randomise)
        for case in cases
        for mode in ("single", "vector")
        for randomise in ((False,) if case in FIVE_AXIS_CASES else (False, True))
    ]
    per_block = max(1, steps // len(blocks))
    t0 = time.perf_counter()
    for j, (case, mode, randomise) in enumerate(blocks):
        n = n_envs if mode == "vector" else 1
        params = None
        try:
            if randomise:
                nominal = ContouringEnv(case=case).plant.params
                params = randomized(nominal, 0.2, n, seed=seed + j)
            if mode == "single":
                soak_single(c, case, params, per_block, rng, seed + j)
            else:
                soak_vector(c, case, params, n_envs, per_block, rng, seed + j)
        except Exception:  # noqa: BLE001 - counted and reported, the soak goes on
            c.exceptions += 1
            c.problem(f"{case} {mode}: {traceback.format_exc(limit=3)}")
        if progress:
            progress(
                f"[{time.perf_counter() - t0:7.1f} s] {case:16s} {mode:6s} "
                f"{'±20 %' if randomise else 'nominal'}: {c.steps} steps, "
                f"{c.failures} failures"
            )
    out = c.to_dict()
    out.update(
        requested_steps=steps,
        seed=seed,
        n_envs=n_envs,
        cases=cases,
        blocks=[f"{case} {mode}{' ±20 %' if r else ''}" for case, mode, r in blocks],
        wall_s=time.perf_counter() - t0,
    )
    return out


def format_summary(res: dict) -> str:
    lines = [
        f"soak: {res['steps']} steps ({res['episodes']} episodes) in {res['wall_s']:.1f} s, "
        f"seed {res['seed']}, vector envs of {res['n_envs']}",
        f"  {len(res['cases'])} cases, {len(res['blocks'])} blocks: {', '.join(res['cases'])}",
        f"  non-finite obs {res['nonfinite_obs']}, reward {res['nonfinite_reward']}, info "
        f"{res['nonfinite_info']}; exceptions {res['exceptions']}",
        f"  NaN/inf actions probed {res['nonfinite_action_probes']} (at an autoreset "
        f"{res['autoreset_action_probes']}), not refused {res['nonfinite_action_not_refused']}",
        f"  episode ends: {res['terminations']}; lowest reward {res['min_reward']}",
    ]
    for p in res["first_problems"]:
        lines.append(f"  problem: {p}")
    lines.append("PASS" if res["failures"] == 0 else f"FAIL: {res['failures']} failures")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, required=True, help="env steps in all")
    ap.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    ap.add_argument("--n-envs", type=int, default=8, help="envs of the vector env (default 8)")
    ap.add_argument("--json", help="write the summary as JSON to this file")
    ap.add_argument("--quiet", action="store_true", help="no per-block progress lines")
    args = ap.parse_args(argv)
    if args.steps < 1 or args.n_envs < 1:
        print("error: --steps and --n-envs: must be >= 1", file=sys.stderr)
        return 2
    res = soak(args.steps, args.seed, args.n_envs, progress=None if args.quiet else print)
    print(format_summary(res))
    if args.json:
        from contour_env.io import atomic_write_json

        atomic_write_json(args.json, res)
    return 0 if res["failures"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
