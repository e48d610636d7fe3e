"""Constraints (joints), each written once as a residual Φ(q, t) = 0.

The Jacobian Φ_q and the acceleration right-hand side γ of Eq. 12 are computed from
these residuals by automatic differentiation in :mod:`ancf_jax.system`; no joint
carries a hand-derived Jacobian.

Sign convention for reactions: the equations of motion read M q̈ + Φ_qᵀ λ = Q
(Eqs. 10, 14, 21), so the constraint force on the coordinates is −Φ_qᵀ λ.
"""

from __future__ import annotations

from typing import Callable, ClassVar

import abc
import dataclasses

import equinox as eqx
import jax.numpy as jnp

from ._products import matvec
from .bodies import rotation
from .element.strain_energy import cross2
from .functions import AbstractPath
from .points import AbstractPoint, BeamNode, BodyPoint


class AbstractConstraint(eqx.Module):
    """A joint: ``size`` scalar equations Φ(q, t) = 0 with a name for messages.

    Linearity in the beam coordinates. The Newton matrix of implicit integrators and
    statics (:func:`ancf_jax.dae.iteration_matrix`) holds the constraint Hessian
    (λ·Φ)_qq only in the rows and columns of the few border coordinates (bodies,
    sliding coordinates): its block between beam coordinates is zero when Φ is linear
    in them, as the joints here are (positions S(ξ) e and slopes S'(ξ) e of beam points
    at fixed ξ). A joint declares this by ``linear_in_beam_coordinates = True`` on its
    class, and its points by the same flag on theirs
    (:class:`ancf_jax.points.AbstractPoint`); for a joint that
    does not (the default of a user's joint class: a joint between rigid bodies, for
    which the matrix is exact, or a distance |r_a − r_b| − ℓ between beam points, for
    which it is not) the Newton matrix warns, naming it
    (:class:`~ancf_jax.errors.InexactNewtonMatrixWarning`; :func:`linear_in_beam_coordinates`).
    """

    name: str = eqx.field(static=True)

    @property
    @abc.abstractmethod
    def size(self) -> int:
        """Number of scalar equations (a class constant, or a property of the joint)."""

    @abc.abstractmethod
    def residual(self, system, q, t):
        """Φ(q, t), shape (size,)."""

    def equation_labels(self) -> tuple[str, ...]:
        """One label per equation, ``name[i]``, for messages and output files."""
        return tuple(f"{self.name}[{i}]" for i in range(self.size))


def nonlinear_joints(system) -> tuple:
    """The joints of ``system`` not declared linear in the beam coordinates
    (:func:`linear_in_beam_coordinates`): the Newton matrix leaves out their chain–chain
    Hessian."""
    return tuple(c for c in system.constraints if not linear_in_beam_coordinates(c))


def linear_in_beam_coordinates(constraint: AbstractConstraint) -> bool:
    """Whether Φ of ``constraint`` is declared linear in the beam coordinates: its class
    and the classes of all its points say so (:class:`AbstractConstraint`)."""
    points = [getattr(constraint, f.name) for f in dataclasses.fields(constraint)]
    points = [p for p in points if isinstance(p, AbstractPoint)]
    # the flag is read from the class, False where a class does not set it (the bases do
    # not declare it: a concrete class attribute there would be overridden by every joint)
    return getattr(constraint, "linear_in_beam_coordinates", False) and all(
        getattr(p, "linear_in_beam_coordinates", False) for p in points)


class Coincident(AbstractConstraint):
    """Two points coincide: r_a(q) − r_b(q) = 0 (2 equations).

    With a ground point this is a pin (ground revolute); between bodies, beam nodes or
    beam points it is a revolute joint (paper §2.2).
    """

    a: AbstractPoint
    b: AbstractPoint
    size: ClassVar[int] = 2
    linear_in_beam_coordinates: ClassVar[bool] = True

    def residual(self, system, q, t):
        return self.a.position(system, q) - self.b.position(system, q)


class Clamp(AbstractConstraint):
    """Ground clamp of a beam node: position and slope fixed.

    ``mode="full"`` fixes the slope vector r' = t₀ (4 equations, as model M1 specifies);
    ``mode="direction"`` fixes only its direction, t₀ × r' = 0 (3 equations), leaving
    the axial stretch at the node free; ``mode="exudyn"`` fixes the coordinates x, y
    and r'_y at their initial values (3 equations, the clamp of Exudyn's cable examples
    by three coordinate constraints; for a beam along x it is the same constraint
    as ``"direction"``, since t₀ × r' = r'_y there).
    """

    node: BeamNode
    location: jnp.ndarray
    slope: jnp.ndarray
    mode: str = eqx.field(static=True, default="full")
    linear_in_beam_coordinates: ClassVar[bool] = True

    @property
    def size(self):  # type: ignore[override]
        return 4 if self.mode == "full" else 3

    def residual(self, system, q, t):
        r = self.node.position(system, q) - self.location
        d = self.node.direction(system, q)
        if self.mode == "full":
            return jnp.concatenate([r, d - self.slope])
        if self.mode == "exudyn":
            return jnp.concatenate([r, (d[1] - self.slope[1])[None]])
        return jnp.concatenate([r, cross2(self.slope, d)[None]])


