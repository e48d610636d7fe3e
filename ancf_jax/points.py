"""Points of a system that joints and forces attach to.

A point maps the system coordinates q to a global position r(q, t) [m]; its velocity,
acceleration and Jacobian follow by automatic differentiation. Points of beams are
addressed by node index or by reference arc length; the element containing an arc
length is found inside traced code, so a point can move across nodes.
"""

from __future__ import annotations

import abc
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp

from .bodies import body_point, rotation


class AbstractPoint(eqx.Module):
    """A point with a position r(q) [m], shape (2,).

    ``linear_in_beam_coordinates``: position and direction are linear in the beam
    coordinates (a joint's requirement: :class:`ancf_jax.joints.AbstractConstraint`);
    False unless a class declares it (``linear_in_beam_coordinates: ClassVar[bool] = True``;
    not declared here, so that no class overrides a concrete attribute).
    """

    @abc.abstractmethod
    def position(self, system, q):
        """Position r(q) [m] of the point, shape (2,), for the system coordinates q (n,)."""

    @abc.abstractmethod
    def direction(self, system, q):
        """A material direction attached to the point (body axis or beam slope), shape (2,)."""

    @abc.abstractmethod
    def coordinates(self, system, q):
        """Indices of q that the position and direction of the point depend on, int
        array of fixed length (the Newton matrix of a force element acting at the
        point couples only these; :meth:`ancf_jax.forces.AbstractForce.coordinates`)."""


class GroundPoint(AbstractPoint):
    """A fixed point of the ground."""

    location: jnp.ndarray
    linear_in_beam_coordinates: ClassVar[bool] = True

    def position(self, system, q):
        return self.location

    def direction(self, system, q):
        return jnp.array([1.0, 0.0])

    def coordinates(self, system, q):
        return jnp.zeros((0,), int)


class BodyPoint(AbstractPoint):
    """A point fixed in rigid body ``body`` at ``local`` (body frame) [m]."""

    body: int = eqx.field(static=True)
    local: jnp.ndarray
    linear_in_beam_coordinates: ClassVar[bool] = True

    def position(self, system, q):
        return body_point(system.body_pose(q, self.body), self.local)

    def direction(self, system, q):
        return rotation(system.body_pose(q, self.body)[2])[:, 0]

    def coordinates(self, system, q):
        return system.body_offset(self.body) + jnp.arange(3)


class BeamNode(AbstractPoint):
    """Node ``node`` of beam ``beam`` (node index is data, so it can be batched)."""

    beam: int = eqx.field(static=True)
    node: jnp.ndarray
    linear_in_beam_coordinates: ClassVar[bool] = True

    def position(self, system, q):
        return system.beam_nodes(q, self.beam)[self.node, :2]

    def direction(self, system, q):
        """The nodal slope r' (not normalized)."""
        return system.beam_nodes(q, self.beam)[self.node, 2:]

    def coordinates(self, system, q):
        node = jnp.mod(self.node, system.beams[self.beam].n_nodes)
        return system.beam_offset(self.beam) + 4 * node + jnp.arange(4)


class BeamPoint(AbstractPoint):
    """The material point of beam ``beam`` at fixed reference arc length ``s`` [m]."""

    beam: int = eqx.field(static=True)
    s: jnp.ndarray
    linear_in_beam_coordinates: ClassVar[bool] = True

    def position(self, system, q):
        return system.beams[self.beam].position(system.beam_nodes(q, self.beam), self.s)

    def direction(self, system, q):
        return system.beams[self.beam].slope(system.beam_nodes(q, self.beam), self.s)

    def coordinates(self, system, q):
        return element_coordinates(system, self.beam, self.s)


class SlidingPoint(AbstractPoint):
    """The point of beam ``beam`` at the current sliding coordinate ``sliding`` (Eq. 19)."""

    beam: int = eqx.field(static=True)
    sliding: int = eqx.field(static=True)
    linear_in_beam_coordinates: ClassVar[bool] = True

    def position(self, system, q):
        return system.beams[self.beam].position(system.beam_nodes(q, self.beam),
                                                system.sliding(q, self.sliding))

    def direction(self, system, q):
        return system.beams[self.beam].slope(system.beam_nodes(q, self.beam),
                                             system.sliding(q, self.sliding))

    def coordinates(self, system, q):
        s = system.sliding(q, self.sliding)
        return jnp.concatenate([element_coordinates(system, self.beam, s),
                                jnp.array([system.sliding_offset + self.sliding])])


def element_coordinates(system, beam: int, s):
    """Indices in q of the 8 coordinates of the element of beam ``beam`` that holds
    the arc length s (the nodes k and k + 1 of :meth:`ancf_jax.mesh.BeamMesh.locate`)."""
    k, _ = system.beams[beam].mesh.locate(s)
    return system.beam_offset(beam) + 4 * k + jnp.arange(8)
