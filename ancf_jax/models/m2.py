"""Model M2: a multibody system sliding on a catenary cable (paper §4.3, Table 2,
Figs. 11–13), in the project's fixed interpretation (docs/models.md).

A 4.02 m steel cable (d = 3 mm, 0.148 kg) pinned at A = (0, 0) and B = (3.8, 0); a
trolley RB1 whose centre slides on the cable (sliding joint, no friction) and a cabin
RB2 hanging 0.5 m below it on a revolute joint; α = 0.01 on the cable. Initial state:
static equilibrium with the trolley held at s₀ = 0.6 m, released at t = 0.
"""

from __future__ import annotations

import jax.numpy as jnp

from .. import mesh
from ..beam import Beam
from ..element.strain_energy import Formulation
from ..errors import ModelError
from ..model import Model, body_point, build_in_equilibrium, node
from ..outputs import Output
from ..section import Section
from ..statics import DEFAULTS as STATIC_DEFAULTS

#: parameters of M2 (SI), as in docs/models.md; I as printed in Table 2; ``height`` lifts
#: support B to (span, height) (0 in M2)
M2 = dict(length=4.02, span=3.8, height=0.0, n_elements=24, diameter=3e-3, area=7.068e-6,
          second_moment=7.952e-12, youngs_modulus=200e9, cable_mass=0.148,
          trolley_mass=2.67, trolley_inertia=0.2242, cabin_mass=2.67, cabin_inertia=0.2242,
          hanger=0.5, s0=0.6, alpha=0.01, beta=0.0, gravity=9.81)


#: the CSV columns of ``ancf-jax run m2``: sliding coordinate, point 1 (the sliding point
#: on the cable), cabin centre RB2
OUTPUTS = (
    Output("s", "sliding", "slider"),
    Output("point1_x", "sliding_point", "slider", "x"),
    Output("point1_y", "sliding_point", "slider", "y"),
    Output("rb2_x", "body", "cabin", "x"),
    Output("rb2_y", "body", "cabin", "y"),
)

#: default run settings (docs/models.md: t in [0, 3] s). The release sends an axial shock
#: through the light, stiff cable; generalized-α with ρ∞ = 0.5 damps it at h = 1 ms.
RUN = dict(t_end=3.0, dt=1e-3, output_dt=1e-2, solver="generalized-alpha",
           solver_options=dict(rho_inf=0.5, max_iterations=30))
ELEMENT_COUNTS = (12, 18, 24)


def m2_model(n_elements: int | None = None, *, formulation: Formulation | None = None,
             hold: bool = True, **overrides) -> Model:
    """The M2 model builder; the trolley's sliding joint is held at s₀ if ``hold``.

    The cable's initial guess is the inextensible catenary through A and B; the bodies
    start on it. Use :func:`m2_initial` for the released system at equilibrium.
    """
    unknown = set(overrides) - set(M2)
    if unknown:
        raise ModelError(f"unknown M2 parameter(s) {sorted(unknown)}; known: {sorted(M2)}")
    p = {**M2, **overrides}
    if n_elements is not None:
        p["n_elements"] = n_elements
    n = p["n_elements"]
    m = Model(gravity=(0.0, -p["gravity"]))
    section = Section(p["youngs_modulus"], p["area"], p["second_moment"],
                      p["cable_mass"] / p["length"], fibre_distance=p["diameter"] / 2)
    guess = mesh.catenary_nodes((0.0, 0.0), (p["span"], p["height"]), p["length"], n)
    cable = mesh.straight((0.0, 0.0), (1.0, 0.0), p["length"], n)
    m.add_beam("cable", cable, section,
               alpha=p["alpha"], beta=p["beta"], formulation=formulation, initial_nodes=guess)
    m.pin("A", node("cable", 0))
    m.pin("B", node("cable", -1))
    # trolley on the cable's initial centre line (the cubic through the guess) at s0,
    # so the sliding joint holds from the start. Placed on the node polygon instead
    # (about 1 mm off the curve), the static solve converged to the inverted cabin, an
    # unstable equilibrium, at 18 and 24 elements: Newton does not tell stable from
    # unstable equilibria, so the guess matters.
    x0, y0 = (float(c) for c in Beam(cable, section).position(jnp.asarray(guess), p["s0"]))
    m.add_body("trolley", mass=p["trolley_mass"], inertia=p["trolley_inertia"], position=(x0, y0))
    m.add_body("cabin", mass=p["cabin_mass"], inertia=p["cabin_inertia"],
               position=(x0, y0 - p["hanger"]))
    m.slider("slider", "trolley", "cable", p["s0"], hold=hold)
    m.revolute("hanger", body_point("trolley"), body_point("cabin", (0.0, p["hanger"])))
    return m


def m2_initial(n_elements: int | None = None, *, pad_to: int | None = None,
               load_steps: int = STATIC_DEFAULTS.load_steps, **overrides):
    """(released system, equilibrium state, static solution) of M2 (see module doc);
    ``load_steps`` of the held static solve (default :class:`~ancf_jax.statics.StaticSolver`)."""
    return build_in_equilibrium(m2_model(n_elements, **overrides), load_steps=load_steps,
                                pad_to=pad_to)
