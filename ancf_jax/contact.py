"""Moving loads and unilateral moving contact on beams (the moving-load problem and its
contact version: a vehicle crossing a bridge, a trolley on a track rope, a pantograph
under a contact wire).

Where on a beam. A moving load acts at the material point under a prescribed position,
either at the reference arc length s(t) (:class:`AtArcLength`) or at the point whose
current horizontal coordinate is x(t) (:class:`AtHorizontalPosition`: a vehicle moving at
speed v along a track is at x = v t, not at arc length v t). The positions are
:class:`~ancf_jax.functions.AbstractPath` objects, whose parameters (e.g. the speed of
:class:`~ancf_jax.functions.ConstantSpeed`) are data: runs are differentiable with
respect to them.

Searches on the deformed beam (traced, differentiable, bounded iteration counts, so a
point crosses nodes without re-tracing; optimistix's Newton root finder, differentiated
implicitly):

* :func:`arc_length_under`: s with r_x(s) = x. The node interval holding x is found
  from the nodes' x (the beam's x must be monotonic along s over its active nodes,
  as a track, rope or wire is), then Newton's method on r_x(s) − x from the linear
  interpolation in that interval (at most :data:`SEARCH_ITERATIONS` steps);
* :func:`closest_arc_length`: the closest point of the beam to a point p, the root of
  f(s) = r'(s)·(r(s) − p) by Newton's method (f' = r''·(r − p) + r'·r') started from
  the point under p. At the closest point the gap's derivative along s vanishes, so a
  contact force derived from the gap by autodiff acts along the beam's normal.

Force elements:

* :class:`MovingForce`: a point force F f(t) [N] at the moving material point, zero
  while the point is off the beam (a load entering at one end and leaving at the
  other). Q = S(s)ᵀ F (the material point's virtual displacement), with ∂s/∂q of the
  horizontal search in its Newton-matrix linearization.
* :class:`UnilateralContact`: a penalty contact between a point (e.g. the head of a
  pantograph) and a beam at its closest point: gap g = σ n̂·(p − r(s*)) − g₀ [m]
  (n̂ the beam's left unit normal, σ = ``side``: +1 if the point is on the side of n̂,
  −1 if on the other; g₀ an offset, e.g. the radii), penetration δ = −g, and the
  normal force [N]

      F_n = k δ + d,   d = max(c δ̇, −k δ)   while δ > 0,   F_n = 0 otherwise,

  so the contact never pulls (the damper is limited as in
  :class:`~ancf_jax.forces.AbstractOneSidedSpringDamper`). Parts: potential ½ k δ₊²,
  dissipation d δ̇ ≥ 0. Its kinks (contact closing, the force reaching zero) are
  located in time by ``locate_crossings`` (:class:`~ancf_jax.forces.AbstractKinkedForce`).
  No contact while the closest point is beyond an end of the beam. Optional friction
  along the beam (:class:`ContactFriction`): the regularized Coulomb law of sliding
  joints, −μ F_n tanh(u/v_ε) − c u, u the point's speed relative to the beam's
  material point under it.

Both name the node crossings of their point (:func:`node_crossing_value`,
:class:`~ancf_jax.forces.AbstractNodeCrossing`), located only with
``RunOptions(locate_load_nodes=True)``: the forces are C¹ in time there, and locating
them changes a run's error by under 1 % (docs/moving-loads.md).

A moving *mass* is a point mass on a sliding joint whose arc length or horizontal
position is prescribed (:meth:`ancf_jax.model.Model.moving_mass`): the sliding joint
carries its inertia, with the convective terms of the moving point, exactly.
"""

from __future__ import annotations

import abc
from typing import Callable, Optional

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx

from .forces import AbstractKinkedForce, AbstractLoad, AbstractNodeCrossing, point_load
from .functions import AbstractPath
from .element.shape_functions import shape_functions, shape_functions_dx
from .points import AbstractPoint, BeamPoint, element_coordinates
from .sliding import regularized_coulomb, reversal_kink

#: most Newton steps of the searches on the deformed beam (from the linear interpolation
#: in the node interval: the residual falls below 1e-14 m after 3 on the tests' wires)
SEARCH_ITERATIONS = 4

