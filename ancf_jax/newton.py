"""The one root finder of ancf_jax: a modified Newton method on structured operators.

Every nonlinear solve of the time integration, the position projection and statics
is F(x) = 0 with a Newton matrix that keeps the system's structure
(:class:`~ancf_jax.linalg.SaddleMatrix`, from :func:`ancf_jax.dae.iteration_matrix`).
:class:`ModifiedNewton` holds how it is solved, in the manner of optimistix's root
finders and diffrax's ``root_finder`` fields: the stopping rule, the refresh policy of
the matrix, and the linear solver (:class:`~ancf_jax.linalg.AbstractSaddleSolver`).

Refresh policy. The matrix is factored at the first iterate and reused while the
iteration contracts fast; it is refactored at the current iterate when a correction
shrinks by less than ``contraction`` (a strongly nonlinear solve falls back to full
Newton), every ``refresh_every`` iterations, and with ``refresh_first`` after the first
correction. ``contraction = 0`` refactors at every iteration (full Newton).

Derivatives. :meth:`ModifiedNewton.root` wraps the iteration in
:func:`jax.lax.custom_root`, so ``jax.grad`` and ``jax.jvp`` differentiate the
converged equations (implicit function theorem) rather than the iterations; the
tangent systems reuse one factorization at the initial iterate with ``refinement``
steps of iterative refinement.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from .linalg import AbstractSaddleSolver, AutoSaddleSolver


def run_if(pred, fn, operand):
    """``fn(operand)`` where ``pred`` holds, else ``operand`` — as a while loop of at
    most one iteration. Unlike ``lax.cond``, which ``vmap`` turns into a select that
    evaluates both branches for every member, a batched while loop runs only while some
    member needs it. Not reverse-mode differentiable (use it on solver internals)."""

    def body(c):
        _, x = c
        return jnp.zeros_like(pred), fn(x)

    return jax.lax.while_loop(lambda c: c[0], body, (pred, operand))[1]


class NewtonSolution(eqx.Module):
    """Outcome of a root solve.

    Attributes:
        x: the last iterate.
        iterations: Newton iterations taken (int).
        converged: whether the last correction met the tolerance (bool).
    """

    x: jnp.ndarray
    iterations: jnp.ndarray
    converged: jnp.ndarray


class ModifiedNewton(eqx.Module):
    """Modified Newton method with a refresh policy (module docstring).

    Attributes:
        tolerance: converged when max |Δx| over the first ``size`` unknowns (the
            coordinates, not the multipliers) is at most this [m or -].
        max_iterations: iterations before the solve counts as not converged.
        refresh_every: refactor after this many iterations without convergence.
        contraction: refactor at the current iterate when a correction is larger than
            this fraction of the previous one.
        refresh_first: also refactor after the first correction.
        linear_solver: solver of the Newton systems.
    """

    tolerance: float = eqx.field(static=True, default=1e-10)
    max_iterations: int = eqx.field(static=True, default=16)
    refresh_every: int = eqx.field(static=True, default=6)
    contraction: float = eqx.field(static=True, default=0.25)
    refresh_first: bool = eqx.field(static=True, default=False)
    linear_solver: AbstractSaddleSolver = AutoSaddleSolver()

    def factor(self, linearize, x, chain_factor=None):
        """Factors of the Newton matrix ``linearize(x)`` (held constant in derivatives)."""
        return jax.lax.stop_gradient(self.linear_solver.init(linearize(x), chain_factor))

    def solve(self, residual, linearize, x0, *, size: int, chain_factor=None) -> NewtonSolution:
        """Solve residual(x) = 0 from x0.

        Args:
            residual: x ↦ F(x), shape (N,) (solver order of the operator).
            linearize: x ↦ :class:`~ancf_jax.linalg.SaddleMatrix` ∂F/∂x (or an
                approximation: modified Newton converges to the same root).
            x0: initial iterate, shape (N,).
            size: the leading unknowns whose correction decides convergence.
            chain_factor: known factors of the operator's chain block, if constant
                (the beam mass of a projection).
        """
        fac_shape = jax.eval_shape(lambda x: self.factor(linearize, x, chain_factor), x0)
        fac_none = jax.tree.map(lambda a: jnp.zeros(a.shape, a.dtype), fac_shape)

        def cond(c):
            _, _, it, done, _, _ = c
            return (~done) & (it < self.max_iterations)

        def body(c):
            x, fac, it, _, err_prev, refresh = c
            # the matrix is factored inside the loop (first iteration and refreshes), so
            # the factorization is traced and compiled once
            fac = run_if(refresh, lambda _: self.factor(linearize, x, chain_factor), fac)
            dx = self.linear_solver.compute(fac, -residual(x))
            x = x + dx
            err = jnp.max(jnp.abs(dx[:size]))
            done = (err <= self.tolerance) & jnp.all(jnp.isfinite(x))
            slow = err > self.contraction * err_prev
            refresh = slow | ((it + 1) % self.refresh_every == 0) | ((it == 0) & self.refresh_first)
            return x, fac, it + 1, done, err, refresh

        x, _, it, done, _, _ = jax.lax.while_loop(
            cond, body, (x0, fac_none, jnp.array(0), jnp.array(False), jnp.array(jnp.inf), jnp.array(True)))
        return NewtonSolution(x, it, done)

    def root(self, residual, linearize, x0, *, size: int, implicit: bool = True,
             refinement: int = 4, chain_factor=None) -> NewtonSolution:
        """:meth:`solve`, differentiated implicitly when ``implicit`` (module docstring)."""
        if not implicit:
            return self.solve(residual, linearize, x0, size=size, chain_factor=chain_factor)

        def solve(f, x_init):
            sol = self.solve(f, linearize, x_init, size=size, chain_factor=chain_factor)
            # auxiliary outputs of custom_root must be floating point
            return sol.x, (sol.iterations.astype(float), sol.converged.astype(float))

        def tangent_solve(g, y):
            # J x = y with the matrix at the initial iterate and iterative refinement
            # (compiled only into code that differentiates the solve)
            fac = self.factor(linearize, jax.lax.stop_gradient(x0), chain_factor)

            def refine(_, x):
                return x + self.linear_solver.compute(fac, y - g(x))

            return jax.lax.fori_loop(0, refinement + 1, refine, jnp.zeros_like(y))

        x, (iters, conv) = jax.lax.custom_root(residual, x0, solve, tangent_solve, has_aux=True)
        return NewtonSolution(x, jax.lax.stop_gradient(iters).astype(jnp.int32),
                              jax.lax.stop_gradient(conv) > 0.5)
