"""Closed-loop check of the five-axis laws (Chen, Khong & Hsieh 2022, §4): PD and the
equivalent-error ISMC on both test paths, RMS tool-tip contour error (µm) and orientation
error (arc-seconds) beside the paper's.

    python scripts/five_axis_check.py [--realistic]

By default on the nominal plant (FiveAxisPlant(ideal=True): the paper's model, no friction,
delay or mismatch); ``--realistic`` runs the true plant with its friction, current-loop lag,
computation delay and inertia mismatch (the controllers keep the nominal model).
"""

from __future__ import annotations

import argparse

import numpy as np

from agents.ismc import EquivalentErrorISMC, JointPD
from contour_env.paths.five_axis import FIVE_AXIS_PATHS, five_axis_path
from contour_env.plants.five_axis import FiveAxisPlant, forward
from contour_env.tool_errors import tool_errors

# Chen 2022 §4: RMS contour error µm, RMS orientation error arcsec
PAPER_RMS = {
    ("five-axis-line", "pd"): (330.7, 145.3),
    ("five-axis-line", "ismc"): (2.9, 4.8),
    ("five-axis-circle", "pd"): (668.4, 649.5),
    ("five-axis-circle", "ismc"): (17.9, 2.8),
}


def run(path, controller, plant):
    """Joint trajectory (n, 5) of ``plant`` under ``controller`` along ``path``'s reference,
    starting at rest on the first reference pose; the measured joints feed the law."""
    ref = path.reference
    state = plant.initial_state(ref.joints[0])
    controller.reset()
    q = np.empty((ref.n_steps, 5))
    for k in range(ref.n_steps):
        q[k] = state.q[0]
        u = controller.command(plant.measure(state)[0], state.qd[0], k)
        state, _ = plant.step(state, u[None, :], k * ref.servo_period_s)
    return q


def rms_errors(path, q):
    """(RMS contour error µm, RMS orientation error arcsec, max µm, max arcsec)."""
    tip, tool = forward(q, path.geometry)
    err = tool_errors(tip, tool, path.tip_path, path.tool_at)
    c, o = err.contour_error_m * 1e6, err.orientation_error_arcsec
    return (
        float(np.sqrt(np.mean(c**2))),
        float(np.sqrt(np.mean(o**2))),
        float(c.max()),
        float(o.max()),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realistic", action="store_true", help="the true (non-ideal) plant")
    args = parser.parse_args()
    plant = FiveAxisPlant("nxv560a", ideal=not args.realistic)
    inertia = plant.nominal.inertia
    print(f"plant: nxv560a ({'realistic' if args.realistic else 'ideal'})")
    print(
        f"{'path':18s} {'law':5s} {'RMS µm':>9s} {'RMS ″':>9s} {'max µm':>9s} {'max ″':>9s}"
        f"   paper RMS µm / ″"
    )
    for name in FIVE_AXIS_PATHS:
        path = five_axis_path(name)
        for label, law in (
            ("pd", JointPD(path, inertia)),
            ("ismc", EquivalentErrorISMC(path, inertia)),
        ):
            rms_c, rms_o, max_c, max_o = rms_errors(path, run(path, law, plant))
            pc, po = PAPER_RMS[(name, label)]
            print(
                f"{name:18s} {label:5s} {rms_c:9.3f} {rms_o:9.3f} {max_c:9.3f} {max_o:9.3f}"
                f"   {pc} / {po}"
            )


if __name__ == "__main__":
    main()
