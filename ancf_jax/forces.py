"""Applied forces and force elements (the Q_e of Eq. 10).

Gravity and the elastic and damping forces of beams belong to the system itself
(:mod:`ancf_jax.system`); this module holds the force elements a user adds. Every
element splits into three parts so that the energy balance can be kept:

* ``potential(system, q, t)``: a conservative part, force = −∂V/∂q;
* ``dissipative_force(system, q, v)``: a damping part (its power is dissipation);
* ``applied_force(system, q, v, t)``: prescribed loads (their power is external work).

A user's law subclasses :class:`AbstractForce` and writes all four methods, or one of
the two partial bases that fix the parts it does not have:
:class:`AbstractConservativeForce` (a potential only: springs, user energies) and
:class:`AbstractLoad` (a prescribed load only).

Forces that depend on the joint reactions λ (friction proportional to a normal force)
are :class:`AbstractReactionForce` elements, held apart in ``System.reaction_forces``.
One-sided members (ropes, stops) are :class:`AbstractOneSidedSpringDamper`.

Point forces map to generalized forces through the point's Jacobian by one
vector-Jacobian product, Q = J_pᵀ F, never a hand-written Jacobian.

Newton matrix. Implicit integrators and statics need ∂Q/∂q and ∂Q/∂v of every force
element; :func:`force_tangent` computes them by forward-mode autodiff of
:meth:`AbstractForce.generalized_force` restricted to the coordinates the element acts
on (:meth:`AbstractForce.coordinates`: the points' element or body coordinates), so a
user-written law enters the Newton matrix exactly like a built-in one, at a cost set by
the element's few coordinates, not by the size of the system.
"""

from __future__ import annotations

import abc
from typing import Callable, ClassVar, Optional

import equinox as eqx
import jax
import jax.numpy as jnp

from .functions import AbstractPath
from .points import AbstractPoint


def point_load(system, point: AbstractPoint, q, force):
    """Generalized force J_p(q)ᵀ F of a force F [N] acting at a point, shape (n,)."""
    _, vjp = jax.vjp(lambda qq: point.position(system, qq), q)
    return vjp(force)[0]


class AbstractForce(eqx.Module):
    """A force element (see the module docstring for its three parts)."""

    name: str = eqx.field(static=True)

    @abc.abstractmethod
    def potential(self, system, q, t):
        """Potential energy V [J] of the conservative part."""

    @abc.abstractmethod
    def dissipative_force(self, system, q, v):
        """Generalized damping force, shape (n,)."""

    @abc.abstractmethod
    def applied_force(self, system, q, v, t):
        """Generalized prescribed load, shape (n,)."""

    @abc.abstractmethod
    def coordinates(self, system, q, t):
        """Indices of q the element depends on and acts on at time t (its generalized
        force is zero elsewhere), int array of fixed length; or None: any coordinate. The Newton
        matrix couples these coordinates (:func:`force_tangent`); None is exact for any
        force but couples all coordinates (cost O(n²)): an element acting at points
        returns its points' :meth:`~ancf_jax.points.AbstractPoint.coordinates`."""

    def generalized_force(self, system, q, v, t, load_factor=1.0):
        """Q(q, v, t) of the element: −∂V/∂q + dissipative + load_factor · applied, shape (n,)."""
        f = -jax.grad(lambda qq: self.potential(system, qq, t))(q)
        return f + self.dissipative_force(system, q, v) + load_factor * self.applied_force(system, q, v, t)



class AbstractConservativeForce(AbstractForce):
    """A force element with a potential only (no damping, no prescribed load): write
    ``potential`` and ``coordinates``."""

    def dissipative_force(self, system, q, v):
        return jnp.zeros_like(q)

    def applied_force(self, system, q, v, t):
        return jnp.zeros_like(q)


class AbstractLoad(AbstractForce):
    """A prescribed load only (no potential, no damping): write ``applied_force`` and
    ``coordinates``."""

    def potential(self, system, q, t):
        return jnp.zeros(())

    def dissipative_force(self, system, q, v):
        return jnp.zeros_like(q)


