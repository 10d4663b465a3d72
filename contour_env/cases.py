"""Named benchmark cases (REFERENCE §4) as data, and the setup shared by every env of a case:
plant, path, feed profile and the per-step reference table.

Choices the papers leave open are documented per case in ``notes``. The numbers in a note
(radius, feed, centripetal acceleration, the feed profile's limits, angles, durations, step
counts, the payload's and the plant's factors) are computed from the case's own setup when the
module is imported (:func:`case_facts`), never typed, so a note cannot disagree with its case.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path

import numpy as np

from . import DEFAULT_CASE
from .paths import FeedProfile, PathGeometry, ReferenceTrajectory, circle, polyline
from .paths.gcode import MAX_FEED_M_S, parse_gcode, read_gcode
from .paths.gcode_source import is_program_text
from .plants import FIVE_AXIS_PLANT_ALIASES, Plant
from .plants.catalog import PLANT_ALIASES, nominal_params

# the programs shipped with the package (named cases on G-code, examples)
DATA_DIR = Path(__file__).resolve().parent / "data"


@dataclass(frozen=True)
class CaseSpec:
    """A named case: plant name, path description and feed (SI units)."""

    name: str
    plant: str
    path: dict
    feedrate_m_s: float
    max_accel_m_s2: float
    max_jerk_m_s3: float
    settle_time_s: float
    # a template: ``{fact}`` fields are filled from case_facts(spec) when the case is added
    notes: str
    published: str = ""
    # per-axis factors true = nominal × factor replacing the realistic mismatch of those fields
    # on the case's own plant (a payload: {"mass_kg": (1.3, 1.3)}); see Plant(true_scale=...)
    true_scale: dict = field(default_factory=dict)
    # the case's own env settings (EnvConfig fields, e.g. disturbance_phase="random" and
    # measurement_noise_std_m), used unless the env is made with other values
    env_config: dict = field(default_factory=dict)


CASES: dict[str, CaseSpec] = {}
# the five-axis machine's cases (Chen 2022), a plant family of their own: kept apart from the
# feed-drive cases above, whose every case runs the per-axis controllers (pd's compiled form,
# ccc, ...) and has the feed-drive plant's facts; get_case / build_setup / `contour-env cases`
# know both tables
FIVE_AXIS_CASES: dict[str, CaseSpec] = {}


def _build_path(desc: dict) -> PathGeometry:
    kind = desc["kind"]
    if kind == "circle":
        return circle(
            desc["center"],
            desc["radius"],
            normal=desc["normal"],
            start_angle=desc["start_angle"],
            sweep=desc["sweep"],
        )
    if kind == "polyline":
        return polyline(np.asarray(desc["points"], dtype=np.float64))
    raise ValueError(f"path kind {kind!r} unknown")


def _num(x: float) -> str:
    """A number as the notes print it: %g, with a true minus sign."""
    return f"{x:g}".replace("-", "−")


def _signed(x: float) -> str:
    return _num(x) if x < 0 else f"+{x:g}"


def _grouped(n: int) -> str:
    """An integer in groups of three digits: 630 000."""
    return f"{n:,}".replace(",", " ")


def _per_axis(values) -> str:
    return "/".join(_num(float(v)) for v in values)


def _planner_kwargs(program) -> dict:
    """The feed planner's inputs from a G-code program: its G61/G64 tolerance (m) at the end of
    each segment, its G04 dwells (s) after each and the pause before the first segment
    (``FeedProfile.build`` keywords)."""
    return dict(
        segment_blend_m=program.segment_blend_m,
        segment_dwell_s=program.segment_dwell_s,
        start_dwell_s=float(program.start_dwell_s),
    )


def case_facts(spec: CaseSpec) -> dict:
    """The numbers a case's notes quote, computed from its setup (SI values as formatted text).

    Every case: ``feed`` (m/s), ``feed_mm_s``, ``feed_m_min``, ``accel`` and ``jerk`` (the
    feed profile's limits), ``settle`` (s), ``servo_ms`` (the plant's servo period),
    ``episode_s`` (the feed profile's duration plus the settle time) and ``steps`` (servo
    periods in an episode: the reference has ceil(episode / T) + 1 samples, an episode steps
    from the first to the last). Circles: ``r`` (m), ``r_mm``, ``centripetal`` (v²/r, m/s²,
    two decimals), ``start_deg``, ``end_deg``, ``sweep_deg``, ``tilt_deg`` (of the plane from
    the xy-plane), ``normal`` (the plane's normal ∝ a small integer vector when it is one),
    ``arc_s`` (the arc at the feed, no ramps), ``rev_s`` and ``rev_steps`` (a full revolution
    at the feed) and ``x_reversal_deg`` (where the x axis reverses, if it does on the arc).
    Polylines: ``legs_mm`` (segment lengths) and ``corner_deg`` (direction changes). A payload
    (``true_scale``) adds ``mass_scale``, ``mass_short_pct`` (what a nominal-mass model lacks,
    in % of the nominal mass); the plant adds ``mass_mismatch`` (the realistic true/nominal
    mass factors) and ``mode_hz`` (the two-mass mode frequencies).
    """
    if spec.path["kind"] == "five-axis":
        return _five_axis_facts(spec)
    params, effects = nominal_params(spec.plant)
    T = float(params.servo_period_s)
    desc = spec.path
    program, geometry, profile = _facts_profile(spec)
    episode = profile.duration + spec.settle_time_s
    f = spec.feedrate_m_s
    facts = {
        "feed": _num(f),
        "feed_mm_s": _num(round(f * 1e3, 9)),
        "feed_m_min": _num(round(f * 60.0, 9)),
        "accel": _num(spec.max_accel_m_s2),
        "jerk": _num(spec.max_jerk_m_s3),
        "settle": _num(spec.settle_time_s),
        "servo_ms": _num(T * 1e3),
        "episode_s": f"{episode:.1f}",
        "steps": _grouped(math.ceil(episode / T - 1e-9)),
        "mass_mismatch": _per_axis(effects.mismatch.get("mass_kg", ())),
        "mode_hz": _per_axis(effects.structural_mode_hz),
    }
    if desc["kind"] == "circle":
        facts.update(_circle_facts(desc, geometry, f, T))
    elif desc["kind"] == "polyline":
        facts.update(_polyline_facts(desc))
    elif desc["kind"] == "gcode":
        facts.update(_gcode_facts(desc, program, geometry, profile, f))
    mass_scale = spec.true_scale.get("mass_kg")
    if mass_scale is not None:
        facts.update(
            mass_scale=_per_axis(sorted(set(mass_scale))),
            mass_short_pct=_per_axis(sorted({round((m - 1) * 100, 6) for m in mass_scale})),
        )
    return facts


def _facts_profile(spec: CaseSpec) -> tuple:
    """(the G-code program or None, the path, its feed profile) of a feed-drive case, for
    case_facts; a program's F must be the case's feed rate."""
    desc = spec.path
    if desc["kind"] != "gcode":
        geometry = _build_path(desc)
        profile = FeedProfile.build(
            geometry,
            spec.feedrate_m_s,
            max_accel_m_s2=spec.max_accel_m_s2,
            max_jerk_m_s3=spec.max_jerk_m_s3,
        )
        return None, geometry, profile
    program = read_gcode(DATA_DIR / desc["file"])
    geometry = program.path
    profile = FeedProfile.build(
        geometry,
        program.feedrate_m_s,
        max_accel_m_s2=spec.max_accel_m_s2,
        max_jerk_m_s3=spec.max_jerk_m_s3,
        segment_feeds=program.segment_feeds_m_s,
        **_planner_kwargs(program),
    )
    if abs(program.feedrate_m_s - spec.feedrate_m_s) > 1e-12:
        raise ValueError(
            f"case {spec.name}: feedrate_m_s {spec.feedrate_m_s} differs from the program's "
            f"F ({program.feedrate_m_s} m/s)"
        )
    return program, geometry, profile


def _circle_facts(desc: dict, geometry: PathGeometry, f: float, T: float) -> dict:
    """case_facts of a circle case (``f``: feed, m/s; ``T``: servo period, s)."""
    r, start, sweep = desc["radius"], desc["start_angle"], desc["sweep"]
    normal = np.asarray(desc["normal"], dtype=float)
    normal = normal / np.linalg.norm(normal)
    smallest = np.min(np.abs(normal[np.abs(normal) > 1e-12]))
    ints = normal / smallest
    normal_text = (
        "(" + ", ".join(f"{int(round(x))}" for x in ints) + ")"
        if np.allclose(ints, np.round(ints), atol=1e-9)
        else "(" + ", ".join(f"{x:.3g}" for x in normal) + ")"
    )
    s = np.linspace(0.0, geometry.total_length, 20001)
    vx = geometry.evaluate(s)["d1"][:, 0]
    flips = np.nonzero((vx[1:] * vx[:-1] <= 0) & (np.abs(vx[1:]) + np.abs(vx[:-1]) > 0))[0]
    return dict(
        r=_num(r),
        r_mm=_num(round(r * 1e3, 9)),
        centripetal=f"{f**2 / r:.2f}",
        start_deg=_signed(round(math.degrees(start), 6)),
        end_deg=_signed(round(math.degrees(start + sweep), 6)),
        sweep_deg=_num(round(math.degrees(sweep), 6)),
        tilt_deg=_num(round(math.degrees(math.acos(min(1.0, abs(normal[2])))), 6)),
        normal=normal_text,
        arc_s=f"{r * sweep / f:.1f}",
        rev_s=f"{2 * math.pi * r / f:.0f}",
        rev_steps=_grouped(round(2 * math.pi * r / f / T)),
        x_reversal_deg=(
            _num(round(math.degrees(start + s[flips[0]] / r)) + 0.0) if len(flips) else "none"
        ),
    )


def _polyline_facts(desc: dict) -> dict:
    """case_facts of a polyline case: leg lengths and corner angles."""
    pts = np.asarray(desc["points"], dtype=float)
    legs = np.diff(pts, axis=0)
    lengths = np.linalg.norm(legs, axis=1)
    unit = legs / lengths[:, None]
    turns = np.degrees(np.arccos(np.clip(np.sum(unit[1:] * unit[:-1], axis=1), -1, 1)))
    return dict(
        legs_mm=_per_axis(np.unique(np.round(lengths * 1e3, 6))),
        corner_deg=_per_axis(np.round(turns, 6)),
    )


def _gcode_facts(desc: dict, program, geometry: PathGeometry, profile, f: float) -> dict:
    """case_facts of a G-code case: its file, length, segments, corners, blends, durations."""
    # corners: direction changes between consecutive segments (tangent at the joint)
    s0 = geometry.seg_s0
    joints = s0[1:] if len(s0) > 1 else np.zeros(0)
    before = geometry.evaluate(np.maximum(joints - 1e-9, 0.0))["d1"]
    after = geometry.evaluate(joints + 1e-9)["d1"]
    cos = np.sum(before * after, axis=1) / (
        np.linalg.norm(before, axis=1) * np.linalg.norm(after, axis=1)
    )
    turns = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    blend = np.unique(program.segment_blend_m[:-1][turns > 0.1])
    return dict(
        file=desc["file"],
        length_mm=_num(round(geometry.total_length * 1e3, 1)),
        n_segments=str(geometry.n_segments),
        corner_deg=_per_axis(np.round(np.sort(turns[turns > 0.1]), 0)),
        blend_um=_per_axis(np.round(blend * 1e6, 3)),
        duration_at_feed_s=f"{geometry.total_length / f:.2f}",
        profile_s=f"{profile.duration:.2f}",
    )


def _five_axis_facts(spec: CaseSpec) -> dict:
    """The numbers a five-axis case's notes quote (Chen 2022 §4), from the path module's
    own constants: ``length_mm`` (tip path), ``duration_s`` (motion), ``feed_mm_s`` (peak
    tip feed of the S-curve), ``settle``."""
    from .paths.five_axis import PAPER_DURATION_S

    return {
        "length_mm": _num(round(spec.path["length_m"] * 1e3, 1)),
        "duration_s": _num(PAPER_DURATION_S),
        "feed_mm_s": _num(round(spec.feedrate_m_s * 1e3, 1)),
        "settle": _num(spec.settle_time_s),
        "abort_mm": _num(spec.env_config.get("abort_contour_error_m", 5e-3) * 1e3),
    }


def _add(spec: CaseSpec, table: dict | None = None) -> None:
    table = CASES if table is None else table
    table[spec.name] = replace(spec, notes=spec.notes.format(**case_facts(spec)))


_HSM2_NOTES = (
    "Lee 2012 Table 1 case {case}: circle of radius {{r}} m at {{feed}} m/s ({{centripetal}} m/s² "
    "centripetal), centre (0, 0), start at the bottom (0, −r), counter-clockwise, one "
    "revolution. The paper does not give the start-up: we ramp with the cosine S-curve "
    "(a ≤ {{accel}} m/s², jerk ≤ {{jerk}} m/s³) and stop at the start point; settle {{settle}} s."
)
for _case, _r, _f, _pub in (
    ("I", 0.1, 0.2, "max/RMS µm: PD 119/43, CCC 46/15, adaptive CCC 63/12"),
    ("II", 0.1, 0.4, "max/RMS µm: PD 288/160, CCC 149/56, adaptive CCC 125/28"),
    ("III", 0.06, 0.4, "max/RMS µm: PD 530/250, CCC 215/86, adaptive CCC 219/49"),
):
    _add(
        CaseSpec(
            name=f"hsm2-circle-{_case}",
            plant="hsm2",
            path=dict(
                kind="circle",
                center=(0.0, 0.0, 0.0),
                radius=_r,
                normal=(0.0, 0.0, 1.0),
                start_angle=-math.pi / 2,
                sweep=2 * math.pi,
            ),
            feedrate_m_s=_f,
            max_accel_m_s2=2.0,
            max_jerk_m_s3=40.0,
            settle_time_s=0.1,
            notes=_HSM2_NOTES.format(case=_case),
            published=_pub,
        )
    )

_add(
    CaseSpec(
        name="hsm2-payload",
        plant="hsm2",
        path=dict(CASES["hsm2-circle-II"].path),
        feedrate_m_s=0.4,
        max_accel_m_s2=2.0,
        max_jerk_m_s3=40.0,
        settle_time_s=0.1,
        notes=(
            "Lee 2012 case II's path (circle r = {r} m at {feed} m/s, start at the bottom, "
            "counter-clockwise, the same cosine S-curve and settle as hsm2-circle-II) on hsm2 "
            "carrying a payload: the true x and y masses are {mass_scale}× the nominal model's "
            "(this replaces the realistic plant's mass mismatch {mass_mismatch}; every other "
            "realistic effect is kept; with ideal=True the paper's model with {mass_scale}× "
            "mass). Controllers still get the nominal model, so a fixed model-based feedforward "
            "is {mass_short_pct} % short on inertia: the case tests whether adaptation finds the "
            "mass. With structural_mode the mode frequencies stay at {mode_hz} Hz."
        ),
        published="not in the paper (ours): a payload variant of case II",
        true_scale={"mass_kg": (1.3, 1.3)},
    )
)

_add(
    CaseSpec(
        name="jee-circle3d",
        plant="jee-triaxial",
        path=dict(
            kind="circle",
            center=(0.0, 0.0, 0.0),
            radius=0.05,
            normal=(1 / math.sqrt(3), 1 / math.sqrt(3), 1 / math.sqrt(3)),
            start_angle=0.0,
            sweep=2 * math.pi,
        ),
        feedrate_m_s=10.0 / 60.0,
        max_accel_m_s2=2.0,
        max_jerk_m_s3=40.0,
        settle_time_s=0.1,
        notes=(
            "Jee 2007: 3-D circle of radius {r_mm} mm at {feed_m_min} m/min. The paper's plane is "
            "not given: we use the plane normal to {normal} so all three axes move; one "
            "revolution, cosine S-curve start/stop (a ≤ {accel} m/s², jerk ≤ {jerk} m/s³), "
            "settle {settle} s."
        ),
        published=(
            "design goal: contour error ≤ 25 µm with tracking error ≤ 250 µm; 0 ≤ K_P ≤ 16.64"
        ),
    )
)

_add(
    CaseSpec(
        name="lm-circle3d",
        plant="linear-motor",
        path=dict(
            kind="circle",
            center=(0.0, 0.0, 0.0),
            radius=0.5,
            normal=(0.0, -math.sin(math.radians(30)), math.cos(math.radians(30))),
            start_angle=-math.pi / 4,
            sweep=math.pi / 2,
        ),
        feedrate_m_s=0.05,
        max_accel_m_s2=0.5,
        max_jerk_m_s3=10.0,
        settle_time_s=0.05,
        notes=(
            "Chen & Lee 2020's circle r = {r} m inclined {tilt_deg}°, {feed} m/s, "
            "T = {servo_ms} ms, turned by 90° about z: the paper's plane is tilted about y "
            "(x = r cos ωt cos 30°, y = r sin ωt, z = r cos ωt sin 30°), ours about x "
            "(x = r cos θ, y = r sin θ cos {tilt_deg}°, z = r sin θ sin {tilt_deg}°). A full "
            "revolution takes {rev_s} s ({rev_steps} steps); the paper does not fix the span, "
            "so the case is the {sweep_deg}° arc from {start_deg}° to "
            "{end_deg}° ({arc_s} s at the feed; the episode, with start-up, stop and settle, "
            "{episode_s} s, {steps} steps): it contains the x-axis velocity reversal at "
            "{x_reversal_deg}°, where Stribeck friction and ripple matter most. Cosine S-curve "
            "start/stop (a ≤ {accel} m/s², jerk ≤ {jerk} m/s³), settle {settle} s."
        ),
        published="(simulation) adaptation reduces the max contour error under friction and ripple",
    )
)

_add(
    CaseSpec(
        name="sharp-corner",
        plant="friction-table",
        path=dict(kind="polyline", points=((0.0, 0.0, 0.0), (0.03, 0.0, 0.0), (0.03, 0.03, 0.0))),
        feedrate_m_s=0.02,
        max_accel_m_s2=0.5,
        max_jerk_m_s3=10.0,
        settle_time_s=0.1,
        notes=(
            "Simba 2018 sharp-corner test on the friction table: two {legs_mm} mm straight "
            "segments meeting at a {corner_deg}° corner, {feed_mm_s} mm/s ({feed_m_min} m/min). "
            "The tool stops exactly at the corner (cosine S-curve, a ≤ {accel} m/s², jerk ≤ "
            "{jerk} m/s³), so the error there comes from friction, stick–slip and the "
            "disturbance; settle {settle} s. A degenerate stiction test, not a part: two "
            "axis-aligned legs and an exact stop (see corner-blend for corners a part "
            "program has)."
        ),
        published="VILCFD lowers the max contour error by about 37 % against conventional ILC",
    )
)

_add(
    CaseSpec(
        name="corner-blend",
        plant="friction-table",
        path=dict(kind="gcode", file="corner_blend.nc"),
        feedrate_m_s=0.02,
        max_accel_m_s2=0.5,
        max_jerk_m_s3=10.0,
        settle_time_s=0.1,
        notes=(
            "A part profile on the friction table in continuous-path mode: {n_segments} "
            "straight legs ({length_mm} mm, contour_env/data/{file}) with corners of "
            "{corner_deg}° and no leg along an axis, G64 with a {blend_um} µm path tolerance, "
            "{feed_mm_s} mm/s ({feed_m_min} m/min), a ≤ {accel} m/s², jerk ≤ {jerk} m/s³. The "
            "look-ahead planner passes each corner at the grbl junction speed of that tolerance "
            "(the reference stays on the programmed corner, the servo rounds it): the run "
            "lasts {profile_s} s against {duration_at_feed_s} s at the programmed feed. The "
            "disturbance phase is drawn at random each episode and the encoder has 50 nm noise "
            "(env defaults of this case), so a figure is not a property of one phase; "
            "settle {settle} s."
        ),
        published="(no published figure: a realistic counterpart of sharp-corner)",
        env_config=dict(disturbance_phase="random", measurement_noise_std_m=5e-8),
    )
)


# the five-axis cases' contour guard on ε + L·θ (m): 8× PD's peak on the realistic plant
FIVE_AXIS_ABORT_CONTOUR_M = 0.02


def _add_five_axis_cases() -> None:
    """Chen, Khong & Hsieh 2022 §4: the line and the inclined circle on the five-axis plant
    (paths, tool towards X_c and the S-curve: :mod:`contour_env.paths.five_axis`)."""
    from .paths.five_axis import (
        _CIRCLE,
        _LINE,
        DEFAULT_RAMP_FRACTION,
        PAPER_DURATION_S,
        _ramp_limits,
    )

    line_m = float(np.linalg.norm(np.subtract(_LINE["end"], _LINE["start"])))
    circle_m = 2 * math.pi * _CIRCLE["radius"]
    for name, length, what, pub in (
        (
            "five-axis-line",
            line_m,
            "line X1 = (0.08, 0.03, 0.02) → X2 = (0.01, 0.05, 0.07) m ({length_mm} mm), tool "
            "towards X_c = (0, −0.05, −0.5) m",
            "RMS tool-tip contour error / orientation error: PD 330.7 µm / 145.3″, "
            "ISMC 2.9 µm / 4.8″",
        ),
        (
            "five-axis-circle",
            circle_m,
            "circle r = 0.1 m in the 45° plane y = z ({length_mm} mm: ε₁ = x² + 2y² − r², "
            "ε₂ = y − z), tool towards X_c = (0, 0.8, −0.8) m",
            "RMS tool-tip contour error / orientation error: PD 668.4 µm / 649.5″, "
            "ISMC 17.9 µm / 2.8″",
        ),
    ):
        feed, accel, jerk = _ramp_limits(length, PAPER_DURATION_S, DEFAULT_RAMP_FRACTION)
        _add(
            CaseSpec(
                name=name,
                plant="five-axis",
                path=dict(kind="five-axis", name=name, length_m=length),
                feedrate_m_s=feed,
                max_accel_m_s2=accel,
                max_jerk_m_s3=jerk,
                settle_time_s=0.0,
                notes=(
                    f"Chen, Khong & Hsieh 2022 §4 on the NXV560A-class A–C table machine "
                    f"(plant five-axis, docs/FIVE_AXIS.md): {what}; the tip runs a cosine "
                    "S-curve over {duration_s} s (ramps a third of the time each, our choice: "
                    "the paper says only S-type), peak {feed_mm_s} mm/s, sampled at 1 ms; "
                    "settle {settle} s. Errors: the tool-tip contour error (distance to the tip "
                    "path) and the orientation error (angle to the reference tool vector); the "
                    "env's contour guard is on ε + L·θ (L = 0.15 m, contour_env.env."
                    "five_axis_core) at {abort_mm} mm, so joint PD on the realistic plant (peak "
                    "about 2.4 mm) keeps a wide margin and standing still costs the guard "
                    "penalty P per step."
                ),
                published=pub,
                env_config=dict(abort_contour_error_m=FIVE_AXIS_ABORT_CONTOUR_M),
            ),
            FIVE_AXIS_CASES,
        )


_add_five_axis_cases()


def case_names() -> list[str]:
    """The feed-drive cases (:data:`CASES`)."""
    return list(CASES)


def five_axis_case_names() -> list[str]:
    """The five-axis machine's cases (:data:`FIVE_AXIS_CASES`)."""
    return list(FIVE_AXIS_CASES)


def all_case_names() -> list[str]:
    """Every named case: the feed-drive ones, then the five-axis ones."""
    return [*CASES, *FIVE_AXIS_CASES]


def get_case(name: str) -> CaseSpec:
    spec = CASES.get(name, FIVE_AXIS_CASES.get(name)) if isinstance(name, str) else None
    if spec is None:
        raise ValueError(f"case: unknown case {name!r}; known cases: {', '.join(all_case_names())}")
    return spec


@dataclass(frozen=True)
class Setup:
    """Everything an env needs that does not change between episodes.

    ``segment_is_rapid`` (per path segment) and ``step_is_rapid`` (per reference step,
    :func:`rapid_steps`): read-only bool arrays for a G-code program with rapid (G00) moves,
    None for any other path (no rapids)."""

    name: str
    plant: Plant
    path: PathGeometry
    profile: FeedProfile
    reference: ReferenceTrajectory
    feedrate_m_s: float
    max_accel_m_s2: float
    notes: str = ""
    extra: dict = field(default_factory=dict)
    segment_is_rapid: np.ndarray | None = None
    step_is_rapid: np.ndarray | None = None
    # a G-code program: the reader's one-line summary of what it ignored or approximated
    # (setup words, dwells, Z taken by an unsimulated axis; "" for other paths) and its notes
    # (``GcodeNote(line, word, action)`` per word)
    program_summary: str = ""
    program_notes: tuple = ()


def rapid_steps(path: PathGeometry, segment_is_rapid, arc_length) -> np.ndarray:
    """Per reference sample (arc lengths ``arc_length``, m): True where the reference lies on a
    rapid move, i.e. on a segment flagged in ``segment_is_rapid``; a junction of a rapid and a
    cutting move (where the reference stops) counts as cutting."""
    flags = np.asarray(segment_is_rapid, dtype=bool).reshape(-1)
    s = np.clip(np.asarray(arc_length, dtype=np.float64).reshape(-1), 0.0, path.total_length)
    after = path.segment_index(s)  # a junction belongs to the next segment ...
    before = np.clip(np.searchsorted(path.seg_s0, s, side="left") - 1, 0, path.n_segments - 1)
    return flags[after] & flags[before]  # ... and, here, to the previous one too


@lru_cache(maxsize=32)
def _cached_setup(*args):
    return _make_setup(*args)


def _is_real_number(value) -> bool:
    # a real number, not a bool (True is no feed rate) nor a complex or a string
    return not isinstance(value, (bool, np.bool_)) and isinstance(
        value, (int, float, np.integer, np.floating)
    )


def build_setup(
    case=None,
    plant=None,
    path=None,
    *,
    feedrate_m_s=None,
    max_accel_m_s2=None,
    max_jerk_m_s3=None,
    settle_time_s=None,
    ideal=False,
    structural_mode=False,
    strict=False,
    rapid_feed_m_s=None,
) -> Setup:
    """Resolve (case | plant + path) into a Setup. Cached for hashable arguments.

    - ``case``: a named case; ``plant``/``path``/feed arguments override its parts. With no
      case, plant or path: the default case ``contour_env.DEFAULT_CASE`` (hsm2-circle-II).
    - ``path``: a PathGeometry, G-code program text (``"G1 X5 F600"``), or a G-code file (an
      ``os.PathLike``, or a str naming one; any extension). A str is told apart by
      :func:`contour_env.paths.gcode_source.is_program_text`: an existing file or a name
      ending in a usual extension (.nc .ngc .gcode .tap .cnc .txt .mpf .eia .ptp) is a file,
      a str with a line break or a G0-G3 word is program text, anything else a file name.
    - ``plant``: a plant name or a mapping of custom parameters (see params_from_mapping).
    - ``strict``: a G-code program with Z motion on a 2-axis plant is refused (ValueError
      naming the lines) instead of run with Z taken by an unsimulated axis (default False:
      Z-only moves become pauses of their duration, XY motion during a Z change is kept; the
      setup's ``program_summary`` says so).
    - ``rapid_feed_m_s``: the machine's rapid rate for G00 moves (m/s > 0; default the
      program's highest F, see ``contour_env.paths.gcode``).
    """
    if case is None and plant is None and path is None:
        case = DEFAULT_CASE
    if case is None and (plant is None or path is None):
        raise ValueError(
            "case: give a named case (case=...) or both plant=... and path=...; "
            f"known cases: {', '.join(all_case_names())}"
        )
    if case is not None and not isinstance(case, str):
        raise ValueError(f"case: expected a case name, got {type(case).__name__}")
    for label, value, rule in (
        ("feedrate_m_s", feedrate_m_s, "> 0"),
        ("max_accel_m_s2", max_accel_m_s2, "> 0"),
        ("max_jerk_m_s3", max_jerk_m_s3, "> 0"),
        ("settle_time_s", settle_time_s, ">= 0"),
        ("rapid_feed_m_s", rapid_feed_m_s, "> 0"),
    ):
        # checked before the cache: True == 1 would otherwise find the setup of 1 m/s
        if value is not None and not (
            _is_real_number(value)
            and math.isfinite(value)
            and (value >= 0 if rule == ">= 0" else value > 0)
        ):
            raise ValueError(f"{label}: must be a finite number {rule}, got {value!r}")
        if label in ("feedrate_m_s", "rapid_feed_m_s") and value is not None:
            # the G-code reader's F limit: keeps every time and distance of the planner finite
            if value > MAX_FEED_M_S:
                raise ValueError(f"{label}: must be > 0 and <= {MAX_FEED_M_S:g} m/s, got {value!r}")
    for label, value in (
        ("ideal", ideal),
        ("structural_mode", structural_mode),
        ("strict", strict),
    ):
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f"{label}: must be True or False, got {value!r}")
    try:
        hash((case, plant, path))
        hashable = True
    except TypeError:
        hashable = False
    args = (
        case,
        plant,
        path,
        feedrate_m_s,
        max_accel_m_s2,
        max_jerk_m_s3,
        settle_time_s,
        bool(ideal),
        bool(structural_mode),
        bool(strict),
        rapid_feed_m_s,
    )
    if hashable:
        return _cached_setup(*args)
    return _make_setup(*args)


