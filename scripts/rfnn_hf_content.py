"""High-frequency content of the normal (contour) error, per controller, on one case (issue 38).

For each controller the case is run once (compiled where the law has a compiled form, seed 0,
realistic plant unless ``--ideal``) and the **normal error** e_n(k) = n(k)ᵀ (x(k) − x_d(k)) is
formed from the record — x the true position, x_d the reference point, n the path frame's
normal at the reference index the step ended at: the task-frame normal component of the error,
the signed estimate of the contour error that ``ccc`` / ``rfnn`` / ``fnn`` act on. Its content
above about ``--cutoff`` f_c (default 100 Hz) is taken with one of two filters:

- ``--filter ma`` (default): e_n minus its centred moving average over N = 2·round(1 / (2 f_c T))
  + 1 samples (``scipy.ndimage.uniform_filter1d``, ends padded with the end values; N = 11 at
  T = 1 ms). The residual's gain is 1 − sin(Nπ f T) / (N sin(π f T)): 0.17 at 30 Hz, 0.43 at
  50 Hz, 0.80 at 75 Hz, 1 at the average's first null 1 / (N T) = 91 Hz, within 0.78–1.22
  above it. This is the measure of issue 38's figures.
- ``--filter butter``: a zero-phase Butterworth high-pass at f_c,
  ``scipy.signal.butter(4, f_c, "highpass", fs=1/T, output="sos")`` applied forwards and
  backwards (``scipy.signal.sosfiltfilt``; −6 dB at f_c, −27 dB at 0.75 f_c): the content
  strictly above f_c.

Printed per controller: the RMS and the peak |·| of the filtered error over the episode (µm;
``--window T0,T1`` restricts both to t in [T0, T1] s, the filter still runs over the whole
episode), the RMS and max of the true contour error, the frequency of the largest peak of the
filtered error's spectrum (Welch, 0.256 s segments, above 20 Hz) and the span where its 10 ms
moving RMS exceeds half its largest value (where the oscillation is).

``--slopes`` adds, for each ``rfnn`` / ``fnn`` controller (run again through the Python loop),
the slope of its learnt network along the path normal — by central differences of the network
(eqs. 5–7) in e and ė at each sample, the memory, θ and w of the sample held, zero where an
input is clipped — as the stiffness −∂y/∂e in units of the softest axis's PD stiffness P and
the damping −∂y/∂ė in units of that axis's D: the median over the span where the filtered error
is loud and the largest over the run; the largest spread of the normal direction's rule weights
(N); and the margins (``agents.margins.loop_margins``,
realistic plant at its nominal masses) of the PD loops with those median values added on every
axis — the loop the network makes of the PD near e = 0::

    python scripts/rfnn_hf_content.py --case hsm2-circle-II --controllers pd,ccc,fnn,rfnn
    python scripts/rfnn_hf_content.py --case hsm2-circle-II --controllers fnn,rfnn --slopes
    python scripts/rfnn_hf_content.py --case hsm2-circle-II --filter butter --json out/hf.json
"""

from __future__ import annotations

import argparse
import json
import sys

import gymnasium as gym
import numpy as np
from scipy import ndimage, signal

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller
from agents.rfnn import INPUT_LIMIT, RFNNController
from contour_env import ENV_ID
from contour_env.evaluation import run_episode
from contour_env.metrics import score

FILTERS = ("ma", "butter")
FILTER_ORDER = 4  # Butterworth order (sosfiltfilt: applied twice)
ENVELOPE_S = 0.010  # moving-RMS window for locating the oscillation
SPECTRUM_FROM_HZ = 20.0  # the dominant frequency is looked for above this


def normal_error(env, record) -> np.ndarray:
    """e_n = nᵀ (x − x_d) per recorded step (m): record row i ended at reference index
    min(i + 1, n_steps − 1) (``contour_env.env.rollout.AxisRecorder``)."""
    core = env.unwrapped.core
    n = len(record.time)
    kk = np.minimum(np.arange(1, n + 1), core.n_steps - 1)
    A = core.dim
    normal = core.frame[kk, :A, 1]  # frame columns: t, n (, b)
    return np.einsum("ki,ki->k", normal, record.position - record.reference)


def moving_average_samples(servo_period_s: float, cutoff_hz: float) -> int:
    """N of the ``ma`` filter: the odd sample count nearest 1 / (f_c T)."""
    return 2 * int(round(1.0 / (2.0 * cutoff_hz * servo_period_s))) + 1


def high_pass(x: np.ndarray, servo_period_s: float, cutoff_hz: float, kind: str = "ma"):
    """``x`` minus its centred moving average (``ma``), or a zero-phase Butterworth high-pass
    (``butter``); see the module docstring."""
    if kind == "ma":
        n = moving_average_samples(servo_period_s, cutoff_hz)
        return x - ndimage.uniform_filter1d(x, n, mode="nearest")
    if kind == "butter":
        fs = 1.0 / servo_period_s
        sos = signal.butter(FILTER_ORDER, cutoff_hz, "highpass", fs=fs, output="sos")
        return signal.sosfiltfilt(sos, x)
    raise ValueError(f"filter: one of {', '.join(FILTERS)}, got {kind!r}")


