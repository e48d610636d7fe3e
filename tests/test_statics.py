"""Statics against closed-form answers: the large-deflection elastica (Bisshopp &
Drucker 1945) and the elastic catenary (Irvine 1981); the default root finder (full
Newton on the structured Newton matrix) against the same iteration with dense LU
solves; the regularization of unloaded, unconstrained coordinates."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from ancf_jax import StaticsError, dae, mesh
from ancf_jax.element import Formulation
from ancf_jax.linalg import AutoSaddleSolver, BorderedChainSolver, DenseLUSolver
from ancf_jax.model import Model, body_point, node
from ancf_jax.models.m2 import m2_model
from ancf_jax.section import Section
from ancf_jax.statics import DEFAULTS, StaticSolver, solve_static

#: the dense-LU root finder: the default's Newton iteration, each Newton system solved by
#: a dense LU of the whole matrix instead of the bordered block-tridiagonal solver
DENSE = StaticSolver(linear_solver=DenseLUSolver()).root_finder()

LOADS = [0.5, 1.0, 2.0, 5.0, 10.0]  # PL²/EI


def elastica_tip(k):
    """Tip (x/L, y/L) of an inextensible cantilever under a dead tip load with
    PL²/EI = k: θ'' = k cos θ on [0, 1], θ(0) = 0, θ'(1) = 0 (shooting)."""
    def shoot(c, full=False):
        sol = solve_ivp(lambda s, y: [y[1], k * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])],
                        (0.0, 1.0), [0.0, c, 0.0, 0.0], rtol=1e-12, atol=1e-13)
        return sol.y[:, -1] if full else sol.y[1, -1]
    c = brentq(shoot, -k - 1.0, 0.0, xtol=1e-15)
    y = shoot(c, full=True)
    return y[2], y[3]


def test_elastica_reference_matches_bisshopp_drucker_table():
    """Our scipy elastica reproduces the published table (PL²/EI = 1, 10)."""
    x, y = elastica_tip(1.0)
    assert abs((1 - x) - 0.05643) < 2e-5 and abs(-y - 0.30172) < 2e-5
    x, y = elastica_tip(10.0)
    assert abs((1 - x) - 0.55500) < 5e-5 and abs(-y - 0.81061) < 5e-5


def cantilever(n, formulation=None):
    """L = 1, EI = 1, EA = 1e7 (extension ~1e-6: negligible against 1e-4), no gravity."""
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), 1.0, n), Section(1e7, 1.0, 1e-7, 1.0),
               formulation=formulation)
    m.clamp("support", "beam", 0)
    m.point_force("load", node("beam", -1), (0.0, -1.0))
    return m.build()


def solve_loaded(system, state, k, root_finder=None):
    """Static solution for PL²/EI = k; the load is array data, so one compile serves all k."""
    import equinox as eqx
    sys_k = eqx.tree_at(lambda s: s.forces[0].force, system, jnp.array([0.0, -k]))
    return sys_k, solve_static(sys_k, state, load_steps=5, root_finder=root_finder)


def solve_tip(system, state, k):
    """Tip position (x, y) [m] for PL²/EI = k."""
    sys_k, sol = solve_loaded(system, state, k)
    return np.asarray(sys_k.beam_nodes(sol.state.q, 0)[-1, :2])


@pytest.fixture(scope="module")
def elastica_results():
    refs = {k: np.array(elastica_tip(k)) for k in LOADS}
    out = {}
    for n in (2, 4, 8, 16):
        system, state = cantilever(n)
        out[n] = {k: solve_tip(system, state, k) for k in LOADS}
    return refs, out


@pytest.mark.parametrize("k", LOADS)
def test_elastica_16_elements_within_1e4(elastica_results, k):
    refs, out = elastica_results
    ref = refs[k]
    err = np.linalg.norm(out[16][k] - ref) / np.linalg.norm(ref - [1.0, 0.0])
    assert err < 1e-4, f"PL²/EI={k}: relative tip error {err:.2e}"


def test_elastica_convergence_rate(elastica_results):
    """Observed order of convergence of the tip displacement in the element count.

    Cubic Hermite elements converge at O(h⁴) in displacement for smooth solutions; the
    observed rate between 8 and 16 elements must be at least 3.5 for every load.
    """
    refs, out = elastica_results
    for k in LOADS:
        errs = [np.linalg.norm(out[n][k] - refs[k]) for n in (2, 4, 8, 16)]
        rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
        assert rates[-1] > 3.5, f"PL²/EI={k}: errors {errs}, rates {rates}"


