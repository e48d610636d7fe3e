"""Generalized-α for constrained mechanical systems (Arnold & Brüls 2007), index 3.

The method for stiff structural dynamics with joints, as in Exudyn and Chrono. With
spectral radius at infinity ρ∞ ∈ [0, 1]:

    α_m = (2ρ∞ − 1)/(ρ∞ + 1),  α_f = ρ∞/(ρ∞ + 1),  γ = ½ + α_f − α_m,  β = ¼ (γ + ½)²

and per step, with q̈ the true and a the pseudo-acceleration,

    (1 − α_m) a_{n+1} + α_m a_n = (1 − α_f) q̈_{n+1} + α_f q̈_n
    v_{n+1} = v_n + h (1 − γ) a_n + h γ a_{n+1}
    q_{n+1} = q_n + h v_n + h² (½ − β) a_n + h² β a_{n+1}
    M q̈_{n+1} + Φ_q(q_{n+1})ᵀ λ_{n+1} = Q(q_{n+1}, v_{n+1}, t_{n+1}),   Φ(q_{n+1}, t_{n+1}) = 0.

The nonlinear equations are solved for the correction u = Δq of the positions from
the predictor (q̈_{n+1} = q̈_n + β' u, β' = (1 − α_m)/(h² β (1 − α_f)), γ' = γ/(h β))
and λ_{n+1} by the root finder (:class:`~ancf_jax.newton.ModifiedNewton`, default:
modified Newton with refreshes) on the exact Newton matrix
[[M β' + C γ' + K, Φ_qᵀ], [Φ_q, 0]] of the residual, elastic, damping, constraint and
force-element terms included (:func:`ancf_jax.dae.iteration_matrix`), factored by its
linear solver (:class:`~ancf_jax.linalg.AbstractSaddleSolver`; default: chosen from the
structure, the bordered block-tridiagonal solver for beams).

Large steps of a stiff cable (M1 at h = 5 ms): the predictor is millimetres off, the
matrix factored there contracts slowly, steps run out of iterations and are redone in
substeps; ``ModifiedNewton(refresh_first=True, contraction=0.1)`` converges in about
5 iterations per step without a failed step. At small steps (M1 at 1 ms: 2 iterations)
it only adds factorizations, so it is off by default. The default block-tridiagonal
solver (4×4 node blocks inverted by cofactors, no LAPACK calls) is also the faster one
for small unbatched systems since 2026-12-05 (M1, 38 unknowns: 0.061 against 0.070 s
for 0–2 s with ``DenseLUSolver``; M2: 0.40 against 0.63 s for 0–3 s;
``benchmarks/single_run.py`` tries both); ``DenseLUSolver`` serves GPU batches.

Reuse of the Newton matrix (``factor_reuse``). :class:`PerStep` (default) forms and
factors the matrix at the first iterate of every step. :class:`AcrossSteps` starts each
step from the factors the previous step ended with, kept in the carry
(:attr:`~ancf_jax.integrators.base.Carry.memory`, a :class:`FactorMemory`, fixed
shapes: jit, vmap and checkpoints keep it), as Exudyn's modified Newton does: modified
Newton converges to the same root with a stale matrix, only more slowly. The factors
are made anew at the first iterate when the step differs from theirs (β' ∝ 1/h² and
γ' ∝ 1/h are in the matrix: the first step, a retry in substeps and the step back to
h, the substeps of a located crossing), when they have served ``max_age`` steps, and
within a step by the root finder's rules (a correction shrinking by less than
``contraction``, ``refresh_every``). Each solve still stops when its correction is
below the tolerance while contracting by ρ ≤ ``contraction``, so the solution differs
from the per-step one by the Newton error (≤ tol·ρ/(1 − ρ) per step). Derivatives are
unchanged: the tangent systems of the implicit differentiation are factored at the
initial iterate of each step as without reuse. Measured
(``python -m benchmarks.pantograph_catenary reuse``: h = 1 ms, 200 steps, interleaved,
best of 5, ``benchmarks/results/pantograph_catenary.json``): the 2-span pantograph–catenary (1,937 coordinates, taut wires moving little per step)
factors 0.185 times per step at 5.0 instead of 3.3 Newton iterations, 4.5 instead of
6.6 ms per step (2026-12-05; 7.6 and 11.6 before the block inverses without LAPACK), 5e-11 m from the per-step run (``max_age`` 64: the same, its
refreshes come from slow contraction); M1 (a stiff wire swinging through large
rotations) at h = 1.25 ms, 0–2 s (interleaved in one process, best of 9) needs more
than one factorization per step either way (1.35 at 5.2 iterations instead of 1 at 3.9)
and runs 1.07–1.2× slower with reuse, so reuse is opt-in. What remained of the catenary's step then was mostly the iterations and the velocity
projection below (2.0 of its 7.2 ms, best of 4), now off by default.

Positions satisfy Φ = 0 to the Newton tolerance at every step (index 3); the
velocities satisfy Φ_q v + Φ_t = 0 to the order of the method. With
``velocity_projection=True`` they are also projected onto it after every step in the
mass metric (one more saddle-point factorization per step, at the new Φ_q). Off by
default: it buys no accuracy in any model measured
(``python -m benchmarks.velocity_projection``, ``benchmarks/results/velocity_projection.md``:
M1, M2 and H1 at three steps and the reduced pantograph–catenary at two, against a
converged reference of the same mesh, the compared output changes by at most 0.5 % of
the run's error (M2 at h = 2 ms: 6.6e-7 m of 1.2e-4 m; M2 at 1 and 0.5 ms: 3e-4 and 2e-4 of it; M1,
H1 and the catenary: under 1e-7 of it), the
multipliers (joint reactions) by at most 5 % of theirs (M2 at 2 ms: 1.2 % of the
largest reaction, whose error there is 27 %); it costs 13–29 % of the run in 11 of
12 timed rows (one within the timing noise). Without it the velocity constraints are violated by
O(h) to O(h²) (M1 at h = 1.25 ms: 3.4e-4 m/s; M2 at 1 ms: 6.9e-4 m/s), without
accumulating; Exudyn has no such projection either.

Constraint level (``constraints``): :class:`PositionLevel` (default, index 3) solves
Φ(q_{n+1}, t_{n+1}) = 0 with the equations of motion; :class:`VelocityLevel` (index 2,
Exudyn's ``useIndex2Constraints``) solves Φ̇ = Φ_q(q_{n+1}) v_{n+1} + Φ_t = 0 instead, so
velocities satisfy the velocity constraints and positions drift off Φ = 0 at the
method's order. At ρ∞ = 1 (α_m = α_f = ½, γ = ½, β = ¼) both are the trapezoidal rule.
The index-2 row is scaled by 1/γ' so that its Newton-matrix block is Φ_q, as at index 3
(the matrix and its solvers are shared); the term (Φ_q v)_q/γ' = O(h) of its exact
derivative is left out, which keeps the converged solution and makes Newton contract
at a rate O(h) instead of quadratically. Measured on a rigid pendulum at ρ∞ = 1
(``tests/integrators/test_integrators.py``): second order in θ and in the drift |Φ|
(4.8e-5 m at h = 4 ms to 7.4e-7 m at 0.5 ms over 1 s), above the loop's default
``RunOptions.drift_tolerance`` (1e-6 m) at common steps, so index-2 runs raise it.

Differentiable: the root finder's :meth:`~ancf_jax.newton.ModifiedNewton.root` gives
the Newton solve a custom JVP, so ``jax.grad`` and ``jax.jvp`` of a trajectory
differentiate the converged equations (implicit function theorem) rather than the
iterations. The tangent systems are solved with the Newton matrix factored at the
step's solution. At index 3 that matrix is made the exact Jacobian of the step residual:
where a beam's matrix leaves out its β-rate term (not
:attr:`~ancf_jax.beam.Beam.exact_tangent`: a β set after the build without
:meth:`~ancf_jax.system.System.with_rate_stiffness`, the fastest forward iteration),
the tangent solves factor the matrix of :meth:`GeneralizedAlpha.tangent_system`, which
has it, while the forward iteration keeps its cheaper matrix; one solve is then the
exact tangent (``refinement`` None: 0; ``tests/test_simulation.py`` checks M1's
gradient against central differences). At index 2, whose matrix leaves out an O(h)
term (and with a joint not declared linear in the beam coordinates, whose chain–chain
Hessian the matrix leaves out), :data:`APPROXIMATE_MATRIX_REFINEMENT` steps of iterative
refinement against the residual's exact linearization make up the difference; an explicit ``refinement``
refines the iteration's own matrix instead. Measured on M1's damping loss
(``python -m benchmarks.gradient``, β set after the build, 0–2 s, 2-core AMD EPYC,
2026-12-07, interleaved in one process; three runs, the machine's speed varying between
them): value and gradient 3.1–5.1× a forward run with the exact tangent matrix (7e-12 off
the gradient of 8 refinement steps), 2.8–4.6× with the iteration's matrix and one
refinement step (1.2e-7 off), 3.5–5.3× with 4 (the default until 2026-12-07), 4.0–5.6×
with 8; forward mode (a JVP per parameter) 2.7–5.1×; with the β-rate
term in the forward iteration's matrix too, the forward run took 2.3× longer (53
against 23 ms for 0–1 s; measured before that term's element tangent became one Hessian,
2026-12-07). Until 2026-12-05 the matrix was factored at the predictor,
and the step sat in a conditional that reverse mode copied every residual through: 6.9×
at 2 refinement steps."""