def hf_content(env, record, cutoff_hz: float = 100.0, window=None, kind: str = "ma") -> dict:
    """The figures printed for one run (µm, Hz, s)."""
    T = float(env.unwrapped.core.T)
    t = np.asarray(record.time)
    hp = high_pass(normal_error(env, record), T, cutoff_hz, kind)
    sel = np.ones(len(t), bool) if window is None else (t >= window[0]) & (t <= window[1])
    f, pxx = signal.welch(hp, fs=1.0 / T, nperseg=min(len(hp), int(round(0.256 / T))))
    above = f >= SPECTRUM_FROM_HZ
    m = max(1, int(round(ENVELOPE_S / T)))
    env_rms = np.sqrt(np.convolve(hp * hp, np.ones(m) / m, mode="same"))
    loud = np.flatnonzero(env_rms >= 0.5 * env_rms.max())
    metrics = score(record)
    return {
        "hf_rms_um": float(np.sqrt(np.mean(hp[sel] ** 2)) * 1e6),
        "hf_peak_um": float(np.max(np.abs(hp[sel])) * 1e6),
        "rms_contour_error_um": metrics["rms_contour_error_um"],
        "max_contour_error_um": metrics["max_contour_error_um"],
        "dominant_hz": float(f[above][np.argmax(pxx[above])]),
        "loud_from_s": float(t[loud[0]]),
        "loud_to_s": float(t[loud[-1]]),
    }


def network_slopes(env, spec: str, seed: int = 0):
    """(record, dy/de (n,), dy/dė (n,), weight spread (n,), controller) of a Python-loop run of
    ``spec`` (an ``rfnn`` / ``fnn``): the slopes of the network's output along the path normal
    (direction 1) at each sample, by central differences of the network with its memory, θ and
    w of the sample held (0 where an input is clipped: the law's clip makes the slope 0 there),
    and the spread max_j w_j − min_j w_j of that direction's weights (N)."""
    c = make_controller(spec)
    if not isinstance(c, RFNNController):
        raise ValueError(f"{spec}: --slopes needs an rfnn or fnn controller")
    c.bind(env)
    forward, law = c.network, c.act
    rows: list[tuple[float, float, float]] = []
    h, p = 1e-4, 1

    def act(signals):
        # the network of this sample, its memory, θ and w held as the law reads them
        x = c.network_inputs(signals)
        B = x.shape[0]
        memory, theta, w = c.memory[:B], c.theta[:B], c.w[:B]
        f = []
        for i in range(2):
            xp, xm = x.copy(), x.copy()
            xp[..., p, i] += h
            xm[..., p, i] -= h
            d = (forward(xp, memory, theta, w)[0] - forward(xm, memory, theta, w)[0]) / (2 * h)
            f.append(0.0 if abs(x[0, p, i]) >= INPUT_LIMIT else float(d[0, p]))
        e0, s0 = c.input_scale  # x = (e / e0, (ė + α e) / s0)
        rows.append((f[0] / e0 + f[1] * c.alpha / s0, f[1] / s0, float(np.ptp(w[0, p]))))
        return law(signals)

    c.act = act  # a law on the instance: the run takes the Python loop, one act per sample
    record = run_episode(env, c, seed=seed, compiled=False)
    arr = np.asarray(rows[: len(record.time)])
    return record, arr[:, 0], arr[:, 1], arr[:, 2], c


def slope_figures(env, spec: str, cutoff_hz: float = 100.0, kind: str = "ma", seed: int = 0):
    """The ``--slopes`` figures of one controller: stiffness / P and damping / D of the softest
    axis (median over the loud span, max over the run) and the margins of the PD loops with
    the medians added."""
    from agents.margins import loop_margins

    record, dyde, dydv, spread, c = network_slopes(env, spec, seed)
    T = float(env.unwrapped.core.T)
    fig = hf_content(env, record, cutoff_hz, None, kind)
    t = np.asarray(record.time)
    loud = (t >= fig["loud_from_s"]) & (t <= fig["loud_to_s"])
    a = int(np.argmin(c.P))
    P, D = np.asarray(c.P, float), np.asarray(c.D, float)
    k_e, k_v = -dyde / P[a], -dydv / D[a]
    med_e, med_v = float(np.median(k_e[loud])), float(np.median(k_v[loud]))
    p = "/".join(f"{v:.9g}" for v in P + med_e * P[a])
    d = "/".join(f"{v:.9g}" for v in np.maximum(D + med_v * D[a], 0.0))
    rep = loop_margins(f"pd:p={p}:d={d}", c.nominal.name, mass_variation=0.0)
    normal = next(r for r in rep["loops"] if r["loop"] == "normal")
    return {
        "stiffness_over_P_median_loud": med_e,
        "stiffness_over_P_max": float(np.max(k_e)),
        "damping_over_D_median_loud": med_v,
        "damping_over_D_max": float(np.max(k_v)),
        "weight_spread_max_N": float(np.max(spread)),
        "loop_stable": bool(rep["stable"]),
        "gain_margin_db": rep["min_gain_margin_db"],
        "phase_margin_deg": rep["min_phase_margin_deg"],
        "normal_phase_crossover_hz": normal.get("phase_crossover_hz"),
        "servo_period_s": T,
    }


