"""Excitation programs for identifying a feed drive (``contour-env excite``), and the package's
simulated response to them.

A program is, per axis, a **position reference** to play through the drive's own position loop
(safe: the drive keeps the axis on the reference, within the travel) and a **force dither** to
add to its current (force) command where the drive allows an offset. The trace to record while
it plays is the force (current) command and the encoder at the servo rate;
:mod:`contour_env.identify` fits the package's axis model to it.

The program, in order (times scale with the plant; ``t_plat`` = ``plateau_s``):

1. **Friction sweep** (about half of the main part): first a creep (4 encoder counts over four
   plateaus, out and back: the force ramps slowly through the static friction, a break-away
   test), then constant-velocity strokes at speeds on a doubling grid from 0.1 v_s (the
   Stribeck velocity; 0.1 mm/s on a model without friction; at least 50 encoder counts per
   plateau)
   up to the fastest speed the travel, the force budget and 1 m/s allow. At each speed the axis
   goes 0 → +d → −d → 0 (d = the distance of a ``t_plat`` plateau plus the ramps, at most 40 %
   of the travel), with a short dwell at rest before every start: each stroke ends in a
   low-speed reversal and a break-away from rest, which is where static friction and the
   Stribeck curve show; the plateaus give friction + viscous force at each speed.
2. **Chirp + PRBS**: a logarithmic position sine sweep from 0.5 Hz to min(100 Hz, 1/(20 T)) whose
   amplitude is held within the travel (20 %), the speed and the acceleration budget, with a
   maximum-length pseudo-random binary force dither (± ``dither_fraction`` of the force limit,
   a bit every two servo periods) added to the command: inertia, delay and current-loop lag.
3. **Validation** (the last 25 % of the program): a shorter friction sweep (every third speed,
   fastest first) and a short chirp with its own dither, held out by ``contour-env identify``
   (``holdout=0.25``) to score the identified model on data it was not fitted to.

The force budget: accelerations up to ``force_fraction`` / 2 of the force limit over the
nominal mass, speeds with a viscous force up to ``force_fraction`` / 2 of it, the dither
``dither_fraction`` of it: with the feedback on top the command stays well inside the limit.

:func:`excite` designs the program for every requested axis of a plant (all programs one length:
the chirps fill up to the longest friction sweep) and, unless told not to, simulates the
package's plant following it with a PID position loop (a triple pole at 0.06 / T rad/s on the
nominal model, with feedforward of the nominal m a + b v + f_c sgn v): the
``simulated_*`` columns of :func:`write_excitation_csv` — a preview of what the drive will do,
and a ready-made trace for a round trip.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field

import numpy as np

from .plants import Plant
from .plants.kernel import plant_step_batch

__all__ = [
    "DEFAULT_FORCE_FRACTION",
    "DEFAULT_DITHER_FRACTION",
    "DEFAULT_PLATEAU_S",
    "DEFAULT_TRAVEL_M",
    "HOLDOUT_FRACTION",
    "AxisProgram",
    "Excitation",
    "design_axis_program",
    "excite",
    "excitation_table",
    "simulate_program",
    "write_excitation_csv",
]

DEFAULT_TRAVEL_M = 0.1  # total stroke the program may use, m (centred on the start position)
DEFAULT_FORCE_FRACTION = 0.5  # share of the force limit the program plans to use
DEFAULT_DITHER_FRACTION = 0.2  # PRBS dither amplitude, share of the force limit
DEFAULT_PLATEAU_S = 0.2  # constant-velocity time per stroke of the friction sweep, s
HOLDOUT_FRACTION = 0.25  # the validation part at the end of the program
LOOP_BANDWIDTH_PER_PERIOD = 0.06  # simulated PID loop: a triple pole at ω = 0.06 / T rad/s
CHIRP_F0_HZ = 0.5
CHIRP_F1_MAX_HZ = 100.0
DWELL_S = 0.03  # rest before every stroke (break-away from rest), s
CREEP_COUNTS = 4.0  # the creep level's stroke, encoder counts
CREEP_PLATEAU = 4.0  # the creep level's plateau, × the plateau
LEAD_S = 0.1  # rest at the start and the end of the program, s
TAPER_S = 0.1  # cosine fade in and out of a chirp, s
MAX_SPEED_M_S = 1.0
LOWEST_SPEED_M_S = 1e-4  # lowest sweep speed on a model without friction, m/s
MAX_PROGRAM_STEPS = 2_000_000


@dataclass(frozen=True)
class AxisProgram:
    """One axis's program, sampled at the servo period (arrays (n,)): the position reference
    (m, relative to the start position), its velocity (m/s) and acceleration (m/s²), and the
    force dither (N) to add to the command; ``speeds_m_s`` the friction sweep's speeds."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    dither: np.ndarray
    speeds_m_s: tuple = ()


