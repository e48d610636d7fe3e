"""Elastic strain energy of the planar ANCF element, written once (paper Eq. 8).

Everything elastic comes from :func:`strain_energy`: the generalized elastic force of
Eq. 9 is its (negative) gradient and the tangent stiffness its Hessian, both by
automatic differentiation (see :mod:`ancf_jax.beam`). Nothing is derived by hand.

Energy (per element, reference arc length x ∈ [0, l], reference metric g = |r₀'|):

    U = ∫₀ˡ ½ EA ε(x)² g dx + ∫₀ˡ ½ EI (κ(x) − κ₀(x))² g dx

Axial strain measures (``axial_strain``):

* ``"green_lagrange"``: ε = ½ (r'·r' − g²) / g²  (Green–Lagrange; default)
* ``"engineering"``:    ε = |r'| / g − 1          (as in Exudyn's ANCFCable2D)

Bending measures (``curvature``):

* ``"exact"``: κ = (r' × r'') / |r'|³ (Eq. 16) with the signed planar cross product
  r' × r'' = r'ₓ r''ᵧ − r'ᵧ r''ₓ, so that κ² is smooth and its gradient finite on a
  straight beam (|r' × r''| would not be differentiable there).
* ``"material"``: κ = (r' × r'') / |r'|² (curvature per unit reference length, as in
  Exudyn's ANCFCable2D); useful for cross-checks.
* ``"small_strain"``: the approximation of Eq. 17, κ ≈ |r''|, giving the classical
  bending energy ½ EI r''·r'' (Berzeri & Shabana 2000). It is only rotation invariant
  for a straight reference configuration, so it is restricted to that case.

Reference metric (``metric``), for references whose element parameter x is not their
arc length (curved references: |r₀'| = g ≠ 1 between the nodes):

* ``"arc_length"`` (default): strains per unit reference arc length, as above
  (ε = |r'|/g − 1, energy integrated over g dx).
* ``"parameter"``: strains per unit of the element parameter and integrated over dx,
  ε = |r'| − g (engineering) or ½ (r'·r' − g²) (Green–Lagrange), curvature change
  κ − κ₀ likewise weighted by dx: Exudyn's ANCFCable2D with
  ``strainIsRelativeToReference = 1`` (its pre-curved cable).

On a straight reference with unit slopes (g = 1) the two are identical.

Quadrature. The axial and bending terms are integrated with separate rules. The
default integrates the axial term with the 3-point Gauss–Lobatto rule and the bending
term with 3-point Gauss. Full integration of the axial term (5-point Gauss, exact for
the degree-8 Green–Lagrange integrand) makes the cubic element lock in bending: the
axial strain field of a bent cubic element carries a spurious quadratic part that full
integration penalises with the large EA. Three Lobatto points keep the constant, linear
and quadratic axial strain modes (no zero-energy mode, unlike 2-point Gauss) while
relaxing that coupling. Both rules are options.

Measured on M1's static equilibrium (tip displacement error against the extensible
Kirchhoff rod solved by shooting, for 3 / 6 / 12 / 24 elements; script in
``tests/models/test_m1.py``):

=================================  =========  =========  =========  =========
axial / bending rule (GL, exact)    3          6          12         24
=================================  =========  =========  =========  =========
Lobatto 3 / Gauss 3 (default)       4.8e-4 m   3.5e-5 m   1.8e-6 m   3.4e-7 m
Gauss 5 / Gauss 3 (full)            8.5e-3 m   1.2e-3 m   2.0e-4 m   8.9e-6 m
Gauss 3 / Gauss 3                   7.9e-3 m   1.2e-3 m   1.8e-4 m   6.4e-6 m
Gauss 2 / Gauss 2                   3.4e-4 m   2.8e-5 m   1.4e-6 m   3.8e-7 m
=================================  =========  =========  =========  =========

Full integration locks (errors 30× larger at 6 elements). With engineering strain
and material curvature the element converges at a clean fourth order to the
Kirchhoff rod (1.3e-4, 8.7e-6, 5.4e-7, 3.4e-8 m); the paper's measures converge to a
limit about 3e-7 m away (their continuum model differs at O(ε)).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from ..errors import ModelError
from .quadrature import RULES, rule
from .shape_functions import interpolate_at, slope, slope_derivative

AXIAL_STRAINS = ("green_lagrange", "engineering")
CURVATURES = ("exact", "material", "small_strain")
METRICS = ("arc_length", "parameter")


def cross2(a, b):
    """Signed planar cross product a × b = aₓ bᵧ − aᵧ bₓ (scalar)."""
    return a[0] * b[1] - a[1] * b[0]


class Formulation(eqx.Module):
    """Choice of strain measures and quadrature rules (all static: part of the trace).

    Attributes:
        axial_strain: ``"green_lagrange"`` or ``"engineering"``.
        curvature: ``"exact"`` (Eq. 16), ``"material"`` or ``"small_strain"`` (Eq. 17).
        axial_quadrature: (kind, points), kind ``"gauss"`` or ``"lobatto"``.
        bending_quadrature: (kind, points).
        metric: ``"arc_length"`` (strains per unit reference arc length) or
            ``"parameter"`` (per unit of the element parameter, Exudyn's
            ``strainIsRelativeToReference = 1``); equal on straight unit-slope
            references (module docstring).
    """

    axial_strain: str = eqx.field(static=True, default="green_lagrange")
    curvature: str = eqx.field(static=True, default="exact")
    axial_quadrature: tuple = eqx.field(static=True, default=("lobatto", 3))
    bending_quadrature: tuple = eqx.field(static=True, default=("gauss", 3))
    metric: str = eqx.field(static=True, default="arc_length")

    def __check_init__(self):
        if self.axial_strain not in AXIAL_STRAINS:
            raise ModelError(f"axial_strain must be one of {AXIAL_STRAINS}, got {self.axial_strain!r}")
        if self.curvature not in CURVATURES:
            raise ModelError(f"curvature must be one of {CURVATURES}, got {self.curvature!r}")
        if self.metric not in METRICS:
            raise ModelError(f"metric must be one of {METRICS}, got {self.metric!r}")
        for name in ("axial_quadrature", "bending_quadrature"):
            q = getattr(self, name)
            if (not isinstance(q, tuple) or len(q) != 2 or q[0] not in RULES
                    or not isinstance(q[1], int) or q[1] < (2 if q[0] == "lobatto" else 1)
                    or q[1] > 10):
                raise ModelError(
                    f"{name} must be (kind, points) with kind in {RULES} and 1..10 points "
                    f"(2..10 for lobatto), got {q!r}")


def _strain(r1r1, g2, measure, metric):
    """Axial strain from r'·r' and g² = r₀'·r₀' (module docstring)."""
    if metric == "parameter":
        if measure == "green_lagrange":
            return 0.5 * (r1r1 - g2)
        return jnp.sqrt(r1r1) - jnp.sqrt(g2)
    if measure == "green_lagrange":
        return 0.5 * (r1r1 - g2) / g2
    return jnp.sqrt(r1r1 / g2) - 1.0


def axial_strain(e, e_ref, x, length, measure="green_lagrange", metric="arc_length"):
    """Axial strain ε at reference arc length x (dimensionless).

    Args:
        e: current element coordinates, shape (8,) [m, -].
        e_ref: stress-free reference element coordinates, shape (8,) [m, -].
        x: local reference arc length [m].
        length: element length l [m].
        measure: ``"green_lagrange"`` or ``"engineering"``.
        metric: ``"arc_length"`` or ``"parameter"`` (:class:`Formulation`).
    """
    r1 = slope(e, x, length)
    r0 = slope(e_ref, x, length)
    return _strain(jnp.dot(r1, r1), jnp.dot(r0, r0), measure, metric)


def curvature(e, x, length, measure="exact"):
    """Signed curvature κ at x [1/m]; positive when the centre line turns counter-clockwise.

    ``"exact"``: Eq. 16, (r' × r'')/|r'|³. ``"material"``: (r' × r'')/|r'|².
    ``"small_strain"``: Eq. 17, |r''| with the sign of r' × r'' (the paper's
    approximation for |r'| ≈ 1; its magnitude is what Eq. 17 prints).
    """
    r1 = slope(e, x, length)
    r2 = slope_derivative(e, x, length)
    c = cross2(r1, r2)
    if measure == "exact":
        return c / jnp.dot(r1, r1) ** 1.5
    if measure == "material":
        return c / jnp.dot(r1, r1)
    if measure == "small_strain":
        n2 = jnp.dot(r2, r2)
        safe = jnp.where(n2 > 0.0, n2, 1.0)  # keeps the gradient finite at r'' = 0
        return jnp.sign(c) * jnp.where(n2 > 0.0, jnp.sqrt(safe), 0.0)
    raise ModelError(f"curvature measure must be one of {CURVATURES}, got {measure!r}")


def _dot(a, b):
    return jnp.sum(a * b, axis=-1)


def axial_strains(e, e_ref, length, formulation: Formulation = Formulation()):
    """Axial strain ε at the axial quadrature points and the integration weight there
    (the reference metric g = |r₀'|, or 1 with ``metric="parameter"``), each shape
    (p,) (the integrand of the axial term of Eq. 8)."""
    xa, _ = rule(*formulation.axial_quadrature)
    r1 = interpolate_at(e, xa, length, 1)
    r1_ref = interpolate_at(e_ref, xa, length, 1)
    g2 = _dot(r1_ref, r1_ref)
    eps = _strain(_dot(r1, r1), g2, formulation.axial_strain, formulation.metric)
    return eps, _weight(g2, formulation)


def _weight(g2, formulation):
    """Integration weight of the energy density per dx: g (arc length) or 1 (parameter)."""
    return jnp.ones_like(g2) if formulation.metric == "parameter" else jnp.sqrt(g2)


def curvature_changes(e, e_ref, length, formulation: Formulation = Formulation()):
    """Curvature change κ − κ₀ at the bending quadrature points and the integration
    weight there (g = |r₀'|, or 1 with ``metric="parameter"``), each shape (p,), for
    the ``"exact"`` and ``"material"`` measures (the integrand of the bending term of
    Eq. 8)."""
    xb, _ = rule(*formulation.bending_quadrature)
    r1 = interpolate_at(e, xb, length, 1)
    r2 = interpolate_at(e, xb, length, 2)
    r1_ref = interpolate_at(e_ref, xb, length, 1)
    r2_ref = interpolate_at(e_ref, xb, length, 2)
    power = 1.5 if formulation.curvature == "exact" else 1.0

    def kappa(a, b):
        return (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) / _dot(a, a) ** power

    return kappa(r1, r2) - kappa(r1_ref, r2_ref), _weight(_dot(r1_ref, r1_ref), formulation)


def strain_energy(e, e_ref, length, axial_stiffness, bending_stiffness,
                  formulation: Formulation = Formulation(), axial_law=None, bending_law=None):
    """Strain energy U of one element [J] (Eq. 8).

    Args:
        e: current element coordinates, shape (8,) [m, -].
        e_ref: stress-free reference coordinates, shape (8,); a straight reference has
            unit slopes along the element.
        length: reference element length l [m].
        axial_stiffness: EA [N].
        bending_stiffness: EI [N·m²].
        formulation: strain measures and quadrature rules.
        axial_law: a law of :mod:`ancf_jax.element.laws` whose energy density W(ε)
            replaces ½ EA ε²; None: linear elastic (Eq. 8 as printed).
        bending_law: likewise for ½ EI (κ − κ₀)²; needs the ``"exact"`` or
            ``"material"`` curvature.

    Returns:
        Scalar energy [J].
    """
    _, wa = rule(*formulation.axial_quadrature)
    _, wb = rule(*formulation.bending_quadrature)

    # axial term at the axial quadrature points (vectorized over points)
    eps, g = axial_strains(e, e_ref, length, formulation)
    w_axial = (0.5 * axial_stiffness * eps**2 if axial_law is None
               else axial_law.energy(eps, axial_stiffness))
    ua = jnp.dot(jnp.asarray(wa), w_axial * g)

    # bending term at the bending quadrature points
    if formulation.curvature == "small_strain":
        if bending_law is not None:
            raise ModelError("a bending law needs curvature 'exact' or 'material', not 'small_strain'")
        xb, _ = rule(*formulation.bending_quadrature)
        r2 = interpolate_at(e, xb, length, 2)
        ub = jnp.dot(jnp.asarray(wb), 0.5 * bending_stiffness * _dot(r2, r2))
    else:
        dk, g = curvature_changes(e, e_ref, length, formulation)
        w_bending = (0.5 * bending_stiffness * dk**2 if bending_law is None
                     else bending_law.energy(dk, bending_stiffness))
        ub = jnp.dot(jnp.asarray(wb), w_bending * g)
    return length * (ua + ub)


def dissipative_force(e, e_dot, e_ref, length, axial_stiffness, bending_stiffness,
                      formulation: Formulation = Formulation(), axial_law=None, bending_law=None):
    """Generalized force of the rate parts of the laws on one element, shape (8,),
    acting against the motion (the resisting force, like ∂U/∂e):

        f_d = ∫₀ˡ [N_d(ε, ε̇) ∂ε/∂e + M_d(κ, κ̇) ∂κ/∂e] g dx,

    with ε̇ = (∂ε/∂e) ė and κ̇ = (∂κ/∂e) ė (one JVP each) and the transposed
    products by one VJP each, at the quadrature points of the energy. Exudyn's cable
    damping (δW = ∫ d γ̇ δγ dx) is this with N_d = d_A ε̇, M_d = d_K κ̇. Laws without a
    rate part add nothing (and nothing is traced for them).
    """
    out = jnp.zeros_like(e)
    for law, stiffness, quadrature, strains in (
            (axial_law, axial_stiffness, formulation.axial_quadrature, axial_strains),
            (bending_law, bending_stiffness, formulation.bending_quadrature, curvature_changes)):
        if law is None or not law.has_rate:
            continue
        if strains is curvature_changes and formulation.curvature == "small_strain":
            raise ModelError("a bending law needs curvature 'exact' or 'material', not 'small_strain'")
        _, w = rule(*quadrature)

        def gamma(x, strains=strains):
            return strains(x, e_ref, length, formulation)[0]

        (g_val, g_dot) = jax.jvp(gamma, (e,), (e_dot,))
        _, metric = strains(e, e_ref, length, formulation)
        n_d = law.rate_force(g_val, g_dot, stiffness)
        _, vjp = jax.vjp(gamma, e)
        out = out + vjp(length * jnp.asarray(w) * metric * n_d)[0]
    return out
