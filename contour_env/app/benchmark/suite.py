"""What each suite runs: a list of :class:`RunSpec`, every run independent of the others.

- ``quick`` (< 2 min on a 2-core machine): every named case × every applicable fixed
  controller (nominal plant, seed 0; the learning controllers are scored in the ILC section),
  the paper's variants of those rows (``ccc:wi=0``, ``rfnn:learn=0``), one small robustness
  sweep (hsm2-circle-II, ±20 %, 8 variations), one short ILC curve (sharp-corner, 5 trials)
  and the circular test (ISO 230-4) of every named 2- and 3-axis plant (:mod:`.circular`);
- ``paper``: every published comparison of the seed papers (:mod:`.published`): Lee 2012
  Tables 2–3, Jee 2007's design goal, Chen & Lee 2020 Tables 1–2, Chen 2022's PD vs ISMC and
  Simba 2018's VILCFD vs conventional ILC (10 trials, repeatable and random);
- ``full``: ``paper`` + every case × every applicable controller (the learning ones' first
  trial too) + robustness over plant variations (every feed-drive case, ±20 %, 32 variations)
  + ILC curves on three cases + the shipped residual agents on their plants' cases + the
  circular test of every named 2- and 3-axis plant (as in ``quick``);
- ``readme``: exactly the runs of the README's generated tables (:data:`README_TABLES`;
  ``scripts/readme_figures.py`` renders them from its results.json): the default gains and
  loop margins (``design`` runs), Lee 2012's circles, the shipped residual agents against
  their bases (``residual`` runs), the ILC benchmark and corner-blend over seeds 0–4.
  ``readme:NAME[,NAME...]`` runs the named tables' runs only.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from functools import cache

from .circular import KIND as CIRCULAR

NOMINAL = "nominal"
ROBUSTNESS = "robustness"
ILC = "ilc"
DESIGN = "design"
RESIDUAL_RUN = "residual"
KINDS = (NOMINAL, ROBUSTNESS, ILC, DESIGN, RESIDUAL_RUN, CIRCULAR)


@dataclass(frozen=True)
class RunSpec:
    """One independent run. ``kind``: nominal (one episode), robustness (plant variations),
    ilc (repeated batch), design (default gains and loop margins; ``case`` is the plant's
    name), residual (a shipped residual agent against its base on one test contour;
    ``case`` is the contour, ``variant`` the agent's name) or circular (the ISO 230-4
    circular test, CW and CCW; ``case`` is the plant's name, ``variant`` the circle,
    ``R50mm F0.2m/s``); ``variant``: the plant variant (``nominal``, ``random±20%x8``,
    ``repeatable`` / ``random`` for ILC); ``settings``: the kind's parameters."""

    kind: str
    case: str
    controller: str
    seed: int = 0
    variant: str = "nominal"
    settings: dict = field(default_factory=dict)

    def key(self) -> tuple:
        return (self.kind, self.case, self.controller, self.variant, self.seed)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> RunSpec:
        return cls(**d)

    def __hash__(self):
        return hash(self.key())


@dataclass(frozen=True)
class Suite:
    name: str
    description: str
    runs: tuple[RunSpec, ...]


# the fixed controllers of the feed-drive plants, in table order; the learning ones after
FIXED = ("pd", "ccc", "adaptive-ccc", "jee-ccc", "rfnn", "fnn")
LEARNING = ("ilc-pd", "ilc-contour", "vilcfd")
# the five-axis cases' controllers: the paper's PD (Table 2 gains), the tuned joint PID
# baseline, the paper's ISMC
FIVE_AXIS = ("pd", "pid", "ismc")
RESIDUAL = "residual"


@cache
def applicable(case: str, controller: str) -> bool:
    """Whether ``controller`` runs on ``case``: it binds to the case's env (jee-ccc needs a
    velocity-command drive, ismc the five-axis plant; ``residual`` needs a shipped agent for
    the case's plant)."""
    import gymnasium as gym

    from agents.registry import make_controller
    from contour_env import ENV_ID

    env = gym.make(ENV_ID, case=case)
    family = getattr(env.unwrapped.setup, "family", None)
    if controller == RESIDUAL:
        from agents.rl.models import shipped_model_for

        try:
            shipped_model_for(env.unwrapped.setup.plant.name)
        except ValueError:
            return False
        return family is None
    try:
        make_controller(controller, plant_family=family).bind(env)
    except ValueError:
        return False
    return True


