"""The Newton matrix is the linearization of the residual (issue 16).

:func:`ancf_jax.dae.iteration_matrix` assembles the matrix from element blocks,
constraint blocks and force-element blocks, each by autodiff of its own physics. The
independent reference here is a dense ``jax.jacfwd`` of the generalized-α residual of
the whole system along the correction Δq (q̈ = q̈⁰ + β' Δq, v = v⁰ + γ' Δq), at a
perturbed, moving, stressed state: both must agree to rounding for

* M1 (clamp, fixed joint, tip body) with Rayleigh β ≠ 0 (the ∂(βKv)/∂q term; β
  given at construction or set after the build) and a user-written nonlinear spring
  (a pure potential, no Jacobian) between a beam point and the ground, a built-in
  spring-damper between two beam points in different elements, and a point force on
  the tip body,
* M2 (sliding joint, revolute, two bodies),
* two wires in an interleaved chain joined by droppers (force elements between beams).

Then the point of it: with the user's spring in the matrix, Newton takes as few
iterations per step as with a built-in spring, where the old matrix (force elements
left out, :class:`WithoutTangent`) needs tens of times more.
"""

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax import dae
from ancf_jax.joints import AbstractConstraint
from ancf_jax.forces import AbstractConservativeForce, AbstractForce, PointForce, SpringDamper
from ancf_jax.models.m1 import m1_model
from ancf_jax.models.m2 import m2_model
from ancf_jax.points import BeamPoint, BodyPoint, GroundPoint


class CubicSpring(AbstractConservativeForce):
    """A hardening spring written as a pure energy: V = ½ k u² + ¼ k₃ u⁴, u = ℓ − ℓ₀."""

    a: BeamPoint
    anchor: GroundPoint
    k: float
    k3: float
    rest: float

    def potential(self, system, q, t):
        d = self.a.position(system, q) - self.anchor.position(system, q)
        u = jnp.sqrt(d @ d) - self.rest
        return 0.5 * self.k * u**2 + 0.25 * self.k3 * u**4

    def coordinates(self, system, q, t):
        return self.a.coordinates(system, q)


class WithoutTangent(AbstractForce):
    """The force of ``inner`` hidden from the Newton matrix where ``keep`` = 0 (data):
    autodiff then sees it as constant in q and v, so its local linearization
    (:func:`ancf_jax.forces.force_tangent`) is zero, as every force element's was before
    issue 16 (a negative control). ``keep`` = 1 is ``inner`` itself, value and
    derivatives (q₀ + (q − q₀) with q₀ = stop_gradient(q)): the force and its control
    share one compiled program."""

    inner: AbstractForce
    keep: jax.Array = eqx.field(default_factory=lambda: jnp.asarray(0.0))

    def potential(self, system, q, t):
        return self.inner.potential(system, q, t)

    def dissipative_force(self, system, q, v):
        return self.inner.dissipative_force(system, q, v)

    def applied_force(self, system, q, v, t):
        return self.inner.applied_force(system, q, v, t)

    def coordinates(self, system, q, t):
        return self.inner.coordinates(system, q, t)

    def generalized_force(self, system, q, v, t, load_factor=1.0):
        def seen(x):  # the value of x; its derivative scaled by keep
            x0 = jax.lax.stop_gradient(x)
            return x0 + self.keep * (x - x0)
        return self.inner.generalized_force(system, seen(q), seen(v), t, load_factor)


def m1(**overrides):
    """M1 (:func:`~ancf_jax.models.m1.m1_model`) as built: straight and at rest, its
    state satisfies the joints as given (``assemble=False`` leaves out the projection
    onto them, whose eager mass matrix is 2 s of op-by-op compilation; likewise for the
    pinned wires below)."""
    return m1_model(**overrides).build(assemble=False)


def with_forces(system, *forces):
    return eqx.tree_at(lambda s: s.forces, system, tuple(system.forces) + tuple(forces))


# One compiled program per system structure, shared by the tests (equinox caches
# filter_jit by function): the structured matrix, its dense form, the constraint
# Jacobian and the reference Jacobian.
iteration_matrix = eqx.filter_jit(dae.iteration_matrix)
effective_dense = eqx.filter_jit(lambda a: a.effective_dense())
constraint_jacobian = eqx.filter_jit(lambda system, q, t: system.constraint_jacobian(q, t))


