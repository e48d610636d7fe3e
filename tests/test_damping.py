"""Eq. 11: Rayleigh coefficients from two frequencies and damping ratios, and back."""

import numpy as np
import pytest

from ancf_jax.damping import modal_damping_ratios, rayleigh_coefficients
from ancf_jax.errors import ModelError


@pytest.mark.parametrize("w1,w2,x1,x2", [(10.0, 60.0, 0.02, 0.05), (3.5, 22.0, 0.01, 0.01),
                                         (100.0, 130.0, 0.0, 0.03)])
def test_coefficients_reproduce_damping_ratios(w1, w2, x1, x2):
    a, b = rayleigh_coefficients(w1, w2, x1, x2)
    np.testing.assert_allclose(modal_damping_ratios(a, b, [w1, w2]), [x1, x2], rtol=1e-12, atol=1e-15)


def test_paper_formula_printed_in_eq_11():
    w1, w2, x1, x2 = 5.0, 40.0, 0.03, 0.02
    a, b = rayleigh_coefficients(w1, w2, x1, x2)
    assert a == pytest.approx(2 * w1 * w2 * (x1 * w2 - x2 * w1) / (w2**2 - w1**2))
    assert b == pytest.approx(2 * (x2 * w2 - x1 * w1) / (w2**2 - w1**2))


def test_mass_proportional_damping_ratio_falls_with_frequency():
    """M1's α = 0.02, β = 0 damps the first mode most."""
    xi = modal_damping_ratios(0.02, 0.0, [10.0, 100.0])
    assert xi[0] == pytest.approx(0.001) and xi[1] == pytest.approx(0.0001)


@pytest.mark.parametrize("args,name", [((0.0, 2.0, 0.1, 0.1), "omega1"), ((1.0, -2.0, 0.1, 0.1), "omega2"),
                                       ((1.0, 2.0, -0.1, 0.1), "xi1"), ((1.0, 1.0, 0.1, 0.1), "differ")])
def test_bad_input(args, name):
    with pytest.raises(ModelError, match=name):
        rayleigh_coefficients(*args)