def _first(idx):
    """True at the first occurrence of each index in idx, shape (k,)."""
    k = idx.shape[0]
    earlier = jnp.arange(k)[:, None] > jnp.arange(k)[None, :]
    return ~jnp.any((idx[:, None] == idx[None, :]) & earlier, axis=1)


def _selection(idx, size, dtype):
    """(k, size) one-hot rows selecting the indices idx, repeated indices counted once."""
    return jax.nn.one_hot(idx, size, dtype=dtype) * _first(idx)[:, None]


def force_tangent(force: AbstractForce, system, q, v, t, damping_coef, load_factor=1.0):
    """Linearization of one force element for a Newton matrix.

    With P the (k, n) selection of the element's coordinates (repeated indices
    counted once), returns ``(P, A)`` with

        A = −P (∂Q/∂q + c_v ∂Q/∂v) Pᵀ,   shape (k, k),

    c_v = ``damping_coef`` (γ' of an implicit integrator, 0 in statics), so that the
    element's contribution to the Newton matrix is Pᵀ A P (exact when Q depends on
    and acts on these coordinates only). A is one ``jax.jacfwd`` over the k local
    coordinates of :meth:`AbstractForce.generalized_force`.
    """
    idx, a = _local_tangent(force, system, q, v, t, damping_coef, load_factor)
    return _selection(idx, q.shape[0], q.dtype), a


def force_tangent_local(force: AbstractForce, system, q, v, t, damping_coef, load_factor=1.0):
    """:func:`force_tangent` as ``(idx, A)``: the element's coordinate indices in q
    (k,) and its local matrix (k, k) (rows and columns of repeated indices zero), for
    adding into a structured matrix."""
    return _local_tangent(force, system, q, v, t, damping_coef, load_factor)


def _local_tangent(force, system, q, v, t, damping_coef, load_factor):
    # gathers and scatters at idx (not products with a dense (k, n) selection: O(k)
    # per direction besides the force itself, which matters with many elements)
    n = q.shape[0]
    idx = force.coordinates(system, q, t)
    idx = jnp.arange(n) if idx is None else jnp.asarray(idx)
    keep = _first(idx).astype(q.dtype)

    def local(d):
        dq = jnp.zeros_like(q).at[idx].add(keep * d)
        return keep * force.generalized_force(system, q + dq, v + damping_coef * dq, t, load_factor)[idx]

    return idx, -jax.jacfwd(local)(jnp.zeros(idx.shape[0], q.dtype))


class BodyMassLoad(AbstractLoad):
    """A mass-proportional load m·a·f(t) [N] at the centre of rigid body ``body`` (a
    gravity-like load on one body only; Exudyn's ``LoadMassProportional``).

    ``time_function`` (a JAX-traceable t ↦ scalar) scales ``acceleration`` [m/s²];
    None: constant.
    """

    body: int = eqx.field(static=True)
    acceleration: jnp.ndarray
    time_function: Optional[Callable] = eqx.field(static=True, default=None)

    def applied_force(self, system, q, v, t):
        a = self.acceleration if self.time_function is None else self.acceleration * self.time_function(t)
        o = system.body_offset(self.body)
        return jnp.zeros_like(q).at[o:o + 2].add(system.bodies.mass[self.body] * a)

    def coordinates(self, system, q, t):
        return system.body_offset(self.body) + jnp.arange(2)


class BeamMassLoad(AbstractLoad):
    """A mass-proportional load on beam ``beam`` only: the consistent load
    ∫ ρA Sᵀ a f(t) dx of :meth:`ancf_jax.beam.Beam.gravity_load` with acceleration a
    [m/s²] (Exudyn's ``LoadMassProportional`` on a cable)."""

    beam: int = eqx.field(static=True)
    acceleration: jnp.ndarray
    time_function: Optional[Callable] = eqx.field(static=True, default=None)

    def applied_force(self, system, q, v, t):
        a = self.acceleration if self.time_function is None else self.acceleration * self.time_function(t)
        b = system.beams[self.beam]
        o = system.beam_offset(self.beam)
        return jnp.zeros_like(q).at[o:o + b.n_coordinates].add(jnp.reshape(b.gravity_load(a), (-1,)))

    def coordinates(self, system, q, t):
        return system.beam_offset(self.beam) + jnp.arange(system.beams[self.beam].n_coordinates)