def spring_system(beta_after_build=False):
    """M1 with Rayleigh β = 2e-4 s (at construction, or set after a build with β = 0:
    :func:`beta_set_after_build`), a user-written hardening spring, a built-in
    spring-damper between two beam points in different elements and a point force on
    the tip body."""
    system, state = beta_set_after_build() if beta_after_build else m1(beta=2e-4)
    f = [CubicSpring("user_spring", BeamPoint(0, jnp.asarray(0.25)), GroundPoint(jnp.array([0.25, -0.05])),
                     2.0e3, 1.0e7, 0.04),
         SpringDamper("sd", BeamPoint(0, jnp.asarray(0.03)), BeamPoint(0, jnp.asarray(0.33)),
                      jnp.asarray(500.0), jnp.asarray(2.0), jnp.asarray(0.29)),
         PointForce("push", BodyPoint(0, jnp.array([0.01, 0.0])), jnp.array([0.3, -0.2]))]
    return with_forces(system, *f), state


def residual_jacobian(system, q, v, qdd, lam, t, beta_p, gamma_p):
    """Dense Jacobian of the generalized-α residual along (Δq, λ), in solver order."""
    n = system.n_coordinates

    def residual(x):
        dq, lm = x[:n], x[n:]
        q1, v1, a1 = q + dq, v + gamma_p * dq, qdd + beta_p * dq
        phi, vjp = jax.vjp(lambda qq: system.constraint(qq, t), q1)
        r = system.mass_times(a1) - system.generalized_force(q1, v1, t) + vjp(lm)[0]
        return dae.to_solver_order(system, r, phi)

    x0 = jnp.concatenate([jnp.zeros(n), lam])
    jac = jax.jacfwd(residual)(x0)
    # columns in solver order too
    perm = np.concatenate([dae.solver_permutation(system), n + np.arange(lam.shape[0])])
    return jac[:, perm]


reference_jacobian = eqx.filter_jit(residual_jacobian)


def assert_matrix_is_the_jacobian(system, q, v, lam, t, beta_p=3.7e5, gamma_p=1.1e3):
    """The dense effective Newton matrix against :func:`residual_jacobian`, to rounding."""
    structured = effective_dense(iteration_matrix(system, q, v, lam, t, beta_p, gamma_p,
                                                  constraint_jacobian(system, q, t)))
    reference = reference_jacobian(system, q, v, jnp.zeros_like(q), lam, t, beta_p, gamma_p)
    scale = jnp.max(jnp.abs(reference))
    assert structured.shape == reference.shape
    np.testing.assert_allclose(structured / scale, reference / scale, rtol=0, atol=1e-13)


def perturbed(system, state, seed):
    key = jax.random.PRNGKey(seed)
    k1, k2, k3 = jax.random.split(key, 3)
    n = system.n_coordinates
    mask = ~np.asarray(system.inactive_mask())
    q = state.q + 1e-2 * jax.random.normal(k1, (n,)) * mask
    if system.n_sliding:
        q = q.at[system.sliding_offset:].set(state.q[system.sliding_offset:] + 0.05)
    v = 0.5 * jax.random.normal(k2, (n,)) * mask
    lam = jax.random.normal(k3, (system.n_constraints,))
    return q, v, lam


def beta_set_after_build():
    """M1 built with β = 0 (its β-rate switch off), then β = 2e-4 s set as the
    identification sets a fitted β."""
    from ancf_jax.identification.parameters import Parameter
    system, state = m1()
    assert not system.beams[0].rate_stiffness
    return Parameter("beta", "beta", "beam", 0).set(system, 2e-4), state


def pinned_wires(beta=1e-4):
    """A model of two 4 m wires of 8 elements, 1 m apart, pinned at both ends (Rayleigh
    ``beta`` [s] on the lower one)."""
    from ancf_jax import mesh
    from ancf_jax.model import Model, node
    from ancf_jax.section import Section
    m = Model(gravity=(0.0, -9.81))
    section = Section.from_stiffness(1e5, 10.0, 1.0)
    m.add_beam("contact", mesh.straight((0, 0), (1, 0), 4.0, 8), section, beta=beta)
    m.add_beam("messenger", mesh.straight((0, 1), (1, 0), 4.0, 8), section)
    for b in ("contact", "messenger"):
        m.pin(f"{b}.start", node(b, 0))
        m.pin(f"{b}.end", node(b, -1))
    return m


