"""A beam: mesh + section + formulation + Rayleigh damping, and its assembled physics.

All elastic quantities derive from the one element energy
:func:`ancf_jax.element.strain_energy`: the generalized elastic force is its negative
gradient (Eq. 9, Q_k = ∂U/∂e in the paper enters Eq. 10 on the left-hand side, so the
force acting on the coordinates is −Q_k), and the tangent stiffness is its Hessian,
computed per element under ``jax.vmap`` and assembled into a block-tridiagonal matrix.

Nodal coordinates of a beam are an array ``nodes`` of shape (n_max + 1, 4).
"""

from __future__ import annotations

import copy

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _products
from ._control import traced_once
from .element import mass as element_mass
from .element.shape_functions import position as _position, shape_matrix, slope as _slope
from .element import laws as _laws
from .element.strain_energy import Formulation, axial_strain as _axial_strain, curvature as _curvature
from .element.strain_energy import dissipative_force as _dissipative, strain_energy
from .element.stress import axial_force as _axial_force, bending_stress
from .errors import ModelError
from .linalg import BlockTridiagonal
from .mesh import BeamMesh
from .section import Section
from .validation import check_nonnegative


class AttachedMasses(eqx.Module):
    """Point masses fixed to material points of a beam (clamps, spacers, markers on a
    wire), translation only: mass m_i at reference arc length s_i.

    Each adds the consistent mass m_i S(x_i)ᵀ S(x_i) (S the 2×8 shape matrix of Eq. 2 in
    the element holding s_i, x_i the local arc length) to that element's mass matrix,
    so the kinetic energy gains ½ m_i |ṙ(s_i)|², and its weight m_i S(x_i)ᵀ g to the
    consistent gravity load. Both are constant: the beam mass stays constant and
    block tridiagonal. No rotary inertia.

    Attributes:
        s: reference arc lengths s_i [m], shape (k,).
        mass: masses m_i [kg], shape (k,).
    """

    s: jnp.ndarray
    mass: jnp.ndarray

    def element_terms(self, mesh: BeamMesh, gravity):
        """(element index (k,), mass terms m Sᵀ S (k, 8, 8), gravity loads m Sᵀ g (k, 8))."""
        def one(si, mi):
            e, x = mesh.locate(si)
            sm = shape_matrix(x, mesh.element_lengths[e])
            return e, mi * sm.T @ sm, mi * sm.T @ gravity
        return jax.vmap(one)(self.s, self.mass)


def _maybe_nonzero(x) -> bool:
    """False only for a concrete zero (a traced value may be anything)."""
    try:
        return bool(np.any(np.asarray(x) != 0.0))
    except (jax.errors.TracerArrayConversionError, jax.errors.ConcretizationTypeError):
        return True