def _family_controllers(case: str, learning: bool) -> list[str]:
    from contour_env.cases import FIVE_AXIS_CASES

    if case in FIVE_AXIS_CASES:
        return list(FIVE_AXIS)
    names = [*FIXED, *(LEARNING if learning else ())]
    return [c for c in names if applicable(case, c)]


def nominal(case: str, controller: str, seed: int = 0) -> RunSpec:
    return RunSpec(NOMINAL, case, controller, seed, "nominal", {"metrics": ["total"]})


def robust(case: str, controller: str, fraction: float, episodes: int, seed: int = 0) -> RunSpec:
    variant = f"random±{fraction * 100:g}%x{episodes}"
    return RunSpec(
        ROBUSTNESS, case, controller, seed, variant, {"fraction": fraction, "episodes": episodes}
    )


def ilc(case: str, controller: str, condition: str, iterations: int, seed: int = 0) -> RunSpec:
    settings = {"iterations": iterations, "condition": condition}
    if condition == "random":
        settings["noise_m"] = 5e-8
    return RunSpec(ILC, case, controller, seed, condition, settings)


def design(plant: str, controller: str) -> RunSpec:
    return RunSpec(DESIGN, plant, controller, 0, "realistic±20%", {"mass_variation": 0.2})


def residual_vs_base(model: str, target: str) -> RunSpec:
    return RunSpec(RESIDUAL_RUN, target, RESIDUAL, 0, model, {"model": model, "target": target})


def circular(
    plant: str, controller: str, radius_m=None, feed_m_s=None, overshoot_deg=None, seed: int = 0
) -> RunSpec:
    """The circular test of ``controller`` on ``plant``; the circle (m, m/s, degrees) defaults
    to the section's (:func:`.circular.circle_settings`)."""
    from .circular import circle_settings, variant_name

    settings = circle_settings(radius_m, feed_m_s, overshoot_deg)
    return RunSpec(CIRCULAR, plant, controller, seed, variant_name(settings), settings)


def _circular_runs() -> list[RunSpec]:
    from .circular import section_runs

    return [circular(plant, c) for plant, c in section_runs()]


# the rows of the published comparisons (our spec of each paper's controller)
PAPER_NOMINAL = {
    **{
        c: ("pd", "ccc:wi=0", "ccc", "adaptive-ccc")
        for c in ("hsm2-circle-I", "hsm2-circle-II", "hsm2-circle-III")
    },
    "jee-circle3d": ("pd", "jee-ccc"),
    "lm-circle3d": ("pd", "fnn", "rfnn", "rfnn:learn=0"),
    "five-axis-line": ("pd", "ismc"),
    "five-axis-circle": ("pd", "ismc"),
}


def _unique(runs) -> tuple[RunSpec, ...]:
    seen, out = set(), []
    for r in runs:
        if r.key() not in seen:
            seen.add(r.key())
            out.append(r)
    return tuple(out)


def _paper_nominal() -> list[RunSpec]:
    return [nominal(case, c) for case, ctrls in PAPER_NOMINAL.items() for c in ctrls]


def _all_nominal(learning: bool) -> list[RunSpec]:
    from contour_env.cases import all_case_names

    runs = []
    for case in all_case_names():
        runs += [nominal(case, c) for c in _family_controllers(case, learning)]
        runs += [nominal(case, c) for c in PAPER_NOMINAL.get(case, ())]
    return runs


def quick_suite() -> Suite:
    runs = _all_nominal(learning=False)
    runs += [robust("hsm2-circle-II", c, 0.2, 8) for c in ("pd", "ccc", "adaptive-ccc")]
    runs += [ilc("sharp-corner", c, "repeatable", 5) for c in ("ilc-contour", "vilcfd")]
    runs += _circular_runs()
    return Suite(
        "quick",
        "every case × fixed controller, a robustness sweep, an ILC curve, the circular tests",
        _unique(runs),
    )


