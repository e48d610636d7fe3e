"""Eqs. 5–6: consistent mass matrix and gravity load."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax.element import gauss_legendre, gravity_load, mass_matrix, shape_matrix


@pytest.mark.parametrize("length,rho_a", [(0.067, 0.00622), (1.0, 1.0), (2.5, 7.8)])
def test_closed_form_equals_quadrature(length, rho_a):
    """M = ρA ∫ Sᵀ S dx: closed form against 4-point Gauss (exact for degree 6)."""
    x, w = gauss_legendre(4)
    mq = sum(wi * length * rho_a * shape_matrix(xi * length, length).T @ shape_matrix(xi * length, length)
             for xi, wi in zip(x, w))
    np.testing.assert_allclose(mass_matrix(length, rho_a), mq, rtol=1e-13, atol=1e-16)


def test_symmetric_positive_definite_and_total_mass():
    l, rho_a = 0.4, 0.3
    m = np.asarray(mass_matrix(l, rho_a))
    np.testing.assert_allclose(m, m.T, atol=0)
    assert np.linalg.eigvalsh(m).min() > 0
    ux = np.array([1, 0, 0, 0, 1, 0, 0, 0.0])  # rigid translation in x
    assert abs(ux @ m @ ux - rho_a * l) < 1e-15


def test_gravity_load_equals_weight_and_work():
    l, rho_a, g = 0.8, 2.0, np.array([0.0, -9.81])
    f = np.asarray(gravity_load(l, rho_a, g))
    assert abs(f[1] + f[5] - rho_a * l * g[1]) < 1e-13
    assert abs(f[0] + f[4]) < 1e-15
    # the load does the work of gravity on any displacement field: f·e = ρA ∫ g·r dx
    e = np.array([0.1, 0.2, 1.0, 0.3, 0.9, -0.1, 0.8, -0.5])
    x, w = gauss_legendre(3)
    work = sum(wi * l * rho_a * g @ (np.asarray(shape_matrix(xi * l, l)) @ e) for xi, wi in zip(x, w))
    assert abs(f @ e - work) < 1e-13