#: a search stops earlier once its Newton step and residual are below this [m]
SEARCH_TOLERANCE = 1e-14


def _node_interval(system, beam: int, q, x):
    """(element coordinates (8,) as (4, 2), element length, arc length of its first node,
    local arc length): the element whose nodes' x bracket x (clamped to the active
    elements) and the linear interpolation in it."""
    b = system.beams[beam]
    nodes = system.beam_nodes(q, beam)
    n = b.mesh.n_elements
    xs = nodes[:, 0]
    sense = jnp.sign(xs[n] - xs[0])
    behind = b.mesh.active_nodes & (sense * xs <= sense * x)
    k = jnp.clip(jnp.sum(behind) - 1, 0, n - 1)
    x0, x1 = xs[k], xs[k + 1]
    length = b.mesh.element_lengths[k]
    frac = jnp.clip((x - x0) / (x1 - x0), 0.0, 1.0)
    e = jnp.reshape(jnp.concatenate([nodes[k], nodes[k + 1]]), (4, 2))
    return e, length, b.mesh.node_arc_lengths[k], frac * length


def _under_residual(e, x, length, u):
    """r_x(u) − x in the element."""
    return shape_functions(u, length) @ e[:, 0] - x


def _closest_residual(e, p, length, u):
    """f(u) = r'(u)·(r(u) − p) in the element."""
    return jnp.dot(shape_functions_dx(u, length) @ e, shape_functions(u, length) @ e - p)


class _Residual(eqx.Module):
    """``residual(e, p, l, u)`` as optimistix's ``fn(u, args)``."""

    residual: Callable

    def __call__(self, u, args):
        return self.residual(*args, u)


def _implicit_root(residual):
    """Newton's method on ``residual(e, p, l, u) = 0`` for u from u₀ (optimistix's
    :class:`optimistix.Newton`, at most :data:`SEARCH_ITERATIONS` steps), differentiated
    by the implicit function theorem (:class:`optimistix.ImplicitAdjoint`:
    du = −∂f/∂(e, p, l)·d(e, p, l) / ∂f/∂u; the start u₀ carries no derivative), so
    derivatives of any order do not pass through the iterations."""
    fn = _Residual(residual)

    def root(e, p, length, u0):
        solution = optx.root_find(fn, optx.Newton(rtol=0.0, atol=SEARCH_TOLERANCE), u0, args=(e, p, length),
                                  adjoint=optx.ImplicitAdjoint(), max_steps=SEARCH_ITERATIONS, throw=False)
        return solution.value

    return root


_under_root = _implicit_root(_under_residual)
_closest_root = _implicit_root(_closest_residual)


def arc_length_under(system, beam: int, q, x):
    """Reference arc length s [m] of the point of beam ``beam`` whose current
    horizontal coordinate is x [m] (module docstring), and whether x lies between the
    beam's end points. Newton's method within the element whose nodes bracket x (a
    monotonic cubic there holds the root). Differentiable in q and x."""
    e, length, s_k, u0 = _node_interval(system, beam, q, x)
    u = jnp.clip(_under_root(e, x, length, jax.lax.stop_gradient(u0)), 0.0, length)
    nodes = system.beam_nodes(q, beam)
    xs, n = nodes[:, 0], system.beams[beam].mesh.n_elements
    inside = (jnp.minimum(xs[0], xs[n]) <= x) & (x <= jnp.maximum(xs[0], xs[n]))
    return s_k + u, inside


def _closest(system, beam: int, q, p):
    """(s*, on the beam, element coordinates (4, 2), local arc length, element length,
    s* before clamping to the element)."""
    e, length, s_k, u0 = _node_interval(system, beam, q, p[0])
    u = _closest_root(e, p, length, jax.lax.stop_gradient(u0))
    total = system.beams[beam].mesh.length
    on = (s_k + u >= 0.0) & (s_k + u <= total)
    raw = s_k + u
    u = jnp.clip(u, 0.0, length)
    return s_k + u, on, e, u, length, raw


def _left_normal(e, u, length):
    """The beam's unit left normal n̂ at local arc length u of the element with
    coordinates e (4, 2)."""
    r1 = shape_functions_dx(u, length) @ e
    return jnp.stack([-r1[1], r1[0]]) / jnp.linalg.norm(r1)