class AbstractReactionForce(eqx.Module):
    """A dissipative force that depends on joint reactions: Q(q, v, t, λ), e.g. Coulomb
    friction proportional to a normal reaction (:class:`ancf_jax.sliding.SlidingFriction`).

    It enters the implicit residual M q̈ − Q − Q_r(q, v, t, λ) + Φ_qᵀ λ with its exact
    linearization in q, v and λ (:func:`reaction_force_tangent`, a non-symmetric
    low-rank term of the Newton matrix), the index-1 accelerations by a fixed-point
    iteration on λ (:func:`ancf_jax.dae.accelerations`), and the energy balance as
    dissipation −v·Q_r. Statics leaves it out (it vanishes at rest for the laws here).
    """

    name: str = eqx.field(static=True)

    @abc.abstractmethod
    def generalized_force(self, system, q, v, t, lam):
        """Q_r(q, v, t, λ), shape (n,); its power v·Q_r must be ≤ 0."""

    @abc.abstractmethod
    def coordinates(self, system, q, t):
        """Indices of q the force depends on and acts on, int array of fixed length."""

    @abc.abstractmethod
    def multiplier_indices(self, system):
        """Indices of λ the force depends on, int array of fixed length."""


def reaction_force_tangent(force: AbstractReactionForce, system, q, v, lam, t, damping_coef):
    """Linearization of a reaction-dependent force for a Newton matrix in the unknowns
    (q, λ): with P (k, n + m) the selection of its coordinates and multipliers,
    returns ``(P, A)``, A = −P ∂[Q_r; 0]/∂(q, λ) Pᵀ with ∂/∂q including c_v ∂/∂v
    (c_v = ``damping_coef``), so that its contribution is Pᵀ A P (non-symmetric)."""
    n, m = q.shape[0], lam.shape[0]
    idx = jnp.concatenate([jnp.asarray(force.coordinates(system, q, t)),
                           n + jnp.asarray(force.multiplier_indices(system))])
    p = _selection(idx, n + m, q.dtype)

    def local(d):
        dx = p.T @ d
        dq, dl = dx[:n], dx[n:]
        return p[:, :n] @ force.generalized_force(system, q + dq, v + damping_coef * dq, t, lam + dl)

    return p, -jax.jacfwd(local)(jnp.zeros(idx.shape[0], q.dtype))


class PointForce(AbstractLoad):
    """A force F·f(t) [N] at a point, fixed in direction (not a follower load).

    ``time_function`` (a JAX-traceable t ↦ scalar) scales ``force``; None: constant.
    """

    point: AbstractPoint
    force: jnp.ndarray
    time_function: Optional[Callable] = eqx.field(static=True, default=None)

    def applied_force(self, system, q, v, t):
        f = self.force if self.time_function is None else self.force * self.time_function(t)
        return point_load(system, self.point, q, f)

    def coordinates(self, system, q, t):
        return self.point.coordinates(system, q)