from __future__ import annotations

import abc
import dataclasses
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import dae
from ..joints import nonlinear_joints
from ..newton import ModifiedNewton
from ..validation import check_count
from .base import AbstractIntegrator, AbstractMemory, Carry, StepInfo


#: iterative-refinement steps of the tangent solves of derivatives where the Newton
#: matrix is not the exact Jacobian of the step residual (index 2; a joint not
#: declared linear in the beam coordinates); with the matrix of a beam whose β-rate
#: term is left out, 4 steps reached the 8-step gradient of M1's damping loss to 4.5e-14
#: (``python -m benchmarks.gradient``)
APPROXIMATE_MATRIX_REFINEMENT = 4


class AbstractConstraintLevel(eqx.Module):
    """Which constraint equations a generalized-α step solves with the equations of
    motion (module docstring)."""

    index: eqx.AbstractClassVar[int]
    #: iterative-refinement steps the tangent solves of derivatives need: 0 where the
    #: step's Newton matrix is the exact Jacobian of its residual (module docstring)
    refinement: eqx.AbstractClassVar[int]

    @abc.abstractmethod
    def residual(self, system, q, v, t, gamma_p):
        """The constraint rows of the step residual at (q_{n+1}, v_{n+1}, t_{n+1}),
        shape (m,), scaled so that their derivative by the position correction is Φ_q
        (up to terms of order h); ``gamma_p`` = ∂v_{n+1}/∂q_{n+1} = γ/(h β) [1/s]."""


