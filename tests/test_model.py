"""The model builder: bad input gives clear errors before any compilation; redundant
and conflicting joints are named."""

import logging

import jax
import numpy as np
import pytest

from ancf_jax import ConstraintError, ModelError, mesh
from ancf_jax.model import Model, beam_point, body_point, ground, node
from ancf_jax.section import Section

SEC = Section(2e11, 1e-6, 1e-13, 0.01)


def compiled_model_code(records):
    """Compilations of model code in the captured log records. JAX compiles a trivial
    'stage' function the first time it places an array of a new shape on the device;
    that is data transfer, not model code, and is ignored."""
    return [r.getMessage() for r in records if r.getMessage().startswith("Compiling")
            and not r.getMessage().startswith(("Compiling jit(stage)", "Compiling jit(convert_element_type)"))]


def two_beam_model():
    m = Model()
    m.add_beam("cable", mesh.straight((0, 0), (1, 0), 2.0, 4), SEC)
    m.add_body("cart", mass=1.0, inertia=0.1, position=(1.0, 0.0))
    return m


BAD_INPUT = [
    (lambda: mesh.straight((0, 0), (1, 0), 0.0, 4), "length"),
    (lambda: mesh.straight((0, 0), (1, 0), -1.0, 4), "length"),
    (lambda: mesh.straight((0, 0), (1, 0), 1.0, 0), "n_elements"),
    (lambda: mesh.straight((0, 0), (1, 0), 1.0, 2.5), "n_elements"),
    (lambda: mesh.straight((0, 0), (0, 0), 1.0, 2), "direction"),
    (lambda: Section(0.0, 1e-6, 1e-13, 0.01), "youngs_modulus"),
    (lambda: Section(2e11, -1e-6, 1e-13, 0.01), "area"),
    (lambda: Section(2e11, 1e-6, 0.0, 0.01), "second_moment"),
    (lambda: Section(2e11, 1e-6, 1e-13, 0.0), "mass_per_length"),
    (lambda: Section.circle(-1e-3, 2e11, density=7800), "diameter"),
    (lambda: Model().add_body("b", mass=0.0, inertia=1.0), "mass of body 'b'"),
    (lambda: Model().add_body("b", mass=1.0, inertia=-1.0), "inertia of body 'b'"),
    (lambda: Model().add_beam("b", mesh.straight((0, 0), (1, 0), 1, 2), SEC, alpha=-0.1), "alpha"),
    (lambda: Model().add_beam("b", mesh.straight((0, 0), (1, 0), 1, 2), SEC, beta=float("nan")), "beta"),
    (lambda: Model(gravity=(0, 1, 2)), "gravity"),
]


@pytest.mark.parametrize("make,name", BAD_INPUT)
def test_bad_input_is_a_value_error_naming_the_parameter(make, name, caplog):
    with jax.log_compiles(True), caplog.at_level(logging.DEBUG):
        with pytest.raises(ValueError, match=name) as err:
            make()
    assert isinstance(err.value, ModelError)
    assert "range" in str(err.value) or ">" in str(err.value) or "must" in str(err.value)
    assert not compiled_model_code(caplog.records)


BAD_REFERENCES = [
    (lambda m: m.clamp("c", "rope", 0), "beam 'rope', which does not exist"),
    (lambda m: m.fixed("f", node("cable", 9), "cart"), "node 9 of beam 'cable' is out of range"),
    (lambda m: m.fixed("f", node("cable", -1), "trolley"), "body 'trolley', which does not exist"),
    (lambda m: m.slider("s", "cart", "rope", 0.5), "sliding joint 's' refers to beam 'rope'"),
    (lambda m: m.slider("s", "cart", "cable", 2.5), "outside beam 'cable'"),
    (lambda m: m.pin("p", beam_point("cable", 3.0)), "outside beam 'cable'"),
    (lambda m: m.revolute("r", body_point("cart"), (1.0, 0.0)), "a point must be given"),
]


@pytest.mark.parametrize("add,message", BAD_REFERENCES)
def test_unknown_references_are_reported_at_build(add, message, caplog):
    m = two_beam_model()
    add(m)
    with jax.log_compiles(True), caplog.at_level(logging.DEBUG):
        with pytest.raises(ModelError, match=message):
            m.build()
    assert not compiled_model_code(caplog.records)