class SpeedSquaredForce(AbstractLoad):
    """A force (F₀ + c ṗ(t)²) e [N] at a point, fixed in direction: a static part plus
    one growing with the square of the speed ṗ of a prescribed path (the uplift of a
    pantograph, static plus aerodynamic, EN 50367: F = F₀ + c_aero v²).

    The speed ṗ(t) is the path's time derivative by autodiff (for
    :class:`~ancf_jax.functions.ConstantSpeed` without a profile: its ``speed``
    leaf), so the force follows the path's data through a batch or a gradient over
    the speed.

    Attributes:
        point: where it acts.
        direction: e, shape (2,) (not normalized: F₀ e and c ṗ² e are the force).
        static: F₀ [N].
        coefficient: c [N/(m/s)² = N·s²/m²].
        path: the path whose speed ṗ [m/s] enters (an
            :class:`~ancf_jax.functions.AbstractPath`).
    """

    point: AbstractPoint
    direction: jnp.ndarray
    static: jnp.ndarray
    coefficient: jnp.ndarray
    path: AbstractPath

    def magnitude(self, t):
        """F₀ + c ṗ(t)² [N]."""
        speed = jax.jvp(self.path, (jnp.asarray(t, float),), (jnp.ones(()),))[1]
        return self.static + self.coefficient * speed ** 2

    def applied_force(self, system, q, v, t):
        return point_load(system, self.point, q, self.magnitude(t) * self.direction)

    def coordinates(self, system, q, t):
        return self.point.coordinates(system, q)


class PointTorque(AbstractLoad):
    """A torque τ·f(t) [N·m] on rigid body ``body`` (index)."""

    body: int = eqx.field(static=True)
    torque: jnp.ndarray
    time_function: Optional[Callable] = eqx.field(static=True, default=None)

    def applied_force(self, system, q, v, t):
        tau = self.torque if self.time_function is None else self.torque * self.time_function(t)
        return jnp.zeros_like(q).at[system.body_offset(self.body) + 2].add(tau)

    def coordinates(self, system, q, t):
        return jnp.array([system.body_offset(self.body) + 2])


class AbstractLinearSpringDamper(AbstractForce):
    """A linear spring-damper on a stage length ℓ(q) between two points: tension
    k (ℓ − ℓ₀) + c ℓ̇ [N]; potential ½ k (ℓ − ℓ₀)², damping −c ℓ̇ ∂ℓ/∂q. Subclasses say
    what ℓ is (:meth:`length`)."""

    a: eqx.AbstractVar[AbstractPoint]
    b: eqx.AbstractVar[AbstractPoint]
    stiffness: eqx.AbstractVar[jnp.ndarray]
    damping: eqx.AbstractVar[jnp.ndarray]
    rest_length: eqx.AbstractVar[jnp.ndarray]

    @abc.abstractmethod
    def length(self, system, q):
        """The stage length ℓ(q) [m]."""

    def potential(self, system, q, t):
        ell = self.length(system, q)
        return spring_law(0, ell, jnp.zeros_like(ell), self.stiffness, self.damping, self.rest_length)[1]

    def applied_force(self, system, q, v, t):
        return jnp.zeros_like(q)

    def dissipative_force(self, system, q, v):
        ell_dot = jax.jvp(lambda qq: self.length(system, qq), (q,), (v,))[1]
        _, vjp = jax.vjp(lambda qq: self.length(system, qq), q)
        return vjp(-self.damping * ell_dot)[0]

    def coordinates(self, system, q, t):
        return jnp.concatenate([self.a.coordinates(system, q), self.b.coordinates(system, q)])


class SpringDamper(AbstractLinearSpringDamper):
    """Linear spring-damper between two points: tension k (ℓ − ℓ₀) + c ℓ̇ [N], ℓ the
    distance between the points.

    Attributes:
        stiffness: k [N/m].
        damping: c [N·s/m].
        rest_length: ℓ₀ [m].
    """

    a: AbstractPoint
    b: AbstractPoint
    stiffness: jnp.ndarray
    damping: jnp.ndarray
    rest_length: jnp.ndarray

    def length(self, system, q):
        """Current distance ℓ between the points [m]."""
        d = self.a.position(system, q) - self.b.position(system, q)
        return jnp.sqrt(jnp.dot(d, d))