def _five_axis_setup(spec, plant, path) -> bool | None:
    """True when the setup is a five-axis one (case or plant), None otherwise; ValueError
    for a five-axis case on another plant or a three-axis case on the five-axis plant."""
    five_plant = isinstance(plant, str) and plant in FIVE_AXIS_PLANT_ALIASES
    five_case = spec is not None and spec.plant == "five-axis"
    if five_case and plant is not None and not five_plant:
        raise ValueError(
            f"plant: the case {spec.name!r} is a five-axis case (joints x, y, z, A, C); it "
            f"runs on plant 'five-axis', not {plant!r}"
        )
    if five_plant and spec is not None and not five_case and path is None:
        raise ValueError(
            f"case: {spec.name!r} is a {spec.plant} (2/3-axis) case; the five-axis plant "
            "runs a five-axis case (five-axis-line, five-axis-circle) or a five-axis G-code "
            "program (path=..., X Y Z A C words)"
        )
    if five_case and path is not None:
        raise ValueError(
            f"path: the five-axis case {spec.name!r} has its own path; give plant='five-axis' "
            "and path=... without a case for a program"
        )
    return True if (five_plant or five_case) else None


def _make_setup(
    case,
    plant,
    path,
    feedrate,
    max_accel,
    max_jerk,
    settle,
    ideal,
    structural_mode,
    strict=False,
    rapid_feed=None,
) -> Setup:
    spec = get_case(case) if case is not None else None
    five = _five_axis_setup(spec, plant, path)
    if five is not None:
        from .env.five_axis_setup import build_five_axis_setup

        return build_five_axis_setup(
            spec,
            plant,
            path,
            ideal=ideal,
            structural_mode=structural_mode,
            feedrate=feedrate,
            max_accel=max_accel,
            max_jerk=max_jerk,
            settle=settle,
            rapid_feed=rapid_feed,
        )
    notes = spec.notes if spec else ""
    geometry, program, name = _setup_path(spec, case, plant, path, rapid_feed)
    plant_obj = _setup_plant(spec, plant, ideal, structural_mode)
    segment_feeds = None
    segment_is_rapid = None
    if program is not None:
        if program.path.dim == 3 and plant_obj.n_axes == 2:
            # Z taken by an unsimulated axis (or refused with strict=True)
            program = program.planar_xy(strict=bool(strict))
        geometry = program.path
        if program.segment_is_rapid.any():
            segment_is_rapid = program.segment_is_rapid.copy()
        if feedrate is None:
            # the program's own F words (per segment); an explicit feedrate overrides them
            segment_feeds = program.segment_feeds_m_s
            feedrate = program.feedrate_m_s
    if geometry.dim != plant_obj.n_axes:
        if geometry.dim == 2 and plant_obj.n_axes == 3:
            pass  # a planar xy path on a 3-axis machine: z is held at 0
        else:
            raise ValueError(
                f"path: a {geometry.dim}-D path cannot be followed by the {plant_obj.n_axes}-axis "
                f"plant {plant_obj.name!r} (a 2-axis plant needs a path in the xy-plane, z = 0)"
            )
    feedrate, accel, jerk, settle_s = _setup_limits(spec, feedrate, max_accel, max_jerk, settle)
    planner = {}
    if program is not None:
        # the program's G61/G64 modes and G04 dwells drive the look-ahead feed planner
        planner = _planner_kwargs(program)
    profile = FeedProfile.build(
        geometry,
        float(feedrate),
        max_accel_m_s2=float(accel),
        max_jerk_m_s3=float(jerk),
        segment_feeds=segment_feeds,
        **planner,
    )
    reference = ReferenceTrajectory.build(
        geometry, profile, plant_obj.servo_period_s, settle_time_s=float(settle_s)
    )
    step_is_rapid = None
    if segment_is_rapid is not None:
        step_is_rapid = rapid_steps(geometry, segment_is_rapid, reference.arc_length)
        segment_is_rapid.setflags(write=False)
        step_is_rapid.setflags(write=False)
    return Setup(
        name=name,
        plant=plant_obj,
        path=geometry,
        profile=profile,
        reference=reference,
        feedrate_m_s=float(feedrate),
        max_accel_m_s2=float(accel),
        notes=notes,
        segment_is_rapid=segment_is_rapid,
        step_is_rapid=step_is_rapid,
        program_summary=program.summary() if program is not None else "",
        program_notes=tuple(program.notes) if program is not None else (),
    )


