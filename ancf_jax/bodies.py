"""Rigid bodies: planar coordinates (x, y, θ) and inertia diag(m, m, J) (paper Eq. 14)."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp

from ._products import matvec


def rotation(theta):
    """Planar rotation matrix A(θ) of a body frame (paper Eq. 19), shape (2, 2)."""
    c, s = jnp.cos(theta), jnp.sin(theta)
    return jnp.array([[c, -s], [s, c]])


def body_point(pose, local):
    """Global position r_c + A(θ) s of a point fixed in a body [m].

    Args:
        pose: (x, y, θ) [m, m, rad], shape (3,).
        local: the point in the body frame [m], shape (2,).
    """
    return pose[:2] + matvec(rotation(pose[2]), local)


class RigidBodies(eqx.Module):
    """Mass properties of all rigid bodies.

    Attributes:
        mass: m [kg], shape (n_bodies,).
        inertia: J about the centre of mass [kg·m²], shape (n_bodies,).
    """

    mass: jnp.ndarray
    inertia: jnp.ndarray

    @property
    def count(self) -> int:
        return self.mass.shape[-1]

    def mass_diagonal(self):
        """Diagonal of the rigid-body mass matrix M^r = diag(m, m, J) per body, shape (3 n,)."""
        return jnp.reshape(jnp.stack([self.mass, self.mass, self.inertia], axis=-1), (-1,))