def node_crossing_value(mesh, s):
    """(−1)ᵏ f (1 − f) with ξ = k + f the global element coordinate of the reference arc
    length s [m] (k the element holding s, f = (s − s_k)/l_k ∈ [0, 1); beyond the ends
    the end elements extended, :meth:`~ancf_jax.mesh.BeamMesh.locate`), ξ clamped to
    [½, n − ½] (n active elements). Continuous in s, exactly zero at the interior nodes
    (ξ = 1 … n − 1), of one sign within each element and alternating from element to
    element: its zero crossings are the node crossings of a point moving along the
    beam. Constant within ½ element of the ends and beyond them: a point's entry or
    exit, where a moving force jumps, is no crossing (located, such a jump stays
    inside a substep, and the error of the run grows: docs/moving-loads.md)."""
    k, x = mesh.locate(s)
    xi = jnp.clip(k + x / mesh.element_lengths[k], 0.5, mesh.n_elements - 0.5)
    j = jnp.floor(xi)
    f = xi - j
    return jnp.where(jnp.mod(j, 2.0) == 0.0, 1.0, -1.0) * f * (1.0 - f)


def closest_arc_length(system, beam: int, q, p):
    """Reference arc length s* [m] of the point of beam ``beam`` closest to p [m]
    (module docstring), and whether it lies on the beam (0 ≤ s* ≤ L). The search runs
    in the element under p (:func:`arc_length_under`'s interval): a closest point
    beyond that element's nodes is taken at the node, which differs from the true one
    by the change of slope across the node times the gap (zero for a point in
    contact). Differentiable in q and p."""
    return _closest(system, beam, q, p)[:2]


class AbstractMovingLocation(eqx.Module):
    """Where on a beam a moving load acts at time t (module docstring)."""

    path: eqx.AbstractVar[AbstractPath]

    @abc.abstractmethod
    def locate(self, system, beam: int, q, t):
        """(s [m], on_beam): the reference arc length of the loaded material point
        (clamped to [0, L]) and whether the load is on the beam."""


class AtArcLength(AbstractMovingLocation):
    """The material point at reference arc length s = ``path(t)`` [m]."""

    path: AbstractPath

    def locate(self, system, beam: int, q, t):
        s = self.path(t)
        length = system.beams[beam].mesh.length
        return jnp.clip(s, 0.0, length), (s >= 0.0) & (s <= length)


class AtHorizontalPosition(AbstractMovingLocation):
    """The material point whose current horizontal coordinate is x = ``path(t)`` [m]
    (:func:`arc_length_under`)."""

    path: AbstractPath

    def locate(self, system, beam: int, q, t):
        return arc_length_under(system, beam, q, self.path(t))


class MovingForce(AbstractLoad, AbstractNodeCrossing):
    """A point force F·f(t) [N] (fixed direction) at a moving material point of beam
    ``beam`` (module docstring); zero while the point is off the beam.

    Attributes:
        beam: beam index (static).
        location: :class:`AtArcLength` or :class:`AtHorizontalPosition`.
        force: F [N], shape (2,).
        time_function: optional JAX-traceable scale t ↦ f(t) (static); None: 1.
    """

    beam: int = eqx.field(static=True)
    location: AbstractMovingLocation
    force: jnp.ndarray
    time_function: Optional[Callable] = eqx.field(static=True, default=None)

    def load_point(self, system, q, t):
        """(s [m], position (2,) [m], on_beam) of the loaded material point."""
        s, on = self.location.locate(system, self.beam, q, t)
        return s, system.beams[self.beam].position(system.beam_nodes(q, self.beam), s), on

    def applied_force(self, system, q, v, t):
        s, on = self.location.locate(system, self.beam, q, t)
        f = self.force if self.time_function is None else self.force * self.time_function(t)
        return point_load(system, BeamPoint(self.beam, s), q, jnp.where(on, f, 0.0))

    def coordinates(self, system, q, t):
        s, _ = self.location.locate(system, self.beam, q, t)
        return element_coordinates(system, self.beam, s)

    def node_crossings(self, system, q, v, t):
        """:func:`node_crossing_value` of the loaded point, shape (1,): zero at the
        interior nodes, where the generalized force S(s)ᵀF is C¹ in time (the second
        derivative of the shape functions jumps)."""
        s, _ = self.location.locate(system, self.beam, q, t)
        return jnp.reshape(node_crossing_value(system.beams[self.beam].mesh, s), (1,))


