"""A cable drawn through n frictional eyelets (issue 19's capstan validation).

A thin steel cable (EA = 6.3e5 N, EI = T ℓ² with ℓ = √(EI/T) = 5 cm, ρA = 0.025 kg/m,
no gravity) runs through n fixed eyelets that turn it by φ = π/2 in all, θ = φ/n each,
along a polygon with straight legs of 8 ℓ between them. A load T₁ = 100 N pulls the free
end; the other end is drawn along the last leg at 0.1 m/s (from rest, smoothly), so
the cable slides through every eyelet with Coulomb friction μ = 0.2 (regularization
v_ε = 1 cm/s, tanh(10) = 1 − 4e-9 at the drawing speed). In steady sliding the hold
tension T₂ at the drawn end over the load T₁ is compared with three closed forms:

* the **capstan** (Euler–Eytelwein) limit e^(μφ) of a continuous contact;
* the textbook **string over a point eyelet**: with friction along the bisector of the
  two legs, T₂/T₁ = (1 + μ tan(θ/2)) / (1 − μ tan(θ/2)) per eyelet;
* an **elastic rod over a point eyelet** (derived here): friction acts along the rod's
  tangent at the contact, which is not the bisector. Each leg ends in an elastica
  boundary layer whose first integral ½ EI θ'² = T (1 − cos ϑ) gives the curvature at
  the contact (2/ℓᵢ) sin(Δᵢ/2), ℓᵢ = √(EI/Tᵢ), Δᵢ the turn on side i; the moment is
  continuous there, so √T₁ sin(Δ₁/2) = √T₂ sin(Δ₂/2) with Δ₁ + Δ₂ = θ, independent
  of EI. The jump of the axial force is the friction, T₂ cos Δ₂ − T₁ cos Δ₁ =
  μ (T₁ sin Δ₁ + T₂ sin Δ₂), which with the moment condition is T₂ − T₁ = μ N: the
  energy balance of steady sliding (the work of the tensions is the friction's
  dissipation μ N u). At θ = π/2, μ = 0.2 it gives 1.326 where the string formula gives
  1.5; both tend to e^(μφ) as n grows (rod from below, string from above).

The ends' legs leave the boundary layers on lines offset from the eyelets by ~ℓ, so
the turn the cable actually takes differs from the polygon's φ (by 0.08 rad at n = 1
with 8 ℓ legs); it is measured from the direction of the drawing force and the
closed forms are evaluated at it, with equal turns per eyelet.

Run: ``python -m benchmarks.eyelets`` (n = 1, 4, 16; about 6 minutes, n = 16 is 544
elements); writes ``benchmarks/results/eyelets.{json,md}`` (the table of
docs/cable-machinery.md) and prints the table.
"""

from __future__ import annotations

import sys
import time

import jax.numpy as jnp
import numpy as np
from scipy.optimize import brentq

from .common import write

MU, PHI, T_LOAD, SPEED, RAMP, V_EPS = 0.2, np.pi / 2, 100.0, 0.1, 0.05, 1e-2
EA, RHOA, ELL = 6.3e5, 0.025, 0.05


def rod_eyelet_ratio(theta: float, mu: float = MU) -> float:
    """T₂/T₁ at slip of an elastic rod turned by ``theta`` [rad] over a point eyelet
    (module docstring)."""
    def sides(r):
        d2 = brentq(lambda d: np.sin((theta - d) / 2) - np.sqrt(r) * np.sin(d / 2), 0.0, theta)
        return theta - d2, d2

    def slip(r):
        d1, d2 = sides(r)
        return (r - 1.0) - mu * (np.sin(d1) + r * np.sin(d2))

    return brentq(slip, 1.0, 10.0)


def string_eyelet_ratio(theta: float, mu: float = MU) -> float:
    """T₂/T₁ at slip of a string over a point eyelet, friction along the bisector."""
    t = np.tan(theta / 2)
    return (1 + mu * t) / (1 - mu * t)


