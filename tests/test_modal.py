"""Natural frequencies of a clamped-free beam, bare and with a tip body, against the
Euler–Bernoulli characteristic equation."""

import numpy as np
import pytest
from scipy.optimize import brentq

from ancf_jax import mesh
from ancf_jax.model import Model, node
from ancf_jax.modal import modal_analysis
from ancf_jax.section import Section

L, EI, RHO_A, EA = 1.0, 1.0, 1.0, 1e7


def characteristic_frequencies(tip_mass, tip_inertia, count=4):
    """Roots ω of the clamped-free beam with a tip mass M and rotary inertia J at x = L.

    w = A(cos βx − cosh βx) + B(sin βx − sinh βx), β⁴ = ρA ω²/EI; the natural boundary
    conditions at L are EI w'' = J ω² w' and EI w''' = −M ω² w.
    """
    def det(beta):
        w2 = beta**4 * EI / RHO_A
        c, s, ch, sh = np.cos(beta * L), np.sin(beta * L), np.cosh(beta * L), np.sinh(beta * L)
        # columns: A, B; rows: moment and shear conditions
        wa, wb = c - ch, s - sh
        d1a, d1b = beta * (-s - sh), beta * (c - ch)
        d2a, d2b = beta**2 * (-c - ch), beta**2 * (-s - sh)
        d3a, d3b = beta**3 * (s - sh), beta**3 * (-c - ch)
        m = np.array([[EI * d2a - tip_inertia * w2 * d1a, EI * d2b - tip_inertia * w2 * d1b],
                      [EI * d3a + tip_mass * w2 * wa, EI * d3b + tip_mass * w2 * wb]])
        return np.linalg.det(m) / (ch * ch)
    betas = np.linspace(0.05, 15.0, 6000)
    vals = [det(b) for b in betas]
    roots = [brentq(det, betas[i], betas[i + 1], xtol=1e-14)
             for i in range(len(betas) - 1) if vals[i] * vals[i + 1] < 0]
    return np.array([b**2 * np.sqrt(EI / RHO_A) for b in roots[:count]])


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