@dataclass
class Excitation:
    """An excitation program for some axes of a plant and (optionally) the package's simulated
    response: ``time_s`` (n,), ``axes`` (names), ``programs`` {axis: AxisProgram},
    ``simulated_command`` / ``simulated_position`` (n, len(axes)) or None (the force command
    the simulated PID loop computed, clipped to the limit, N; the encoder reading, m),
    ``settings`` (what was asked and derived, JSON-ready)."""

    time_s: np.ndarray
    axes: tuple
    programs: dict
    servo_period_s: float
    plant_name: str
    simulated_command: np.ndarray | None = None
    simulated_position: np.ndarray | None = None
    settings: dict = field(default_factory=dict)


# ----------------------------------------------------------------------------- the design


def _move(distance: float, v: float, a: float, T: float) -> np.ndarray:
    """Velocity samples (m/s) of a trapezoidal (or triangular) move of ``distance`` (signed, m)
    at speed ``v`` and acceleration ``a``, sampled every T, ending at rest; its sum × T equals
    the distance exactly."""
    d = abs(distance)
    if d == 0.0:
        return np.zeros(0)
    if d >= v * v / a:
        t_acc = v / a
        t_total = d / v + t_acc
    else:
        t_acc = math.sqrt(d / a)
        v = a * t_acc
        t_total = 2 * t_acc
    n = max(2, int(math.ceil(t_total / T)))
    t = (np.arange(n) + 0.5) * (t_total / n)
    vel = np.minimum(np.minimum(a * t, v), a * (t_total - t))
    vel *= d / (vel.sum() * T)
    return math.copysign(1.0, distance) * vel


def _sweep_velocity(speeds, travel, a, T, t_plat, creep=None) -> np.ndarray:
    """The friction sweep's velocity: per speed 0 → +d → −d → 0 with a dwell before each;
    first, with ``creep``, the same at that speed with CREEP_PLATEAU × the plateau."""
    dwell = np.zeros(max(1, int(round(DWELL_S / T))))
    parts = []
    levels = [(v, t_plat) for v in speeds]
    if creep:
        levels.insert(0, (creep, CREEP_PLATEAU * t_plat))
    for v, tp in levels:
        d = min(0.4 * travel, v * tp + v * v / a)
        for dist in (d, -2 * d, d):
            parts += [dwell, _move(dist, v, a, T)]
    parts.append(dwell)
    return np.concatenate(parts)


