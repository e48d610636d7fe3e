"""Applied forces and force elements (the Q_e of Eq. 10).

Gravity and the elastic and damping forces of beams belong to the system itself
(:mod:`ancf_jax.system`); this module holds the force elements a user adds. Every
element splits into three parts so that the energy balance can be kept:

* ``potential(system, q, t)``: a conservative part, force = −∂V/∂q;
* ``dissipative_force(system, q, v)``: a damping part (its power is dissipation);
* ``applied_force(system, q, v, t)``: prescribed loads (their power is external work).

Point forces map to generalized forces through the point's Jacobian by one
vector-Jacobian product, Q = J_pᵀ F, never a hand-written Jacobian.
"""

from __future__ import annotations

from typing import Callable, Optional

import equinox as eqx
import jax
import jax.numpy as jnp

from .points import AbstractPoint


def point_load(system, point: AbstractPoint, q, force):
    """Generalized force J_p(q)ᵀ F of a force F [N] acting at a point, shape (n,)."""
    _, vjp = jax.vjp(lambda qq: point.position(system, qq), q)
    return vjp(force)[0]


class AbstractForce(eqx.Module):
    """A force element (see the module docstring for its three parts)."""

    name: str = eqx.field(static=True)

    def potential(self, system, q, t):
        """Potential energy V [J] of the conservative part."""
        return jnp.zeros(())

    def dissipative_force(self, system, q, v):
        """Generalized damping force, shape (n,)."""
        return jnp.zeros_like(q)

    def applied_force(self, system, q, v, t):
        """Generalized prescribed load, shape (n,)."""
        return jnp.zeros_like(q)


class PointForce(AbstractForce):
    """A force F·f(t) [N] at a point, fixed in direction (not a follower load).

    ``time_function`` (a JAX-traceable t ↦ scalar) scales ``force``; None: constant.
    """

    point: AbstractPoint
    force: jnp.ndarray
    time_function: Optional[Callable] = eqx.field(static=True, default=None)

    def applied_force(self, system, q, v, t):
        f = self.force if self.time_function is None else self.force * self.time_function(t)
        return point_load(system, self.point, q, f)


class PointTorque(AbstractForce):
    """A torque τ·f(t) [N·m] on rigid body ``body`` (index)."""

    body: int = eqx.field(static=True)
    torque: jnp.ndarray
    time_function: Optional[Callable] = eqx.field(static=True, default=None)

    def applied_force(self, system, q, v, t):
        tau = self.torque if self.time_function is None else self.torque * self.time_function(t)
        return jnp.zeros_like(q).at[system.body_offset(self.body) + 2].add(tau)


class SpringDamper(AbstractForce):
    """Linear spring-damper between two points: tension k (ℓ − ℓ₀) + c ℓ̇ [N].

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

    def potential(self, system, q, t):
        return 0.5 * self.stiffness * (self.length(system, q) - self.rest_length) ** 2

    def dissipative_force(self, system, q, v):
        ell_dot = jax.jvp(lambda qq: self.length(system, qq), (q,), (v,))[1]
        _, vjp = jax.vjp(lambda qq: self.length(system, qq), q)
        return vjp(-self.damping * ell_dot)[0]