class FixedJoint(AbstractConstraint):
    """Rigid connection of a beam node (or a body point) to a rigid body (3 equations).

    The position of ``point`` coincides with the body point ``body_point`` and the
    direction of ``point`` (the beam slope at a node, or a body's x axis) keeps the
    angle it had at assembly in the body frame: (A(θ) u₀) × d(q) = 0, with u₀ the
    direction in the body frame. This is the fixed joint of model M1: the tip body
    rotates with the tip slope.
    """

    point: AbstractPoint
    body_point: BodyPoint
    direction_local: jnp.ndarray
    size: ClassVar[int] = 3
    linear_in_beam_coordinates: ClassVar[bool] = True

    def residual(self, system, q, t):
        r = self.point.position(system, q) - self.body_point.position(system, q)
        theta = system.body_pose(q, self.body_point.body)[2]
        u = matvec(rotation(theta), self.direction_local)
        return jnp.concatenate([r, cross2(u, self.point.direction(system, q))[None]])


class PrescribedCoordinate(AbstractConstraint):
    """A coordinate follows a function of time: q[index] − f(t) = 0 (1 equation).

    ``function`` maps t [s] to the value; it must be traceable by JAX.
    """

    index: int = eqx.field(static=True)
    function: Callable = eqx.field(static=True)
    size: ClassVar[int] = 1
    linear_in_beam_coordinates: ClassVar[bool] = True

    def residual(self, system, q, t):
        return jnp.reshape(q[self.index] - self.function(t), (1,))


class PathCoordinate(AbstractConstraint):
    """A coordinate follows a path whose parameters are data: q[index] − p(t) = 0 (1
    equation), p an :class:`~ancf_jax.functions.AbstractPath` (e.g.
    :class:`~ancf_jax.functions.ConstantSpeed`: a vehicle at x = x₀ + v t), so a run
    can be differentiated with respect to the speed."""

    index: int = eqx.field(static=True)
    path: AbstractPath
    size: ClassVar[int] = 1
    linear_in_beam_coordinates: ClassVar[bool] = True

    def residual(self, system, q, t):
        return jnp.reshape(q[self.index] - self.path(t), (1,))


class FixedCoordinate(AbstractConstraint):
    """One coordinate of q held at a value: q[index] − value = 0 (1 equation), Exudyn's
    ``CoordinateConstraint`` to the ground. ``value`` is array data (it can be batched
    and differentiated); a value that follows a function of time is a
    :class:`PrescribedCoordinate`."""

    index: int = eqx.field(static=True)
    value: jnp.ndarray
    size: ClassVar[int] = 1
    linear_in_beam_coordinates: ClassVar[bool] = True

    def residual(self, system, q, t):
        return jnp.reshape(q[self.index] - self.value, (1,))


class PrescribedPoint(AbstractConstraint):
    """A point follows a path: r(q) − f(t) = 0 (2 equations), f(t) shape (2,) [m]."""

    point: AbstractPoint
    function: Callable = eqx.field(static=True)
    size: ClassVar[int] = 2
    linear_in_beam_coordinates: ClassVar[bool] = True

    def residual(self, system, q, t):
        return self.point.position(system, q) - jnp.reshape(self.function(t), (2,))


class SlidingJoint(AbstractConstraint):
    """Sliding joint (paper §4.1, Eqs. 19–20): a body point stays on a beam centre line.

    Φ = r_beam(s) − (r_c + A(θ) s_p) = 0 (2 equations), with s the sliding coordinate,
    a non-generalized coordinate without mass or force (Eq. 21). s is one global
    reference arc length along the beam; the element and the local coordinate are
    found from it inside traced code (:meth:`ancf_jax.mesh.BeamMesh.locate`), so the
    joint crosses nodes without events and without re-tracing. The reaction force on
    the body is +λ (2-vector).
    """

    beam: int = eqx.field(static=True)
    sliding: int = eqx.field(static=True)
    body_point: BodyPoint
    size: ClassVar[int] = 2
    linear_in_beam_coordinates: ClassVar[bool] = True

    def residual(self, system, q, t):
        s = system.sliding(q, self.sliding)
        r = system.beams[self.beam].position(system.beam_nodes(q, self.beam), s)
        return r - self.body_point.position(system, q)


class SlidingHold(AbstractConstraint):
    """Holds a sliding coordinate at a given arc length: s − s₀ = 0 (1 equation)."""

    sliding: int = eqx.field(static=True)
    value: jnp.ndarray
    size: ClassVar[int] = 1
    linear_in_beam_coordinates: ClassVar[bool] = True

    def residual(self, system, q, t):
        return jnp.reshape(system.sliding(q, self.sliding) - self.value, (1,))