def assert_same_equilibrium(a, b, what):
    """Two static solutions agree to round-off: q to 1e-12 m (or 1e-12 for slopes), the
    multipliers to 1e-12 of the largest."""
    dq = float(np.max(np.abs(np.asarray(a.state.q) - np.asarray(b.state.q))))
    lam_a, lam_b = np.asarray(a.multipliers), np.asarray(b.multipliers)
    dlam = float(np.max(np.abs(lam_a - lam_b))) / max(float(np.max(np.abs(lam_a))), 1e-300)
    assert dq < 1e-12 and dlam < 1e-12, f"{what}: |dq| {dq:.2e}, |dlam|/max|lam| {dlam:.2e}"
    assert np.asarray(a.converged).all() and np.asarray(b.converged).all()


def test_structured_default_is_the_dense_newton_on_a_cantilever():
    """The default root finder (full Newton on the structured Newton matrix, bordered
    block-tridiagonal solves) and the same iteration with dense LU solves reach the same
    large-deflection equilibrium (16 elements, PL²/EI = 10) to round-off."""
    assert isinstance(DEFAULTS.linear_solver, AutoSaddleSolver) and DEFAULTS.root_finder().contraction == 0.0
    system, state = cantilever(16)
    _, structured = solve_loaded(system, state, 10.0)  # the elastica fixture's program
    _, dense = solve_loaded(system, state, 10.0, DENSE)
    assert_same_equilibrium(structured, dense, "cantilever")


def test_structured_default_is_the_dense_newton_on_m2_held():
    """M2 with the trolley held (cable, trolley, cabin; the Newton matrix bordered by
    the bodies, the sliding coordinate and the multipliers): the default and the dense-LU
    root finder reach the same equilibrium to round-off."""
    system, state = m2_model(hold=True).build()
    structured = solve_static(system, state)
    dense = solve_static(system, state, root_finder=DENSE)
    assert_same_equilibrium(structured, dense, "M2 held")


def test_regularization_keeps_a_free_rotation_solvable():
    """A wheel hinged at its centre to a cantilever tip: its rotation has neither
    stiffness nor load, so the Newton matrix is singular without the mass-proportional
    regularization; with it the solution is the linear tip deflection under the wheel's
    weight, δ = m g L³ / (3 EI) (δ/L ~ 7e-5: the nonlinearity is below 1e-8 relative).
    The beam is 1e8 times lighter than the wheel: the regularization of the beam chain,
    which the bordered solver factors alone (its rigid-body modes held by the clamp's
    multipliers only), must not vanish beside the wheel's mass."""
    L, ei, mass, g = 1.0, 5e3, 0.1, 9.81
    m = Model(gravity=(0.0, -g))
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), L, 4), Section(2e9, 1e-3, ei / 2e9, 1e-9))
    m.clamp("root", "beam", 0)
    m.add_body("wheel", mass=mass, inertia=1e-3, position=(L, 0.0))
    m.revolute("hinge", node("beam", -1), body_point("wheel"))
    system, state = m.build()
    sol = solve_static(system, state, load_steps=1)
    tip = np.asarray(system.beam_nodes(sol.state.q, 0))[-1]
    assert -tip[1] == pytest.approx(mass * g * L**3 / (3 * ei), rel=1e-6)
    with pytest.raises(StaticsError):
        solve_static(system, state, load_steps=1, regularization=0.0)


# ---------------------------------------------------------------------------- catenary
SPAN, L0, W, EA = 3.8, 4.02, 0.36, 60.0   # soft cable: ~1 % stretch, so extensibility shows


def elastic_catenary(s, h):
    """Position of the material point s of a symmetric elastic catenary (Irvine 1981)
    with Hooke's law T = EA ε, weight W per unstretched length, horizontal tension h."""
    u = W * (s - L0 / 2) / h
    u0 = W * L0 / (2 * h)
    x = h * s / EA + h / W * (np.arcsinh(u) + np.arcsinh(u0))
    y = W * (s**2 - L0 * s) / (2 * EA) + h / W * (np.sqrt(1 + u**2) - np.sqrt(1 + u0**2))
    return x, y


@pytest.fixture(scope="module")
def catenary():
    h = brentq(lambda h: elastic_catenary(L0, h)[0] - SPAN, 1e-3, 1e3, xtol=1e-14)
    out = {}
    for n in (8, 16):
        m = Model(gravity=(0.0, -9.81))
        # engineering strain |r'| − 1 is Hooke's law of the elastic catenary; EI → 0
        sec = Section(EA, 1.0, 1e-9, W / 9.81)
        m.add_beam("cable", mesh.straight((0, 0), (1, 0), L0, n), sec,
                   formulation=Formulation(axial_strain="engineering"),
                   initial_nodes=mesh.catenary_nodes((0, 0), (SPAN, 0), L0, n))
        m.pin("A", node("cable", 0))
        m.pin("B", node("cable", -1))
        system, state = m.build()
        sol = solve_static(system, state, load_steps=2)
        nodes = np.asarray(system.beam_nodes(sol.state.q, 0))
        s_nodes = np.asarray(system.beams[0].mesh.node_arc_lengths)
        out[n] = (nodes, s_nodes, np.asarray(sol.multipliers))
    return h, out