class DirectedSpringDamper(AbstractLinearSpringDamper):
    """Linear spring-damper between two points along a fixed unit direction e (a
    suspension of a lumped-mass chain, e.g. a pantograph's vertical stages): with the
    stage length ℓ = e·(r_b − r_a), tension k (ℓ − ℓ₀) + c ℓ̇ [N] (pulling b towards a
    along e). Sideways motion of the points is free, so a chain whose points move with
    a vehicle keeps its stages along e.

    Attributes:
        direction: e, shape (2,), unit.
        stiffness: k [N/m]. damping: c [N·s/m]. rest_length: ℓ₀ [m].
    """

    a: AbstractPoint
    b: AbstractPoint
    stiffness: jnp.ndarray
    damping: jnp.ndarray
    rest_length: jnp.ndarray
    direction: jnp.ndarray

    def length(self, system, q):
        """ℓ = e·(r_b − r_a) [m]."""
        return jnp.dot(self.direction, self.b.position(system, q) - self.a.position(system, q))


class AbstractKinked(eqx.Module):
    """A law with kinks: points in (q, v) where its stiffness or force jumps (a rope
    going taut, a contact closing, friction reversing). It names them as the zero
    crossings of :meth:`kinks`, so that fixed steps can be split there
    (:func:`kink_values`, ``locate_crossings`` of :mod:`ancf_jax.integrate`). Force
    elements take it through :class:`AbstractKinkedForce`; reaction-dependent forces
    (friction, :class:`ancf_jax.sliding.SlidingFriction`) inherit it directly."""

    @abc.abstractmethod
    def kinks(self, system, q, v):
        """Values whose zero crossings are the kinks of the law, shape (k,), k fixed."""


class AbstractKinkedForce(AbstractForce, AbstractKinked):
    """A force element whose law has kinks (:class:`AbstractKinked`)."""


class AbstractNodeCrossing(eqx.Module):
    """A force element acting at a point that moves along a beam (a moving force, a
    contact point): it names the point's node crossings as the zero crossings of
    :meth:`node_crossings`, so that fixed steps can be split there
    (:func:`node_crossing_values`, ``locate_load_nodes`` of
    :class:`~ancf_jax.integrate.RunOptions`). Its force is C¹ in the point's arc length
    at a node (only the curvature of the cubic elements jumps), so, unlike the kinks of
    :class:`AbstractKinked`, these are not located by ``locate_crossings``
    (docs/moving-loads.md: located, they change a run's error by under 1 %)."""

    @abc.abstractmethod
    def node_crossings(self, system, q, v, t):
        """Values whose zero crossings are the point's node crossings at the state
        (q, v) at time t [s], shape (k,), k fixed; continuous in (q, v, t)."""


