"""Eqs. 8–9: one strain-energy function; forces and stiffness by autodiff.

Checks the autodiff gradient and Hessian against central finite differences on random
configurations (hypothesis), and that rigid-body motion stores no energy.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ancf_jax.element import Formulation, axial_strain, curvature, strain_energy
from ancf_jax.errors import ModelError
from ancf_jax.mesh import arc

FORMULATIONS = {
    "gl-exact": Formulation(),
    "eng-exact": Formulation(axial_strain="engineering"),
    "gl-small": Formulation(curvature="small_strain"),
    "eng-material": Formulation(axial_strain="engineering", curvature="material"),
    "full-gauss": Formulation(axial_quadrature=("gauss", 5), bending_quadrature=("gauss", 5)),
}
EA, EI = 1.0e4, 2.0


@functools.lru_cache(maxsize=None)
def compiled(key):
    f = FORMULATIONS[key]
    energy = jax.jit(lambda e, er, l: strain_energy(e, er, l, EA, EI, f))
    force = jax.jit(lambda e, er, l: -jax.grad(strain_energy)(e, er, l, EA, EI, f))
    hess = jax.jit(lambda e, er, l: jax.hessian(strain_energy)(e, er, l, EA, EI, f))
    return energy, force, hess


def straight_reference(length):
    return jnp.array([0.0, 0.0, 1.0, 0.0, length, 0.0, 1.0, 0.0])


def rigid_motion(e, phi, c):
    r = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
    ee = np.asarray(e).reshape(4, 2)
    out = np.stack([r @ ee[0] + c, r @ ee[1], r @ ee[2] + c, r @ ee[3]])
    return jnp.asarray(out.reshape(8))


configs = st.tuples(
    st.floats(0.2, 2.0),                                   # element length
    st.lists(st.floats(-0.15, 0.15), min_size=8, max_size=8),  # perturbation (relative)
    st.floats(0.0, 2 * np.pi),                             # rigid rotation
)


def random_configuration(length, pert, phi):
    e = np.asarray(straight_reference(length)) + np.asarray(pert) * np.array([length, length, 1, 1] * 2)
    return rigid_motion(e, phi, np.array([0.3, -0.2]))


@pytest.mark.parametrize("key", list(FORMULATIONS))
@settings(max_examples=15, deadline=None)
@given(cfg=configs)
def test_force_is_minus_gradient_by_finite_differences(key, cfg):
    length, pert, phi = cfg
    energy, force, _ = compiled(key)
    e, er = random_configuration(length, pert, phi), straight_reference(length)
    f = np.asarray(force(e, er, length))
    h = 1e-6
    fd = np.array([-(float(energy(e.at[i].add(h), er, length)) - float(energy(e.at[i].add(-h), er, length))) / (2 * h)
                   for i in range(8)])
    # central differences: round-off ~ 1e-16 U / h, truncation ~ h² ∂³U ~ h² EA / l³
    truncation = 10 * h**2 * EA / length**3
    np.testing.assert_allclose(f, fd, rtol=0, atol=1e-6 * np.max(np.abs(f)) + truncation)


@pytest.mark.parametrize("key", list(FORMULATIONS))
@settings(max_examples=10, deadline=None)
@given(cfg=configs)
def test_stiffness_symmetric_and_equal_to_force_jacobian(key, cfg):
    length, pert, phi = cfg
    _, force, hess = compiled(key)
    e, er = random_configuration(length, pert, phi), straight_reference(length)
    k = np.asarray(hess(e, er, length))
    np.testing.assert_allclose(k, k.T, rtol=0, atol=1e-10 * np.max(np.abs(k)))
    h = 1e-6
    fd = np.stack([-(np.asarray(force(e.at[i].add(h), er, length)) - np.asarray(force(e.at[i].add(-h), er, length))) / (2 * h)
                   for i in range(8)], axis=1)
    np.testing.assert_allclose(k, fd, rtol=0, atol=1e-6 * np.max(np.abs(k)))


@pytest.mark.parametrize("key", list(FORMULATIONS))
def test_rigid_translation_and_rotation_store_no_energy(key):
    """Zero strain energy and zero elastic force for rotations 0…2π and translations."""
    energy, force, _ = compiled(key)
    length = 0.7
    er = straight_reference(length)
    for phi in np.linspace(0.0, 2 * np.pi, 17):
        e = rigid_motion(er, phi, np.array([1.5, -4.0]))
        assert abs(float(energy(e, er, length))) < 1e-20 * EA + 1e-24
        np.testing.assert_allclose(force(e, er, length), 0.0, atol=1e-11 * EA)


@pytest.mark.parametrize("key", ["gl-exact", "eng-exact", "eng-material"])
def test_curved_reference_is_stress_free(key):
    """A curved stress-free reference (arc) under rigid motion stores no energy."""
    energy, force, _ = compiled(key)
    mesh = arc((0.0, 0.0), 0.5, 0.0, 1.2, 3)
    er = mesh.reference_elements[1]
    length = float(mesh.element_lengths[1])
    for phi in np.linspace(0.0, 2 * np.pi, 9):
        e = rigid_motion(er, phi, np.array([0.2, 0.1]))
        assert abs(float(energy(e, er, length))) < 1e-22 * EA
        np.testing.assert_allclose(force(e, er, length), 0.0, atol=1e-10 * EA)
    # and bending it further does store energy
    e = er.at[7].add(0.05)
    assert float(energy(e, er, length)) > 1e-6


def test_small_strain_curvature_needs_straight_reference():
    from ancf_jax.beam import Beam
    from ancf_jax.section import Section
    with pytest.raises(ModelError, match="straight reference"):
        Beam(arc((0, 0), 1.0, 0.0, 1.0, 2), Section(1e9, 1e-4, 1e-9, 1.0),
             formulation=Formulation(curvature="small_strain"))


def test_energy_of_uniform_stretch_and_pure_bending_closed_form():
    """Uniform stretch λ: U = ½ EA ε² l exactly; constant curvature (cubic with
    linear-free r''): U = ½ EI κ² l for the small-strain measure."""
    length = 0.8
    er = straight_reference(length)
    lam = 1.01
    e = jnp.array([0.0, 0.0, lam, 0.0, lam * length, 0.0, lam, 0.0])
    for key, eps in [("gl-exact", 0.5 * (lam**2 - 1)), ("eng-exact", lam - 1)]:
        energy, _, _ = compiled(key)
        np.testing.assert_allclose(float(energy(e, er, length)), 0.5 * EA * eps**2 * length, rtol=1e-12)
    # r(x) = (x, ½ κ x²): r'' = (0, κ) constant, |r''|² = κ²
    kappa = 0.3
    e = jnp.array([0.0, 0.0, 1.0, 0.0, length, 0.5 * kappa * length**2, 1.0, kappa * length])
    energy, _, _ = compiled("gl-small")
    # axial part: ε = ½((1 + κ²x²) − 1) = ½ κ² x² integrated by 3-point Lobatto (exact, degree 4)
    ax = 0.5 * EA * np.sum(np.array([1, 4, 1]) / 6 * length * (0.5 * kappa**2 * (np.array([0, 0.5, 1]) * length) ** 2) ** 2)
    np.testing.assert_allclose(float(energy(e, er, length)), 0.5 * EI * kappa**2 * length + ax, rtol=1e-12)


def test_axial_strain_and_curvature_measures():
    # a cubic element interpolates the circle with an O((l/R)^4) error: l/R = 1/8
    length = 0.25
    er = straight_reference(length)
    # circle of radius R traversed with stretch λ: r(x) = λR(sin(x/R), 1 - cos(x/R))
    R, lam = 2.0, 1.05
    f = lambda x: lam * R * jnp.array([jnp.sin(x / R), 1 - jnp.cos(x / R)])
    df = jax.jacfwd(f)
    e = jnp.concatenate([f(0.0), df(0.0), f(length), df(length)])
    # r'' of a cubic is linear: curvature is O((l/R)²) accurate in general (6.5e-4 at
    # the midpoint here) and superconvergent at the Barlow points (Barlow 1976)
    from ancf_jax.element import BARLOW_POINTS
    x = BARLOW_POINTS[0] * length
    np.testing.assert_allclose(float(axial_strain(e, er, x, length, "engineering")), lam - 1, atol=1e-6)
    np.testing.assert_allclose(float(axial_strain(e, er, x, length)), 0.5 * (lam**2 - 1), atol=1e-6)
    np.testing.assert_allclose(float(curvature(e, x, length, "exact")), 1 / (lam * R), rtol=5e-6)
    np.testing.assert_allclose(float(curvature(e, x, length, "material")), 1 / R, rtol=5e-6)
    np.testing.assert_allclose(float(curvature(e, x, length, "small_strain")), lam / R, rtol=5e-6)
    mid = float(curvature(e, 0.5 * length, length, "exact"))
    assert abs(mid * lam * R - 1) > 1e-4  # not superconvergent away from them
    # clockwise bending gives negative signed curvature
    e_cw = e * jnp.array([1, -1] * 4)
    assert float(curvature(e_cw, x, length, "exact")) < 0
    assert float(curvature(e_cw, x, length, "small_strain")) < 0
