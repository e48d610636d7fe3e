"""Natural frequencies of a clamped-free beam, bare and with a tip body, against the
Euler–Bernoulli characteristic equation."""

import numpy as np
import pytest

from ancf_jax import mesh
from ancf_jax.model import Model, node
from ancf_jax.modal import modal_analysis
from ancf_jax.section import Section

from .beam_theory import clamped_free_frequencies

L, EI, RHO_A, EA = 1.0, 1.0, 1.0, 1e7


def characteristic_frequencies(tip_mass, tip_inertia, count=4):
    return clamped_free_frequencies(EI, RHO_A, L, tip_mass, tip_inertia, count)


def test_characteristic_equation_bare_limit():
    """Without a tip body the roots are the textbook βL = 1.8751, 4.6941, 7.8548, 10.9955."""
    w = characteristic_frequencies(0.0, 0.0)
    np.testing.assert_allclose(np.sqrt(w), [1.87510407, 4.69409113, 7.85475744, 10.99554073], rtol=1e-8)


def clamped_beam(n, tip_mass=None, tip_inertia=None):
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), L, n), Section(EA, 1.0, EI / EA, RHO_A))
    m.clamp("support", "beam", 0)
    if tip_mass is not None:
        m.add_body("tip", mass=tip_mass, inertia=tip_inertia, position=(L, 0.0))
        m.fixed("tip_joint", node("beam", -1), body="tip")
    return m.build()


@pytest.mark.parametrize("tip", [None, (0.5, 0.02)], ids=["bare", "tip-mass"])
def test_first_four_frequencies_at_12_elements(tip):
    system, state = clamped_beam(12, *(tip or (None, None)))
    result = modal_analysis(system, state.q, n_modes=4)
    exact = characteristic_frequencies(*(tip or (0.0, 0.0)))
    np.testing.assert_allclose(result.angular_frequencies, exact, rtol=1e-3)
    np.testing.assert_allclose(result.frequencies_hz, exact / (2 * np.pi), rtol=1e-3)


def test_frequencies_converge_from_above():
    """Consistent-mass finite elements bound the frequencies from above and converge.

    (The bound holds up to the round-off of the eigensolver, ~1e-7 relative here
    because the axial stiffness EA/l is 1e5 times the bending stiffness.)"""
    exact = characteristic_frequencies(0.5, 0.02)
    errs = []
    for n in (3, 6, 12):
        w = modal_analysis(*(lambda s: (s[0], s[1].q))(clamped_beam(n, 0.5, 0.02)), n_modes=4).angular_frequencies
        assert np.all(w >= exact * (1 - 1e-6))
        errs.append(np.max(w / exact - 1))
    assert errs[0] > errs[1] > errs[2]


def test_mode_shapes_are_mass_normalized_and_satisfy_constraints():
    system, state = clamped_beam(6, 0.5, 0.02)
    r = modal_analysis(system, state.q, n_modes=3)
    mass = np.asarray(system.mass_matrix())
    np.testing.assert_allclose(r.mode_shapes @ mass @ r.mode_shapes.T, np.eye(3), atol=1e-9)
    jac = np.asarray(system.constraint_jacobian(state.q))
    np.testing.assert_allclose(jac @ r.mode_shapes.T, 0.0, atol=1e-10)
