"""Generalized-α for constrained mechanical systems (Arnold & Brüls 2007), index 3.

The method for stiff structural dynamics with joints, as in Exudyn and Chrono. With
spectral radius at infinity ρ∞ ∈ [0, 1]:

    α_m = (2ρ∞ − 1)/(ρ∞ + 1),  α_f = ρ∞/(ρ∞ + 1),  γ = ½ + α_f − α_m,  β = ¼ (γ + ½)²

and per step, with q̈ the true and a the pseudo-acceleration,

    (1 − α_m) a_{n+1} + α_m a_n = (1 − α_f) q̈_{n+1} + α_f q̈_n
    v_{n+1} = v_n + h (1 − γ) a_n + h γ a_{n+1}
    q_{n+1} = q_n + h v_n + h² (½ − β) a_n + h² β a_{n+1}
    M q̈_{n+1} + Φ_q(q_{n+1})ᵀ λ_{n+1} = Q(q_{n+1}, v_{n+1}, t_{n+1}),   Φ(q_{n+1}, t_{n+1}) = 0.

The nonlinear equations in (q̈_{n+1}, λ_{n+1}) are solved by a modified Newton method:
the iteration matrix [[M β' + C γ' + K, Φ_qᵀ], [Φ_q, 0]] (β' = (1 − α_m)/(h² β (1 − α_f)),
γ' = γ/(h β)) is assembled at the predictor from the per-element Hessians of the
strain energy (:func:`ancf_jax.dae.iteration_matrix`), factored once in bordered
block-tridiagonal form and reused while the iteration contracts fast; it is refactored
at the current iterate when a correction shrinks by less than ``contraction`` (so a
strongly nonlinear step falls back to full Newton), and, with ``refresh_first``, after
the first correction of every step. The iteration stops when the last correction is
below ``newton_tol``.

Large steps of a stiff cable (M1 at h = 5 ms): the predictor is millimetres off, the
matrix factored there contracts slowly, steps run out of iterations and are redone in
substeps; ``refresh_first=True, contraction=0.1`` converges in about 5 iterations per
step without a failed step (9.5 with retries by default). At small steps (M1 at 1 ms: 2
iterations) it only adds factorizations, so it is off by default. ``dense=True`` is
faster for small unbatched systems (M1, 38 unknowns; measured in
``benchmarks/single_run.py``); vmapped batches run the block-tridiagonal solver faster.

Positions satisfy Φ = 0 to the Newton tolerance at every step (index 3). With
``velocity_projection=True`` (default) the velocities are also projected onto
Φ_q v + Φ_t = 0 after the step in the mass metric (the beam-mass factors are constant,
so this costs one small Schur complement).

Differentiable: the Newton solve is wrapped in :func:`jax.lax.custom_root`, so
``jax.grad`` and ``jax.jvp`` of a trajectory differentiate the converged equations
(implicit function theorem) rather than the iterations; the tangent systems are
solved with the same factors and a few steps of iterative refinement.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import dae
from ..linalg import factor_saddle, solve_saddle
from .base import AbstractIntegrator, Carry, StepInfo, run_if


class GeneralizedAlpha(AbstractIntegrator):
    """Generalized-α (Arnold & Brüls 2007) at a fixed step.

    Attributes:
        rho_inf: spectral radius at infinite frequency (1: no numerical damping,
            0: maximal). Default 0.9, as Exudyn's default.
        newton_tol: tolerance on the Newton correction of the positions [m or -].
        max_iterations: Newton iterations per step before the step counts as failed.
        refresh_every: rebuild and refactor the iteration matrix after this many
            iterations without convergence.
        contraction: refactor at the current iterate when a correction is larger than
            this fraction of the previous one (slow or diverging modified Newton).
        velocity_projection: project v onto the velocity constraints after each step.
        refinement: iterative-refinement steps of the tangent solves (derivatives).
        dense: dense LU instead of the bordered block-tridiagonal solver.
        implicit_diff: differentiate the converged step equations (implicit function
            theorem) instead of the Newton iterations.
        refresh_first: also refactor after the first correction of every step.
    """

    rho_inf: float = eqx.field(static=True, default=0.9)
    newton_tol: float = eqx.field(static=True, default=1e-10)
    max_iterations: int = eqx.field(static=True, default=16)
    refresh_every: int = eqx.field(static=True, default=6)
    contraction: float = eqx.field(static=True, default=0.25)
    velocity_projection: bool = eqx.field(static=True, default=True)
    refinement: int = eqx.field(static=True, default=4)
    dense: bool = eqx.field(static=True, default=False)
    implicit_diff: bool = eqx.field(static=True, default=True)
    refresh_first: bool = eqx.field(static=True, default=False)

    @property
    def order(self) -> int:
        return 2

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

    def forward_only(self) -> "GeneralizedAlpha":
        # lax.custom_root traces the tangent solve (a second factorization) and the
        # residual once more even when nothing is differentiated: ~1 s of tracing
        return dataclasses.replace(self, implicit_diff=False) if self.implicit_diff else self

    def init(self, system, state, context) -> Carry:
        t = jnp.asarray(state.t, float)
        acc, lam = dae.accelerations(system, state.q, state.v, t, chain_factor=context,
                                     dense=self.dense)
        return Carry(t, state.q, state.v, acc, acc, lam, jnp.zeros(3),
                     dae.powers(system, state.q, state.v, t, lam))

    def step(self, system, carry: Carry, h, context):
        am, af, gamma, beta = self.coefficients
        beta_p = (1.0 - am) / (h * h * beta * (1.0 - af))
        gamma_p = gamma / (h * beta)
        t1 = carry.t + h
        n = system.n_coordinates

        def kinematics(qdd):
            a1 = (af * carry.acc - am * carry.aux + (1.0 - af) * qdd) / (1.0 - am)
            v1 = carry.v + h * ((1.0 - gamma) * carry.aux + gamma * a1)
            q1 = carry.q + h * carry.v + h * h * ((0.5 - beta) * carry.aux + beta * a1)
            return q1, v1, a1

        def residual(x):
            qdd, lam = x[:n], x[n:]
            q1, v1, _ = kinematics(qdd)
            r_q = system.mass_times(qdd) - system.generalized_force(q1, v1, t1)
            if system.n_constraints:
                phi, vjp = jax.vjp(lambda qq: system.constraint(qq, t1), q1)
                r_q = r_q + vjp(lam)[0]
            else:
                phi = jnp.zeros((0,), q1.dtype)
            return jnp.concatenate([r_q, phi])

        def factor_at(x):
            qdd, lam = x[:n], x[n:]
            q1, v1, _ = kinematics(qdd)
            jac = system.constraint_jacobian(q1, t1)
            s = dae.iteration_matrix(system, q1, v1, lam, t1, beta_p, gamma_p, jac)
            return jax.lax.stop_gradient(factor_saddle(s, dense=self.dense))

        def correction(fac, r):
            """Newton correction for residual r: (δq̈, δλ) with δq̈ = β' Δq."""
            dx = solve_saddle(fac, -dae.to_solver_order(system, r[:n], r[n:]))
            dq, dlam = dae.from_solver_order(system, dx)
            return jnp.concatenate([beta_p * dq, dlam]), dq

        x0 = jnp.concatenate([carry.acc, carry.lam])
        # the iteration matrix is factored inside the loop (first iteration and every
        # refresh_every-th), so the factorization is traced and compiled once
        fac_shape = jax.eval_shape(factor_at, x0)
        fac_none = jax.tree.map(lambda a: jnp.zeros(a.shape, a.dtype), fac_shape)

        def newton(f, x_init):
            def cond(c):
                _, _, it, done, _, _ = c
                return (~done) & (it < self.max_iterations)

            def body(c):
                x, fac, it, _, err_prev, refresh = c
                fac = run_if(refresh, lambda _: factor_at(x), fac)
                dx, dq = correction(fac, f(x))
                x = x + dx
                err = jnp.max(jnp.abs(dq))
                done = (err <= self.newton_tol) & jnp.all(jnp.isfinite(x))
                # refactor at the new iterate when the modified Newton iteration
                # contracts slowly (or diverges), and every refresh_every iterations
                slow = err > self.contraction * err_prev
                refresh = slow | ((it + 1) % self.refresh_every == 0) | ((it == 0) & self.refresh_first)
                return x, fac, it + 1, done, err, refresh

            x, fac, it, done, _, _ = jax.lax.while_loop(
                cond, body, (x_init, fac_none, jnp.array(0), jnp.array(False), jnp.array(jnp.inf),
                             jnp.array(True)))
            # auxiliary outputs of custom_root must be floating point
            return x, (it.astype(float), done.astype(float))

        def tangent_solve(g, y):
            # solve J x = y with the iteration matrix at the predictor and iterative
            # refinement (compiled only into code that differentiates a step)
            fac = factor_at(jax.lax.stop_gradient(x0))

            def refine(_, x):
                return x + correction(fac, g(x) - y)[0]

            return jax.lax.fori_loop(0, self.refinement + 1, refine, jnp.zeros_like(y))

        if self.implicit_diff:
            x, (iters, converged) = jax.lax.custom_root(residual, x0, newton, tangent_solve,
                                                        has_aux=True)
        else:
            x, (iters, converged) = newton(residual, x0)
        iters = jax.lax.stop_gradient(iters).astype(jnp.int32)
        converged = jax.lax.stop_gradient(converged) > 0.5
        qdd, lam = x[:n], x[n:]
        q1, v1, a1 = kinematics(qdd)
        if self.velocity_projection and system.n_constraints:
            # mass-metric projection; the beam-mass factors are constant (context)
            jac = system.constraint_jacobian(q1, t1)
            mfac = dae.mass_saddle_factor(system, jac, context, dense=self.dense)
            v1 = dae.project_velocity(system, q1, v1, t1, mfac, jac)
        p1 = dae.powers(system, q1, v1, t1, lam)
        work = carry.work + 0.5 * h * (carry.power + p1)  # trapezoidal rule (order 2)
        return Carry(t1, q1, v1, qdd, a1, lam, work, p1), StepInfo(iters, converged)
