"""Beam-level physics: assembled energy, stress along a beam, maxima, Barlow points."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax import mesh
from ancf_jax.beam import Beam
from ancf_jax.element import BARLOW_POINTS
from ancf_jax.model import Model, node
from ancf_jax.section import Section
from ancf_jax.statics import solve_static

L, E, D = 0.5, 200e9, 1e-3
SEC = Section.circle(D, E, density=7850.0)
EI = float(SEC.bending_stiffness)
C = D / 2


def cantilever(n, *, tip_torque=None, tip_force=None, gravity=(0.0, 0.0)):
    m = Model(gravity=gravity)
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), L, n), SEC)
    m.clamp("support", "beam", 0)
    if tip_torque is not None:
        m.add_body("tip", mass=1e-3, inertia=1e-9, position=(L, 0.0))
        m.fixed("tip_joint", node("beam", -1), body="tip")
        m.torque("moment", "tip", tip_torque)
    if tip_force is not None:
        m.point_force("load", node("beam", -1), tip_force)
    system, state = m.build()
    sol = solve_static(system, state, load_steps=4)
    return system, system.beam_nodes(sol.state.q, 0)


def test_pure_bending_gives_uniform_stress_and_a_circle():
    """An end moment bends an (almost inextensible) beam into a circle of curvature M/EI;
    here one radian of arc, far beyond small deflections."""
    moment = EI / L  # κ L = 1
    system, nodes = cantilever(4, tip_torque=moment)
    beam = system.beams[0]
    expect = -E * C * moment / EI  # κ > 0 (counter-clockwise): upper fibre compressed
    # a cubic represents a circle of 1/4 rad per element to O(Δφ²) in curvature...
    s, sig = beam.stress_along(nodes, 9)
    np.testing.assert_allclose(np.asarray(sig), expect, rtol=1e-2)
    # ...and superconvergently at the Barlow points
    for k in range(4):
        for xi in BARLOW_POINTS:
            np.testing.assert_allclose(float(beam.element_stress(nodes, k, xi)), expect, rtol=1e-4)
    tip = np.asarray(nodes[-1, :2])
    # 4 elements of 1/4 rad: position error O(Δφ⁴), measured 1.6e-5 L
    np.testing.assert_allclose(tip, [L * np.sin(1.0), L * (1 - np.cos(1.0))], atol=3e-5 * L)
    peak, where = beam.max_stress(nodes)
    np.testing.assert_allclose(float(peak), abs(expect), rtol=1e-2)


def test_stress_at_any_arc_length_matches_element_stress():
    system, nodes = cantilever(3, tip_force=(0.0, -0.05))
    beam = system.beams[0]
    l = float(beam.mesh.element_lengths[0])
    for k, xi in [(0, 0.3), (1, 0.0), (2, 0.75)]:
        np.testing.assert_allclose(float(beam.stress(nodes, (k + xi) * l)),
                                   float(beam.element_stress(nodes, k, xi)), rtol=1e-12)


def test_max_stress_at_the_root_under_a_tip_load():
    """Small deflection: σ_max = P L c / I at the clamp, upper fibre in tension."""
    p = 1e-4
    system, nodes = cantilever(4, tip_force=(0.0, -p))
    beam = system.beams[0]
    peak, where = beam.max_stress(nodes)
    np.testing.assert_allclose(float(peak), p * L * C / float(SEC.second_moment), rtol=1e-4)
    assert float(where) == 0.0
    assert float(beam.stress(nodes, 0.0)) > 0


def test_barlow_points_are_exact_for_a_quadratic_moment():
    """Under a uniform load the moment is quadratic; the cubic element's linear
    curvature equals it at the Barlow (2-point Gauss) points and not in between."""
    g = 1e-3  # tiny load: linear regime
    n = 4
    system, nodes = cantilever(n, gravity=(0.0, -g))
    beam = system.beams[0]
    w = float(SEC.mass_per_length) * g
    l = L / n
    exact = lambda x: E * C * w * (L - x) ** 2 / (2 * EI)  # upper fibre tension
    err_barlow, err_mid = [], []
    for k in range(n):
        for xi in BARLOW_POINTS:
            err_barlow.append(abs(float(beam.element_stress(nodes, k, xi)) / exact((k + xi) * l) - 1))
        err_mid.append(abs(float(beam.element_stress(nodes, k, 0.5)) / exact((k + 0.5) * l) - 1))
    assert max(err_barlow) < 1e-5
    assert min(err_mid) > 1e-3


def test_stress_along_marks_padding_as_nan():
    m = mesh.straight((0, 0), (1, 0), L, 3, n_max=5)
    beam = Beam(m, SEC)
    s, sig = jax.jit(lambda b, n: b.stress_along(n, 5))(beam, m.reference_nodes)
    assert s.shape == (5, 5)
    assert np.all(np.isnan(np.asarray(sig[3:]))) and np.all(np.asarray(sig[:3]) == 0.0)


def test_padded_beam_has_the_same_physics():
    """Inactive elements add no energy, force, mass or load."""
    sec = Section(1e5, 1.0, 1e-2, 2.0)
    small = Beam(mesh.straight((0, 0), (1, 0), 1.2, 3), sec)
    big = Beam(mesh.straight((0, 0), (1, 0), 1.2, 3, n_max=7), sec)

    @jax.jit
    def physics(beam, nodes):
        return (beam.strain_energy(nodes), beam.elastic_force(nodes), beam.mass().to_dense(),
                beam.gravity_load(jnp.array([0.0, -9.81])), beam.stiffness(nodes).to_dense(),
                beam.total_mass)

    rng = np.random.default_rng(1)
    nodes = small.mesh.reference_nodes + 0.05 * rng.normal(size=(4, 4))
    padded = big.mesh.reference_nodes.at[:4].set(nodes)
    u1, f1, m1, g1, k1, _ = physics(small, nodes)
    u2, f2, m2, g2, k2, mass2 = physics(big, padded)
    assert float(u2) == pytest.approx(float(u1), rel=1e-14)
    np.testing.assert_allclose(f2[:4], f1, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(f2[4:], 0.0, atol=0)
    np.testing.assert_allclose(m2[:16, :16], m1, rtol=1e-15)
    np.testing.assert_allclose(m2[16:, 16:], np.eye(16), atol=0)  # dummy mass on padding
    np.testing.assert_allclose(g2[:4], g1, rtol=1e-15)
    np.testing.assert_allclose(g2[4:], 0.0, atol=0)
    np.testing.assert_allclose(k2[:16, :16], k1, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(k2[16:], 0.0, atol=0)
    assert float(mass2) == pytest.approx(2.0 * 1.2)
