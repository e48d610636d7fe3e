"""Dynamic bending stress from curvature (paper Eqs. 15–18), and the axial force.

M = EI κ (Eq. 15), κ from the exact formula (Eq. 16) or the small-strain approximation
(Eq. 17), and the fibre stress σ = E·y·κ (Eq. 18).

Sign convention (the paper's κ is unsigned): κ is the signed curvature, positive when
the centre line turns counter-clockwise, and y is measured along the left normal
n = Ĩ r'/|r'| (Ĩ the 90° rotation of Eq. 16). The fibre at y lies on the convex side,
in tension, when y·κ < 0, so the signed stress (tension positive) is

    σ(x, y) = −E · y · (κ(x) − κ₀(x))

with κ₀ the curvature of the stress-free reference. For a cantilever bending downwards
(κ < 0) the upper fibre (y > 0) is in tension, σ > 0.
"""

from __future__ import annotations

import numpy as np

from .strain_energy import axial_strain, curvature

#: Barlow points of the cubic element on [0, 1]: the 2-point Gauss points, where the
#: bending moment of the cubic interpolation is most accurate (Barlow 1976).
BARLOW_POINTS = 0.5 + np.array([-0.5, 0.5]) / np.sqrt(3.0)


def bending_stress(e, e_ref, x, length, youngs_modulus, y, measure="exact"):
    """Signed bending stress σ [Pa] at local x [m] on the fibre at distance y [m] (Eq. 18).

    Args:
        e: current element coordinates, shape (8,) [m, -].
        e_ref: stress-free reference element coordinates, shape (8,) [m, -].
        x: local reference arc length [m].
        length: element length l [m].
        youngs_modulus: E [Pa].
        y: fibre distance from the centre line along the left normal [m].
        measure: ``"exact"`` (Eq. 16) or ``"small_strain"`` (Eq. 17), or ``"material"``.
    """
    k = curvature(e, x, length, measure) - curvature(e_ref, x, length, measure)
    return -youngs_modulus * y * k


def bending_moment(e, e_ref, x, length, bending_stiffness, measure="exact"):
    """Bending moment M = EI (κ − κ₀) [N·m] (Eq. 15)."""
    k = curvature(e, x, length, measure) - curvature(e_ref, x, length, measure)
    return bending_stiffness * k


def axial_force(e, e_ref, x, length, axial_stiffness, measure="green_lagrange", metric="arc_length"):
    """Axial force N = EA·ε [N] at local x [m], tension positive.

    ε is the element's own axial strain measure (:func:`~.strain_energy.axial_strain`,
    the one in the strain energy of Eq. 8), so N is the force conjugate to the energy
    the dynamics use.

    Args:
        e: current element coordinates, shape (8,) [m, -].
        e_ref: stress-free reference element coordinates, shape (8,) [m, -].
        x: local reference arc length [m].
        length: element length l [m].
        axial_stiffness: EA [N].
        measure: ``"green_lagrange"`` or ``"engineering"``.
        metric: ``"arc_length"`` or ``"parameter"`` (the formulation's).
    """
    return axial_stiffness * axial_strain(e, e_ref, x, length, measure, metric)