class PositionLevel(AbstractConstraintLevel):
    """Index 3: Φ(q_{n+1}, t_{n+1}) = 0 [m] (the default)."""

    index: ClassVar[int] = 3
    refinement: ClassVar[int] = 0

    def residual(self, system, q, v, t, gamma_p):
        return system.constraint(q, t)


class VelocityLevel(AbstractConstraintLevel):
    """Index 2: Φ̇(q_{n+1}, v_{n+1}, t_{n+1}) = Φ_q v + Φ_t = 0, scaled by 1/γ' [m]
    (Exudyn's ``useIndex2Constraints``)."""

    index: ClassVar[int] = 2
    refinement: ClassVar[int] = APPROXIMATE_MATRIX_REFINEMENT

    def residual(self, system, q, v, t, gamma_p):
        return system.constraint_velocity(q, v, t) / gamma_p


#: constraint levels by index, for flat options (``index = 2`` or ``3``)
CONSTRAINT_LEVELS = {3: PositionLevel, 2: VelocityLevel}


class FactorMemory(AbstractMemory):
    """The Newton-matrix factors a step leaves to the next (:class:`AcrossSteps`),
    held in :attr:`~ancf_jax.integrators.base.Carry.memory`.

    Attributes:
        factors: factors of the Newton matrix (``linear_solver.init``'s pytree).
        h: the step they were made for [s] (β', γ' depend on it; NaN: none yet, or
            invalid).
        age: steps that have used them, the one that made them included (int).
        factorizations: factorizations of the Newton matrix since the run began (int;
            a diagnostic).
    """

    factors: object
    h: jnp.ndarray
    age: jnp.ndarray
    factorizations: jnp.ndarray

    def select(self, keep, old):
        """The factors of a discarded step are kept as well, but marked invalid (h NaN:
        the next step factors anew at its first iterate), so that the megabytes of
        factors are never copied by a select (:func:`~ancf_jax.integrators.base.select_carry`).
        A discarded step is retried with a smaller step (which refactored before as
        well: the same solution), or the run stops or ends (a checkpoint then continues
        to the Newton tolerance, not bit for bit: :class:`~ancf_jax.integrate.Checkpoint`)."""
        return FactorMemory(self.factors, jnp.where(keep, self.h, jnp.nan),
                            jnp.where(keep, self.age, old.age),
                            jnp.where(keep, self.factorizations, old.factorizations))


