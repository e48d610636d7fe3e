"""Static equilibrium: Newton's method on the total potential with load stepping.

Solves, for load factors μ = 1/N, 2/N, …, 1,

    −Q(q, 0, t; μ) + Φ_q(q, t)ᵀ λ = 0,     Φ(q, t) = 0,

where Q holds the elastic forces (−∂U/∂q), μ·(gravity + applied loads) and the
force elements, and λ are the Lagrange multipliers of the joints (clamps, pins,
prescribed points, sliding joints, holds). The root finder is the one of the time
integration (:class:`~ancf_jax.newton.ModifiedNewton`, here as full Newton with a
retreat from non-finite residuals), and the Newton matrix the same structured
linearization (:func:`ancf_jax.dae.iteration_matrix` at rest: tangent stiffness from
the element energies including the geometric stiffness of the current stresses, the
constraint Hessian λ·Φ_qq, and the force elements' local linearizations), so a static
solve costs O(elements) per iteration like a time step.

The solver is written in JAX (``lax.scan`` over load steps, the root finder's
``lax.while_loop`` for Newton), so it is jittable and vmappable; :func:`solve_static` is the host wrapper
that raises a :class:`~ancf_jax.errors.StaticsError` naming the failed load step.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import dae
from .errors import StaticsError
from .linalg import AutoSaddleSolver
from .newton import ModifiedNewton
from .system import State, System
from .validation import check_count, check_positive


class StaticSolution(eqx.Module):
    """Result of a static solve.

    Attributes:
        state: equilibrium configuration (v = 0).
        multipliers: Lagrange multipliers λ at equilibrium, shape (m,) (constraint
            force on the coordinates is −Φ_qᵀ λ).
        iterations: Newton iterations per load step, shape (N,).
        residuals: final scaled residual per load step, shape (N,).
        converged: per load step, shape (N,).
        load_factors: shape (N,).
    """

    state: State
    multipliers: jnp.ndarray
    iterations: jnp.ndarray
    residuals: jnp.ndarray
    converged: jnp.ndarray
    load_factors: jnp.ndarray


def static_residual(system: System, q, lam, t, load_factor, q_fixed):
    """Residual of the static equations (see module docstring); padding coordinates
    are held at ``q_fixed``. Returns (force residual (n,), constraint residual (m,)).

    Damping forces vanish at rest and are left out.
    """
    inactive = system.inactive_mask()
    zero_v = jnp.zeros_like(q)
    r = -(system.conservative_force(q, t, load_factor)
          + system.applied_force(q, zero_v, t, load_factor))
    if system.n_constraints:
        phi, vjp = jax.vjp(lambda qq: system.constraint(qq, t), q)
        r = r + vjp(lam)[0]
    else:
        phi = jnp.zeros((0,), q.dtype)
    return jnp.where(inactive, q - q_fixed, r), phi


def _load_scale(system: System, q, t):
    """A force scale for the convergence test: the largest external load entry."""
    ext = system.gravity_load() + system.applied_force(q, jnp.zeros_like(q), t)
    return jnp.maximum(jnp.max(jnp.abs(ext)), 1e-12)


@eqx.filter_jit
def _solve(system: System, q0, lam0, t, load_factors, tolerance, max_iterations, regularization):
    n = q0.shape[0]
    fscale = _load_scale(system, q0, t)
    lscale = jnp.maximum(jnp.max(jnp.abs(q0)), 1.0)
    inactive = system.inactive_mask()
    chain = system.chain_slice()
    zero_v = jnp.zeros_like(q0)

    def residual(y, lf):
        q, lam = dae.from_solver_order(system, y)
        r, c = static_residual(system, q, lam, t, lf, q0)
        return dae.to_solver_order(system, r, c)

    def norm(r_s):
        # the residual scaled by the largest external load (forces) and the model size
        # (constraints)
        r, c = dae.from_solver_order(system, r_s)
        rc = jnp.max(jnp.abs(c)) / lscale if c.shape[0] else jnp.zeros(())
        return jnp.maximum(jnp.max(jnp.abs(r)) / fscale, rc)

    beam_mass = system.beam_mass() if system.chain_size else None
    border_mass = system.border_mass_diagonal()
    n_border = border_mass.shape[0]
    m_max = jnp.maximum(jnp.max(jnp.diag(system.mass_matrix()) * ~inactive, initial=0.0), 1e-300)

    def tangent(y, lf):
        """The structured Newton matrix of the static residual: K + (λ·Φ)_qq and Φ_q
        (dae.iteration_matrix at rest, β' = γ' = 0), plus a mass-proportional
        regularization ε M, with the identity rows of the padding coordinates
        (residual q − q_fixed there).

        ε = ``regularization`` · max|diag K| / max(m): coordinates with neither
        stiffness nor load (e.g. the rotation of a body whose joints all act at its
        centre) would make K singular; the residual, hence the solution, is unchanged.
        ε is taken from the matrix being built, so the tangent is traced once."""
        q, lam = dae.from_solver_order(system, y)
        a = dae.iteration_matrix(system, q, zero_v, lam, t, 0.0, 0.0,
                                 system.constraint_jacobian(q, t), load_factor=lf)
        diag = jnp.abs(jnp.diagonal(a.e))[:n_border]
        if system.chain_size:
            pad = inactive[chain]
            diag = jnp.concatenate([jnp.abs(jax.vmap(jnp.diagonal)(a.chain.diagonal)).ravel() * ~pad, diag])
        eps = regularization * jnp.max(diag, initial=0.0) / m_max
        if system.chain_size:
            # the beam mass has a unit dummy mass on padding nodes: those rows become I
            a = eqx.tree_at(lambda m: m.chain, a,
                            (a.chain + beam_mass.scale(eps)).add_diagonal(pad.astype(q.dtype) * (1.0 - eps)))
        idx = jnp.arange(n_border)
        return eqx.tree_at(lambda m: m.e, a, a.e.at[idx, idx].add(eps * border_mass))

    x0 = dae.to_solver_order(system, q0, lam0)

    # full Newton steps: the residual of a slender beam may grow by orders of magnitude
    # after the first (linear) step and still converge quadratically, so a monotone
    # line search would stall; a step is halved only while the residual at the trial
    # point is not finite. Converged when the scaled residual is below tolerance, or
    # when the correction is below 1e-10 of the model size: with quadratic convergence
    # the error is then ~1e-20 and the residual at its round-off floor (which the axial
    # stiffness EA sets, whatever the size of the load)
    newton = ModifiedNewton(tolerance=1e-10, max_iterations=max_iterations, contraction=0.0,
                            residual_tolerance=tolerance, max_backtracks=max_iterations,
                            linear_solver=AutoSaddleSolver())

    def load_step(carry, lf):
        x, failed = carry
        sol = newton.solve(lambda y: residual(y, lf), lambda y: tangent(y, lf), x, size=n,
                           scale=lscale, residual_norm=norm)
        ok = sol.converged & ~failed
        x_out = jnp.where(ok, sol.x, x)
        return (x_out, failed | ~ok), (sol.iterations, sol.residual_norm, ok)

    (x, _), (its, res, ok) = jax.lax.scan(load_step, (x0, jnp.array(False)), load_factors)
    q, lam = dae.from_solver_order(system, x)
    return q, lam, its, res, ok


def solve_static_pure(system: System, state: State, *, load_steps: int = 1,
                      tolerance: float = 1e-9, max_iterations: int = 50,
                      regularization: float = 1e-12) -> StaticSolution:
    """Jittable/vmappable static solve; never raises (check ``converged``)."""
    load_factors = jnp.arange(1, load_steps + 1, dtype=float) / load_steps
    lam0 = jnp.zeros(system.n_constraints)
    q, lam, its, res, ok = _solve(system, state.q, lam0, jnp.asarray(state.t, float), load_factors,
                                  tolerance, max_iterations, regularization)
    # full Newton steps may turn a body by whole revolutions: report angles in (−π, π]
    theta = 3 * jnp.arange(system.n_bodies) + 2
    q = q.at[theta].set(jnp.pi - jnp.mod(jnp.pi - q[theta], 2 * jnp.pi))
    return StaticSolution(State(q, jnp.zeros_like(q), state.t), lam, its, res, ok, load_factors)


def solve_static(system: System, state: State, *, load_steps: int = 1, tolerance: float = 1e-9,
                 max_iterations: int = 50, regularization: float = 1e-12) -> StaticSolution:
    """Static equilibrium from the initial guess ``state`` (see module docstring).

    Args:
        load_steps: number of equal load increments N (>= 1).
        tolerance: on the residual, scaled by the largest external load entry (also
            converged when the Newton correction falls below 1e-10 of the model size).
        max_iterations: Newton iterations per load step.
        regularization: relative weight of a mass-proportional term added to the Newton
            matrix (not the residual) so that unloaded, unconstrained coordinates do not
            make it singular.

    Raises:
        StaticsError: a load step did not converge; names the step, its load factor and
            the residual reached, and carries the last converged state.
    """
    load_steps = check_count("load_steps", load_steps, 1)
    tolerance = check_positive("tolerance", tolerance)
    max_iterations = check_count("max_iterations", max_iterations, 1)
    sol = solve_static_pure(system, state, load_steps=load_steps, tolerance=tolerance,
                            max_iterations=max_iterations, regularization=regularization)
    ok = np.asarray(sol.converged)
    if not ok.all():
        k = int(np.argmin(ok))
        lf = float(sol.load_factors[k])
        res = float(sol.residuals[k])
        raise StaticsError(
            f"static Newton solver did not converge in load step {k + 1} of {load_steps} "
            f"(load factor {lf:.3g}): scaled residual {res:.3g} after "
            f"{int(sol.iterations[k])} iterations (tolerance {tolerance:g}); "
            "try more load_steps or a better initial guess",
            load_step=k, load_factor=lf, residual=res, state=sol.state)
    return sol