def test_duplicate_names_are_rejected():
    m = two_beam_model()
    with pytest.raises(ModelError, match="duplicate name 'cart'"):
        m.add_body("cart", mass=1.0, inertia=1.0)
    with pytest.raises(ModelError, match="duplicate name 'cable'"):
        m.clamp("cable", "cable", 0)


def test_redundant_constraints_name_the_joints():
    m = two_beam_model()
    m.clamp("left", "cable", 0)
    m.pin("extra", node("cable", 0))
    m.pin("right", node("cable", -1))
    with pytest.raises(ConstraintError, match=r"redundant.*left, extra") as err:
        m.build()
    assert "right" not in str(err.value).split("joints involved:")[1].split("(")[0]


def test_conflicting_constraints_are_detected():
    m = Model()
    m.add_body("a", mass=1.0, inertia=1.0)
    m.pin("here", body_point("a"), location=(0.0, 0.0))
    m.prescribe_body("there", "a", "x", lambda t: 1.0 + 0.0 * t)
    with pytest.raises(ConstraintError, match="here.*there|there.*here"):
        m.build()


def test_build_projects_an_inconsistent_initial_state():
    """A body placed 1 mm off its revolute joint is moved onto it."""
    m = Model()
    m.add_body("a", mass=1.0, inertia=0.1, position=(0.5, 0.001))
    m.pin("hinge", body_point("a", (-0.5, 0.0)), location=(0.0, 0.0))
    system, state = m.build()
    np.testing.assert_allclose(system.constraint(state.q), 0.0, atol=1e-12)


def test_build_resolves_negative_node_indices_and_padding():
    m = two_beam_model()
    m.pin("end", node("cable", -1))
    system, _ = m.build(pad_to=7)
    assert int(system.constraints[0].a.node) == 4
    assert system.beams[0].mesh.n_max == 7
    with pytest.raises(ModelError, match="pad_to"):
        m.build(pad_to=2)


def test_build_projects_to_the_nearest_consistent_state_in_the_mass_metric():
    """The initial position projection is argmin ½|p − q|²_M subject to Φ(p) = 0:
    compared with an independent solution of its first-order conditions (MINPACK's
    hybrid method on the same M and Φ) for a clamped beam whose tip carries a hinged
    body placed 5 mm and 0.1 rad off; padding nodes do not move."""
    from scipy.optimize import root

    m = Model()
    m.add_beam("cable", mesh.straight((0, 0), (1, 0), 1.0, 2), SEC)
    m.add_body("cart", mass=2.0, inertia=0.05, position=(1.2, 0.005), angle=0.1)
    m.clamp("root", "cable", 0)
    m.revolute("hinge", node("cable", -1), body_point("cart", (-0.2, 0.0)))
    system, guess = m.build(pad_to=4, assemble=False)
    _, state = m.build(pad_to=4)
    q0 = np.asarray(guess.q)
    free = ~np.asarray(system.inactive_mask())
    mass = np.asarray(system.mass_matrix())[np.ix_(free, free)]
    phi = jax.jit(lambda q: system.constraint(q))
    jac = jax.jit(jax.jacfwd(lambda q: system.constraint(q)))

    def full(x):
        q = q0.copy()
        q[free] = x
        return q

    # the first-order conditions M (x - q0) + J(x)^T lam = 0, Phi(x) = 0, solved by
    # MINPACK's hybrid method (finite-difference Jacobian; SLSQP at ftol 1e-16 stopped at
    # its iteration limit with scipy 1.17); the mass is scaled to order 1
    w = 1e8 * mass
    n = int(free.sum())

    def kkt(z):
        x, lam = z[:n], z[n:]
        return np.concatenate([w @ (x - q0[free]) + np.asarray(jac(full(x)))[:, free].T @ lam,
                               np.asarray(phi(full(x)))])

    m_c = np.asarray(phi(full(q0[free]))).size
    res = root(kkt, np.concatenate([q0[free], np.zeros(m_c)]), method="hybr", options=dict(xtol=1e-12))
    assert res.success, res.message
    x_ref = res.x[:n]
    assert np.max(np.abs(q0[free] - x_ref)) > 1e-3  # the guess was off
    np.testing.assert_allclose(system.constraint(state.q), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(state.q)[free], x_ref, atol=1e-10)
    np.testing.assert_array_equal(np.asarray(state.q)[~free], q0[~free])
