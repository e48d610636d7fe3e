"""Model M1: cantilever with a tip body (paper §3.3, Table 1, Figs. 4–8).

A 0.402 m steel wire (d = 1 mm, E = 200 GPa, 0.0025 kg) clamped at x = 0 with a
0.02 kg tip body fixed to its free end, released straight from rest under gravity;
Rayleigh damping α = 0.02, β = 0 on the beam. Every parameter can be overridden.
"""

from __future__ import annotations

from .. import mesh
from ..element.strain_energy import Formulation
from ..model import Model, node
from ..outputs import Output
from ..section import Section

#: parameters of M1 (SI), as in docs/models.md
M1 = dict(length=0.402, n_elements=6, diameter=1e-3, area=7.854e-7, second_moment=4.909e-14,
          youngs_modulus=200e9, beam_mass=0.0025, tip_mass=0.02, tip_inertia=1.58e-6,
          alpha=0.02, beta=0.0, gravity=9.81)

#: where the paper evaluates the stress: midpoint of element E1, fibre y = +0.5 mm
STRESS_ELEMENT, STRESS_XI, STRESS_FIBRE = 0, 0.5, 0.5e-3
#: that point as a fixed arc length, s = L/12 [m] (E1's midpoint with the paper's 6
#: elements), so that the stress column is the same material point on every mesh
STRESS_S = 0.0335

#: the CSV columns of ``ancf-jax run m1``: tip of the last node, stress at E1's midpoint
#: of the 6-element mesh
OUTPUTS = (
    Output("tip_x", "node", "beam", "x", node=-1),
    Output("tip_y", "node", "beam", "y", node=-1),
    Output("sigma_e1_mid", "stress", "beam", s=STRESS_S, fibre=STRESS_FIBRE, measure="exact"),
)

#: default run settings (docs/models.md: t in [0, 2] s; outputs every 1 ms)
RUN = dict(t_end=2.0, dt=1e-3, output_dt=1e-3, solver="generalized-alpha", solver_options={})


def m1_model(n_elements: int | None = None, *, formulation: Formulation | None = None,
             **overrides) -> Model:
    """The M1 model builder (call ``.build()`` for the system and initial state).

    Args:
        n_elements: number of elements (default 6).
        formulation: strain measures and quadrature (default :class:`Formulation`).
        **overrides: any key of :data:`M1`.
    """
    unknown = set(overrides) - set(M1)
    if unknown:
        from ..errors import ModelError
        raise ModelError(f"unknown M1 parameter(s) {sorted(unknown)}; known: {sorted(M1)}")
    p = {**M1, **overrides}
    if n_elements is not None:
        p["n_elements"] = n_elements
    m = Model(gravity=(0.0, -p["gravity"]))
    section = Section(p["youngs_modulus"], p["area"], p["second_moment"],
                      p["beam_mass"] / p["length"], fibre_distance=p["diameter"] / 2)
    m.add_beam("beam", mesh.straight((0.0, 0.0), (1.0, 0.0), p["length"], p["n_elements"]), section,
               alpha=p["alpha"], beta=p["beta"], formulation=formulation)
    m.add_body("tip", mass=p["tip_mass"], inertia=p["tip_inertia"], position=(p["length"], 0.0))
    m.clamp("clamp", "beam", 0)
    m.fixed("tip_joint", node("beam", -1), body="tip")
    return m