def two_wires(layout=None):
    """Two pinned wires one above the other joined by tension-only droppers at
    matching arc lengths (inside an element and at nodes) and a support spring: the
    droppers and the spring enter the chain (:func:`ancf_jax.model.chain_structure`).
    At the perturbed states of the tests some droppers are taut and some slack (seed 0:
    the first two taut, the third slack; it shares the messenger's node with the
    support spring)."""
    from ancf_jax.model import beam_point, ground
    m = pinned_wires()
    for i, s in enumerate((0.75, 1.5, 2.0)):
        m.spring_damper(f"dropper{i}", beam_point("contact", s), beam_point("messenger", s),
                        stiffness=1e3, damping=2.0, rest_length=0.99, acts="tension")
    m.spring_damper("support", beam_point("messenger", 2.0), ground(2.0, 1.5), stiffness=1e3)
    return m.build(layout=layout, assemble=False)


@pytest.fixture(scope="module")
def wires():
    """:func:`two_wires` in the interleaved chain (built once for the module)."""
    return two_wires()


def m2_released():
    """M2 (12 elements) released (the system of :func:`~ancf_jax.models.m2.m2_initial`),
    at its model's initial guess, the inextensible catenary: its static solve, 6 s of
    compilation, is left out, the state being perturbed anyway."""
    return m2_model(12, hold=False).build(assemble=False)


@pytest.mark.parametrize("case", ["m1_forces", "m1_beta_set", "m2", "two_wires"])
def test_iteration_matrix_is_the_jacobian_of_the_residual(case, request):
    """The cases of the module docstring; M1's β term is checked with its forces (β at
    construction, and β set after the build: one program)."""
    if case == "two_wires":
        from ancf_jax.linalg import InterleavedChain
        system, state = request.getfixturevalue("wires")
        assert isinstance(system.layout, InterleavedChain) and system.banded_forces == (0, 1, 2, 3)
    elif case == "m2":
        system, state = m2_released()
        assert system.n_sliding == 1
    else:
        system, state = spring_system(beta_after_build=case == "m1_beta_set")
        assert system.beams[0].rate_stiffness
    q, v, lam = perturbed(system, state, 0)
    assert_matrix_is_the_jacobian(system, q, v, lam, 0.1)


class BeamPointDistance(AbstractConstraint):
    """|r_a − r_b| − ℓ = 0 between two beam points: nonlinear in the beam coordinates,
    and not declared linear (the default of a user's joint)."""

    a: BeamPoint
    b: BeamPoint
    length: float
    size: ClassVar[int] = 1

    def residual(self, system, q, t):
        d = self.a.position(system, q) - self.b.position(system, q)
        return jnp.reshape(jnp.sqrt(d @ d) - self.length, (1,))