def _setup_path(spec, case, plant, path, rapid_feed) -> tuple:
    """(the path, the G-code program or None, the setup's name) of `_make_setup`: the case's
    own path, a PathGeometry, G-code text or a G-code file."""
    program = None
    name = case or "custom"
    if path is None and spec.path["kind"] == "gcode":
        # a named case on a program shipped in contour_env/data
        path = str(DATA_DIR / spec.path["file"])
        name = case
    if path is None:
        geometry = _build_path(spec.path)
    elif isinstance(path, PathGeometry):
        geometry = path
    elif isinstance(path, (str, os.PathLike)):
        text = os.fspath(path)
        try:
            if is_program_text(path):
                program = parse_gcode(text, rapid_feed_m_s=rapid_feed)
                name = case or "gcode"
            else:
                program = read_gcode(text, rapid_feed_m_s=rapid_feed)
                name = case or os.path.basename(text)
        except ValueError as exc:
            if "rotary axis" not in str(exc):
                raise
            on = plant if plant is not None else spec.plant
            raise ValueError(
                f"{exc}; the plant {on!r} has only linear axes: A and C words need "
                "plant='five-axis'"
            ) from None
        geometry = program.path
    else:
        raise ValueError(
            "path: expected a PathGeometry, G-code text or a G-code file (a str or "
            f"os.PathLike), got {type(path).__name__}"
        )
    return geometry, program, name