def eyelet_model(n: int, *, per_ell: int = 4, legs: float = 8.0):
    """The cable through ``n`` eyelets (module docstring): elements of ℓ/``per_ell``,
    legs of ``legs`` ℓ. Each eyelet sits in the middle of an element (a sliding joint
    started exactly on a node sits where r'' jumps). Returns (Model, drawing direction)."""
    from ancf_jax import mesh
    from ancf_jax.model import Model, body_point, node
    from ancf_jax.section import Section

    theta = PHI / n
    he = ELL / per_ell
    per_leg = int(round(legs * ELL / he))
    ne = per_leg * (n + 1)
    stretch = 1.0 + T_LOAD / EA
    dirs = [np.array([np.cos(j * theta), np.sin(j * theta)]) for j in range(n + 1)]
    # leg lengths (reference): half an element more on the first, less on the last
    lengths = [(per_leg + (0.5 if j == 0 else 0.0) - (0.5 if j == n else 0.0)) * he for j in range(n + 1)]
    starts = np.concatenate([[0.0], np.cumsum(lengths)])
    corners = [np.zeros(2)]
    for j in range(n + 1):
        corners.append(corners[-1] + stretch * lengths[j] * dirs[j])
    nodes = np.zeros((ne + 1, 4))
    for i in range(ne + 1):
        j = min(int(np.searchsorted(starts, i * he, side="right")) - 1, n)
        nodes[i, :2] = corners[j] + stretch * (i * he - starts[j]) * dirs[j]
        nodes[i, 2:] = stretch * dirs[j]
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("cable", mesh.straight((0.0, 0.0), (1.0, 0.0), ne * he, ne),
               Section.from_stiffness(EA, T_LOAD * ELL**2, RHOA), initial_nodes=nodes)
    for k in range(n):
        eyelet = m.add_body(f"eyelet{k}", mass=1.0, inertia=1.0, position=tuple(corners[k + 1]))
        for c in ("x", "y", "theta"):
            m.coordinate(f"eyelet{k}.{c}", body_point(eyelet), c)
        m.slider(f"e{k}", eyelet, "cable", float(starts[k + 1]), hold=True)
        m.slider_friction(f"e{k}.friction", f"e{k}", mu=MU, regularization=V_EPS)
    end, d = jnp.asarray(nodes[-1, :2]), jnp.asarray(dirs[-1])
    m.prescribe_point("draw", node("cable", ne),
                      lambda t: end + d * SPEED * (t - RAMP + RAMP * jnp.exp(-t / RAMP)))
    m.point_force("load", node("cable", 0), (-T_LOAD, 0.0))
    return m, dirs[-1]


def eyelet_initial(n: int, **kw):
    """System and initial state: the static equilibrium with the eyelets held (the
    boundary layers), then again with them released (frictionless statics: the
    tension T₁ all along, the sliding coordinates where it puts them). Returns
    (system, State)."""
    from ancf_jax.model import build_in_equilibrium
    from ancf_jax.statics import solve_static
    from ancf_jax.system import State

    m, _ = eyelet_model(n, **kw)
    system, state, _ = build_in_equilibrium(m, check_stability=False)
    released = solve_static(system, state, load_steps=1)  # from the held equilibrium: the full load at once
    return system, State(released.state.q, state.v, state.t)


def eyelet_run(n: int, *, dt: float = 1e-3, t_end: float = 0.3, window: float = 0.1, **kw) -> dict:
    """Draw the cable for ``t_end`` and average the last ``window`` seconds: the
    tension ratio |F_draw|/T₁, the turn the cable takes (direction of the drawing
    force), friction and normal force per eyelet, and the closed forms at that turn."""
    from ancf_jax.simulation import simulate

    start = time.perf_counter()
    system, state = eyelet_initial(n, **kw)
    res = simulate(system, state, t_end=t_end, dt=dt, progress=False)
    late = res.t > t_end - window
    f = res.joint_force("draw")[late]
    turn = float(np.mean(np.arctan2(f[:, 1], f[:, 0])))
    ratio = float(np.mean(np.linalg.norm(f, axis=1)) / T_LOAD)
    per = [res.friction(f"e{k}.friction")[late].mean(axis=0) for k in range(n)]
    return dict(n=n, elements=int(system.beams[0].mesh.n_elements), turn=turn, ratio=ratio,
                spread=float(np.ptp(np.linalg.norm(f, axis=1)) / T_LOAD),
                friction=[float(p[0]) for p in per], normal=[float(p[1]) for p in per],
                rod=rod_eyelet_ratio(turn / n) ** n, string=string_eyelet_ratio(turn / n) ** n,
                capstan=float(np.exp(MU * turn)), seconds=time.perf_counter() - start)


def main(counts=(1, 4, 16)) -> list[dict]:
    rows = [eyelet_run(n) for n in counts]
    lines = ["| n | elements | turn [rad] | T₂/T₁ simulated | rod, point eyelets | string, point eyelets "
             "| capstan e^(μθ) | run [s] |", "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r['n']} | {r['elements']} | {r['turn']:.4f} | {r['ratio']:.5f} | {r['rod']:.5f} "
                     f"| {r['string']:.5f} | {r['capstan']:.5f} | {r['seconds']:.0f} |")
    md = "\n".join(lines) + "\n"
    path = write("eyelets", dict(runs=rows), md)
    print(md)
    print(f"written {path}")
    return rows


if __name__ == "__main__":
    main(tuple(int(a) for a in sys.argv[1:]) or (1, 4, 16))
