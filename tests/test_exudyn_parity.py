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