def _chirp(n: int, T: float, amp_pos, v_top, a_top, f0, f1) -> np.ndarray:
    """Position (m) of a logarithmic sine sweep f0 → f1 over n samples, amplitude at each
    frequency within ``amp_pos``, ``v_top`` / ω and ``a_top`` / ω², faded in and out."""
    if n < 4:
        return np.zeros(n)
    dur = n * T
    t = np.arange(n) * T
    k = math.log(f1 / f0) / dur
    freq = f0 * np.exp(k * t)
    phase = 2 * math.pi * f0 / k * (np.exp(k * t) - 1.0)
    w = 2 * math.pi * freq
    # a smooth minimum of the three bounds (a kink in the envelope is a jump in acceleration)
    amp = (amp_pos**-4 + (v_top / w) ** -4 + (a_top / w**2) ** -4) ** -0.25
    taper = np.ones(n)
    m = min(n // 2, max(1, int(round(TAPER_S / T))))
    ramp = 0.5 - 0.5 * np.cos(np.pi * np.arange(m) / m)
    taper[:m] = ramp
    taper[n - m :] = ramp[::-1]
    x = amp * taper * np.sin(phase)
    # the envelope's own rate of change adds to the speed and acceleration: scale the whole
    # sweep back within the bounds where it adds too much
    v = np.gradient(x, T)
    a = np.gradient(v, T)
    scale = min(1.0, v_top / max(np.max(np.abs(v)), 1e-300), a_top / max(np.max(np.abs(a)), 1e-300))
    return x * scale


def _prbs(n: int, amplitude: float, seed: int) -> np.ndarray:
    """± ``amplitude`` maximum-length sequence, a bit every sample (white up to the Nyquist
    frequency, where a delay and a lag differ most), n samples (the start drawn from
    ``seed``)."""
    from scipy.signal import max_len_seq  # loaded where used (CLI start-up)

    if n == 0 or amplitude == 0.0:
        return np.zeros(n)
    nbits = 12
    seq = max_len_seq(nbits)[0].astype(np.float64) * 2.0 - 1.0
    shift = int(np.random.default_rng(seed).integers(len(seq)))
    reps = int(math.ceil(n / len(seq))) + 1
    bits = np.roll(np.tile(seq, reps), -shift)
    return amplitude * bits[:n]


def _axis_budget(params, i: int, travel: float, force_fraction: float, t_plat: float):
    """(acceleration a, top speed, speeds of the friction sweep) of axis i."""
    m = float(params.mass_kg[i])
    b = float(params.viscous_Ns_m[i])
    fmax = float(params.force_limit_N[i])
    fs = float(params.static_N[i])
    vs = float(params.stribeck_velocity_m_s[i])
    q = float(params.encoder_resolution_m[i])
    budget = 0.5 * force_fraction * fmax
    a = max(budget - fs, 0.1 * budget) / m
    v_top = min(MAX_SPEED_M_S, math.sqrt(a * 0.4 * travel), budget / b if b > 0 else math.inf)
    # down to 0.1 v_s, or 0.1 mm/s where the model has no friction (the machine will have
    # some), and at least 50 encoder counts per plateau
    v_low = max(0.1 * vs if fs > 0 else LOWEST_SPEED_M_S, 50.0 * q / t_plat, 1e-6)
    v_low = min(v_low, v_top)
    # creep: a few encoder counts over a long plateau; whatever the loop, the force then
    # ramps slowly through the static friction at its start and at each reversal, so that
    # the break-away force is the static friction, not a servo period's force step beyond it
    creep = CREEP_COUNTS * q / (CREEP_PLATEAU * t_plat) if q > 0 else 0.05 * v_low
    creep = min(creep, 0.5 * v_low)
    speeds = [v_low]
    while speeds[-1] * 2.0 < v_top * 0.999:
        speeds.append(speeds[-1] * 2.0)
    if speeds[-1] < v_top * 0.999:
        speeds.append(v_top)
    return a, v_top, speeds, creep


@dataclass(frozen=True)
class _Parts:
    sweep_main: np.ndarray  # velocity samples
    sweep_val: np.ndarray
    a: float
    v_top: float
    speeds: tuple


def _axis_parts(params, i, travel, force_fraction, t_plat) -> _Parts:
    T = params.servo_period_s
    a, v_top, speeds, creep = _axis_budget(params, i, travel, force_fraction, t_plat)
    main = _sweep_velocity(speeds, travel, a, T, t_plat, creep)
    val = _sweep_velocity(speeds[::-3], travel, a, T, t_plat)
    return _Parts(main, val, a, v_top, tuple([creep, *speeds]))


def _natural_steps(parts: _Parts, T: float) -> int:
    """Program length (samples) the axis would choose alone: chirps 0.6 × the sweeps, the
    validation part a quarter of the whole."""
    lead = int(round(LEAD_S / T))
    main = len(parts.sweep_main) * 1.6 + lead
    val = len(parts.sweep_val) * 1.6 + lead
    return int(math.ceil(max(main / (1 - HOLDOUT_FRACTION), val / HOLDOUT_FRACTION)))


def design_axis_program(
    params,
    axis_index: int,
    n_steps: int,
    *,
    travel_m: float = DEFAULT_TRAVEL_M,
    force_fraction: float = DEFAULT_FORCE_FRACTION,
    dither_fraction: float = DEFAULT_DITHER_FRACTION,
    plateau_s: float = DEFAULT_PLATEAU_S,
    seed: int = 0,
) -> AxisProgram:
    """The program of axis ``axis_index`` of ``params`` (PlantParams, the model the program is
    planned on) over ``n_steps`` servo periods: lead-in rest, friction sweep, chirp + PRBS up to
    75 % of the length, then the validation part (short sweep, short chirp + PRBS) and rest.
    ``n_steps`` must be at least the axis's natural length (:func:`excite` takes the longest of
    the axes)."""
    T = params.servo_period_s
    i = axis_index
    parts = _axis_parts(params, i, travel_m, force_fraction, plateau_s)
    lead = int(round(LEAD_S / T))
    n_main = int(round((1 - HOLDOUT_FRACTION) * n_steps))
    n_val = n_steps - n_main
    chirp_main = n_main - lead - len(parts.sweep_main)
    chirp_val = n_val - lead - len(parts.sweep_val)
    if chirp_main < 0 or chirp_val < 0:
        raise ValueError(f"n_steps: {n_steps} is shorter than the program of axis {i} needs")
    f1 = min(CHIRP_F1_MAX_HZ, 1.0 / (20.0 * T))
    fmax = float(params.force_limit_N[i])
    amp_pos = 0.2 * travel_m
    a_chirp = parts.a
    v_chirp = parts.v_top
    vel = np.zeros(n_steps)
    pos_chirp = np.zeros(n_steps)
    dither = np.zeros(n_steps)
    # main part: rest, sweep (velocity), chirp (position)
    k = lead
    vel[k : k + len(parts.sweep_main)] = parts.sweep_main
    k += len(parts.sweep_main)
    pos_chirp[k : k + chirp_main] = _chirp(
        chirp_main, T, amp_pos, v_chirp, a_chirp, CHIRP_F0_HZ, f1
    )
    amp_d = dither_fraction * fmax
    dither[k : k + chirp_main] = _prbs(chirp_main, amp_d, seed)
    # validation part: sweep, chirp, rest
    k = n_main
    vel[k : k + len(parts.sweep_val)] = parts.sweep_val
    k += len(parts.sweep_val)
    pos_chirp[k : k + chirp_val] = _chirp(chirp_val, T, amp_pos, v_chirp, a_chirp, 1.0, f1)
    dither[k : k + chirp_val] = _prbs(chirp_val, amp_d, seed + 1)
    # position: the sweep's integral (exactly back to 0 after each speed) plus the chirp
    pos_sweep = np.concatenate([[0.0], np.cumsum(vel[:-1]) * T])
    position = pos_sweep + pos_chirp
    velocity = np.gradient(position, T)
    acceleration = np.gradient(velocity, T)
    return AxisProgram(position, velocity, acceleration, dither, parts.speeds)


# ----------------------------------------------------------------------------- simulation


def simulate_program(
    plant: Plant,
    references: np.ndarray,
    velocities: np.ndarray,
    accelerations: np.ndarray,
    dither: np.ndarray,
    *,
    noise_m: float = 0.0,
    seed: int = 0,
    bandwidth_rad_s: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The plant following the references (n, A) with a PID position loop on the encoder
    (backward-difference velocity; a triple pole at ``bandwidth_rad_s``, default 0.06 / T, on
    the nominal model; the integral within half the force limit), feedforward of the nominal
    m a + b v + f_c sgn v and the dither added. Returns (command, encoder) (n, A): the force
    command computed at each sample, clipped to the force limit (what a drive's trace records),
    and the encoder reading at that sample (quantised, with Gaussian noise of ``noise_m``
    before the rounding). The plant's own computation delay, current-loop lag, friction,
    ripple and disturbance act in between."""
    p = plant.params
    nom = plant.nominal
    T = p.servo_period_s
    n, A = references.shape
    w = LOOP_BANDWIDTH_PER_PERIOD / T if bandwidth_rad_s is None else bandwidth_rad_s
    m, b = nom.mass_kg, nom.viscous_Ns_m
    # PID with a triple pole at ω on the nominal m s² + b s: the integral drives the force
    # through the static friction at every low-speed start and reversal (a break-away), as a
    # drive's own loop would
    P = 3.0 * m * w * w
    D = np.maximum(3.0 * m * w - b, 0.0)
    KI = m * w**3
    ff = (
        m * accelerations
        + b * velocities
        + nom.coulomb_N * np.sign(np.where(np.abs(velocities) > 1e-9, velocities, 0.0))
    )
    limit = p.force_limit_N
    state = plant.initial_state(np.zeros((1, A)))
    z, stuck, pending = state.z, state.stuck, state.u_pending
    packed = plant.packed
    applied = np.zeros((1, A))
    w_extra = np.zeros((1, A))
    res = p.encoder_resolution_m
    safe = np.where(res > 0, res, 1.0)
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal((n, A)) * float(noise_m) if noise_m > 0 else np.zeros((n, A))
    command = np.empty((n, A))
    encoder = np.empty((n, A))
    prev = np.zeros(A)
    integral = np.zeros(A)
    i_max = 0.5 * limit
    u = np.empty((1, A))
    for k in range(n):
        xm = z[0, :, 0] + noise[k]
        xm = np.where(res > 0, np.floor(xm / safe + 0.5) * safe, xm)
        vm = (xm - prev) / T if k > 0 else np.zeros(A)
        prev = xm
        e = references[k] - xm
        de = velocities[k] - vm
        integral = np.clip(integral + KI * e * T, -i_max, i_max)
        uk = np.clip(ff[k] + P * e + D * de + integral + dither[k], -limit, limit)
        command[k] = uk
        encoder[k] = xm
        u[0] = uk
        plant_step_batch(
            z,
            stuck,
            pending,
            u,
            k * T,
            T,
            p.friction_substeps,
            p.computation_delay,
            *packed,
            applied,
            w_extra,
        )
    return command, encoder


# ----------------------------------------------------------------------------- entry point


def _check_number(label, value, lo, hi, *, lo_open=True):
    ok = (
        not isinstance(value, bool)
        and isinstance(value, (int, float, np.integer, np.floating))
        and math.isfinite(value)
        and (value > lo if lo_open else value >= lo)
        and value <= hi
    )
    if not ok:
        rule = f"{'>' if lo_open else '>='} {lo:g} and <= {hi:g}"
        raise ValueError(f"{label}: must be a number {rule}, got {value!r}")
    return float(value)


def excite(
    plant="friction-table",
    axes=None,
    *,
    travel_m: float = DEFAULT_TRAVEL_M,
    force_fraction: float = DEFAULT_FORCE_FRACTION,
    dither_fraction: float = DEFAULT_DITHER_FRACTION,
    plateau_s: float = DEFAULT_PLATEAU_S,
    seed: int = 0,
    ideal: bool = False,
    simulate: bool = True,
    noise_m: float = 0.0,
) -> Excitation:
    """The excitation program of ``axes`` (names, default every axis) of ``plant`` (a plant
    name, a mapping of parameters or a JSON file of them), planned on the plant's nominal
    model, and with ``simulate`` the package's true plant (``ideal``: the textbook one)
    following it (see the module docstring). ``travel_m`` (m): the whole stroke the program
    may use, centred on the start position; ``force_fraction``, ``dither_fraction``: shares of
    the force limit; ``plateau_s`` (s): constant-velocity time per stroke; ``noise_m`` (m):
    encoder noise of the simulated trace; ``seed``: the PRBS start and the noise."""
    travel_m = _check_number("travel", travel_m, 0.0, 100.0)
    force_fraction = _check_number("force_fraction", force_fraction, 0.0, 1.0)
    dither_fraction = _check_number("dither_fraction", dither_fraction, 0.0, 0.5, lo_open=False)
    plateau_s = _check_number("plateau", plateau_s, 0.0, 100.0)
    noise_m = _check_number("noise", noise_m, 0.0, 1.0, lo_open=False)
    obj = Plant(plant, ideal=bool(ideal))
    nom = obj.nominal
    T = nom.servo_period_s
    if plateau_s < 20 * T:
        raise ValueError(
            f"plateau: must be at least 20 servo periods ({20 * T:g} s), got {plateau_s:g}"
        )
    names = list(nom.axis_names)
    if axes is None:
        axes = names
    if isinstance(axes, str):
        axes = [a.strip() for a in axes.split(",") if a.strip()]
    bad = [a for a in axes if a not in names]
    if bad or not axes or len(set(axes)) != len(axes):
        raise ValueError(
            f"axis: {', '.join(bad) if bad else axes!r} is not an axis of plant {nom.name!r} "
            f"(axes {', '.join(names)}); give one or several, comma-separated"
        )
    idx = [names.index(a) for a in axes]
    parts = {i: _axis_parts(nom, i, travel_m, force_fraction, plateau_s) for i in idx}
    n = max(_natural_steps(parts[i], T) for i in idx)
    if n > MAX_PROGRAM_STEPS:
        raise ValueError(
            f"the program would take {n} servo periods ({n * T:.4g} s), more than "
            f"{MAX_PROGRAM_STEPS}: raise the plateau's speed range (a shorter plateau or travel)"
        )
    programs = {}
    for j, i in enumerate(idx):
        programs[names[i]] = design_axis_program(
            nom,
            i,
            n,
            travel_m=travel_m,
            force_fraction=force_fraction,
            dither_fraction=dither_fraction,
            plateau_s=plateau_s,
            seed=seed * 7919 + j,
        )
    time_s = np.arange(n) * T
    exc = Excitation(
        time_s=time_s,
        axes=tuple(axes),
        programs=programs,
        servo_period_s=T,
        plant_name=nom.name,
        settings={
            "plant": nom.name,
            "axes": list(axes),
            "servo_period_s": T,
            "duration_s": n * T,
            "travel_m": travel_m,
            "force_fraction": force_fraction,
            "dither_fraction": dither_fraction,
            "plateau_s": plateau_s,
            "seed": seed,
            "holdout_from_s": round((1 - HOLDOUT_FRACTION) * n) * T,
            "speeds_m_s": {a: list(programs[a].speeds_m_s) for a in axes},
        },
    )
    if simulate:
        A = nom.n_axes
        refs, vels, accs, dith = (np.zeros((n, A)) for _ in range(4))
        for a, i in zip(axes, idx, strict=True):
            pr = programs[a]
            refs[:, i], vels[:, i], accs[:, i], dith[:, i] = (
                pr.position,
                pr.velocity,
                pr.acceleration,
                pr.dither,
            )
        cmd, enc = simulate_program(obj, refs, vels, accs, dith, noise_m=noise_m, seed=seed)
        exc.simulated_command = cmd[:, idx]
        exc.simulated_position = enc[:, idx]
        exc.settings.update(
            simulated_plant="ideal" if ideal else "realistic",
            simulated_noise_m=noise_m,
            simulated_loop_bandwidth_rad_s=LOOP_BANDWIDTH_PER_PERIOD / T,
            simulated_peak_command_fraction={
                a: float(np.max(np.abs(cmd[:, i])) / obj.params.force_limit_N[i])
                for a, i in zip(axes, idx, strict=True)
            },
            simulated_position_range_m={
                a: [float(enc[:, i].min()), float(enc[:, i].max())]
                for a, i in zip(axes, idx, strict=True)
            },
        )
    return exc


def excitation_table(exc: Excitation) -> tuple[list[str], np.ndarray]:
    """(header, rows (n, columns)) of the program's CSV: ``time_s``; per axis
    ``reference_position_<a>`` (m), ``reference_velocity_<a>`` (m/s), ``dither_force_<a>``
    (N); with the simulation ``simulated_command_<a>`` (N) and ``simulated_position_<a>`` (m,
    the simulated encoder)."""
    header = ["time_s"]
    cols = [exc.time_s]
    for a in exc.axes:
        pr = exc.programs[a]
        header += [f"reference_position_{a}", f"reference_velocity_{a}", f"dither_force_{a}"]
        cols += [pr.position, pr.velocity, pr.dither]
    if exc.simulated_command is not None:
        for j, a in enumerate(exc.axes):
            header += [f"simulated_command_{a}", f"simulated_position_{a}"]
            cols += [exc.simulated_command[:, j], exc.simulated_position[:, j]]
    return header, np.column_stack(cols)


def write_excitation_csv(path, exc: Excitation):
    """Write the program (and its simulated response) as CSV, atomically."""
    from .io import atomic_write_text

    header, rows = excitation_table(exc)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in rows:
        w.writerow([repr(float(x)) for x in row])
    return atomic_write_text(path, buf.getvalue())
