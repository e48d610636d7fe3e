"""Eqs. 1–4: Hermite interpolation of nodal positions and slopes."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax.element import (position, shape_functions, shape_functions_dx,
                              shape_functions_dxx, shape_matrix, slope, slope_derivative)


@pytest.mark.parametrize("length", [0.05, 1.0, 3.7])
def test_nodal_interpolation(length, rng):
    """Eq. 4: r(0), r'(0), r(l), r'(l) are the nodal coordinates."""
    e = jnp.asarray(rng.normal(size=8))
    np.testing.assert_allclose(position(e, 0.0, length), e[0:2], atol=1e-14)
    np.testing.assert_allclose(slope(e, 0.0, length), e[2:4], atol=1e-13)
    np.testing.assert_allclose(position(e, length, length), e[4:6], atol=1e-13)
    np.testing.assert_allclose(slope(e, length, length), e[6:8], atol=1e-12)


def test_shape_functions_closed_form():
    """Eq. 2 as printed, and the x-derivatives from autodiff."""
    l, x = 0.7, 0.23
    s = np.asarray(shape_functions(x, l))
    expect = [1 - 3 * x**2 / l**2 + 2 * x**3 / l**3, x - 2 * x**2 / l + x**3 / l**2,
              3 * x**2 / l**2 - 2 * x**3 / l**3, -x**2 / l + x**3 / l**2]
    np.testing.assert_allclose(s, expect, rtol=1e-14)
    ds = [-6 * x / l**2 + 6 * x**2 / l**3, 1 - 4 * x / l + 3 * x**2 / l**2,
          6 * x / l**2 - 6 * x**2 / l**3, -2 * x / l + 3 * x**2 / l**2]
    np.testing.assert_allclose(shape_functions_dx(x, l), ds, rtol=1e-13)
    dds = [-6 / l**2 + 12 * x / l**3, -4 / l + 6 * x / l**2, 6 / l**2 - 12 * x / l**3,
           -2 / l + 6 * x / l**2]
    np.testing.assert_allclose(shape_functions_dxx(x, l), dds, rtol=1e-13)


def test_partition_of_unity_and_rigid_translation():
    l = 1.3
    for x in np.linspace(0, l, 7):
        s = shape_functions(x, l)
        assert abs(float(s[0] + s[2]) - 1.0) < 1e-14
    S = shape_matrix(0.4, l)
    assert S.shape == (2, 8)
    e = jnp.array([1.0, 2.0, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0])
    np.testing.assert_allclose(S @ e, [1.0, 2.0], atol=1e-14)


def test_straight_line_is_reproduced_exactly():
    """Positions along a straight element with unit slope are x along the line."""
    l = 2.0
    e = jnp.array([0.0, 0.0, 0.6, 0.8, 1.2, 1.6, 0.6, 0.8])
    for x in np.linspace(0, l, 5):
        np.testing.assert_allclose(position(e, x, l), [0.6 * x, 0.8 * x], atol=1e-14)
        np.testing.assert_allclose(slope_derivative(e, x, l), [0.0, 0.0], atol=1e-13)


def test_cubic_reproduction():
    """Any cubic curve is interpolated exactly (r'' linear)."""
    l = 0.9
    f = lambda x: jnp.array([x + 0.3 * x**3, 0.2 * x**2 - x**3])
    df = jax.jacfwd(f)
    e = jnp.concatenate([f(0.0), df(0.0), f(l), df(l)])
    for x in np.linspace(0, l, 6):
        np.testing.assert_allclose(position(e, x, l), f(x), atol=1e-14)
        np.testing.assert_allclose(slope_derivative(e, x, l), jax.jacfwd(df)(x), atol=1e-12)