def test_joints_are_linear_in_the_beam_coordinates_or_named():
    """The Newton matrix leaves out the chain–chain block of (λ·Φ)_qq. The joints of M1
    (clamp, fixed joint), declared linear in the beam coordinates, have zero second
    derivative along a random beam direction at a perturbed state (those of M2, pins and
    the sliding joint, as well: there the matrix equals the residual's Jacobian); a distance
    joint has not (the check detects it), and the Newton matrix warns, naming it,
    rather than leave its Hessian out silently."""
    from ancf_jax.errors import InexactNewtonMatrixWarning
    from ancf_jax.joints import linear_in_beam_coordinates

    @eqx.filter_jit
    def curvature(system, q, w):  # d²Φ(q + εw)/dε², shape (m,)
        def slope(x):
            return jax.jvp(lambda z: system.constraint(z, 0.1), (x,), (w,))[1]
        return jax.jvp(slope, (q,), (w,))[1]

    from ancf_jax.integrators.generalized_alpha import APPROXIMATE_MATRIX_REFINEMENT, GeneralizedAlpha
    from ancf_jax.joints import nonlinear_joints

    system, state = m1()
    distance = BeamPointDistance("strut", BeamPoint(0, jnp.asarray(0.1)), BeamPoint(0, jnp.asarray(0.3)), 0.2)
    assert all(linear_in_beam_coordinates(c) for c in system.constraints)
    assert not linear_in_beam_coordinates(distance)
    # derivatives refine their tangent solves where the matrix leaves the joint's Hessian out
    assert GeneralizedAlpha().tangent_refinement(system) == 0 and nonlinear_joints(system) == ()
    system = eqx.tree_at(lambda s: s.constraints, system, (*system.constraints, distance))
    assert nonlinear_joints(system) == (distance,)
    assert GeneralizedAlpha().tangent_refinement(system) == APPROXIMATE_MATRIX_REFINEMENT
    q, _, _ = perturbed(system, state, 5)
    w = jnp.zeros_like(q).at[system.chain_indices()].set(
        jax.random.normal(jax.random.PRNGKey(6), (system.chain_size,)))
    h = np.abs(np.asarray(curvature(system, q, w)))
    assert h[:-1].max() < 1e-12 and h[-1] > 1e-3, h
    with pytest.warns(InexactNewtonMatrixWarning, match="joint 'strut' .BeamPointDistance. is not declared linear"):
        jax.eval_shape(lambda x: dae.iteration_matrix(system, x, x, jnp.zeros(system.n_constraints), 0.1, 1.0, 1.0,
                                                      system.constraint_jacobian(x, 0.1)), q)  # traced only


def test_rate_stiffness_switch():
    """The β-rate term β ∂(K ė)/∂e is a static switch of each beam: on where β ≠ 0 at
    construction or β is set by the identification; off, the element tangent is
    K (1 + γ' β) and differs from the exact one by that term (so the exact matrix
    really holds it). Systems with the switch on and off batch together (set on for
    all), and a sweep over β does not count it as a change of shape."""
    from ancf_jax.simulation import harmonize_rate_stiffness
    from ancf_jax.sweep.runner import _signature
    system, state = beta_set_after_build()
    assert system.beams[0].rate_stiffness

    @eqx.filter_jit
    def tangents(beam, nodes, vel):  # one program (eagerly, 4 s of op-by-op dispatch)
        off = beam.with_rate_stiffness(False)
        return (beam.element_tangent(nodes, vel, 1.1e3), off.element_tangent(nodes, vel, 1.1e3),
                beam.element_stiffness(nodes))

    nodes = system.beam_nodes(state.q, 0) + 1e-2
    exact, off, stiffness = tangents(system.beams[0], nodes, jnp.ones_like(nodes))
    np.testing.assert_allclose(off, stiffness * (1 + 1.1e3 * 2e-4), rtol=1e-14)
    assert float(jnp.max(jnp.abs(exact - off))) > 1e-6 * float(jnp.max(jnp.abs(exact)))
    zero, _ = m1()
    a, b = harmonize_rate_stiffness([zero, system])
    assert jax.tree.structure(a) == jax.tree.structure(b) and a.beams[0].rate_stiffness
    assert _signature(zero, state) == _signature(system, state)


def test_low_rank_border_solves_like_dense():
    """Solves and products of a matrix with auxiliary unknowns equal those of the
    dense effective matrix (chain solver and dense LU)."""
    from ancf_jax.linalg import factor_saddle, solve_saddle
    system, state = spring_system()
    q, v, lam = perturbed(system, state, 1)
    a = iteration_matrix(system, q, v, lam, 0.1, 3.7e5, 1.1e3, constraint_jacobian(system, q, 0.1))
    assert a.n_aux == 8 + 16 + 3
    dense = effective_dense(a)
    r = jax.random.normal(jax.random.PRNGKey(3), (a.size,))
    x_ref = jnp.linalg.solve(dense, r)
    for use_dense in (False, True):
        x = solve_saddle(factor_saddle(a, dense=use_dense), r)
        np.testing.assert_allclose(x, x_ref, rtol=1e-9, atol=1e-12 * float(jnp.max(jnp.abs(x_ref))))
    np.testing.assert_allclose(a.matvec(x_ref), r, atol=1e-9 * float(jnp.max(jnp.abs(r))))