def test_hanging_cable_matches_elastic_catenary(catenary):
    h, out = catenary
    for n, tol in ((8, 2e-4), (16, 2e-5)):
        nodes, s, _ = out[n]
        x, y = elastic_catenary(s, h)
        err = np.max(np.hypot(nodes[:, 0] - x, nodes[:, 1] - y))
        assert err < tol, f"{n} elements: max node distance {err:.2e} m"
    # the stretch is visible: the inextensible sag would be off by far more
    nodes, s, lam = out[16]
    sag = -nodes[len(s) // 2, 1]
    sag_inext = -elastic_catenary(L0 / 2, brentq(lambda hh: elastic_catenary(L0, hh)[0] - SPAN, 1e-3, 1e3))[1]
    assert abs(sag - sag_inext) < 2e-5
    x_inext = mesh.catenary_nodes((0, 0), (SPAN, 0), L0, 16)
    assert np.max(np.abs(x_inext[:, 1] - nodes[:, 1])) > 1e-2


def test_hanging_cable_support_reactions(catenary):
    """The pin multipliers are the support reactions: horizontal H and half the weight."""
    h, out = catenary
    _, _, lam = out[16]
    # residual of pin A is r_A − a, so its multiplier is minus the force of the support
    assert abs(abs(lam[0]) - h) < 1e-4 * h
    np.testing.assert_allclose(abs(lam[1]) + abs(lam[3]), W * L0, rtol=1e-9)


def test_failure_names_the_load_step():
    system, state = cantilever(4)
    import equinox as eqx
    sys_k = eqx.tree_at(lambda s: s.forces[0].force, system, jnp.array([0.0, -10.0]))
    with pytest.raises(StaticsError, match=r"load step 1 of 2 \(load factor 0.5\).*residual") as err:
        solve_static(sys_k, state, load_steps=2, max_iterations=2)
    assert err.value.load_step == 0 and err.value.residual > 0


def test_cantilever_on_a_user_spring_is_euler_bernoulli():
    """Statics runs on the same structured Newton matrix as the time integration, force
    elements included: a clamped cantilever (L = 1 m, EI = 2 N·m²) with a user-written
    spring (a pure energy, k = 30 N/m) from its tip to the ground and a small tip load
    P. Linear Euler–Bernoulli: δ = P / (3EI/L³ + k), exact for cubic elements; the
    load is small (δ/L ~ 1e-4) so the geometric nonlinearity is below 1e-7 relative.
    Full Newton on the exact matrix converges in a few iterations."""
    import equinox as eqx

    from ancf_jax.points import BeamPoint, GroundPoint
    from tests.test_newton_matrix import CubicSpring

    L, ei, k, p = 1.0, 2.0, 30.0, 3.6e-3
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), L, 4), Section(2e9, 1e-3, ei / 2e9, 0.1))
    m.clamp("root", "beam", 0)
    m.point_force("load", node("beam", -1), (0.0, -p))
    system, state = m.build()
    spring = CubicSpring("spring", BeamPoint(0, jnp.asarray(L)), GroundPoint(jnp.array([L, -0.5])),
                         k, 0.0, 0.5)
    system = eqx.tree_at(lambda s: s.forces, system, tuple(system.forces) + (spring,))
    # the default root finder factors the bordered matrix (the spring an auxiliary
    # unknown of the border), not a dense one
    lam = jnp.zeros(system.n_constraints)
    shape = jax.eval_shape(lambda q: dae.iteration_matrix(system, q, q, lam, state.t, 0.0, 0.0,
                                                          system.constraint_jacobian(q, state.t)), state.q)
    assert shape.n_aux > 0 and isinstance(DEFAULTS.linear_solver.select(shape), BorderedChainSolver)
    # without beams there is no chain: the same choice is a dense LU (a rigid pendulum)
    from tests.dynamics import pendulum_model
    rigid, rigid_state = pendulum_model(0.3).build()
    lam = jnp.zeros(rigid.n_constraints)
    shape = jax.eval_shape(lambda q: dae.iteration_matrix(rigid, q, q, lam, 0.0, 0.0, 0.0,
                                                          rigid.constraint_jacobian(q, 0.0)), rigid_state.q)
    assert shape.chain_size == 0 and isinstance(DEFAULTS.linear_solver.select(shape), DenseLUSolver)
    sol = solve_static(system, state, load_steps=1, tolerance=1e-12)
    tip = np.asarray(system.beam_nodes(sol.state.q, 0))[-1]
    delta = p / (3 * ei / L**3 + k)
    assert -tip[1] == pytest.approx(delta, rel=1e-6)
    assert int(np.max(sol.iterations)) <= 4
