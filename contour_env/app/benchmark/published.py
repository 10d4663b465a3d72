"""The seed papers' published figures as data, keyed by (case, controller, metric).

``controller`` is the spec of *our* row that stands for the paper's controller (Lee 2012's
benchmark CCC is the proportional cross-coupling ``ccc:wi=0``, see scripts/lee2012_table.py;
Chen & Lee 2020's "without update" is ``rfnn:learn=0``; Chen 2022's PD is the five-axis joint
PD ``pd``). Metrics use the names of :func:`contour_env.metrics.score` and its units (µm,
arc-seconds), plus ``rms_x_torque_Nm`` / ``rms_y_force_N`` (hsm2's effort as Lee's Table 3
gives it). Each entry says its source (paper, table).

``kind``: ``"value"`` a figure; ``"bound"`` a design goal (``value`` is an upper bound);
``"relative"`` a relative change of one controller against another (``value`` is the ratio,
e.g. 0.63 for "37 % lower"; :data:`RELATIVE`).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Published:
    value: float
    source: str
    table: str
    kind: str = "value"
    note: str = ""


LEE = "Lee, Dixon & Ziegert 2012"
JEE = "Jee & Lee 2007"
CHEN_LEE = "Chen & Lee 2020"
CHEN = "Chen, Khong & Hsieh 2022"
SIMBA = "Simba et al. 2018"

PUBLISHED: dict[tuple[str, str, str], Published] = {}


def _add(case, controller, metric, value, source, table, kind="value", note=""):
    PUBLISHED[(case, controller, metric)] = Published(float(value), source, table, kind, note)


# Lee 2012 Table 2 (max / RMS contour error, µm) and Table 3 (RMS x torque N m, RMS y force N)
_LEE = {
    "hsm2-circle-I": {"pd": (119, 43, 3.85, 287), "ccc:wi=0": (46, 15, 3.83, 293),
                      "adaptive-ccc": (63, 12, 3.86, 288)},
    "hsm2-circle-II": {"pd": (288, 160, 15.2, 1270), "ccc:wi=0": (149, 56, 15.3, 1310),
                       "adaptive-ccc": (125, 28, 15.3, 1280)},
    "hsm2-circle-III": {"pd": (530, 250, 24.0, 1980), "ccc:wi=0": (215, 86, 24.2, 2010),
                        "adaptive-ccc": (219, 49, 24.2, 1990)},
}  # fmt: skip
for _case, _rows in _LEE.items():
    for _ctrl, (_mx, _rms, _tx, _fy) in _rows.items():
        _note = "Lee's benchmark CCC (proportional coupling)" if _ctrl == "ccc:wi=0" else ""
        _add(_case, _ctrl, "max_contour_error_um", _mx, LEE, "Table 2", note=_note)
        _add(_case, _ctrl, "rms_contour_error_um", _rms, LEE, "Table 2", note=_note)
        _add(_case, _ctrl, "rms_x_torque_Nm", _tx, LEE, "Table 3", note=_note)
        _add(_case, _ctrl, "rms_y_force_N", _fy, LEE, "Table 3", note=_note)

# Jee 2007: the design goal of the integrated three-axis CCC (a bound, not a measurement)
_add("jee-circle3d", "jee-ccc", "max_contour_error_um", 25, JEE, "§5 design goal", "bound")
_add("jee-circle3d", "jee-ccc", "max_tracking_error_um", 250, JEE, "§5 design goal", "bound")

# Chen & Lee 2020 Tables 1–2 (mm in the paper; here µm): case 2 "without update" is the
# network at its initial values (rfnn:learn=0), case 3 and Table 2's RFNN the adaptive RFNN
_CL = "the paper's own ripple model and network values: compare ratios, not absolutes"
for _ctrl, _table, (_mx, _tot, _rms) in (
    ("rfnn:learn=0", "Table 1 case 2", (15.0848, 106000.0, 9.0539)),
    ("fnn", "Table 2 FNN", (16.1006, 113410.19, 9.4631)),
    ("rfnn", "Table 2 RFNN", (15.3143, 61780.23, 4.6759)),
):
    _add("lm-circle3d", _ctrl, "max_contour_error_um", _mx * 1e3, CHEN_LEE, _table, note=_CL)
    _add("lm-circle3d", _ctrl, "total_contour_error_um", _tot * 1e3, CHEN_LEE, _table, note=_CL)
    _add("lm-circle3d", _ctrl, "rms_contour_error_um", _rms * 1e3, CHEN_LEE, _table, note=_CL)

# Chen 2022 §4 (simulation): RMS tool-tip contour error (µm) and orientation error (″)
for _case, (_pd, _pd_o, _is, _is_o) in (
    ("five-axis-line", (330.7, 145.3, 2.9, 4.8)),
    ("five-axis-circle", (668.4, 649.5, 17.9, 2.8)),
):
    _add(_case, "pd", "rms_contour_error_um", _pd, CHEN, "§4, Figs. 6–7")
    _add(_case, "pd", "rms_orientation_error_arcsec", _pd_o, CHEN, "§4, Figs. 6–7")
    _add(_case, "ismc", "rms_contour_error_um", _is, CHEN, "§4, Figs. 6–7")
    _add(_case, "ismc", "rms_orientation_error_arcsec", _is_o, CHEN, "§4, Figs. 6–7")


@dataclass(frozen=True)
class Relative:
    """A published relative figure: ``controller``'s ``metric`` is ``value`` × ``against``'s."""

    case: str
    controller: str
    against: tuple[str, ...]
    metric: str
    value: float
    source: str
    table: str
    note: str = ""


# Simba 2018: VILCFD lowers the max contour error by about 37 % on average against
# conventional ILC (sharp-corner, experiments); compared with trial N of each pure ILC law
RELATIVE = [
    Relative(
        "sharp-corner",
        "vilcfd",
        ("ilc-pd", "ilc-contour"),
        "max_contour_error_um",
        0.63,
        SIMBA,
        "abstract and §1",
        "about 37 % lower max contour error on average than conventional ILC",
    )
]


def published_for(case: str, controller: str) -> dict[str, Published]:
    """metric → :class:`Published` for one row (empty when the papers have none)."""
    return {m: p for (c, k, m), p in PUBLISHED.items() if c == case and k == controller}


def published_cases() -> list[str]:
    return sorted({c for c, _, _ in PUBLISHED})
