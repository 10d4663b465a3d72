"""Derive the five-axis joint-space dynamics (Chen, Khong & Hsieh 2022, eq. 4) by Lagrange.

Offline check of the closed-form expressions hand-written in
``contour_env/plants/five_axis/dynamics.py`` (sympy is not a runtime dependency):

    python scripts/derive_five_axis_dynamics.py          # print M(ξ), g(ξ) and compare

Model (docs/FIVE_AXIS.md): ξ = (x, y, z, A, C) with ISO 841 signs (x, y: tool relative to
the table, so the table moves by (−x, −y) in the ground frame; z: spindle head up). Bodies:
y saddle m1 (moves in y); x table m2 (x and y); A cradle m3, centre of mass r3 along the
cradle's z axis from the A axis, inertia I3 about the A axis through its centre of mass;
C table + fixture + workpiece m4, centre of mass (e4, 0, h4) in the C frame, inertia
diag(I4r, I4r, I4z) about its centre of mass in the C frame; spindle head m5 (z).
"""

from __future__ import annotations

import sympy as sp


def derive():
    t = sp.symbols("t")
    x, y, z, a, c = (sp.Function(n)(t) for n in ("x", "y", "z", "a", "c"))
    q = [x, y, z, a, c]
    m1, m2, m3, m4, m5, r3, i3, e4, h4, i4r, i4z, g = sp.symbols(
        "m1 m2 m3 m4 m5 r3 I3 e4 h4 I4r I4z g", real=True
    )
    ra = sp.rot_axis1(-a)  # rotation about x by +A (sympy's rot_axis is the transpose)
    rc = sp.rot_axis3(-c)
    pivot = sp.Matrix([-x, -y, 0])
    com3 = pivot + ra * sp.Matrix([0, 0, r3])
    com4 = pivot + ra * sp.Matrix([0, 0, h4]) + ra * rc * sp.Matrix([e4, 0, 0])
    v3 = com3.diff(t)
    v4 = com4.diff(t)
    w4_c = (ra * rc).T * (sp.Matrix([a.diff(t), 0, 0]) + ra * sp.Matrix([0, 0, c.diff(t)]))
    kin = (
        sp.Rational(1, 2) * m1 * y.diff(t) ** 2
        + sp.Rational(1, 2) * m2 * (x.diff(t) ** 2 + y.diff(t) ** 2)
        + sp.Rational(1, 2) * m3 * (v3.T * v3)[0]
        + sp.Rational(1, 2) * i3 * a.diff(t) ** 2
        + sp.Rational(1, 2) * m4 * (v4.T * v4)[0]
        + sp.Rational(1, 2) * (i4r * (w4_c[0] ** 2 + w4_c[1] ** 2) + i4z * w4_c[2] ** 2)
        + sp.Rational(1, 2) * m5 * z.diff(t) ** 2
    )
    pot = g * (m5 * z + m3 * com3[2] + m4 * com4[2])
    qd = [qi.diff(t) for qi in q]
    mass = sp.Matrix(5, 5, lambda i, j: sp.simplify(sp.diff(kin, qd[i], qd[j])))
    grav = sp.Matrix([sp.simplify(sp.diff(pot, qi)) for qi in q])
    # plain symbols for printing / lambdify
    xs, ys, zs, as_, cs = sp.symbols("x y z A C", real=True)
    sub = dict(zip(q, [xs, ys, zs, as_, cs], strict=True))
    mass = sp.simplify(mass.subs(sub))
    grav = sp.simplify(grav.subs(sub))
    # in the order of FiveAxisInertia.packed() (dynamics.I_* indices)
    syms = (m1, m2, m3, r3, i3, m4, h4, e4, i4r, i4z, m5, g)
    return mass, grav, (xs, ys, zs, as_, cs), syms


def main():
    mass, grav, _, _ = derive()
    for i in range(5):
        for j in range(i, 5):
            if mass[i, j] != 0:
                print(f"M[{i},{j}] = {mass[i, j]}")
    for i in range(5):
        print(f"g[{i}] = {grav[i]}")


if __name__ == "__main__":
    main()
