"""Shape functions of the planar ANCF beam element (paper Eqs. 1–4).

An element has 8 absolute nodal coordinates (Eq. 3)

    e = [r_x(0), r_y(0), r_x'(0), r_y'(0), r_x(l), r_y(l), r_x'(l), r_y'(l)]

(positions and global slopes ∂r/∂x of its two nodes, Eq. 4) and the position of the
point at the reference arc length x ∈ [0, l] is r(x) = S(x) e (Eq. 1) with the cubic
Hermite functions S1…S4 of Eq. 2. Derivatives with respect to x come from automatic
differentiation of :func:`shape_functions`, so there is one definition of the
interpolation.

Units: x and l in metres; positions in metres; slopes dimensionless.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def shape_functions(x, length):
    """The four scalar shape functions (S1, S2, S3, S4) of Eq. 2 at x ∈ [0, l].

    Args:
        x: reference arc length within the element [m], scalar.
        length: reference element length l [m], scalar.

    Returns:
        Array of shape (4,).
    """
    xi = x / length
    xi2 = xi * xi
    xi3 = xi2 * xi
    return jnp.stack([
        1.0 - 3.0 * xi2 + 2.0 * xi3,
        length * (xi - 2.0 * xi2 + xi3),
        3.0 * xi2 - 2.0 * xi3,
        length * (xi3 - xi2),
    ])


_dx = jax.jacfwd(shape_functions, argnums=0)
_dxx = jax.jacfwd(_dx, argnums=0)


def shape_functions_dx(x, length):
    """dS/dx at x, shape (4,) [1/m relative to :func:`shape_functions`] (autodiff of Eq. 2)."""
    return _dx(jnp.asarray(x, float), length)


def shape_functions_dxx(x, length):
    """d²S/dx² at x, shape (4,) (autodiff of Eq. 2)."""
    return _dxx(jnp.asarray(x, float), length)


def shape_matrix(x, length):
    """The 2×8 shape-function matrix S(x) of Eq. 2, so that r(x) = S(x) e."""
    s = shape_functions(x, length)
    return jnp.kron(s[None, :], jnp.eye(2))


def _interpolate(weights, e):
    return weights @ jnp.reshape(e, (4, 2))


def position(e, x, length):
    """Position r(x) = S(x) e [m], shape (2,) (Eq. 1)."""
    return _interpolate(shape_functions(x, length), e)


def slope(e, x, length):
    """Slope r'(x) = ∂r/∂x, shape (2,) (dimensionless)."""
    return _interpolate(shape_functions_dx(x, length), e)


def slope_derivative(e, x, length):
    """Second derivative r''(x) = ∂²r/∂x², shape (2,) [1/m]."""
    return _interpolate(shape_functions_dxx(x, length), e)
