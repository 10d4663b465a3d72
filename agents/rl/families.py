"""Training path families: a seeded generator of parts for residual-agent training and for the
validation set that picks the checkpoint (docs/RESIDUAL_TRAINING.md).

``generate_path(family, plant, seed)`` draws one :class:`GeneratedPath` — geometry, feed, feed
limits, true-plant variation and a random disturbance phase — from ``numpy.random.
default_rng(seed)`` alone, so a seed names a path. Families (:data:`FAMILIES`):

- ``polylines``: 3–8 straight legs written as a G-code program with ``G64 P<tolerance>``
  (read by :mod:`contour_env.paths.gcode`, timed by the look-ahead planner), corners of
  random angle and sign, the whole part at a random orientation with no leg within
  :data:`MIN_AXIS_ANGLE_DEG` of a machine axis;
- ``arcs``: one arc of random radius, start angle, sweep and direction;
- ``circles``: one full circle of random radius, start angle and direction;
- ``splines``: an open C² spline through 5–7 points of a random walk of chords;
- ``programs``: a planar contour as a shop program carries it — lines with or without
  tangent G02/G03 fillets at the corners, free or right-angle (axis-aligned) corners, exact
  stop (G61) or blending (G64 P), a rapid (G00) approach, a Z plunge and retract (pauses on a
  2-axis plant), a G04 dwell (:func:`_program`);
- ``helices`` (3-axis plants only): a helix of random radius, pitch, turns and axis.

On a 3-axis plant half of the parts lie in a plane of uniformly random normal, the other half
in the xy-plane (a planar part, as most are); on a 2-axis plant every part is in the
xy-plane at a random in-plane rotation. Sizes, feeds and feed limits per plant are data
(:data:`PLANT_RANGES`), chosen from the plant's named cases (``contour_env.cases``).
Training seeds are drawn below :data:`VALIDATION_SEED_BASE`; the validation set
(:func:`validation_set`) uses the seeds from it upwards, so the two never share a path.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from functools import cache

import numpy as np

from contour_env.paths import PathGeometry, arc, circle, helix, spline
from contour_env.plants import Plant
from contour_env.plants.catalog import PLANT_ALIASES
from contour_env.plants.from_file import is_plant_file
from contour_env.plants.randomize import randomized

from ..records import attributes

FAMILIES = ("polylines", "arcs", "circles", "splines", "programs", "helices")
THREE_AXIS_FAMILIES = ("helices",)
# training path seeds are drawn in [0, VALIDATION_SEED_BASE); validation path k has seed
# VALIDATION_SEED_BASE + k
VALIDATION_SEED_BASE = 2**31
# no polyline leg closer than this to a machine axis (deg)
MIN_AXIS_ANGLE_DEG = 5.0
# corner (tangent-jump) angles of a polyline, |turn| in this range (deg), either sign
CORNER_ANGLE_DEG = (15.0, 150.0)
POLYLINE_LEGS = (3, 8)
ARC_SWEEP_DEG = (30.0, 330.0)
SPLINE_POINTS = (5, 7)
# turn of the spline's control polygon at each interior point (deg, either way)
SPLINE_TURN_DEG = (10.0, 75.0)
HELIX_TURNS = (0.5, 3.0)
# helix rise per revolution as a fraction of its radius
HELIX_PITCH_PER_RADIUS = (0.05, 0.5)
# share of parts on a 3-axis plant in a plane of random normal (the rest: the xy-plane)
TILTED_SHARE = 0.5
_MAX_TRIES = 200
# the time the machine stands at the end point before the episode ends (s): held-out programs
# and real ones end with a retract or a dwell, and an agent that leaves the table off the path
# when it stops pays for it only while the episode goes on
SETTLE_TIME_S = (0.1, 1.0)


@dataclass(frozen=True)
class PlantRanges:
    """What a plant's generated parts may be (SI units).

    size_m : (min, max) part size: the largest side of a polyline's or spline's bounding box,
        a circle's, arc's or helix's diameter.
    feed_m_s : (min, max) programmed feed.
    max_accel_m_s2, max_jerk_m_s3 : the feed profile's limits (as the plant's named cases).
    max_centripetal_m_s2 : the feed on a curve is at most sqrt(a / κ_max).
    blend_tolerance_m : (min, max) G64 P path tolerance of a polyline's corners.
    travel_m : every point of a part lies within ±travel of the origin on each axis.
    max_path_time_s : the path length over the feed is at most this (a short episode); a
        longer part is shrunk.
    """

    size_m: tuple
    feed_m_s: tuple
    max_accel_m_s2: float
    max_jerk_m_s3: float
    max_centripetal_m_s2: float
    blend_tolerance_m: tuple
    travel_m: float
    max_path_time_s: float


# from the named cases: hsm2-circle-I..III (r 60–100 mm, 0.2–0.4 m/s, ≤ 2.67 m/s²
# centripetal, a 2 m/s², j 40 m/s³); jee-circle3d (r 50 mm, 0.167 m/s); lm-circle3d (r 0.5 m
# arc, 0.05 m/s, a 0.5 m/s², j 10 m/s³; 0.1 ms servo: episodes kept short); sharp-corner and
# corner-blend (30 mm legs, 0.02 m/s, a 0.5 m/s², j 10 m/s³, G64 P0.01 mm). The lowest feeds of
# hsm2 and the linear motor are a shop's finishing feeds (10 and 5 mm/s; issue 48): the agents'
# envelopes bound the programmed feed from below, and parts programmed at 13–25 mm/s — most shop
# programs — were outside the named cases' 50 and 20 mm/s
_RANGES_TABLE = {
    # plant: (size_m, feed_m_s, max_accel_m_s2, max_jerk_m_s3, max_centripetal_m_s2,
    #         blend_tolerance_m, travel_m, max_path_time_s), the fields of PlantRanges
    "hsm2": ((0.02, 0.2), (0.01, 0.4), 2.0, 40.0, 2.7, (10e-6, 100e-6), 0.25, 4.0),
    "jee-triaxial": ((0.01, 0.1), (0.03, 0.25), 2.0, 40.0, 1.0, (10e-6, 50e-6), 0.15, 4.0),
    "linear-motor": ((0.02, 0.3), (0.005, 0.15), 0.5, 10.0, 0.5, (10e-6, 50e-6), 0.5, 3.0),
    "friction-table": ((0.01, 0.06), (0.005, 0.04), 0.5, 10.0, 0.1, (5e-6, 50e-6), 0.1, 6.0),
}
PLANT_RANGES = {plant: PlantRanges(*row) for plant, row in _RANGES_TABLE.items()}


@dataclass(frozen=True)
class GeneratedPath:
    """One generated part: what an env needs to run it, and the drawn parameters.

    ``path`` is G-code text (``polylines``) or a :class:`PathGeometry`; ``feedrate_m_s`` the
    programmed feed (m/s); ``plant_params`` the true plant of the episode (a list of one
    PlantParams, or None for the plant's own); ``reset_seed`` the episode seed that fixes the
    random disturbance phase when the path is scored (validation)."""

    family: str
    plant: str
    seed: int
    path: object
    feedrate_m_s: float
    max_accel_m_s2: float
    max_jerk_m_s3: float
    plant_params: list | None
    reset_seed: int
    params: dict = field(default_factory=dict)
    settle_time_s: float = 0.1

    def env_kwargs(self) -> dict:
        """Keyword arguments of ``gym.make(ENV_ID, ...)`` (the disturbance phase random)."""
        kw = attributes(self, "plant", "path", "feedrate_m_s", "max_accel_m_s2", "max_jerk_m_s3")
        kw.update(settle_time_s=self.settle_time_s, disturbance_phase="random")
        if self.plant_params is not None:
            kw["plant_params"] = list(self.plant_params)
        return kw

    def describe(self) -> dict:
        """A JSON-able record: family, plant, seed, feed and the drawn shape parameters."""
        return {
            **attributes(
                self, "family", "plant", "seed", "feedrate_m_s", "settle_time_s", "reset_seed"
            ),
            **self.params,
        }


def plant_key(plant) -> str:
    """The catalogue name of a plant (aliases resolved), or a plant file's path; a plant
    without ranges is an error."""
    if is_plant_file(plant):
        key = os.fspath(plant)
        plant_ranges(key)  # the file holds what the parts may be
        return key
    key = PLANT_ALIASES.get(plant, plant)
    if key not in PLANT_RANGES:
        raise ValueError(
            f"plant: no training path families for {plant!r}; plants with families: "
            f"{', '.join(PLANT_RANGES)}, or a plant file (.json) with travel and feed_range"
        )
    return key


# a plant file's parts, scaled to what its trace covered (contour_env.identify.result): sizes
# 10–60 % of the travel (the named plants': 8–80 %), blend tolerances as the named plants',
# the centripetal limit half the acceleration, the jerk 20× it, episodes of at most 4 s (3 s
# below a 0.5 ms servo period, as the linear motor's)
FILE_SIZE_FRACTIONS = (0.1, 0.6)
FILE_BLEND_TOLERANCE_M = (10e-6, 50e-6)


def plant_ranges(plant) -> PlantRanges:
    """The :class:`PlantRanges` of a named plant (:data:`PLANT_RANGES`) or of a plant file,
    from its ``travel``, ``feed_range`` and ``max_acceleration`` (ValueError naming the file
    when it has none: ``contour-env identify`` writes them)."""
    if not is_plant_file(plant):
        return PLANT_RANGES[plant_key(plant)]
    name = os.fspath(plant)
    p = _plant(name).params
    missing = [
        k
        for k, v in (("travel", p.travel_m), ("feed_range", p.feed_range_m_s),
                     ("max_acceleration", p.max_acceleration_m_s2))
        if v is None
    ]  # fmt: skip
    if missing:
        raise ValueError(
            f"{name}: training on a plant file needs {', '.join(missing)} (the parts your "
            "machine runs: half the stroke per axis in m, [low, high] feeds in m/s, the "
            "acceleration limit in m/s²); contour-env identify writes them from the trace, or "
            "add them by hand (docs/FILES.md)"
        )
    travel = float(np.min(p.travel_m))
    a = p.max_acceleration_m_s2
    return PlantRanges(
        size_m=(FILE_SIZE_FRACTIONS[0] * travel, FILE_SIZE_FRACTIONS[1] * travel),
        feed_m_s=tuple(p.feed_range_m_s),
        max_accel_m_s2=a,
        max_jerk_m_s3=20.0 * a,
        max_centripetal_m_s2=0.5 * a,
        blend_tolerance_m=FILE_BLEND_TOLERANCE_M,
        travel_m=travel,
        max_path_time_s=4.0 if p.servo_period_s >= 5e-4 else 3.0,
    )


@cache
def _plant(key: str) -> Plant:
    return Plant(key)


def families_for(plant: str) -> tuple:
    """The families a plant takes (helices need three axes)."""
    n_axes = _plant(plant_key(plant)).n_axes
    return tuple(f for f in FAMILIES if n_axes == 3 or f not in THREE_AXIS_FAMILIES)


def check_families(families, plant: str) -> tuple:
    """``families`` as a tuple, each known and taken by ``plant``; () means all it takes."""
    fams = tuple(families)
    unknown = [f for f in fams if f not in FAMILIES]
    if unknown:
        raise ValueError(f"families: unknown {unknown}; allowed: {', '.join(FAMILIES)}")
    allowed = families_for(plant)
    refused = [f for f in fams if f not in allowed]
    if refused:
        raise ValueError(
            f"families: {refused} need a 3-axis plant; {plant!r} has 2 axes (allowed: "
            f"{', '.join(allowed)})"
        )
    return fams or allowed


# --- geometry helpers ------------------------------------------------------------------------
def _plane_basis(rng, n_axes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """(u, v, w, tilted): an orthonormal in-plane pair (u, v) at a random rotation and the
    normal w; on a 3-axis plant, with probability TILTED_SHARE, a plane of random normal."""
    tilted = n_axes == 3 and bool(rng.random() < TILTED_SHARE)
    if tilted:
        w = rng.normal(size=3)
        w /= np.linalg.norm(w)
    else:
        w = np.array([0.0, 0.0, 1.0])
    ref = np.array([1.0, 0.0, 0.0]) if abs(w[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - (ref @ w) * w
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(w, e1)
    phi = rng.uniform(0.0, 2 * math.pi)
    u = math.cos(phi) * e1 + math.sin(phi) * e2
    v = np.cross(w, u)
    return u, v, w, tilted


def _axis_angles_deg(directions: np.ndarray) -> np.ndarray:
    """Angle (deg) of each direction (rows, 3-D) to the nearest machine axis x, y or z."""
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.max(np.abs(d), axis=1), -1.0, 1.0)))


def _max_curvature(path: PathGeometry, n: int = 2001) -> float:
    s = np.linspace(0.0, path.total_length, n)
    _, kappa, _ = path.frames(s)
    return float(np.max(np.abs(kappa)))


def _fits(points: np.ndarray, travel_m: float) -> bool:
    return bool(np.all(np.abs(points) <= travel_m))


class _Draw:
    """One family's draw: the shape at a scale, the feed interval, the time cap."""

    def __init__(self, rng, ranges: PlantRanges, n_axes: int):
        self.rng = rng
        self.r = ranges
        self.n_axes = n_axes

    def feed(self, length_m: float, kappa_max: float) -> float | None:
        """A feed uniform in [max(f_lo, L / T_max), min(f_hi, sqrt(a_c / κ))], None if empty."""
        lo = max(self.r.feed_m_s[0], length_m / self.r.max_path_time_s)
        hi = self.r.feed_m_s[1]
        if kappa_max > 0:
            hi = min(hi, math.sqrt(self.r.max_centripetal_m_s2 / kappa_max))
        if lo > hi:
            return None
        return float(self.rng.uniform(lo, hi))

    def size(self) -> float:
        return float(self.rng.uniform(*self.r.size_m))


def _polyline(d: _Draw):
    rng = d.rng
    n_legs = int(rng.integers(POLYLINE_LEGS[0], POLYLINE_LEGS[1] + 1))
    turns = np.radians(rng.uniform(*CORNER_ANGLE_DEG, size=n_legs - 1))
    turns *= rng.choice([-1.0, 1.0], size=n_legs - 1)
    headings = np.concatenate([[0.0], np.cumsum(turns)])
    lengths = rng.uniform(0.2, 0.6, size=n_legs)
    planar = np.column_stack([np.cos(headings), np.sin(headings)]) * lengths[:, None]
    pts2 = np.vstack([np.zeros(2), np.cumsum(planar, axis=0)])
    extent = float(np.max(np.ptp(pts2, axis=0)))
    size = d.size()
    pts2 *= size / extent
    for _ in range(_MAX_TRIES):
        u, v, w, tilted = _plane_basis(rng, d.n_axes)
        pts = pts2[:, :1] * u + pts2[:, 1:] * v
        if np.min(_axis_angles_deg(np.diff(pts, axis=0))) >= MIN_AXIS_ANGLE_DEG:
            break
    else:
        return None
    length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    feed = float(rng.uniform(*d.r.feed_m_s))
    if length > feed * d.r.max_path_time_s:
        # longer than the time cap at its feed: shrink the part (corners keep their angles)
        scale = feed * d.r.max_path_time_s / length
        pts *= scale
        size *= scale
        length *= scale
    tol = float(rng.uniform(*d.r.blend_tolerance_m))
    text = _polyline_gcode(pts, feed, tol, d.n_axes == 3 and tilted)
    params = {
        "size_m": size,
        "n_legs": n_legs,
        "corner_deg": [round(float(x), 6) for x in np.degrees(turns)],
        "blend_tolerance_m": tol,
        "normal": [float(x) for x in w],
        "length_m": length,
    }
    return text, feed, params, pts


def _polyline_gcode(pts: np.ndarray, feed_m_s: float, tol_m: float, with_z: bool) -> str:
    """The program a CAM post writes for the legs: mm, absolute, G64 P (mm), F (mm/min); it
    starts at the origin (the first point), where the machine is."""
    lines = [
        "(generated training part: polyline)",
        "G21 G90 G17 G94",
        f"G64 P{tol_m * 1e3:.4f}",
    ]
    for k, p in enumerate(pts[1:]):
        words = f"X{p[0] * 1e3:.4f} Y{p[1] * 1e3:.4f}"
        if with_z:
            words += f" Z{p[2] * 1e3:.4f}"
        lines.append(f"G1 {words} F{feed_m_s * 6e4:.3f}" if k == 0 else words)
    lines.append("M30")
    return "\n".join(lines) + "\n"


# programs: share of parts with each feature; fillet radius / part size; pauses (s)
PROGRAM_FEATURE_P = 0.5
PROGRAM_AXIS_ALIGNED_P = 1 / 3
PROGRAM_FILLET = (0.03, 0.2)
PROGRAM_PAUSE_S = (0.2, 1.5)
PROGRAM_LEGS = (3, 7)


def _fillet(p_prev, p, p_next, r):
    """(arc start, arc end, centre, ccw) of a tangent fillet of radius r at corner p (2-D)."""
    u_in = (p - p_prev) / np.linalg.norm(p - p_prev)
    u_out = (p_next - p) / np.linalg.norm(p_next - p)
    turn = math.atan2(u_in[0] * u_out[1] - u_in[1] * u_out[0], float(u_in @ u_out))
    d = r * math.tan(abs(turn) / 2)
    a, b = p - d * u_in, p + d * u_out
    left = np.array([-u_in[1], u_in[0]])
    ccw = turn > 0
    centre = a + (r if ccw else -r) * left
    return a, b, centre, ccw


def _program(d: _Draw):
    rng = d.rng
    P = PROGRAM_FEATURE_P
    n_legs = int(rng.integers(PROGRAM_LEGS[0], PROGRAM_LEGS[1] + 1))
    aligned = bool(rng.random() < PROGRAM_AXIS_ALIGNED_P)
    if aligned:  # right-angle corners along the machine axes (rectangles, steps)
        turns = np.radians(90.0) * rng.choice([-1.0, 1.0], size=n_legs - 1)
        phi = math.radians(90.0) * int(rng.integers(4))
    else:
        turns = np.radians(rng.uniform(*CORNER_ANGLE_DEG, size=n_legs - 1))
        turns *= rng.choice([-1.0, 1.0], size=n_legs - 1)
        phi = float(rng.uniform(0.0, 2 * math.pi))
    headings = phi + np.concatenate([[0.0], np.cumsum(turns)])
    lengths = rng.uniform(0.2, 0.6, size=n_legs)
    legs = np.column_stack([np.cos(headings), np.sin(headings)]) * lengths[:, None]
    pts = np.vstack([np.zeros(2), np.cumsum(legs, axis=0)])
    if np.min(np.linalg.norm(np.diff(pts, axis=0), axis=1)) <= 0:
        return None
    size = d.size()
    offset = np.zeros(2)
    if rng.random() < P:  # a rapid approach from where the machine stands
        ang = float(rng.uniform(0.0, 2 * math.pi))
        offset = float(rng.uniform(0.2, 0.5)) * np.array([math.cos(ang), math.sin(ang)])
    # the part with its approach from the origin spans ``size``
    unit = np.vstack([np.zeros(2), pts / float(np.max(np.ptp(pts, axis=0))) + offset])
    scale = size / float(np.max(np.ptp(unit, axis=0)))
    pts = (pts / float(np.max(np.ptp(pts, axis=0))) + offset) * scale
    offset = offset * scale
    fillets = rng.random() < P
    frac = rng.uniform(*PROGRAM_FILLET, size=n_legs - 1)
    feed0 = float(rng.uniform(*d.r.feed_m_s))
    plunge_s = float(rng.uniform(*PROGRAM_PAUSE_S)) if rng.random() < P else 0.0
    # the approach, and the plunge and retract (3 mm of Z; a pause on a 2-axis plant)
    z_travel = 3e-3 if plunge_s else 0.0
    travel = float(np.linalg.norm(offset))
    length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    if length + travel + z_travel > feed0 * d.r.max_path_time_s:
        # longer than the time cap at its feed: shrink the part (angles kept)
        shrink = (feed0 * d.r.max_path_time_s - z_travel) / (length + travel) * 0.99
        pts, offset, size = pts * shrink, offset * shrink, size * shrink
        length, travel = length * shrink, travel * shrink
    travel += z_travel
    # tangent fillets: radius ~ the part size, at most what the shorter adjacent leg allows;
    # the feed then keeps the centripetal limit on the tightest one
    radii = np.zeros(n_legs - 1)
    feed = feed0
    if fillets:
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        for i in range(n_legs - 1):
            room = 0.45 * min(seg[i], seg[i + 1]) / math.tan(abs(turns[i]) / 2)
            radii[i] = min(float(frac[i]) * size, room)
        feed = min(feed, math.sqrt(d.r.max_centripetal_m_s2 * float(np.min(radii))))
        if feed < d.r.feed_m_s[0] or (length + travel) / feed > d.r.max_path_time_s:
            return None
    exact_stop = bool(rng.random() < P)
    tol = float(rng.uniform(*d.r.blend_tolerance_m))
    dwell_s = float(rng.uniform(*PROGRAM_PAUSE_S)) if rng.random() < P else 0.0
    dwell_after = int(rng.integers(n_legs))
    mm = 1e3
    f_mm_min = feed * 6e4

    def xy(p):
        return f"X{p[0] * mm:.4f} Y{p[1] * mm:.4f}"

    lines = ["(generated training part: program)", "G21 G90 G17 G94"]
    lines.append("G61" if exact_stop else f"G64 P{tol * mm:.4f}")
    if np.any(offset != 0):
        lines.append(f"G00 {xy(pts[0])}")
    first_f = f" F{f_mm_min:.3f}"
    if plunge_s:
        depth_mm = 1.0
        lines.append(f"G01 Z-{depth_mm:.3f} F{depth_mm / plunge_s * 60:.3f}")
    for i in range(n_legs):
        end = pts[i + 1]
        if i < n_legs - 1 and radii[i] > 0:
            a, b, c, ccw = _fillet(pts[i], pts[i + 1], pts[i + 2], radii[i])
            lines.append(f"G01 {xy(a)}{first_f}")
            first_f = ""
            ij = (c - a) * mm
            lines.append(f"G0{3 if ccw else 2} {xy(b)} I{ij[0]:.4f} J{ij[1]:.4f}")
            pts[i + 1] = b  # the next leg starts where the fillet ends
        else:
            lines.append(f"G01 {xy(end)}{first_f}")
            first_f = ""
        if dwell_s and i == dwell_after:
            lines.append(f"G04 P{dwell_s:.3f}")
    if plunge_s:
        lines.append("G00 Z1.000")
    lines.append("M30")
    params = {
        "size_m": size,
        "n_legs": n_legs,
        "axis_aligned": aligned,
        "corner_deg": [round(float(x), 6) for x in np.degrees(turns)],
        "fillet_radius_m": [float(x) for x in radii],
        "exact_stop": exact_stop,
        "blend_tolerance_m": None if exact_stop else tol,
        "rapid_approach_m": [float(x) for x in offset],
        "plunge_pause_s": plunge_s,
        "dwell_s": dwell_s,
        "normal": [0.0, 0.0, 1.0],
        "length_m": length + travel,
    }
    pts3 = np.column_stack([np.vstack([np.zeros(2), pts]), np.zeros(len(pts) + 1)])
    return "\n".join(lines) + "\n", feed, params, pts3


def _arc_or_circle(d: _Draw, full: bool):
    rng = d.rng
    u, v, w, _ = _plane_basis(rng, d.n_axes)
    radius = d.size() / 2
    sweep = 2 * math.pi if full else math.radians(rng.uniform(*ARC_SWEEP_DEG))
    ccw = bool(rng.integers(2))
    start = float(rng.uniform(0.0, 2 * math.pi))
    length = radius * sweep
    feed = d.feed(length, 1.0 / radius)
    if feed is None:
        return None
    kw = dict(normal=tuple(w), u=tuple(u), start_angle=start)
    if full:
        path = circle((0.0, 0.0, 0.0), radius, ccw=ccw, **kw)
    else:
        path = arc((0.0, 0.0, 0.0), radius, sweep=sweep if ccw else -sweep, **kw)
    params = {
        "radius_m": radius,
        "sweep_deg": math.degrees(sweep),
        "ccw": ccw,
        "start_angle_rad": start,
        "normal": [float(x) for x in w],
        "length_m": length,
    }
    return path, feed, params, path.sample_points(400)


def _spline(d: _Draw):
    rng = d.rng
    n = int(rng.integers(SPLINE_POINTS[0], SPLINE_POINTS[1] + 1))
    size = d.size()
    u, v, w, tilted = _plane_basis(rng, d.n_axes)
    # control points as a walk of chords U[0.5, 1] turning by U[SPLINE_TURN_DEG] either way at
    # each point: random points in a square (the first form) put cusps in one spline in two,
    # whose curvature no feed of the plant's interval could follow (linear motor: 2 % drawn)
    turns = np.radians(rng.uniform(*SPLINE_TURN_DEG, size=n - 2))
    turns *= rng.choice([-1.0, 1.0], size=n - 2)
    headings = float(rng.uniform(0.0, 2 * math.pi)) + np.concatenate([[0.0], np.cumsum(turns)])
    chords = rng.uniform(0.5, 1.0, size=n - 1)
    steps = np.column_stack([np.cos(headings), np.sin(headings)]) * chords[:, None]
    local = np.vstack([np.zeros(2), np.cumsum(steps, axis=0)])
    local /= max(float(np.max(np.ptp(local, axis=0))), 1e-12)
    pts = local[:, :1] * u + local[:, 1:] * v
    if d.n_axes == 3 and tilted:
        # a fully 3-D spline: the points leave the plane too
        pts = pts + np.outer(rng.uniform(-0.25, 0.25, size=n), w)
        pts -= pts[0]
    # the curve (not only its control points) spans `size` on its widest machine axis
    extent = float(np.max(np.ptp(spline(pts).sample_points(400), axis=0)))
    pts = pts * (size / extent)
    path = spline(pts)
    feed0 = float(rng.uniform(*d.r.feed_m_s))
    if path.total_length > feed0 * d.r.max_path_time_s:
        # longer than the time cap at that feed: shrink the part
        shrink = feed0 * d.r.max_path_time_s / path.total_length
        pts, size = pts * shrink, size * shrink
        path = spline(pts)
    length = path.total_length
    feed = d.feed(length, _max_curvature(path))
    if feed is None:
        return None
    params = {"size_m": size, "n_points": n, "normal": [float(x) for x in w], "length_m": length}
    return path, feed, params, path.sample_points(400)


def _helix(d: _Draw):
    rng = d.rng
    radius = d.size() / 2
    pitch = radius * float(rng.uniform(*HELIX_PITCH_PER_RADIUS))
    turns = float(rng.uniform(*HELIX_TURNS))
    ccw = bool(rng.integers(2))
    u, v, w, tilted = _plane_basis(rng, 3)
    h = pitch / (2 * math.pi)
    length = turns * 2 * math.pi * math.hypot(radius, h)
    feed = d.feed(length, radius / (radius**2 + h**2))
    if feed is None:
        return None
    path = helix(
        (0.0, 0.0, 0.0),
        radius,
        pitch,
        turns,
        axis=tuple(w),
        start_angle=float(rng.uniform(0.0, 2 * math.pi)),
        ccw=ccw,
    )
    params = {
        "radius_m": radius,
        "pitch_per_rev_m": pitch,
        "turns": turns,
        "ccw": ccw,
        "axis": [float(x) for x in w],
        "length_m": length,
    }
    return path, feed, params, path.sample_points(400)


_BUILDERS = {
    "polylines": _polyline,
    "arcs": lambda d: _arc_or_circle(d, full=False),
    "circles": lambda d: _arc_or_circle(d, full=True),
    "splines": _spline,
    "programs": _program,
    "helices": _helix,
}


def generate_path(family: str, plant: str, seed: int, *, plant_variation: float = 0.0):
    """One :class:`GeneratedPath` of ``family`` for ``plant``, drawn from ``seed`` (an integer
    ≥ 0) alone; ``plant_variation`` in [0, 1): every field of
    :data:`contour_env.plants.randomize.RANDOMIZED_FIELDS` of the true plant × U[1 − p, 1 + p]
    (0: the plant's own true parameters)."""
    key = plant_key(plant)
    if family not in FAMILIES:
        raise ValueError(f"family: unknown {family!r}; allowed: {', '.join(FAMILIES)}")
    check_families((family,), key)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed: expected an integer >= 0, got {seed!r}")
    if not (isinstance(plant_variation, (int, float)) and 0.0 <= plant_variation < 1.0):
        raise ValueError(f"plant_variation: must be in [0, 1), got {plant_variation!r}")
    ranges = plant_ranges(key)
    plant_obj = _plant(key)
    rng = np.random.default_rng(int(seed))
    draw = _Draw(rng, ranges, plant_obj.n_axes)
    for _ in range(_MAX_TRIES):
        got = _BUILDERS[family](draw)
        if got is not None and _fits(got[3], ranges.travel_m):
            break
    else:  # pragma: no cover - the ranges make a draw succeed within a few tries
        raise RuntimeError(f"families: no {family} for {key} from seed {seed}")
    path, feed, params, _ = got
    variation_seed = int(rng.integers(0, 2**31))
    reset_seed = int(rng.integers(0, 2**31))
    settle = float(rng.uniform(*SETTLE_TIME_S))
    plant_params = None
    if plant_variation:
        plant_params = randomized(plant_obj.params, plant_variation, 1, seed=variation_seed)
    return GeneratedPath(
        family=family,
        plant=key,
        seed=int(seed),
        path=path,
        feedrate_m_s=float(feed),
        max_accel_m_s2=ranges.max_accel_m_s2,
        max_jerk_m_s3=ranges.max_jerk_m_s3,
        plant_params=plant_params,
        reset_seed=reset_seed,
        params=params,
        settle_time_s=settle,
    )


def validation_set(
    plant: str, families=(), n_paths: int = 8, *, plant_variation: float = 0.0
) -> list[GeneratedPath]:
    """The fixed validation paths of ``plant``: path k is family ``families[k % len]`` (all the
    plant takes when empty) with seed ``VALIDATION_SEED_BASE + k`` — never a training seed,
    never a named case or a held-out program."""
    if isinstance(n_paths, bool) or not isinstance(n_paths, int) or n_paths < 1:
        raise ValueError(f"n_paths: expected an integer >= 1, got {n_paths!r}")
    fams = check_families(families, plant_key(plant))
    return [
        generate_path(
            fams[k % len(fams)], plant, VALIDATION_SEED_BASE + k, plant_variation=plant_variation
        )
        for k in range(n_paths)
    ]