def test_banded_force_elements_leave_the_border(wires):
    """With the droppers in the interleaved chain the border holds only the pins'
    multipliers (no auxiliary unknowns) and solves equal a dense solve; the sequential
    layout keeps them as 3 × 16 auxiliary unknowns (the support spring, on one beam, is
    banded in both). The interleaved matrix is the program of
    test_iteration_matrix_is_the_jacobian_of_the_residual[two_wires]."""
    from ancf_jax.linalg import SequentialChain, factor_saddle, solve_saddle
    for (system, state), n_aux in ((wires, 0), (two_wires(SequentialChain()), 48)):
        q, v, lam = perturbed(system, state, 2)
        a = iteration_matrix(system, q, v, lam, 0.1, 3.7e5, 1.1e3, constraint_jacobian(system, q, 0.1))
        assert a.n_aux == n_aux and a.e.shape[0] == n_aux + system.n_constraints
        r = jax.random.normal(jax.random.PRNGKey(4), (a.size,))
        x_ref = jnp.linalg.solve(effective_dense(a), r)
        x = solve_saddle(factor_saddle(a), r)
        np.testing.assert_allclose(x, x_ref, rtol=1e-8, atol=1e-11 * float(jnp.max(jnp.abs(x_ref))))


def iterations_per_step(system, state, t_end=0.02, dt=1e-3):
    from ancf_jax.simulation import simulate
    res = simulate(system, state, t_end=t_end, dt=dt, output_dt=t_end, progress=False)
    assert res.status == "ok", res.status
    return float(np.sum(res.iterations)) / round(t_end / dt)


def test_user_spring_converges_as_fast_as_a_built_in_one():
    """A stiff hardening spring (k = 2e4 N/m, k₃ = 1e10 N/m³, well above the inertia
    term β'm of the element it holds) written as a pure energy: with its exact local
    linearization in the Newton matrix, steps take as many iterations as with the
    built-in :class:`~ancf_jax.forces.SpringDamper` of the same k and rest length
    (measured 4.15 and 4.15 per step over the first 20 steps). Negative control: the same
    law with its tangent left out of the matrix (the solver before issue 16) contracts
    at ~k/(k + β'm) per iteration (measured 228 per step). One system holds both
    springs, the user's in :class:`WithoutTangent`; each run switches one on by data
    (the other's stiffness zero: no force, no tangent) and ``keep`` hides the user's
    tangent or not: the three runs are one program."""
    base, state = m1()
    point, anchor = BeamPoint(0, jnp.asarray(0.25)), GroundPoint(jnp.array([0.25, -0.05]))
    spring = CubicSpring("user_spring", point, anchor, jnp.asarray(2.0e4), jnp.asarray(1.0e10), 0.05)
    built_in = SpringDamper("spring", point, anchor, jnp.asarray(2.0e4), jnp.asarray(0.0), jnp.asarray(0.05))
    both = with_forces(base, WithoutTangent("user_spring", spring, jnp.asarray(1.0)), built_in)

    def iterations(user, keep=1.0):
        """Newton iterations per step with the user's spring (``user``) or the built-in one."""
        on = jnp.asarray(float(user)), jnp.asarray(float(not user))
        system = eqx.tree_at(lambda s: (s.forces[-2].keep, s.forces[-2].inner.k, s.forces[-2].inner.k3,
                                        s.forces[-1].stiffness),
                             both, (jnp.asarray(keep), 2.0e4 * on[0], 1.0e10 * on[0], 2.0e4 * on[1]))
        return iterations_per_step(system, state)

    n_user, n_built_in = iterations(user=True), iterations(user=False)
    assert n_user <= n_built_in + 0.05, (n_user, n_built_in)
    n_left_out = iterations(user=True, keep=0.0)
    assert n_left_out > 10 * n_user, (n_left_out, n_user)


#: the nodes and damping [N·s/m] of the droppers of :func:`wires_with_sets`
SET_NODES, SET_DAMPING = (1, 3, 4, 6), (2.0, 1.0, 0.5, 3.0)


