"""Question: What do the recurrent weights θ of rfnn do on a run: how far do they move, and how
large is Chen & Lee 2020's eq. 23 per sample?

Answer: With the default θ0 they barely move and their learning changes nothing shown; the
tables [B] and [C] of docs/RFNN.md give the figures.

Cited by: docs/RFNN.md (tables [B], [C]).

What the recurrent weights θ of ``rfnn`` do on a run (issue 38): how far they move, and the
largest per-sample value of Chen & Lee 2020's eq. 23 the run met.

For each controller (``rfnn`` / ``fnn`` variants) one episode of the case (seed 0, realistic
plant) is run and printed: max / RMS contour error (µm), Chen & Lee's total contour error Σ|ε|
(mm), the largest and the mean |θ − θ0| over every link at the end of the run, the range of θ,
and ``eq23 peak``: the largest value over the run's samples and task-frame directions of
lr_w ‖∂y/∂w‖² + lr_theta ‖∂y/∂θ‖² / w_max² (= η_w y_u² ‖∂O⁽⁴⁾/∂w‖² + η_θ y_u² ‖∂O⁽⁴⁾/∂θ‖², the
quantity eq. 23 keeps below 2; the law records it on every path; ``--python`` runs every
controller through the Python env loop, one ``act`` per step, the same law and figures).
``--tuning`` runs ``agents.rfnn.TUNING_PATH`` (scripts/rfnn_tune.py's arc; not a named case)
instead of ``--case``; ``--feedrate`` overrides the case's feed (fewer samples).

``--paper-gradient`` (Python loop) also prints, over every sample and direction of each run, the
5/25/50/75/95th percentiles of ‖g_paper‖ / ‖g‖: the θ gradient as the paper's eq. 19 writes it,
g_paper,ij = −w_j O_j⁽³⁾ · 2 (u_ij − m_ij) O_ij(k−1) / σ_ij² (the derivative of the
unnormalised Σ w_j O_j⁽³⁾), against the law's exact gradient of eq. 7's normalised output,
g_ij = −ψ_j (w_j − y) · 2 (u_ij − m_ij) O_ij(k−1) / σ_ij² (samples where g = 0 left out)::

    python research/rfnn_theta.py --case lm-circle3d --controllers rfnn,rfnn:theta0=0 --python
    python research/rfnn_theta.py --tuning --controllers rfnn:instant=1:lr_theta=80
    python research/rfnn_theta.py --case lm-circle3d --feedrate 0.25 --controllers rfnn \
        --paper-gradient
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller
from contour_env import ENV_ID
from contour_env.evaluation import run_episode
from contour_env.metrics import score

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
from rfnn_tune import tuning_env  # noqa: E402

PERCENTILES = (5, 25, 50, 75, 95)


def theta_figures(
    env, spec: str, python: bool = False, seed: int = 0, paper_gradient: bool = False
) -> dict:
    """One run of ``spec`` on ``env``: the printed figures (µm, mm, dimensionless)."""
    c = make_controller(spec).bind(env)
    ratios: list[np.ndarray] = []
    if paper_gradient:
        law = c.act

        def act(signals):
            # the network of this sample with the state the law reads (before its update)
            x = c.network_inputs(signals)
            B = x.shape[0]
            memory, theta, w = c.memory[:B], c.theta[:B], c.w[:B]
            y, psi, O2, d = c.network(x, memory, theta, w)
            factor = 2.0 * d * memory * c.inv_sigma2
            exact = c.theta_gradient(psi, w, y, d, memory)
            paper = -(w * (O2[..., 0, :] * O2[..., 1, :]))[..., None, :] * factor
            n_exact = np.sqrt(np.sum(exact * exact, axis=(-2, -1)))
            n_paper = np.sqrt(np.sum(paper * paper, axis=(-2, -1)))
            ratios.append(n_paper[n_exact > 0] / n_exact[n_exact > 0])
            return law(signals)

        c.act = act
    record = run_episode(env, c, seed=seed, compiled=False if (python or paper_gradient) else None)
    m = score(record, metrics=("total",))
    moved = np.abs(c.theta[0] - c.theta0)
    return {
        "max_contour_error_um": m["max_contour_error_um"],
        "rms_contour_error_um": m["rms_contour_error_um"],
        "total_contour_error_mm": m["total_contour_error_um"] * 1e-3,
        "theta_max_moved": float(moved.max()),
        "theta_mean_moved": float(moved.mean()),
        "theta_min": float(c.theta[0].min()),
        "theta_max": float(c.theta[0].max()),
        "eq23_peak": None if math.isnan(c.eq23_peak) else float(c.eq23_peak),
        "eq23_a_priori": float(c.lr_w + c.lr_theta * c.g_theta),
        "rms_effort": [float(v) for v in m["rms_effort"]],
        "completed": bool(m["completed"]),
        "paper_over_exact_percentiles": (
            [float(v) for v in np.percentile(np.concatenate(ratios), PERCENTILES)]
            if ratios and np.concatenate(ratios).size
            else None
        ),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", default="lm-circle3d")
    ap.add_argument("--tuning", action="store_true", help="agents.rfnn.TUNING_PATH, not --case")
    ap.add_argument("--controllers", default="rfnn,rfnn:theta0=0,fnn")
    ap.add_argument(
        "--python", action="store_true", help="the Python env loop (same law and figures)"
    )
    ap.add_argument("--feedrate", type=float, default=None, help="feed override, m/s")
    ap.add_argument("--paper-gradient", action="store_true", help="‖g_paper‖ / ‖g‖ (above)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    extra = {} if a.feedrate is None else {"feedrate_m_s": a.feedrate}
    if a.tuning and extra:
        ap.error("--feedrate: not with --tuning")
    env = tuning_env() if a.tuning else gym.make(ENV_ID, case=a.case, **extra)
    where = "TUNING_PATH (linear motor)" if a.tuning else a.case
    if extra:
        where += f" at {a.feedrate:g} m/s"
    specs = [s for s in a.controllers.split(",") if s]
    rows = {s: theta_figures(env, s, a.python, a.seed, a.paper_gradient) for s in specs}
    python = a.python or a.paper_gradient
    print(f"{where}, seed {a.seed}" + (", Python loop" if python else ""))
    w = max(10, *(len(s) for s in specs))
    head = ("max ε µm", "RMS ε µm", "total mm", "max|Δθ|", "mean|Δθ|", "θ range",
            "eq23 peak", "eq23 worst")  # fmt: skip
    print(f"{'controller':<{w}}  " + "  ".join(f"{h:>10}" for h in head))
    for s, r in rows.items():
        peak = "—" if r["eq23_peak"] is None else f"{r['eq23_peak']:.3g}"
        rng = f"{r['theta_min']:.2f}..{r['theta_max']:.2f}"
        print(
            f"{s:<{w}}  {r['max_contour_error_um']:>10.2f}  {r['rms_contour_error_um']:>10.3f}  "
            f"{r['total_contour_error_mm']:>10.1f}  {r['theta_max_moved']:>10.3g}  "
            f"{r['theta_mean_moved']:>10.3g}  {rng:>10}  {peak:>10}  {r['eq23_a_priori']:>10.3g}"
            + ("" if r["completed"] else "  (incomplete)")
        )
    if a.paper_gradient:
        print(f"‖g_paper‖ / ‖g‖, percentiles {'/'.join(map(str, PERCENTILES))} over the samples:")
        for s, r in rows.items():
            q = r["paper_over_exact_percentiles"]
            print(f"{s:<{w}}  " + ("—" if q is None else " / ".join(f"{v:.2f}" for v in q)))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump({"where": where, "seed": a.seed, "results": rows}, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