class ContactFriction(eqx.Module):
    """Regularized Coulomb friction at a :class:`UnilateralContact` (the law of sliding
    joints, :func:`~ancf_jax.sliding.regularized_coulomb`):

        F_t = −μ F_n tanh(u / v_ε) − c u  [N]   on the point along t̂, −F_t t̂ on the beam,

    F_n the contact's normal force, t̂ = r′(s*)/|r′(s*)| the beam's unit tangent at the
    contact point and u = t̂·(ṗ − ṙ(s*)) [m/s] the sliding speed of the point relative
    to the beam's material point under it (ṙ at fixed s*). Zero while the contact is
    open (penetration δ <= 0), the viscous part too. Its power F_t u <= 0 is
    dissipation.

    Attributes:
        mu: friction coefficient μ >= 0.
        regularization: v_ε [m/s] > 0 (a point held by friction creeps at
            v_ε artanh(F/(μ F_n)) under a tangential load F < μ F_n).
        viscous: c [N·s/m] >= 0.
    """

    mu: jnp.ndarray
    regularization: jnp.ndarray
    viscous: jnp.ndarray


class UnilateralContact(AbstractKinkedForce, AbstractNodeCrossing):
    """Penalty contact between ``point`` and beam ``beam`` at the closest point
    (module docstring).

    Attributes:
        point: the contacting point (a body point, a node of another beam...).
        beam: beam index (static).
        side: σ = +1 if the point is on the side of the beam's left normal n̂ (above a
            beam running in +x), −1 if on the other side (static).
        stiffness: k [N/m] > 0.
        damping: c [N·s/m] >= 0.
        offset: g₀ [m]: the gap at which contact begins (radii of wire and shoe).
        friction: :class:`ContactFriction`, or None: frictionless.
    """

    point: AbstractPoint
    beam: int = eqx.field(static=True)
    side: float = eqx.field(static=True)
    stiffness: jnp.ndarray
    damping: jnp.ndarray
    offset: jnp.ndarray
    friction: Optional[ContactFriction] = None

    def contact_point(self, system, q):
        """(s* [m], on_beam): the closest point of the beam to the contacting point."""
        return closest_arc_length(system, self.beam, q, self.point.position(system, q))

    def _gaps(self, system, q):
        """(g, on the beam, s* before clamping): the gap g = σ n̂·(p − r(s*)) − g₀ [m]
        (negative: penetration) at the closest point, whether or not it is on the
        beam."""
        p = self.point.position(system, q)
        _, on, e, u, length, raw = _closest(system, self.beam, q, p)
        n = _left_normal(e, u, length)
        return self.side * jnp.dot(n, p - shape_functions(u, length) @ e) - self.offset, on, raw

    def unit_normal_load(self, system, q):
        """Generalized force of a unit force σ n̂ [N] on the beam's material point at the
        closest point s* (the force the contact's point would exert on the beam pushed
        into it), shape (n,): the load of :func:`ancf_jax.modal.contact_point_stiffness`."""
        s, _, e, u, length, _ = _closest(system, self.beam, q, self.point.position(system, q))
        return -point_load(system, BeamPoint(self.beam, s), q, self.side * _left_normal(e, u, length))

    def gap(self, system, q):
        """g = σ n̂·(p − r(s*)) − g₀ [m] (negative: penetration), whether or not s* is
        on the beam."""
        return self._gaps(system, q)[0]

    def _penetration(self, system, q):
        """δ = −g while the closest point is on the beam, else −1 m (open)."""
        g, on, _ = self._gaps(system, q)
        return jnp.where(on, -g, -1.0)

    def _state(self, system, q, v):
        """(δ, ∂δ/∂q, δ̇, d): penetration, its gradient and rate, limited damper force."""
        delta, grad = jax.value_and_grad(lambda qq: self._penetration(system, qq))(q)
        rate = jnp.dot(grad, v)
        e = jnp.maximum(delta, 0.0)
        d = jnp.where(e > 0.0, jnp.maximum(self.damping * rate, -self.stiffness * e), 0.0)
        return delta, grad, rate, d

    def normal_force(self, system, q, v):
        """F_n [N] >= 0 (class and module docstrings)."""
        delta, _, _, d = self._state(system, q, v)
        return self.stiffness * jnp.maximum(delta, 0.0) + d

    def engaged(self, system, q):
        """Whether the contact is closed (δ > 0)."""
        return self._penetration(system, q) > 0.0

    def potential(self, system, q, t):
        return 0.5 * self.stiffness * jnp.maximum(self._penetration(system, q), 0.0) ** 2

    def applied_force(self, system, q, v, t):
        return jnp.zeros_like(q)

    def _slip(self, system, q, v):
        """(u [m/s], t̂ (2,), relative position p(q′) − r(q′; s*) as a function of q′ with
        s* = s*(q) held): the sliding speed and tangent of :class:`ContactFriction`."""
        p = self.point.position(system, q)
        s, _, e, u, length, _ = _closest(system, self.beam, q, p)
        r1 = shape_functions_dx(u, length) @ e
        tangent = r1 / jnp.linalg.norm(r1)
        beam = system.beams[self.beam]

        def relative(qq):
            return self.point.position(system, qq) - beam.position(system.beam_nodes(qq, self.beam), s)

        _, rate = jax.jvp(relative, (q,), (v,))
        return jnp.dot(tangent, rate), tangent, relative

    def tangential_force(self, system, q, v):
        """F_t [N] on the point along the beam's unit tangent t̂ (its reaction on the
        beam), :class:`ContactFriction`; 0 without friction."""
        if self.friction is None:
            return jnp.zeros(())
        u, _, _ = self._slip(system, q, v)
        return self._friction_law(self._penetration(system, q), self.normal_force(system, q, v), u)

    def _friction_law(self, delta, normal, u):
        """F_t [N] of :class:`ContactFriction` at penetration δ, normal force F_n and
        sliding speed u; zero while the contact is open (δ <= 0), viscous part
        included."""
        f = self.friction
        return jnp.where(delta > 0.0, regularized_coulomb(normal, u, f.mu, f.regularization, f.viscous), 0.0)

    def dissipative_force(self, system, q, v):
        delta, grad, _, d = self._state(system, q, v)
        out = -d * grad
        if self.friction is not None:
            u, tangent, relative = self._slip(system, q, v)
            force = self._friction_law(delta, self.stiffness * jnp.maximum(delta, 0.0) + d, u)
            _, vjp = jax.vjp(relative, q)
            out = out + vjp(force * tangent)[0]
        return out

    def coordinates(self, system, q, t):
        s, _ = self.contact_point(system, q)
        return jnp.concatenate([self.point.coordinates(system, q), element_coordinates(system, self.beam, s)])

    def kinks(self, system, q, v):
        """δ [m] (contact closing or opening; the stiffness jumps from 0 to k, a damped
        contact's force by c δ̇) and k δ + c δ̇ [N] while δ > 0 (the force reaching
        zero: the damper's limit), else k δ; with friction, the reversal of the sliding
        speed u while closed (:func:`~ancf_jax.sliding.reversal_kink`), else 0."""
        delta, _, rate, _ = self._state(system, q, v)
        values = [delta, jnp.where(delta > 0.0, self.stiffness * delta + self.damping * rate, self.stiffness * delta)]
        if self.friction is not None:
            # the reversal of the sliding speed while in contact (friction's near-jump)
            u, _, _ = self._slip(system, q, v)
            values.append(jnp.where(delta > 0.0, reversal_kink(u, self.friction.regularization), 0.0))
        return jnp.stack(values)

    def node_crossings(self, system, q, v, t):
        """Node crossings of the contact point while the contact is closed, shape (1,):
        :func:`node_crossing_value` of s* (before clamping to the beam) times
        max(δ, 0) [m], zero (no crossing) while the contact is open and carries no
        force. The force is C¹ in s*; the beam's curvature, so the contact's
        stiffness along the beam, jumps at the nodes."""
        g, on, raw = self._gaps(system, q)
        delta = jnp.where(on, -g, -1.0)
        return jnp.reshape(node_crossing_value(system.beams[self.beam].mesh, raw) * jnp.maximum(delta, 0.0), (1,))