def _setup_plant(spec, plant, ideal, structural_mode) -> Plant:
    """The plant of `_make_setup`: ``plant`` or the case's own, with the case's true-plant
    change (a payload) only on the case's own plant."""
    own_plant = spec is not None and (
        plant is None or (isinstance(plant, str) and PLANT_ALIASES.get(plant, plant) == spec.plant)
    )
    return Plant(
        plant if plant is not None else spec.plant,
        ideal=ideal,
        structural_mode=structural_mode,
        true_scale=spec.true_scale if own_plant and spec.true_scale else None,
    )


def _setup_limits(spec, feedrate, max_accel, max_jerk, settle) -> tuple:
    """(feed rate, acceleration, jerk, settle time) of `_make_setup`: the given values, else
    the case's (defaults for a custom path: 2 m/s², 40 m/s³, 0.1 s; a feed rate is needed)."""
    if feedrate is None:
        if spec is None:
            raise ValueError("feedrate_m_s: required for a custom path without F words")
        feedrate = spec.feedrate_m_s
    accel = max_accel if max_accel is not None else (spec.max_accel_m_s2 if spec else 2.0)
    jerk = max_jerk if max_jerk is not None else (spec.max_jerk_m_s3 if spec else 40.0)
    settle_s = settle if settle is not None else (spec.settle_time_s if spec else 0.1)
    for label, value in (
        ("feedrate_m_s", feedrate),
        ("max_accel_m_s2", accel),
        ("max_jerk_m_s3", jerk),
    ):
        if not (
            isinstance(value, (int, float, np.floating)) and math.isfinite(value) and value > 0
        ):
            raise ValueError(f"{label}: must be a finite number > 0, got {value!r}")
    if not (math.isfinite(settle_s) and settle_s >= 0):
        raise ValueError(f"settle_time_s: must be >= 0 seconds, got {settle_s!r}")
    return feedrate, accel, jerk, settle_s
