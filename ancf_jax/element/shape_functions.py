"""Shape functions of the planar ANCF beam element (paper Eqs. 1–4).

An element has 8 absolute nodal coordinates (Eq. 3)

    e = [r_x(0), r_y(0), r_x'(0), r_y'(0), r_x(l), r_y(l), r_x'(l), r_y'(l)]

(positions and global slopes ∂r/∂x of its two nodes, Eq. 4) and the position of the
point at the reference arc length x ∈ [0, l] is r(x) = S(x) e (Eq. 1) with the cubic
Hermite functions S1…S4 of Eq. 2. In the unit coordinate ξ = x / l,

    S(x) = [N1(ξ), l N2(ξ), N3(ξ), l N4(ξ)]

with N the Hermite polynomials (one coefficient table, :data:`HERMITE`); x-derivatives
are the ξ-derivatives of those polynomials times powers of 1/l. Tables of N, N', N''
at quadrature points are computed once on the host (:func:`hermite_table`), which
keeps traced element code small.

Units: x and l in metres; positions in metres; slopes dimensionless.
"""

from __future__ import annotations

import functools

import jax.numpy as jnp
import numpy as np

from .._products import dot


#: Power-basis coefficients of the cubic Hermite polynomials N1…N4 (rows) in
#: 1, ξ, ξ², ξ³ (columns): the single definition of the interpolation of Eq. 2.
HERMITE = np.array([[1.0, 0.0, -3.0, 2.0],
                    [0.0, 1.0, -2.0, 1.0],
                    [0.0, 0.0, 3.0, -2.0],
                    [0.0, 0.0, -1.0, 1.0]])


@functools.lru_cache(maxsize=None)
def _coefficients(order: int) -> np.ndarray:
    """Coefficients of the ``order``-th ξ-derivative of the Hermite polynomials."""
    c = HERMITE
    for _ in range(order):
        c = np.polynomial.polynomial.polyder(c, axis=1)
        c = np.concatenate([c, np.zeros((4, 4 - c.shape[1]))], axis=1)
    return c


def hermite(xi, order: int = 0):
    """Cubic Hermite polynomials (N1, N2, N3, N4) of ξ ∈ [0, 1], or their
    ``order``-th ξ-derivative, shape (4,)."""
    xi = jnp.asarray(xi, float)
    powers = jnp.stack([jnp.ones_like(xi), xi, xi * xi, xi * xi * xi])
    return jnp.asarray(_coefficients(order)) @ powers


def _scales(length, order):
    """Factors turning ξ-derivatives of N into x-derivatives of S (Eq. 2)."""
    one = jnp.ones_like(length)
    base = jnp.stack([one, length, one, length])
    return base / length**order


def shape_functions(x, length):
    """The four scalar shape functions (S1, S2, S3, S4) of Eq. 2 at x ∈ [0, l], shape (4,).

    Args:
        x: reference arc length within the element [m].
        length: reference element length l [m].
    """
    return hermite(jnp.asarray(x, float) / length, 0) * _scales(length, 0)


def shape_functions_dx(x, length):
    """dS/dx at x, shape (4,)."""
    return hermite(jnp.asarray(x, float) / length, 1) * _scales(length, 1)


def shape_functions_dxx(x, length):
    """d²S/dx² at x, shape (4,)."""
    return hermite(jnp.asarray(x, float) / length, 2) * _scales(length, 2)


@functools.lru_cache(maxsize=None)
def _table(points: tuple, order: int) -> np.ndarray:
    xi = np.asarray(points, float)
    return np.stack([np.ones_like(xi), xi, xi**2, xi**3], axis=1) @ _coefficients(order).T


def hermite_table(points, order: int) -> np.ndarray:
    """N^(order)(ξ) at the given unit-interval points, shape (p, 4), on the host."""
    return _table(tuple(float(p) for p in np.ravel(points)), order)


def interpolate_at(e, points, length, order: int):
    """The ``order``-th x-derivative of r at unit points ξ_k, shape (p, 2).

    Args:
        e: element coordinates, shape (8,).
        points: unit-interval points ξ (host constants, e.g. a quadrature rule).
        length: element length l [m].
        order: 0 (position), 1 (slope r') or 2 (r'').
    """
    weights = jnp.asarray(hermite_table(points, order)) * _scales(length, order)[None, :]
    return dot(weights, jnp.reshape(e, (4, 2)))


def shape_matrix(x, length):
    """The 2×8 shape-function matrix S(x) of Eq. 2, so that r(x) = S(x) e."""
    s = shape_functions(x, length)
    return jnp.kron(s[None, :], jnp.eye(2))


def _interpolate(weights, e):
    return dot(weights, jnp.reshape(e, (4, 2)))


def position(e, x, length):
    """Position r(x) = S(x) e [m], shape (2,) (Eq. 1)."""
    return _interpolate(shape_functions(x, length), e)


def slope(e, x, length):
    """Slope r'(x) = ∂r/∂x, shape (2,) (dimensionless)."""
    return _interpolate(shape_functions_dx(x, length), e)


def slope_derivative(e, x, length):
    """Second derivative r''(x) = ∂²r/∂x², shape (2,) [1/m]."""
    return _interpolate(shape_functions_dxx(x, length), e)