class Beam(eqx.Module):
    """A planar ANCF beam.

    Attributes:
        mesh: reference geometry (possibly padded).
        section: cross-section and material.
        alpha: Rayleigh mass-proportional damping coefficient α [1/s] (Eq. 11).
        beta: Rayleigh stiffness-proportional damping coefficient β [s] (Eq. 11).
        formulation: strain measures and quadrature (static).
        rate_stiffness: whether Newton matrices include the β-rate term β ∂(K ė)/∂e
            (static; default: where β ≠ 0 at construction). See :meth:`element_tangent`.
        axial_law, bending_law: material laws N(ε, ε̇) and M(κ, κ̇)
            (:mod:`ancf_jax.element.laws`); None (default): linear elastic with the
            section's EA and EI, through the unchanged energy of Eq. 8.
        attached: point masses fixed to the beam (:class:`AttachedMasses`), or None.
    """

    mesh: BeamMesh
    section: Section
    alpha: jnp.ndarray
    beta: jnp.ndarray
    formulation: Formulation = eqx.field(static=True)
    rate_stiffness: bool = eqx.field(static=True)
    axial_law: _laws.AbstractLaw | None = None
    bending_law: _laws.AbstractLaw | None = None
    attached: AttachedMasses | None = None

    def __init__(self, mesh: BeamMesh, section: Section, *, alpha=0.0, beta=0.0,
                 formulation: Formulation | None = None, rate_stiffness: bool | None = None,
                 axial_law: _laws.AbstractLaw | None = None, bending_law: _laws.AbstractLaw | None = None,
                 attached: AttachedMasses | None = None):
        self.attached = attached
        self.mesh = mesh
        self.section = section
        self.alpha = jnp.asarray(check_nonnegative("alpha (Rayleigh, mass-proportional)", alpha, "1/s"), float)
        self.beta = jnp.asarray(check_nonnegative("beta (Rayleigh, stiffness-proportional)", beta, "s"), float)
        self.formulation = Formulation() if formulation is None else formulation
        self.rate_stiffness = _maybe_nonzero(self.beta) if rate_stiffness is None else bool(rate_stiffness)
        self.axial_law = _laws.check_law("axial_law", axial_law)
        self.bending_law = _laws.check_law("bending_law", bending_law)
        if bending_law is not None and self.formulation.curvature == "small_strain":
            raise ModelError("a bending law needs curvature 'exact' or 'material', not 'small_strain'")
        if self.formulation.curvature == "small_strain":
            ref = jax.device_get(mesh.reference_nodes)
            n = int(mesh.n_elements)
            t = ref[: n + 1, 2:]
            if abs(t[:, 0] * t[0, 1] - t[:, 1] * t[0, 0]).max() > 1e-12:
                raise ModelError("curvature='small_strain' (Eq. 17) needs a straight reference "
                                 "configuration; use curvature='exact' for curved beams")

    # ------------------------------------------------------------------ sizes
    @property
    def n_nodes(self) -> int:
        return self.mesh.n_nodes

    @property
    def n_coordinates(self) -> int:
        return 4 * self.mesh.n_nodes

    # ------------------------------------------------------------------ energy
    def element_energies(self, nodes):
        """Strain energy of every element [J], shape (n_max,), zero for inactive ones."""
        e = self.mesh.element_coordinates(nodes)
        e_ref = self.mesh.reference_elements
        ea = self.section.axial_stiffness
        ei = self.section.bending_stiffness
        with _products.batch(self.mesh.n_max):
            u = jax.vmap(lambda ee, er, l: strain_energy(ee, er, l, ea, ei, self.formulation,
                                                         self.axial_law, self.bending_law))(
                e, e_ref, self.mesh.element_lengths)
        return jnp.where(self.mesh.active, u, 0.0)

    @traced_once
    def strain_energy(self, nodes):
        """Total strain energy U of the beam [J] (Eq. 8 summed over elements)."""
        return jnp.sum(self.element_energies(nodes))

    def elastic_force(self, nodes):
        """Generalized elastic force −∂U/∂e, shape (n_max + 1, 4) [N, N·m] (Eq. 9)."""
        return -jax.grad(self.strain_energy)(nodes)

    @traced_once
    def element_stiffness(self, nodes):
        """Tangent stiffness ∂²U/∂e² of every element, shape (n_max, 8, 8), zero when inactive."""
        e = self.mesh.element_coordinates(nodes)
        e_ref = self.mesh.reference_elements
        ea = self.section.axial_stiffness
        ei = self.section.bending_stiffness
        with _products.batch(self.mesh.n_max):
            h = jax.vmap(jax.hessian(
                lambda ee, er, l: strain_energy(ee, er, l, ea, ei, self.formulation,
                                                self.axial_law, self.bending_law)))(
                e, e_ref, self.mesh.element_lengths)
        return jnp.where(self.mesh.active[:, None, None], h, 0.0)

    @traced_once
    def element_tangent(self, nodes, velocities, damping_coef):
        """Linearization of the elastic and stiffness-proportional damping forces of
        every element for a Newton matrix, shape (n_max, 8, 8), zero when inactive:

            ∂f/∂e + c_v ∂f/∂ė = K(e) + β ∂(K(e) ė)/∂e + c_v β K(e),
            f(e, ė) = ∂U/∂e + β K(e) ė,

        with K the Hessian of the element strain energy (Eq. 8), ė the element
        velocities and c_v = ``damping_coef`` (γ' of an implicit integrator, 0 in
        statics): per element the Hessian of the scalar (1 + c_v β) U(e) + β DU(e)[ė]
        (ė held fixed), or with a rate law one ``jax.jacfwd`` of f along (δe, c_v δe). The
        β-rate term β ∂(K ė)/∂e (a third derivative of U contracted with ė) is included where
        :attr:`rate_stiffness` is set (static: by default where β ≠ 0 at construction);
        without it the tangent is K (1 + c_v β), which a modified Newton method converges
        with as well (the residual always holds β K ė). A static switch, because under
        ``vmap`` any control flow on a batched β costs more than the term itself
        (measured, M1 batch of 64: element tangent 19 µs per member with a one-trip while
        loop, 13.5 with the term always computed, 7 without it). The mass-proportional
        part α M ė is linear and enters with the mass (:func:`ancf_jax.dae.iteration_matrix`).
        A beam with a rate law (:attr:`has_rate_law`) adds the rate parts' resisting
        force f_d(e, ė) to f and always takes this path (the β-rate term included).
        """
        if not (self.rate_stiffness or self.has_rate_law):
            return self.element_stiffness(nodes) * (1.0 + damping_coef * self.beta)
        e = self.mesh.element_coordinates(nodes)
        ed = self.mesh.element_coordinates(velocities)
        e_ref = self.mesh.reference_elements
        ea = self.section.axial_stiffness
        ei = self.section.bending_stiffness

        def one(ee, eed, er, l):
            def u(x):
                return strain_energy(x, er, l, ea, ei, self.formulation, self.axial_law, self.bending_law)

            if not self.has_rate_law:
                # the Jacobian at x = e of f(x) = ∇U(x) + β K(x) ẋ, ẋ = ė + c_v (x − e), is
                # K (1 + c_v β) + β ∂(K ė)/∂e: the Hessian of the scalar
                # (1 + c_v β) U(x) + β DU(x)[ė] (ė held fixed), one jax.hessian (measured,
                # M1's 6 elements, traced β, fresh processes: 84 against 104 µs per call for
                # jacfwd of f, 24 elements 239 against 304 µs; equal to 2e-16)
                def psi(x):
                    return (1.0 + damping_coef * self.beta) * u(x) + self.beta * jax.jvp(u, (x,), (eed,))[1]
                return jax.hessian(psi)(ee)

            def f(x):  # with the rate parts' resisting force f_d(e, ė) of the rate law
                x_dot = eed + damping_coef * (x - ee)
                g, kw = jax.jvp(jax.grad(u), (x,), (x_dot,))
                return g + self.beta * kw + self._element_dissipative(x, x_dot, er, l)
            return jax.jacfwd(f)(ee)

        with _products.batch(self.mesh.n_max):
            h = jax.vmap(one)(e, ed, e_ref, self.mesh.element_lengths)
        return jnp.where(self.mesh.active[:, None, None], h, 0.0)

    # ------------------------------------------------------------------ rate laws
    @property
    def has_rate_law(self) -> bool:
        """Whether a material law of the beam has a rate part (static)."""
        return any(law is not None and law.has_rate for law in (self.axial_law, self.bending_law))

    def _element_dissipative(self, e, e_dot, e_ref, length):
        return _dissipative(e, e_dot, e_ref, length, self.section.axial_stiffness,
                            self.section.bending_stiffness, self.formulation, self.axial_law,
                            self.bending_law)

    def dissipative_force(self, nodes, velocities):
        """Generalized force of the rate parts of the laws, −∫ (N_d δε + M_d δκ) g dx,
        shape (n_max + 1, 4) [N, N·m] (acting on the coordinates; zero without a rate
        law). See :func:`ancf_jax.element.strain_energy.dissipative_force`."""
        if not self.has_rate_law:
            return jnp.zeros_like(nodes)
        with _products.batch(self.mesh.n_max):
            f = jax.vmap(self._element_dissipative)(
                self.mesh.element_coordinates(nodes), self.mesh.element_coordinates(velocities),
                self.mesh.reference_elements, self.mesh.element_lengths)
        f = jnp.where(self.mesh.active[:, None], f, 0.0)
        out = jnp.zeros((self.n_nodes, 4))
        return -out.at[:-1].add(f[:, :4]).at[1:].add(f[:, 4:])

    @property
    def exact_tangent(self) -> bool:
        """Whether :meth:`element_tangent` is the exact Jacobian of the element force:
        the β-rate term included (:attr:`rate_stiffness`, a rate law), or β a concrete
        zero. (False for a β traced or set after construction without
        :meth:`with_rate_stiffness`: derivatives then factor a matrix with the term for
        their tangent solves, :meth:`ancf_jax.integrators.generalized_alpha.GeneralizedAlpha.tangent_system`.)"""
        return bool(self.rate_stiffness or self.has_rate_law or not _maybe_nonzero(self.beta))

    def with_rate_stiffness(self, on: bool = True) -> "Beam":
        """The same beam with :attr:`rate_stiffness` set to ``on`` (for systems whose β
        is changed after construction, e.g. fitted from 0, or batched with others)."""
        if self.rate_stiffness == bool(on):
            return self
        new = copy.copy(self)
        object.__setattr__(new, "rate_stiffness", bool(on))
        return new

    def stiffness(self, nodes) -> BlockTridiagonal:
        """Assembled tangent stiffness (block tridiagonal, 4×4 node blocks)."""
        return BlockTridiagonal.from_element_matrices(self.element_stiffness(nodes))

    def stiffness_product(self, nodes, direction):
        """K(nodes) · direction as one Jacobian-vector product of the elastic force."""
        return -jax.jvp(self.elastic_force, (nodes,), (direction,))[1]

    # ------------------------------------------------------------------ inertia
    def element_mass(self):
        """Element mass matrices (Eq. 6), shape (n_max, 8, 8), zero when inactive."""
        m = jax.vmap(lambda l: element_mass.mass_matrix(l, self.section.mass_per_length))(
            self.mesh.element_lengths)
        m = jnp.where(self.mesh.active[:, None, None], m, 0.0)
        if self.attached is not None:
            k, mm, _ = self.attached.element_terms(self.mesh, jnp.zeros(2))
            m = m.at[k].add(mm)
        return m

    @traced_once
    def mass(self) -> BlockTridiagonal:
        """Assembled consistent mass matrix with a unit dummy mass on inactive nodes."""
        m = BlockTridiagonal.from_element_matrices(self.element_mass())
        dummy = jnp.where(self.mesh.active_nodes, 0.0, 1.0)
        return m.add_diagonal(jnp.repeat(dummy, 4))

    def gravity_load(self, gravity):
        """Consistent gravity load, shape (n_max + 1, 4) [N, N·m]."""
        f = jax.vmap(lambda l: element_mass.gravity_load(l, self.section.mass_per_length, gravity))(
            self.mesh.element_lengths)
        f = jnp.where(self.mesh.active[:, None], f, 0.0)
        if self.attached is not None:
            k, _, fg = self.attached.element_terms(self.mesh, jnp.asarray(gravity, float))
            f = f.at[k].add(fg)
        out = jnp.zeros((self.n_nodes, 4))
        return out.at[:-1].add(f[:, :4]).at[1:].add(f[:, 4:])

    @property
    def total_mass(self):
        """ρA · L of the active elements plus the attached masses [kg]."""
        m = self.section.mass_per_length * self.mesh.length
        return m if self.attached is None else m + jnp.sum(self.attached.mass)

    # ------------------------------------------------------------------ kinematics
    def element_at(self, nodes, s):
        """(element coordinates (8,), local x, element length, element index) at arc length s."""
        k, x = self.mesh.locate(s)
        e = jnp.concatenate([nodes[k], nodes[k + 1]])
        return e, x, self.mesh.element_lengths[k], k

    def position(self, nodes, s):
        """Position [m] of the point at reference arc length s, shape (2,)."""
        e, x, l, _ = self.element_at(nodes, s)
        return _position(e, x, l)

    def slope(self, nodes, s):
        """Slope ∂r/∂x at arc length s, shape (2,)."""
        e, x, l, _ = self.element_at(nodes, s)
        return _slope(e, x, l)

    # ------------------------------------------------------------------ stress
    # (jitted: these are the post-processing entry points users call eagerly)
    @eqx.filter_jit
    def stress(self, nodes, s, y=None, measure="exact"):
        """Signed bending stress σ [Pa] at arc length s on fibre y (default: outer fibre,
        left side) (Eqs. 15–18)."""
        self.section.require_modulus("a bending stress")
        y = self.section.fibre_distance if y is None else y
        e, x, l, k = self.element_at(nodes, s)
        e_ref = jnp.concatenate([self.mesh.reference_nodes[k], self.mesh.reference_nodes[k + 1]])
        return bending_stress(e, e_ref, x, l, self.section.youngs_modulus, y, measure)

    @eqx.filter_jit
    def element_stress(self, nodes, element, xi, y=None, measure="exact"):
        """Stress [Pa] in element ``element`` at local coordinate ξ = x/l ∈ [0, 1]."""
        self.section.require_modulus("a bending stress")
        y = self.section.fibre_distance if y is None else y
        e = self.mesh.element_coordinates(nodes)[element]
        e_ref = self.mesh.reference_elements[element]
        l = self.mesh.element_lengths[element]
        return bending_stress(e, e_ref, xi * l, l, self.section.youngs_modulus, y, measure)

    @eqx.filter_jit
    def axial_force(self, nodes, s):
        """Axial force N = EA·ε [N] at arc length s (tension positive), with the
        formulation's axial strain measure."""
        e, x, l, k = self.element_at(nodes, s)
        e_ref = jnp.concatenate([self.mesh.reference_nodes[k], self.mesh.reference_nodes[k + 1]])
        return self.elastic_axial_force(e, e_ref, x, l)

    def axial_strain(self, nodes, s):
        """Axial strain ε [-] at arc length s (the formulation's measure)."""
        e, x, l, k = self.element_at(nodes, s)
        e_ref = jnp.concatenate([self.mesh.reference_nodes[k], self.mesh.reference_nodes[k + 1]])
        return _axial_strain(e, e_ref, x, l, self.formulation.axial_strain, self.formulation.metric)

    def axial_force_with_rate(self, nodes, velocities, s):
        """Axial force N = W'(ε) + N_d(ε, ε̇) [N] at arc length s: the elastic part of the
        axial law (:meth:`axial_force`) plus its rate part (strain-rate damping), with
        ε̇ from the nodal velocities."""
        n = self.axial_force(nodes, s)
        law = self.axial_law
        if law is None or not law.has_rate:
            return n
        eps, eps_dot = jax.jvp(lambda nn: self.axial_strain(nn, s), (nodes,), (velocities,))
        return n + law.rate_force(eps, eps_dot, self.section.axial_stiffness)

    def curvature_change(self, nodes, s):
        """Curvature change κ − κ₀ [1/m] at arc length s (the formulation's measure;
        positive when the centre line turns more counter-clockwise than at rest)."""
        e, x, l, k = self.element_at(nodes, s)
        e_ref = jnp.concatenate([self.mesh.reference_nodes[k], self.mesh.reference_nodes[k + 1]])
        measure = self.formulation.curvature
        return _curvature(e, x, l, measure) - _curvature(e_ref, x, l, measure)

    def bending_moment_with_rate(self, nodes, velocities, s):
        """Bending moment M = W'(κ − κ₀) + M_d [N·m] at arc length s: the elastic part
        of the bending law (EI (κ − κ₀) without one) plus its rate part, with κ̇ from
        the nodal velocities (any law: no linear-elastic section model needed)."""
        law, ei = self.bending_law, self.section.bending_stiffness
        dk, dk_dot = jax.jvp(lambda nn: self.curvature_change(nn, s), (nodes,), (velocities,))
        if law is None:
            return ei * dk
        m = jax.grad(law.energy)(dk, ei)
        return m + law.rate_force(dk, dk_dot, ei) if law.has_rate else m

    def elastic_axial_force(self, e, e_ref, x, l):
        """Elastic axial force N = W'(ε) [N] of the axial law (EA·ε without one)."""
        if self.axial_law is None:
            return _axial_force(e, e_ref, x, l, self.section.axial_stiffness, self.formulation.axial_strain,
                                self.formulation.metric)
        eps = _axial_strain(e, e_ref, x, l, self.formulation.axial_strain, self.formulation.metric)
        return jax.grad(self.axial_law.energy)(eps, self.section.axial_stiffness)

    @eqx.filter_jit
    def element_axial_force(self, nodes, element, xi):
        """Axial force N [N] in element ``element`` at local coordinate ξ = x/l ∈ [0, 1]."""
        e = self.mesh.element_coordinates(nodes)[element]
        e_ref = self.mesh.reference_elements[element]
        l = self.mesh.element_lengths[element]
        return self.elastic_axial_force(e, e_ref, xi * l, l)

    @eqx.filter_jit
    def stress_along(self, nodes, points_per_element=11, y=None, measure="exact"):
        """Stress at ``points_per_element`` equally spaced points of every element.

        Returns:
            (s, sigma), each shape (n_max, points_per_element); entries of inactive
            elements are NaN (so plots and maxima skip them).
        """
        xi = jnp.linspace(0.0, 1.0, points_per_element)
        elems = jnp.arange(self.mesh.n_max)
        sig = jax.vmap(lambda k: jax.vmap(lambda z: self.element_stress(nodes, k, z, y, measure))(xi))(elems)
        s = self.mesh.node_arc_lengths[:-1, None] + xi[None, :] * self.mesh.element_lengths[:, None]
        mask = self.mesh.active[:, None]
        return jnp.where(mask, s, jnp.nan), jnp.where(mask, sig, jnp.nan)

    @eqx.filter_jit
    def max_stress(self, nodes, points_per_element=21, y=None, measure="exact"):
        """Maximum |σ| over the beam [Pa] and the arc length where it occurs [m]."""
        s, sig = self.stress_along(nodes, points_per_element, y, measure)
        a = jnp.where(jnp.isnan(sig), -jnp.inf, jnp.abs(sig)).ravel()
        i = jnp.argmax(a)
        return a[i], s.ravel()[i]