class AbstractFactorReuse(eqx.Module):
    """Where a generalized-α step gets the factors of its Newton matrix from (module
    docstring, "Reuse of the Newton matrix")."""

    @abc.abstractmethod
    def initial(self, factor_shape) -> FactorMemory | None:
        """The memory of a run's first step (None: nothing carried); ``factor_shape()``
        gives the shapes and dtypes of the factors (:func:`jax.eval_shape`; called only
        by a policy that carries them, as it traces the Newton matrix)."""

    @abc.abstractmethod
    def start(self, memory: FactorMemory | None, h):
        """(factors to start from or None, whether to factor at the first iterate)."""

    @abc.abstractmethod
    def update(self, memory: FactorMemory | None, solution, h) -> FactorMemory | None:
        """The memory after a step of size h whose Newton solve returned ``solution``."""


class PerStep(AbstractFactorReuse):
    """Factor at the first iterate of every step, and nothing carried (the default)."""

    def initial(self, factor_shape):
        return None

    def start(self, memory, h):
        return None, True

    def update(self, memory, solution, h):
        return None


class AcrossSteps(AbstractFactorReuse):
    """Start every step from the factors the previous step ended with; factor anew at
    the first iterate when the step size differs from theirs (a retry in substeps, a
    located crossing, the first step) or when they have served ``max_age`` steps.
    Within a step the root finder's refresh rules apply as ever (slow contraction,
    ``refresh_every``). ``AcrossSteps(max_age=1)`` is :class:`PerStep`.

    Attributes:
        max_age: most steps one factorization serves (integer >= 1).

    Raises:
        ModelError: ``max_age`` out of its range (on construction).
    """

    max_age: int = eqx.field(static=True, default=16)

    def __check_init__(self):
        check_count("max_age", self.max_age, 1)

    def initial(self, factor_shape):
        zeros = jax.tree.map(lambda a: jnp.zeros(a.shape, a.dtype), factor_shape())
        none = jnp.zeros((), jnp.int32)
        return FactorMemory(zeros, jnp.array(jnp.nan), none, none)

    def start(self, memory, h):
        return memory.factors, (memory.h != h) | (memory.age >= self.max_age)

    def update(self, memory, solution, h):
        made = solution.factorizations > 0
        return FactorMemory(solution.factors, jnp.asarray(h, memory.h.dtype),
                            jnp.where(made, 1, memory.age + 1).astype(jnp.int32),
                            memory.factorizations + solution.factorizations)