def wires_with_sets(beta=1e-4, as_set=True, support=True):
    """two_wires' droppers (at nodes, tension-only) and support spring (``support``) as
    vectorized sets (:class:`~ancf_jax.forces.NodeSpringSet`), or (``as_set=False``) as
    separate elements: (system, state)."""
    from ancf_jax.model import ground, node
    m = pinned_wires(beta)
    ends = {f"d{i}": (node("contact", n), node("messenger", n)) for i, n in enumerate(SET_NODES)}
    if as_set:
        m.spring_damper_set("droppers", ends, stiffness=1e3, damping=SET_DAMPING, rest_length=0.99, acts="tension")
        if support:
            m.spring_damper_set("supports", {"s": (ground(2.0, 1.5), node("messenger", 4))}, stiffness=1e3,
                                rest_length=0.5)
    else:
        for (name, (a, b)), c in zip(ends.items(), SET_DAMPING):
            m.spring_damper(name, a, b, stiffness=1e3, damping=c, rest_length=0.99, acts="tension")
        m.spring_damper("s", ground(2.0, 1.5), node("messenger", 4), stiffness=1e3, rest_length=0.5)
    return m.build(assemble=False)


def test_a_spring_set_is_its_members():
    """The droppers and the support spring of two_wires as vectorized sets
    (:class:`~ancf_jax.forces.NodeSpringSet`): generalized force, potential, kinks and
    member forces equal those of the separate elements, and the Newton matrix (one
    local block per member, in the interleaved chain) is the Jacobian of the residual."""
    from ancf_jax.forces import kink_values

    @eqx.filter_jit
    def forces_of(system, q, v, t):  # one program per system, not hundreds of eager ops
        return system.generalized_force(q, v, t), system.force_potential(q, t), kink_values(system, q, v)

    (system, state), (separate, _) = wires_with_sets(), wires_with_sets(as_set=False)
    assert system.banded_forces == (0, 1)
    q, v, lam = perturbed(system, state, 3)
    t = 0.1
    (force, potential, kinks), (force_ref, potential_ref, kinks_ref) = (forces_of(s, q, v, t)
                                                                         for s in (system, separate))
    np.testing.assert_allclose(force, force_ref, rtol=0, atol=1e-12)
    assert float(potential) == pytest.approx(float(potential_ref), rel=1e-14)
    np.testing.assert_allclose(np.sort(kinks), np.sort(kinks_ref), atol=1e-12)
    tensions = system.forces[0].member_forces(system, q, v)
    np.testing.assert_allclose(tensions, [float(f.tension(separate, q, v)) for f in separate.forces[:4]], atol=1e-10)
    assert_matrix_is_the_jacobian(system, q, v, lam, t)


@pytest.mark.study
def test_the_interleaved_solver_runs_under_grad():
    """The multi-beam solver (two wires in an interleaved chain with a set of
    tension-only droppers, the set of :func:`wires_with_sets`) under jax.grad, as the
    chain solver: the derivative of the contact wire's height at 2 m after 50 steps
    with respect to one dropper's stiffness against central finite differences of the
    same runs at a relative step of 1e-3 (agreement to 1.0e-7 measured: the
    differences' truncation error, 1.0e-5 at a step of 1e-2, second order; the bound
    1e-5 tells a wrong derivative apart). Its vmap against single runs: the speed
    batch of the catenary, an interleaved chain with droppers
    (tests/test_catenary.py). Rayleigh β and the support spring (a force on one beam,
    3 s of compilation) left out and the droppers as one set: a smaller program to
    compile."""
    from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha
    from ancf_jax.linalg import InterleavedChain
    from ancf_jax.simulation import trajectory
    system, state = wires_with_sets(beta=0.0, support=False)
    assert isinstance(system.layout, InterleavedChain) and system.banded_forces == (0,)
    solver = GeneralizedAlpha()

    def run(k):
        s = eqx.tree_at(lambda s: s.forces[0].stiffness, system, system.forces[0].stiffness.at[1].set(k))
        seg, loop = trajectory(s, state, solver, t_end=0.05, dt=1e-3)
        return system.beam_nodes(seg.q[-1], 0)[4, 1], loop.status  # node 4: s = 2 m

    k0, e = 1e3, 1.0
    value_and_grad = jax.jit(jax.value_and_grad(run, has_aux=True))
    ((_, s0), g), ((yp, sp), _), ((ym, sm), _) = (value_and_grad(jnp.asarray(k)) for k in (k0, k0 + e, k0 - e))
    assert int(s0) == int(sp) == int(sm) == 0
    fd = (float(yp) - float(ym)) / (2 * e)
    assert abs(float(g) - fd) < 1e-5 * abs(fd) and abs(fd) > 1e-8, (float(g), fd)