class AbstractOneSidedSpringDamper(AbstractKinkedForce):
    """A spring-damper between two points that acts on one side only: a rope, dropper or
    hanger (tension only) or a stop or buffer (compression only).

    With x = ℓ − ℓ₀ the extension and σ = :attr:`sense` (+1: tension only, −1:
    compression only), the member is engaged while σx > 0, with the engaged extension
    e = max(σx, 0) [m]. Its parts:

    * potential V = ½ k e² [J] (conservative, C¹ in q: the force is continuous at
      the slack/taut transition, the stiffness jumps from 0 to k);
    * damping only while engaged, limited so that the member never pushes (tension
      only) or pulls (compression only): d = max(c σℓ̇, −k e) if e > 0 else 0 [N], so
      the member force σ(k e + d) has the sign σ or is zero. Its power d σℓ̇ ≥ 0 is
      dissipation in the energy balance.

    :meth:`tension` is the member force [N] (positive in tension); :meth:`engaged`
    the taut (or, compression only, the closed) state.

    Attributes:
        stiffness: k [N/m].
        damping: c [N·s/m].
        rest_length: ℓ₀ [m] (slack length of a rope, gap of a stop).
    """

    a: AbstractPoint
    b: AbstractPoint
    stiffness: jnp.ndarray
    damping: jnp.ndarray
    rest_length: jnp.ndarray

    @property
    @abc.abstractmethod
    def sense(self) -> float:
        """σ: +1 (tension only) or −1 (compression only)."""

    def length(self, system, q):
        """Current distance ℓ between the points [m]."""
        d = self.a.position(system, q) - self.b.position(system, q)
        return jnp.sqrt(jnp.dot(d, d))

    def engaged_extension(self, system, q):
        """e = max(σ (ℓ − ℓ₀), 0) [m]."""
        return jnp.maximum(self.sense * (self.length(system, q) - self.rest_length), 0.0)

    def engaged(self, system, q):
        """Whether the member is taut (tension only) or closed (compression only)."""
        return self.engaged_extension(system, q) > 0.0

    def _law(self, system, q, v):
        """(member force [N], potential [J]) by :func:`spring_law`."""
        ell, ell_dot = jax.jvp(lambda qq: self.length(system, qq), (q,), (v,))
        return spring_law(self.sense, ell, ell_dot, self.stiffness, self.damping, self.rest_length)

    def tension(self, system, q, v):
        """Member force σ (k e + d) [N], positive in tension, zero while disengaged."""
        return self._law(system, q, v)[0]

    def potential(self, system, q, t):
        return self._law(system, q, jnp.zeros_like(q))[1]

    def applied_force(self, system, q, v, t):
        return jnp.zeros_like(q)

    def dissipative_force(self, system, q, v):
        # the damper's part σ d of the member force, along −∂ℓ/∂q
        d = self.tension(system, q, v) - self.tension(system, q, jnp.zeros_like(v))
        _, vjp = jax.vjp(lambda qq: self.length(system, qq), q)
        return vjp(-d)[0]

    def coordinates(self, system, q, t):
        return jnp.concatenate([self.a.coordinates(system, q), self.b.coordinates(system, q)])

    def kinks(self, system, q, v):
        """With x = σ(ℓ − ℓ₀):

        * x [m]: slack/taut (open/closed); the stiffness jumps from 0 to k there, and a
          damped member's force jumps by c σℓ̇ when it engages;
        * k x + c σℓ̇ [N] while x > 0, else k x: the force limit of the damper (a taut
          member retracting fast reaches zero force before x does, and stays at zero).
        """
        x, x_dot = jax.jvp(lambda qq: self.sense * (self.length(system, qq) - self.rest_length), (q,), (v,))
        return one_sided_kinks(x, x_dot, self.stiffness, self.damping)


class TensionOnlySpringDamper(AbstractOneSidedSpringDamper):
    """A rope, dropper or hanger: resists extension only (σ = +1,
    :class:`AbstractOneSidedSpringDamper`)."""

    sense: ClassVar[float] = 1.0


class CompressionOnlySpringDamper(AbstractOneSidedSpringDamper):
    """A stop or buffer: resists shortening only (σ = −1,
    :class:`AbstractOneSidedSpringDamper`)."""

    sense: ClassVar[float] = -1.0


def kink_values(system, q, v):
    """Values whose zero crossings are the kinks of the force laws of ``system``, shape
    (k,), or None when the system has none: the :meth:`AbstractKinkedForce.kinks` of
    its kinked force elements (one-sided spring-dampers, unilateral contacts), then of
    its kinked reaction-dependent forces (friction reversals).

    Fixed steps are split at their crossings by ``locate_crossings``
    (:mod:`ancf_jax.integrate`)."""
    members = _kinked(system)
    if not members:
        return None
    return jnp.concatenate([f.kinks(system, q, v) for f in members])


def node_crossing_values(system, q, v, t):
    """The :meth:`AbstractNodeCrossing.node_crossings` of the force elements of
    ``system`` at time t [s], concatenated, shape (k,), or None when it has none."""
    members = _crossing_points(system)
    if not members:
        return None
    return jnp.concatenate([f.node_crossings(system, q, v, t) for f in members])


def _crossing_points(system) -> list:
    return [f for f in system.forces if isinstance(f, AbstractNodeCrossing)]


def has_node_crossings(system) -> bool:
    """Whether ``system`` has force elements with moving points (static)."""
    return bool(_crossing_points(system))