class GeneralizedAlpha(AbstractIntegrator):
    """Generalized-α (Arnold & Brüls 2007) at a fixed step.

    Attributes:
        rho_inf: spectral radius at infinite frequency (1: no numerical damping,
            0: maximal). Default 0.9, as Exudyn's default.
        root_finder: the Newton solver of every step (tolerance on the position
            correction, refresh policy, linear solver).
        velocity_projection: project v onto the velocity constraints after each step
            (default off: module docstring).
        refinement: iterative-refinement steps of the tangent solves (derivatives;
            integer >= 0), with the iteration's own Newton matrix; None: as many as
            the tangent matrix needs (:meth:`tangent_refinement`: 0 at index 3, whose
            tangent matrix is exact, :meth:`tangent_system`).
        implicit_diff: differentiate the converged step equations (implicit function
            theorem) instead of the Newton iterations.
        constraints: the constraint level, :class:`PositionLevel` (index 3, default)
            or :class:`VelocityLevel` (index 2).
        factor_reuse: where a step's Newton-matrix factors come from,
            :class:`PerStep` (default) or :class:`AcrossSteps` (module docstring).
    """

    rho_inf: float = eqx.field(static=True, default=0.9)
    root_finder: ModifiedNewton = ModifiedNewton()
    velocity_projection: bool = eqx.field(static=True, default=False)
    refinement: int | None = eqx.field(static=True, default=None)
    implicit_diff: bool = eqx.field(static=True, default=True)
    constraints: AbstractConstraintLevel = PositionLevel()
    factor_reuse: AbstractFactorReuse = PerStep()

    @property
    def name(self) -> str:
        return "generalized-alpha"

    @property
    def order(self) -> int:
        return 2

    @property
    def linear_solver(self):
        """The linear solver of the root finder (also used by the initial accelerations
        and the velocity projection)."""
        return self.root_finder.linear_solver

    def tangent_refinement(self, system) -> int:
        """Iterative-refinement steps of the tangent solves for ``system``:
        ``refinement``, or when None the constraint level's (0 at index 3, where the
        tangent matrix is exact: :meth:`tangent_system`), and at least
        :data:`APPROXIMATE_MATRIX_REFINEMENT` where a joint is not declared linear in
        the beam coordinates (its chain–chain Hessian is not in the matrix:
        :func:`ancf_jax.joints.linear_in_beam_coordinates`)."""
        if self.refinement is not None:
            return self.refinement
        if nonlinear_joints(system):
            return max(self.constraints.refinement, APPROXIMATE_MATRIX_REFINEMENT)
        return self.constraints.refinement

    def tangent_system(self, system):
        """The system whose Newton matrix the tangent solves of derivatives factor, or
        None where that is ``system``'s own: with ``refinement`` None, ``system`` with
        the β-rate term in the matrix of every beam that leaves it out (not
        :attr:`~ancf_jax.beam.Beam.exact_tangent`, e.g. β set after the build), so
        that at index 3 one solve gives the exact tangent while the forward iteration
        keeps its cheaper matrix (module docstring)."""
        if self.refinement is not None or all(b.exact_tangent for b in system.beams):
            return None
        return system.with_rate_stiffness([b.rate_stiffness or not b.exact_tangent for b in system.beams])

    @property
    def coefficients(self):
        r = self.rho_inf
        am = (2.0 * r - 1.0) / (r + 1.0)
        af = r / (r + 1.0)
        gamma = 0.5 + af - am
        beta = 0.25 * (gamma + 0.5) ** 2
        return am, af, gamma, beta

    def prepare(self, system):
        return dae.mass_chain_factor(system)

    def __check_init__(self):
        if self.refinement is not None:
            check_count("refinement", self.refinement, 0, 50)

    def forward_only(self) -> "GeneralizedAlpha":
        # the implicit derivative traces the tangent solve (a second factorization) and
        # the residual once more even when nothing is differentiated: ~1 s of tracing
        return dataclasses.replace(self, implicit_diff=False) if self.implicit_diff else self

    def _initial_memory(self, system, q, v, lam, t):
        """The factor memory of a first step (:meth:`AbstractFactorReuse.initial`)."""

        def factors(q, v, lam, t):
            jac = system.constraint_jacobian(q, t)
            matrix = dae.iteration_matrix(system, q, v, lam, t, 1.0, 1.0, jac)
            return self.linear_solver.init(matrix, None)

        return self.factor_reuse.initial(lambda: jax.eval_shape(factors, q, v, lam, t))

    def init(self, system, state, context) -> Carry:
        t = jnp.asarray(state.t, float)
        acc, lam = dae.accelerations(system, state.q, state.v, t, chain_factor=context,
                                     linear_solver=self.linear_solver)
        return Carry(t, state.q, state.v, acc, acc, lam, jnp.zeros(3),
                     dae.powers(system, state.q, state.v, t, lam),
                     self._initial_memory(system, state.q, state.v, lam, t))

    def resume(self, system, carry, context):
        fresh = self._initial_memory(system, carry.q, carry.v, carry.lam, carry.t)
        leaves, tree = jax.tree.flatten(fresh)
        kept = jax.tree.leaves(carry.memory)
        fits = (fresh is not None and len(kept) == len(leaves)
                and all(jnp.shape(a) == b.shape and jnp.result_type(a) == b.dtype for a, b in zip(kept, leaves)))
        memory = jax.tree.unflatten(tree, [jnp.asarray(a) for a in kept]) if fits else fresh
        return dataclasses.replace(carry, memory=memory)

    def newton_factors(self, h):
        """(β', γ') of a step of size h [s]: ∂q̈/∂Δq and ∂v/∂Δq along the position
        correction Δq, the factors of the mass and of the damping in the Newton matrix
        (:func:`ancf_jax.dae.iteration_matrix`) [1/s², 1/s]."""
        am, af, gamma, beta = self.coefficients
        return (1.0 - am) / (h * h * beta * (1.0 - af)), gamma / (h * beta)

    def step(self, system, carry: Carry, h, context):
        am, af, gamma, beta = self.coefficients
        beta_p, gamma_p = self.newton_factors(h)
        t1 = carry.t + h
        n = system.n_coordinates

        def kinematics(y):
            """(q, v, q̈, a) at t_{n+1} and λ from the unknowns y = [u; λ] (solver order)."""
            u, lam = dae.from_solver_order(system, y)
            qdd = carry.acc + beta_p * u
            a1 = (af * carry.acc - am * carry.aux + (1.0 - af) * qdd) / (1.0 - am)
            v1 = carry.v + h * ((1.0 - gamma) * carry.aux + gamma * a1)
            q1 = carry.q + h * carry.v + h * h * ((0.5 - beta) * carry.aux + beta * a1)
            return q1, v1, qdd, a1, lam

        def residual(y):
            q1, v1, qdd, _, lam = kinematics(y)
            r_q = system.mass_times(qdd) - system.generalized_force(q1, v1, t1)
            if system.reaction_forces:
                r_q = r_q - system.reaction_force(q1, v1, t1, lam)
            if system.n_constraints:
                _, vjp = jax.vjp(lambda qq: system.constraint(qq, t1), q1)
                r_q = r_q + vjp(lam)[0]
                phi = self.constraints.residual(system, q1, v1, t1, gamma_p)
            else:
                phi = jnp.zeros((0,), q1.dtype)
            return dae.to_solver_order(system, r_q, phi)

        def matrix(system):
            def linearize(y):
                q1, v1, _, _, lam = kinematics(y)
                jac = system.constraint_jacobian(q1, t1)
                return dae.iteration_matrix(system, q1, v1, lam, t1, beta_p, gamma_p, jac)
            return linearize

        exact = self.tangent_system(system) if self.implicit_diff else None
        y0 = dae.to_solver_order(system, jnp.zeros_like(carry.q), carry.lam)
        factors, refresh = self.factor_reuse.start(carry.memory, h)
        sol = self.root_finder.root(residual, matrix(system), y0, size=n, implicit=self.implicit_diff,
                                    refinement=self.tangent_refinement(system), factors=factors, refresh=refresh,
                                    tangent_linearize=None if exact is None else matrix(exact))
        memory = self.factor_reuse.update(carry.memory, sol, h)
        q1, v1, qdd, a1, lam = kinematics(sol.x)
        if self.velocity_projection and system.n_constraints:
            # mass-metric projection; the beam-mass factors are constant (context)
            jac = system.constraint_jacobian(q1, t1)
            mfac = dae.mass_saddle_factor(system, jac, context, linear_solver=self.linear_solver)
            v1 = dae.project_velocity(system, q1, v1, t1, mfac, jac)
        p1 = dae.powers(system, q1, v1, t1, lam)
        work = carry.work + 0.5 * h * (carry.power + p1)  # trapezoidal rule (order 2)
        return Carry(t1, q1, v1, qdd, a1, lam, work, p1, memory), StepInfo(sol.iterations, sol.converged)