def paper_suite() -> Suite:
    runs = _paper_nominal()
    runs += [
        ilc("sharp-corner", c, cond, 10) for cond in ("repeatable", "random") for c in LEARNING
    ]
    return Suite("paper", "every published comparison of the seed papers", _unique(runs))


def full_suite() -> Suite:
    from contour_env.cases import CASES

    runs = list(paper_suite().runs) + _all_nominal(learning=True)
    runs += [nominal(case, RESIDUAL) for case in CASES if applicable(case, RESIDUAL)]
    runs += [
        robust(case, c, 0.2, 32)
        for case in CASES
        for c in ("pd", "ccc", "adaptive-ccc")
        if applicable(case, c)
    ]
    runs += [
        ilc(case, c, cond, 10)
        for case in ("sharp-corner", "corner-blend", "hsm2-circle-II")
        for cond in ("repeatable", "random")
        for c in LEARNING
    ]
    runs += _circular_runs()
    return Suite(
        "full",
        "paper + every controller, robustness, ILC curves, residual agents, circular tests",
        _unique(runs),
    )


# --- the README's generated tables: what each one needs ------------------------------------

LEE2012_CASES = ("hsm2-circle-I", "hsm2-circle-II", "hsm2-circle-III")
CORNER_BLEND = ("pd", "ccc", "adaptive-ccc")
CORNER_BLEND_SEEDS = 5
# scripts/ilc_benchmark.py's defaults: 10 trials, seed 0, 50 nm encoder noise when random
ILC_TABLE_CASES = ("sharp-corner", "hsm2-circle-II")
ILC_TABLE_ITERATIONS = 10


def _controller_table_runs() -> list[RunSpec]:
    from contour_env.plants.catalog import plant_names

    from .design import CONTROLLERS, applies

    return [design(p, c) for p in plant_names() for c in CONTROLLERS if applies(p, c)]


def _lee2012_table_runs() -> list[RunSpec]:
    return [nominal(case, c) for case in LEE2012_CASES for c in PAPER_NOMINAL[case]]


def _residual_table_runs() -> list[RunSpec]:
    from .residual import shipped_targets

    return [residual_vs_base(model, target) for model, target in shipped_targets()]


def _ilc_table_runs() -> list[RunSpec]:
    return [
        ilc(case, c, cond, ILC_TABLE_ITERATIONS)
        for case in ILC_TABLE_CASES
        for cond in ("repeatable", "random")
        for c in LEARNING
    ]


def _corner_blend_table_runs() -> list[RunSpec]:
    return [
        nominal("corner-blend", c, seed) for c in CORNER_BLEND for seed in range(CORNER_BLEND_SEEDS)
    ]


# table name (as in the README's markers) → the runs it is rendered from
README_TABLES = {
    "controller_table": _controller_table_runs,
    "lee2012_table": _lee2012_table_runs,
    "residual_table": _residual_table_runs,
    "ilc_table": _ilc_table_runs,
    "corner_blend_table": _corner_blend_table_runs,
}


def readme_suite(tables=None) -> Suite:
    """The runs of the README's tables ``tables`` (default: all of :data:`README_TABLES`)."""
    names = list(README_TABLES) if tables is None else list(tables)
    bad = [n for n in names if n not in README_TABLES]
    if bad or not names:
        raise ValueError(
            f"--suite: readme:TABLE[,TABLE...] with tables of {', '.join(README_TABLES)}; "
            f"got {', '.join(bad) or 'none'}"
        )
    runs = [r for n in names for r in README_TABLES[n]()]
    name = "readme" if tables is None else f"readme:{','.join(names)}"
    return Suite(name, "the runs of the README's generated tables", _unique(runs))


SUITES = {"quick": quick_suite, "paper": paper_suite, "full": full_suite, "readme": readme_suite}


def get_suite(name: str) -> Suite:
    """The suite ``name`` (``readme:TABLE[,TABLE...]``: those README tables' runs only);
    ``ValueError`` naming ``--suite`` and the allowed values."""
    base, sep, rest = str(name).partition(":")
    if sep and base == "readme":
        return readme_suite([t.strip() for t in rest.split(",") if t.strip()])
    if name not in SUITES:
        raise ValueError(f"--suite: unknown suite {name!r}; allowed: {', '.join(SUITES)}")
    return SUITES[name]()