def _kinked(system) -> list:
    return [f for f in tuple(system.forces) + tuple(system.reaction_forces) if isinstance(f, AbstractKinked)]


def has_kinks(system) -> bool:
    """Whether ``system`` has force laws with kinks (static)."""
    return bool(_kinked(system))


# ---------------------------------------------------------------------- sets of force elements
class AbstractForceSet(AbstractForce):
    """m force elements of one law evaluated together (vectorized over the members,
    jax-md style): one gather of the members' coordinates, the law mapped over them,
    one scatter-add. Each member acts on k coordinates (:meth:`member_coordinates`);
    its Newton matrix is one local (k, k) matrix per member (:meth:`member_tangents`),
    which :func:`ancf_jax.dae.iteration_matrix` adds into the chain where every member
    lies in two neighbouring chain blocks (a catenary's droppers). Cost and compiled
    size O(n + m k²), where m separate elements cost O(m n) and m traced copies.

    ``names`` are the members' names (outputs: :meth:`~ancf_jax.results.Results.member`)."""

    names: eqx.AbstractVar[tuple]

    @abc.abstractmethod
    def member_coordinates(self, system, q, t):
        """Indices in q of each member's coordinates, int array (m, k)."""

    @abc.abstractmethod
    def member_tangents(self, system, q, v, t, damping_coef, load_factor=1.0):
        """``(idx (m, k), A (m, k, k))``: per member A = −(∂Q/∂q + c_v ∂Q/∂v) over its
        coordinates (as :func:`force_tangent` for one element)."""

    def coordinates(self, system, q, t):
        return jnp.reshape(self.member_coordinates(system, q, t), (-1,))


def spring_law(sense, length, rate, stiffness, damping, rest_length):
    """Member force [N] (positive in tension) and potential [J] of a linear or
    one-sided spring-damper at length ℓ and rate ℓ̇ (the laws of :class:`SpringDamper`
    and :class:`AbstractOneSidedSpringDamper`; ``sense`` 0: both ways, +1: tension
    only, −1: compression only)."""
    if sense == 0:
        x = length - rest_length
        return stiffness * x + damping * rate, 0.5 * stiffness * x * x
    e = jnp.maximum(sense * (length - rest_length), 0.0)
    d = jnp.where(e > 0.0, jnp.maximum(damping * sense * rate, -stiffness * e), 0.0)
    return sense * (stiffness * e + d), 0.5 * stiffness * e * e


def one_sided_kinks(x, x_dot, stiffness, damping):
    """The kinks of a one-sided law at the signed extension x = σ(ℓ − ℓ₀) and its rate:
    x (slack/taut) and the damper's force limit k x + c ẋ while x > 0, shape (2,)
    (:meth:`AbstractOneSidedSpringDamper.kinks`)."""
    return jnp.stack([x, jnp.where(x > 0.0, stiffness * x + damping * x_dot, stiffness * x)])


