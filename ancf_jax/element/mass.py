"""Consistent mass matrix and gravity load of the planar ANCF element (paper Eqs. 5–6)."""

from __future__ import annotations

import jax.numpy as jnp


def mass_matrix(length, mass_per_length):
    """Consistent element mass matrix M = ρA ∫₀ˡ Sᵀ S dx (Eq. 6), closed form.

    The Hermite integrals are the classical (ρA l / 420) table; the 2-D interpolation
    of Eq. 2 repeats them for x and y (Kronecker product with I₂).

    Args:
        length: element length l [m].
        mass_per_length: ρA [kg/m].

    Returns:
        (8, 8) symmetric positive definite matrix [kg, kg·m, kg·m²].
    """
    l = length
    h = jnp.array([
        [156.0, 22.0 * l, 54.0, -13.0 * l],
        [22.0 * l, 4.0 * l * l, 13.0 * l, -3.0 * l * l],
        [54.0, 13.0 * l, 156.0, -22.0 * l],
        [-13.0 * l, -3.0 * l * l, -22.0 * l, 4.0 * l * l],
    ])
    return jnp.kron(mass_per_length * l / 420.0 * h, jnp.eye(2))


def gravity_load(length, mass_per_length, gravity):
    """Consistent element load of a uniform body force: ρA ∫₀ˡ Sᵀ g dx.

    Args:
        length: element length l [m].
        mass_per_length: ρA [kg/m].
        gravity: acceleration vector g [m/s²], shape (2,).

    Returns:
        (8,) generalized force [N, N·m].
    """
    l = length
    s = mass_per_length * l * jnp.array([0.5, l / 12.0, 0.5, -l / 12.0])
    return jnp.kron(s, jnp.asarray(gravity))
