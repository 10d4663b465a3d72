"""Plant integration accuracy against scipy.integrate.solve_ivp (rtol 1e-10) over 1 s.

Prints the maximum position error of the compiled plant step for each named plant with a
seeded random held input (linear plants: ideal, i.e. the paper's model; friction plants: the
paper's friction, velocity reversals included). Usage: ``python scripts/plant_accuracy.py``.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from contour_env.plants import Plant


def simulate(plant: Plant, u: np.ndarray) -> np.ndarray:
    state = plant.initial_state(np.zeros((1, plant.n_axes)))
    out = np.empty_like(u)
    T = plant.servo_period_s
    for k in range(u.shape[0]):
        state, _ = plant.step(state, u[k][None, :], k * T)
        out[k] = state.position[0]
    return out


def reference(plant: Plant, u: np.ndarray) -> np.ndarray:
    """Piecewise solve_ivp with events at velocity reversals and a stick–slip rule."""
    p = plant.params
    T = p.servo_period_s
    m, b = p.mass_kg, p.viscous_Ns_m
    fc, fs, vs = p.coulomb_N, p.static_N, p.stribeck_velocity_m_s
    out = np.empty_like(u)
    for i in range(plant.n_axes):
        x, v, stuck = 0.0, 0.0, fs[i] > 0
        for k in range(u.shape[0]):
            t, t_end = k * T, (k + 1) * T
            uk = float(np.clip(u[k, i], -p.force_limit_N[i], p.force_limit_N[i]))

            def ext(xx, tt, i=i):
                f = p.ripple_amplitude_N[i] * np.sin(2 * np.pi * xx / p.ripple_period_m[i])
                f += p.disturbance_amplitude_N[i] * np.sin(
                    2 * np.pi * p.disturbance_frequency_hz[i] * tt + i * np.pi / 2
                )
                return f

            while t < t_end - 1e-15:
                if stuck:
                    if abs(uk - ext(x, t)) <= fs[i]:
                        # stays stuck unless the disturbance changes: step to the period end
                        t = t_end
                        continue
                    stuck = False
                    direction = np.sign(uk - ext(x, t))
                elif v != 0.0:
                    direction = np.sign(v)
                else:  # slipping through a reversal: friction opposes the net force
                    direction = np.sign(uk - ext(x, t))

                def rhs(tt, y, d=direction, uk=uk, i=i):
                    vv = y[1]
                    mag = fc[i] + (fs[i] - fc[i]) * np.exp(-((vv / vs[i]) ** 2)) if fs[i] else 0.0
                    return [vv, (uk - b[i] * vv - d * mag - ext(y[0], tt)) / m[i]]

                def reversal(tt, y, d=direction):
                    return y[1] * d if d != 0 else 1.0

                reversal.terminal = True
                reversal.direction = -1
                sol = solve_ivp(
                    rhs,
                    (t, t_end),
                    [x, v],
                    method="DOP853",
                    rtol=1e-10,
                    atol=1e-14,
                    events=reversal if fs[i] else None,
                )
                x, v = sol.y[0, -1], sol.y[1, -1]
                t = sol.t[-1]
                if sol.status == 1:  # reversal: stick or slip through
                    v = 0.0
                    if abs(uk - ext(x, t)) <= fs[i]:
                        stuck = True
            out[k, i] = x
    return out


def main() -> None:
    rng = np.random.default_rng(0)
    print(f"{'plant':16s} {'regime':34s} {'max |x − x_ref|':>16s}")
    for name in ("hsm2", "jee-triaxial"):
        plant = Plant(name, ideal=True)
        n = int(round(1.0 / plant.servo_period_s))
        u = rng.uniform(-0.3, 0.3, (n, plant.n_axes)) * plant.params.force_limit_N
        err = np.max(np.abs(simulate(plant, u) - reference(plant, u)))
        print(f"{name:16s} {'linear, random held input':34s} {err * 1e9:13.3g} nm")
    for name in ("linear-motor", "friction-table"):
        # the paper's friction and ripple; the friction table's sinusoidal disturbance is left
        # out here because the event-based reference would need events on it too
        plant = Plant(Plant(name, ideal=True).params.replace(disturbance_amplitude_N=0.0))
        n = int(round(1.0 / plant.servo_period_s))
        t = np.arange(n) * plant.servo_period_s
        amp = 3.0 * plant.params.static_N
        u = np.outer(np.sin(2 * np.pi * 2.0 * t) * np.where(t < 0.5, 1.0, 0.3), amp)
        err = np.max(np.abs(simulate(plant, u) - reference(plant, u)))
        print(f"{name:16s} {'friction, reversals and sticking':34s} {err * 1e6:13.3g} µm")


if __name__ == "__main__":
    main()