class NodeSpringSet(AbstractForceSet, AbstractKinkedForce):
    """m spring-dampers, member i between node ``node_a[i]`` of beam ``beam_a`` (or the
    ground point ``ground[i]`` when ``beam_a`` is −1) and node ``node_b[i]`` of beam
    ``beam_b``: linear (``sense`` 0), tension only (+1: droppers, hangers) or
    compression only (−1), each with :func:`spring_law`. Droppers between the
    interleaved wires of a catenary and the support springs of its poles.

    Attributes:
        names: member names (static).
        beam_a, beam_b: beam indices (static; ``beam_a`` −1: ground points).
        node_a, node_b: node indices, shape (m,) (data).
        ground: ground points [m], shape (m, 2) (used when ``beam_a`` is −1).
        stiffness, damping, rest_length: [N/m, N·s/m, m], shape (m,).
        sense: 0, +1 or −1 (static).
    """

    name: str = eqx.field(static=True)
    names: tuple = eqx.field(static=True)
    beam_a: int = eqx.field(static=True)
    beam_b: int = eqx.field(static=True)
    node_a: jnp.ndarray
    node_b: jnp.ndarray
    ground: jnp.ndarray
    stiffness: jnp.ndarray
    damping: jnp.ndarray
    rest_length: jnp.ndarray
    sense: float = eqx.field(static=True, default=0.0)

    def member_coordinates(self, system, q, t=0.0):
        def node_coords(beam, node):
            n = system.beams[beam].n_nodes
            return system.beam_offset(beam) + 4 * jnp.mod(node, n)[:, None] + jnp.arange(4)[None, :]
        b = node_coords(self.beam_b, self.node_b)
        if self.beam_a < 0:
            return b
        return jnp.concatenate([node_coords(self.beam_a, self.node_a), b], axis=1)

    def _length(self, x, ground):
        """Length ℓ [m] of one member from its local coordinates x (k,)."""
        d = (x[0:2] - ground) if self.beam_a < 0 else (x[4:6] - x[0:2])
        return jnp.sqrt(jnp.dot(d, d))

    def _member(self, x, xd, ground, k, c, l0):
        """(force [N], potential [J], generalized force on the member's coordinates (k,))."""
        ell, ell_dot = jax.jvp(lambda xx: self._length(xx, ground), (x,), (xd,))
        grad_ell = jax.grad(self._length)(x, ground)
        force, energy = spring_law(self.sense, ell, ell_dot, k, c, l0)
        return force, energy, -force * grad_ell

    def _mapped(self, system, q, v):
        idx = self.member_coordinates(system, q)
        return idx, jax.vmap(self._member)(q[idx], v[idx], self.ground, self.stiffness, self.damping,
                                           self.rest_length)

    def member_forces(self, system, q, v):
        """Member forces [N] (positive in tension), shape (m,)."""
        return self._mapped(system, q, v)[1][0]

    def member_engaged(self, system, q):
        """Taut (tension only) or closed (compression only) members (always for linear
        ones), shape (m,) bool."""
        idx = self.member_coordinates(system, q)
        ell = jax.vmap(self._length)(q[idx], self.ground)
        return jnp.ones(ell.shape, bool) if self.sense == 0 else self.sense * (ell - self.rest_length) > 0.0

    def potential(self, system, q, t):
        _, (_, energy, _) = self._mapped(system, q, jnp.zeros_like(q))
        return jnp.sum(energy)

    def dissipative_force(self, system, q, v):
        # the member forces less their elastic parts, on the members' coordinates
        idx, (_, _, total) = self._mapped(system, q, v)
        _, (_, _, elastic) = self._mapped(system, q, jnp.zeros_like(v))
        return jnp.zeros_like(q).at[idx].add(total - elastic)

    def applied_force(self, system, q, v, t):
        return jnp.zeros_like(q)

    def member_tangents(self, system, q, v, t, damping_coef, load_factor=1.0):
        idx = self.member_coordinates(system, q)

        def local(x, xd, ground, k, c, l0):
            f = lambda d: self._member(x + d, xd + damping_coef * d, ground, k, c, l0)[2]  # noqa: E731
            return -jax.jacfwd(f)(jnp.zeros_like(x))

        return idx, jax.vmap(local)(q[idx], v[idx], self.ground, self.stiffness, self.damping, self.rest_length)

    def kinks(self, system, q, v):
        """Per one-sided member the kinks of :meth:`AbstractOneSidedSpringDamper.kinks`
        (slack/taut and the damper's force limit), shape (2m,); none for linear ones."""
        if self.sense == 0:
            return jnp.zeros((0,), q.dtype)
        idx = self.member_coordinates(system, q)

        def one(x, xd, ground, k, c, l0):
            e, e_dot = jax.jvp(lambda xx: self.sense * (self._length(xx, ground) - l0), (x,), (xd,))
            return one_sided_kinks(e, e_dot, k, c)

        return jnp.reshape(jax.vmap(one)(q[idx], v[idx], self.ground, self.stiffness, self.damping,
                                         self.rest_length), (-1,))