def wires_in_groups(count=3):
    """``count`` pinned 4 m wires 1 m apart: the first two alike (8 element slots each,
    the second with 7 elements padded to 8, other α and β: one group of like beams), the
    third of 6 elements (a group of its own)."""
    from ancf_jax import mesh
    from ancf_jax.model import Model, node
    from ancf_jax.section import Section
    m = Model(gravity=(0.0, -9.81))
    section = Section.from_stiffness(1e5, 10.0, 1.0)
    for name, y, n, alpha, beta in (("a", 0.0, 8, 0.3, 1e-4), ("b", 1.0, 7, 0.7, 3e-4),
                                    ("c", 2.0, 6, 0.5, 2e-4))[:count]:
        m.add_beam(name, mesh.straight((0, y), (1, 0), 4.0, n), section, alpha=alpha, beta=beta)
        m.pin(f"{name}.start", node(name, 0))
        m.pin(f"{name}.end", node(name, -1))
    return m.build(assemble=False, pad_to={"b": 8} if count > 1 else None)


def test_like_beams_are_evaluated_together():
    """Beams of one structure and shapes are stacked and evaluated in one vectorized
    evaluation (:meth:`~ancf_jax.system.System.map_beams`): forces, strain energy and
    the Newton matrix's beam blocks equal those of each beam evaluated alone (its own
    α, β, nodes and active elements, one of the pair padded: a mix-up within the group
    would show), and the program holds the
    element code once per group: the beam forces of two like beams lower to under 1.5
    times the StableHLO of one beam's (measured 1.17; evaluated beam by beam 1.93)."""
    from ancf_jax.linalg import BlockTridiagonal
    system, state = wires_in_groups()
    assert system.beam_groups() == ((0, 1), (2,))
    q, v, lam = perturbed(system, state, 1)
    beta_p, gamma_p = 3.7e5, 1.1e3

    @eqx.filter_jit
    def grouped(system, q, v, lam):
        a = dae.iteration_matrix(system, q, v, lam, 0.1, beta_p, gamma_p, system.constraint_jacobian(q, 0.1))
        return system._beam_forces(q, v), system.strain_energy(q), a.chain

    @eqx.filter_jit
    def alone(system, q, v):
        elastic, damping, energy, blocks = jnp.zeros_like(q), jnp.zeros_like(q), 0.0, []
        for i, b in enumerate(system.beams):
            nodes, vel = system.beam_nodes(q, i), system.beam_nodes(v, i)
            f, minus_kv = jax.jvp(b.elastic_force, (nodes,), (vel,))
            sl = slice(system.beam_offset(i), system.beam_offset(i) + b.n_coordinates)
            elastic = elastic.at[sl].set(f.ravel())
            # the beam mass holds a unit dummy mass on padding nodes, which carry no damping
            m = b.mass().add_diagonal(-jnp.repeat(jnp.where(b.mesh.active_nodes, 0.0, 1.0), 4))
            damping = damping.at[sl].set(-b.alpha * m.matvec(vel.ravel()) + b.beta * minus_kv.ravel())
            energy = energy + b.strain_energy(nodes)
            blocks.append(b.mass().scale(beta_p + b.alpha * gamma_p)
                          + BlockTridiagonal.from_element_matrices(b.element_tangent(nodes, vel, gamma_p)))
        return (elastic, damping), energy, system.layout.assemble(blocks)

    got, ref = grouped(system, q, v, lam), alone(system, q, v)
    for g, r in zip(jax.tree.leaves(got), jax.tree.leaves(ref)):
        np.testing.assert_allclose(g, r, rtol=1e-13, atol=1e-13 * float(jnp.max(jnp.abs(r))))

    def lines(s):
        z = jnp.zeros(s.n_coordinates)
        return eqx.filter_jit(lambda s, q, v: s._beam_forces(q, v)).lower(s, z, z).as_text().count("\n")

    two, one = wires_in_groups(2)[0], wires_in_groups(1)[0]
    assert two.beam_groups() == ((0, 1),)
    assert lines(two) < 1.5 * lines(one), (lines(two), lines(one))
