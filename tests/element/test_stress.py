"""Eqs. 15–18: bending moment and stress from curvature; sign convention."""

import jax.numpy as jnp
import numpy as np

from ancf_jax.element import bending_moment, bending_stress

E, C = 200e9, 0.5e-3
STRAIGHT = jnp.array([0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0])


def parabola(kappa, length=1.0):
    """r = (x, ½ κ x²): r'' = (0, κ), curvature κ at x = 0."""
    return jnp.array([0.0, 0.0, 1.0, 0.0, length, 0.5 * kappa * length**2, 1.0, kappa * length])


def test_stress_sign_tension_on_convex_side():
    """Bending up (κ > 0) compresses the upper fibre (y > 0) and stretches the lower."""
    e = parabola(0.01)
    top = float(bending_stress(e, STRAIGHT, 0.0, 1.0, E, +C))
    bottom = float(bending_stress(e, STRAIGHT, 0.0, 1.0, E, -C))
    assert top < 0 < bottom
    np.testing.assert_allclose(top, -E * C * 0.01, rtol=1e-12)  # |r'| = 1 at x = 0
    np.testing.assert_allclose(bottom, -top, rtol=1e-14)
    # a cantilever bending down: upper fibre in tension
    assert float(bending_stress(parabola(-0.01), STRAIGHT, 0.0, 1.0, E, +C)) > 0


def test_exact_and_small_strain_agree_for_small_strain_and_differ_with_stretch():
    """Eq. 17 is Eq. 16 with f = |r'| = 1: equal on an unstretched fibre, off by the
    stretch where the beam is stretched."""
    e = parabola(0.02)
    for x in (0.0, 0.3):
        ex = float(bending_stress(e, STRAIGHT, x, 1.0, E, C, "exact"))
        ap = float(bending_stress(e, STRAIGHT, x, 1.0, E, C, "small_strain"))
        f = np.sqrt(1 + (0.02 * x) ** 2)
        np.testing.assert_allclose(ap / ex, f**3, rtol=1e-12)  # |r''| f³ / (r'×r'') = f³ here
    # stretching the whole element by λ (r' → λ r', r'' → λ r'') divides the exact
    # curvature by λ and multiplies the approximate one by λ
    lam = 1.1
    stretched = lam * e
    ex = float(bending_stress(stretched, STRAIGHT, 0.5, 1.0, E, C, "exact"))
    ap = float(bending_stress(stretched, STRAIGHT, 0.5, 1.0, E, C, "small_strain"))
    f = np.sqrt(1 + (0.02 * 0.5) ** 2)
    np.testing.assert_allclose(ap / ex, lam**2 * f**3, rtol=1e-12)


def test_moment_is_ei_kappa():
    np.testing.assert_allclose(float(bending_moment(parabola(0.03), STRAIGHT, 0.0, 1.0, 2.0)), 0.06, rtol=1e-12)
