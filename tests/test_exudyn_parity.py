"""Exudyn parity (issue 22): sections from EA, EI, ρA; coordinate constraints and the
Exudyn-style clamp; point masses and per-item loads; CSV precision; material laws.

Each feature is checked against a closed form or against the equivalent model written
the existing way; the Exudyn cross-checks of the laws are in tests/exudyn_cases.py
(run in a spawned interpreter by tests/test_exudyn_crosscheck.py).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax import mesh
from ancf_jax.beam import Beam
from ancf_jax.errors import ModelError
from ancf_jax.section import Section

E, A, I, RHO_A = 2.0e11, 1.0e-4, 1.0e-9, 0.785


def _deformed(beam, seed=0):
    ref = np.asarray(beam.mesh.reference_nodes)
    return jnp.asarray(ref + 0.01 * np.random.default_rng(seed).standard_normal(ref.shape))


# ----------------------------------------------------------------------------- 1. sections
def test_section_from_stiffness_is_the_same_beam():
    """EA, EI, ρA without E: the element sees exactly E·A and E·I (bitwise equal forces);
    with E given as well the stiffnesses agree to round-off, and stresses agree."""
    m = mesh.straight((0, 0), (1, 0), 1.0, 3)
    by_modulus = Beam(m, Section(E, A, I, RHO_A))
    by_stiffness = Beam(m, Section.from_stiffness(E * A, E * I, RHO_A))
    with_e = Beam(m, Section.from_stiffness(E * A, E * I, RHO_A, youngs_modulus=E))
    nodes = _deformed(by_modulus)
    force = eqx.filter_jit(lambda b, n: b.elastic_force(n))
    f0 = np.asarray(force(by_modulus, nodes))
    assert np.array_equal(np.asarray(force(by_stiffness, nodes)), f0)
    assert float(by_stiffness.section.mass_per_length) == float(by_modulus.section.mass_per_length)
    np.testing.assert_allclose(np.asarray(force(with_e, nodes)), f0, rtol=1e-15, atol=1e-15 * abs(f0).max())
    assert float(by_stiffness.section.fibre_distance) == float(by_modulus.section.fibre_distance)
    s0 = float(by_modulus.stress(nodes, 0.3))
    assert float(with_e.stress(nodes, 0.3)) == pytest.approx(s0, rel=1e-14)
    with pytest.raises(ModelError, match="needs Young's modulus.*youngs_modulus"):
        by_stiffness.stress(nodes, 0.3)


@pytest.mark.parametrize("bad, match", [
    (dict(axial_stiffness=0.0), r"axial_stiffness \(EA\)"),
    (dict(bending_stiffness=-1.0), r"bending_stiffness \(EI\)"),
    (dict(youngs_modulus=0.0), r"youngs_modulus \(E\)"),
])
def test_section_from_stiffness_rejects_bad_input(bad, match):
    args = dict(axial_stiffness=E * A, bending_stiffness=E * I, mass_per_length=RHO_A) | bad
    with pytest.raises(ModelError, match=match):
        Section.from_stiffness(**args)


SCENARIO = '''
gravity = [0.0, -9.81]
[beams.arm]
geometry = {{ type = "straight", length = 1.0 }}
elements = 3
section = {{ {section}, mass_per_length = 0.785 }}
[joints.clamp]
type = "clamp"
beam = "arm"
[solver]
t_end = 0.01
'''


def test_scenario_section_given_both_ways_is_identical(tmp_path):
    from ancf_jax.scenario import load_scenario
    sections = {"modulus": f"E = {E!r}, A = {A!r}, I = {I!r}",
                "stiffness": f"EA = {E * A!r}, EI = {E * I!r}"}
    beams = {}
    for key, text in sections.items():
        path = tmp_path / f"{key}.toml"
        path.write_text(SCENARIO.format(section=text))
        beams[key] = load_scenario(str(path)).model()._beams["arm"].section
    a, b = beams["modulus"], beams["stiffness"]
    assert float(a.axial_stiffness) == float(b.axial_stiffness)
    assert float(a.bending_stiffness) == float(b.bending_stiffness)
    assert float(a.mass_per_length) == float(b.mass_per_length)
    assert not b.modulus_known


# ----------------------------------------------------------------------------- 2. coordinate constraints
EA_C, EI_C, L_C = 1.0e8, 1.0e2, 1.0


def _cantilever(clamp):
    from ancf_jax.model import Model, node
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), L_C, 2), Section.from_stiffness(EA_C, EI_C, 0.1))
    clamp(m, node)
    return m


def test_exudyn_clamp_cantilever_matches_beam_theory():
    """The Exudyn clamp (x, y, r'_y held: 3 equations of rank 3), written as three
    coordinate constraints, under a small tip load: δ = P L³ / 3EI. Cubic elements hold
    the linear solution exactly; the rest is the geometric nonlinearity, O((δ/L)²) ≈
    1e-10 at δ/L = 1e-5, and the statics tolerance."""
    from ancf_jax.model import _JACOBIAN
    from ancf_jax.statics import solve_static

    delta = 1e-5 * L_C
    p = 3.0 * EI_C * delta / L_C**3

    def clamp(m, node):
        m.coordinate("x0", node("beam", 0), "x")
        m.coordinate("y0", node("beam", 0), "y", value=0.0)
        m.coordinate("slope0", node("beam", 0), "slope_y")
        m.point_force("load", node("beam", -1), (0.0, -p))

    system, state = _cantilever(clamp).build()
    assert system.n_constraints == 3
    assert np.linalg.matrix_rank(np.asarray(_JACOBIAN(system, state.q, jnp.zeros(())))) == 3
    sol = solve_static(system, state, load_steps=1, tolerance=1e-12)
    nodes = np.asarray(system.beam_nodes(sol.state.q, 0))
    assert nodes[-1, 1] == pytest.approx(-delta, rel=1e-8)
    assert abs(nodes[0, 1]) < 1e-20 and abs(nodes[0, 3]) < 1e-20

    # the named clamp option is the same three equations
    named, _ = _cantilever(lambda m, node: m.clamp("support", "beam", 0, mode="exudyn")).build(assemble=False)
    q = jnp.asarray(np.random.default_rng(1).standard_normal(system.n_coordinates))
    np.testing.assert_array_equal(np.asarray(named.constraint(q)), np.asarray(system.constraint(q)))


def test_coordinate_constraint_follows_a_time_function():
    """A coordinate given by a function of time: Φ = q[i] − f(t) (beam node and body)."""
    from ancf_jax.model import body_point

    def clamp(m, node):
        m.add_body("b", mass=1.0, inertia=1.0, position=(0.0, 1.0))
        m.coordinate("tip", node("beam", -1), "slope_x", function=lambda t: 1.0 + 0.1 * t)
        m.coordinate("turn", body_point("b"), "theta", function=lambda t: 2.0 * t)

    system, state = _cantilever(clamp).build(assemble=False)
    q = jnp.asarray(np.random.default_rng(2).standard_normal(system.n_coordinates))
    phi = np.asarray(system.constraint(q, 0.5))
    tip = system.beam_offset(0) + 4 * 2 + 2
    np.testing.assert_array_equal(phi, [float(q[tip]) - 1.05, float(q[2]) - 1.0])


@pytest.mark.parametrize("call, match", [
    (lambda m, node: m.coordinate("c", node("beam", 0), "theta"), "component of coordinate constraint 'c'"),
    (lambda m, node: m.coordinate("c", node("beam", 0), "x", value=1.0, function=lambda t: t),
     "give value or function, not both"),
    (lambda m, node: m.clamp("c", "beam", 0, mode="exuydn"), "mode of clamp 'c'"),
])
def test_coordinate_constraint_errors(call, match):
    with pytest.raises(ModelError, match=match):
        _cantilever(call)
