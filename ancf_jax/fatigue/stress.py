"""Stress for fatigue: axial plus bending stress at the two surface fibres of a beam.

At a point of a beam with axial force N = EA·ε (the formulation's axial strain,
:func:`ancf_jax.element.stress.axial_force`) and bending stress σ_b = −E·c·(κ − κ₀)
(Eq. 18 on the fibre y = +c, :func:`ancf_jax.element.stress.bending_stress`), the
stresses of the two surface fibres, each times a stress concentration factor K_t, are

    σ₊ = K_t (N/A + σ_b),    σ₋ = K_t (N/A − σ_b)        [Pa]

(fibre +c on the left normal of the beam, −c on the right). Either curvature measure
(``"exact"``, Eq. 16; ``"small_strain"``, Eq. 17; or ``"material"``) gives σ_b.

Points are (element, ξ = x/l) pairs: the Barlow points of every element (the 2-point
Gauss points, where the cubic element's bending moment is most accurate), a uniform grid
of ξ in every element, or chosen arc lengths. Every function here is pure JAX
(vmapped over points and output rows), so stresses and anything computed from them are
differentiable in the coordinates and in the section.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..beam import Beam
from ..element.stress import BARLOW_POINTS, bending_stress
from ..errors import ModelError
from ..system import System

#: layouts of points along a beam
LAYOUTS = ("barlow", "uniform")


def fibre_stress(beam: Beam, nodes, element, xi, fibre=None, measure="exact"):
    """Stresses (σ₊, σ₋) [Pa] of the two surface fibres, shape (2,), without K_t.

    Args:
        beam: the beam.
        nodes: its nodal coordinates, shape (n_max + 1, 4).
        element: element index (0-based, may be traced).
        xi: local coordinate ξ = x/l ∈ [0, 1].
        fibre: fibre distance c [m] (default the section's outer fibre).
        measure: curvature measure of the bending stress.
    """
    beam.section.require_modulus("a fibre stress")
    c = beam.section.fibre_distance if fibre is None else fibre
    e = beam.mesh.element_coordinates(nodes)[element]
    e_ref = beam.mesh.reference_elements[element]
    length = beam.mesh.element_lengths[element]
    x = xi * length
    n = beam.elastic_axial_force(e, e_ref, x, length)
    sb = bending_stress(e, e_ref, x, length, beam.section.youngs_modulus, c, measure)
    return n / beam.section.area + jnp.stack([sb, -sb])


def points_along(beam: Beam, layout: str = "barlow", points_per_element: int = 5):
    """Evaluation points of every active element of a beam.

    Args:
        beam: the beam.
        layout: ``"barlow"`` (the 2 Barlow points per element) or ``"uniform"``
            (``points_per_element`` values of ξ from 0 to 1).
        points_per_element: points per element of the uniform layout (≥ 2).

    Returns:
        (element, xi, s): NumPy arrays, shape (P,): element index, ξ and the reference
        arc length s [m] of each point.
    """
    if layout not in LAYOUTS:
        raise ModelError(f"layout must be one of {LAYOUTS}, got {layout!r}")
    if layout == "barlow":
        xi = np.asarray(BARLOW_POINTS, float)
    else:
        if int(points_per_element) < 2:
            raise ModelError(f"points_per_element must be >= 2, got {points_per_element!r}")
        xi = np.linspace(0.0, 1.0, int(points_per_element))
    n = int(beam.mesh.n_elements)
    s_nodes = np.asarray(beam.mesh.node_arc_lengths)[: n + 1]
    lengths = np.asarray(beam.mesh.element_lengths)[:n]
    element = np.repeat(np.arange(n), xi.size)
    xis = np.tile(xi, n)
    return element, xis, s_nodes[element] + xis * lengths[element]


def points_at(beam: Beam, s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(element, xi, s) of chosen reference arc lengths s [m] (each in [0, L])."""
    s = np.atleast_1d(np.asarray(s, float))
    n = int(beam.mesh.n_elements)
    s_nodes = np.asarray(beam.mesh.node_arc_lengths)[: n + 1]
    if (s < 0.0).any() or (s > s_nodes[-1] * (1 + 1e-12)).any():
        raise ModelError(f"arc lengths must lie in [0, {s_nodes[-1]:g}] m, got {s.tolist()}")
    k = np.clip(np.searchsorted(s_nodes, s, side="right") - 1, 0, n - 1)
    xi = (s - s_nodes[k]) / (s_nodes[k + 1] - s_nodes[k])
    return k, xi, s


@eqx.filter_jit
def stress_history(system: System, beam: int, q, element, xi, fibre=None, measure: str = "exact",
                   scf=1.0):
    """Surface-fibre stresses at points over output rows.

    Args:
        system: the system.
        beam: beam index (static).
        q: coordinates, shape (N, n).
        element: element index of each point, shape (P,).
        xi: local coordinate ξ of each point, shape (P,).
        fibre: fibre distance c [m] (default the section's).
        measure: curvature measure (static).
        scf: stress concentration factor K_t, scalar or shape (P,).

    Returns:
        σ [Pa], shape (N, P, 2) (last axis: fibres +c, −c).
    """
    b = system.beams[beam]
    scf = jnp.broadcast_to(jnp.asarray(scf, float), jnp.shape(element))

    def row(qq):
        nodes = system.beam_nodes(qq, beam)
        return jax.vmap(lambda k, z: fibre_stress(b, nodes, k, z, fibre, measure))(element, xi)

    return jax.vmap(row)(q) * scf[None, :, None]