def measure(
    case: str,
    controllers,
    cutoff_hz: float = 100.0,
    window=None,
    seed: int = 0,
    kind="ma",
    ideal: bool = False,
) -> dict:
    """{controller: figures} for one run of each controller on ``case``."""
    env = gym.make(ENV_ID, case=case, ideal=ideal)
    rows = {}
    for spec in controllers:
        c = make_controller(spec).bind(env)
        rows[spec] = hf_content(env, run_episode(env, c, seed=seed), cutoff_hz, window, kind)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", default="hsm2-circle-II")
    ap.add_argument("--controllers", default="ccc,fnn,rfnn")
    ap.add_argument("--cutoff", type=float, default=100.0, help="high-pass corner, Hz")
    ap.add_argument("--filter", default="ma", choices=FILTERS)
    ap.add_argument("--slopes", action="store_true", help="the learnt network's slope (above)")
    ap.add_argument("--window", default=None, help="T0,T1: RMS / peak over t in [T0, T1] s")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ideal", action="store_true", help="the textbook plant (no delay, lag, …)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    window = None if a.window is None else tuple(float(v) for v in a.window.split(","))
    specs = [s for s in a.controllers.split(",") if s]
    rows = measure(a.case, specs, a.cutoff, window, a.seed, a.filter, a.ideal)
    where = "" if window is None else f", t in [{window[0]:g}, {window[1]:g}] s"
    T = float(gym.make(ENV_ID, case=a.case, ideal=a.ideal).unwrapped.core.T)
    how = (
        f"minus its centred {moving_average_samples(T, a.cutoff)}-sample moving average"
        if a.filter == "ma"
        else f"Butterworth order {FILTER_ORDER} high-pass, zero-phase sosfiltfilt"
    )
    print(
        f"{a.case}{' (ideal plant)' if a.ideal else ''}: normal error e_n = nᵀ(x − x_d) above "
        f"~{a.cutoff:g} Hz ({how}{where}); seed {a.seed}"
    )
    head = ("controller", "HF RMS µm", "HF peak µm", "RMS ε µm", "max ε µm", "HF peak Hz",
            "HF loud s")  # fmt: skip
    w = max(len(head[0]), *(len(s) for s in specs))
    print(f"{head[0]:<{w}}  " + "  ".join(f"{h:>10}" for h in head[1:]))
    for spec, r in rows.items():
        print(
            f"{spec:<{w}}  {r['hf_rms_um']:>10.3f}  {r['hf_peak_um']:>10.3f}  "
            f"{r['rms_contour_error_um']:>10.3f}  {r['max_contour_error_um']:>10.3f}  "
            f"{r['dominant_hz']:>10.1f}  {r['loud_from_s']:>5.2f}–{r['loud_to_s']:.2f}"
        )
    if a.slopes:
        env = gym.make(ENV_ID, case=a.case, ideal=a.ideal)
        print(
            "learnt network along the normal (Python loop): stiffness −∂y/∂e / P and damping "
            "−∂y/∂ė / D of the softest axis; the PD loops with the loud-span medians added"
        )
        for spec in specs:
            if not isinstance(make_controller(spec), RFNNController):
                continue
            r = slope_figures(env, spec, a.cutoff, a.filter, a.seed)
            rows[spec]["slopes"] = r
            gm, pm = r["gain_margin_db"], r["phase_margin_deg"]
            hz = r["normal_phase_crossover_hz"]
            loop = (
                f"GM {gm:.2f} dB, PM {pm:.1f}°, normal loop's phase crossover {hz:.1f} Hz"
                if r["loop_stable"] and gm is not None and pm is not None and hz is not None
                else "unstable"
            )
            print(
                f"{spec:<{w}}  stiffness/P median {r['stiffness_over_P_median_loud']:.2f} "
                f"(max {r['stiffness_over_P_max']:.2f}), damping/D median "
                f"{r['damping_over_D_median_loud']:.2f} (max {r['damping_over_D_max']:.2f}), "
                f"weight spread max {r['weight_spread_max_N']:.0f} N; PD + medians: {loop}"
            )
    if a.json:
        with open(a.json, "w") as fh:
            out = {"case": a.case, "cutoff_hz": a.cutoff, "filter": a.filter, "window": window}
            json.dump({**out, "seed": a.seed, "results": rows}, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
