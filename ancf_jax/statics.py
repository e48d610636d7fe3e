"""Static equilibrium: Newton's method on the total potential with load stepping.

Solves, for load factors μ = 1/N, 2/N, …, 1,

    −Q(q, 0, t; μ) + Φ_q(q, t)ᵀ λ = 0,     Φ(q, t) = 0,

where Q holds the elastic forces (−∂U/∂q), μ·(gravity + applied loads) and the
force elements, and λ are the Lagrange multipliers of the joints (clamps, pins,
prescribed points, sliding joints, holds). The Newton matrix is the exact Jacobian
of this residual by forward-mode autodiff (tangent stiffness including the geometric
stiffness of the current stresses and the constraint Hessian λ·Φ_qq); a backtracking
line search on the residual norm safeguards large deflections.

The solver is written in JAX (``lax.scan`` over load steps, ``lax.while_loop`` for
Newton), so it is jittable and vmappable; :func:`solve_static` is the host wrapper
that raises a :class:`~ancf_jax.errors.StaticsError` naming the failed load step.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import dae
from .errors import StaticsError
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

    def residual(x, lf):
        r, c = static_residual(system, x[:n], x[n:] * fscale, t, lf, q0)
        out = jnp.concatenate([r / fscale, c / lscale])
        return out, out

    def newton(x0, lf):
        # carry: accepted x, trial x, Newton step, step fraction, iteration, residual, done
        # Full Newton steps: the residual of a slender beam may grow by orders of
        # magnitude after the first (linear) step and still converge quadratically, so
        # a monotone line search would stall; a step is halved only while the residual
        # at the trial point is not finite.
        def cond(c):
            return (~c[6]) & (c[4] < max_iterations)

        def body(c):
            x_acc, x_try, dx, a, it, _, _ = c
            jac, r = jax.jacfwd(residual, has_aux=True)(x_try, lf)
            jac = jac + reg
            rn = jnp.max(jnp.abs(r))
            finite = jnp.isfinite(rn)
            step = jnp.where(it > 0, jnp.max(jnp.abs(a * dx[:n])), jnp.inf)
            # converged when the scaled residual is below tolerance, or when the Newton
            # correction is below 1e-10 of the model size: with quadratic convergence the
            # error is then ~1e-20, and the residual is at its round-off floor (which the
            # axial stiffness EA sets, whatever the size of the load)
            done = finite & ((rn <= tolerance) | (step <= 1e-10 * lscale))
            dx_new = jnp.linalg.solve(jac, -r)
            x_acc = jnp.where(finite, x_try, x_acc)
            dx = jnp.where(finite, dx_new, dx)
            a = jnp.where(finite, 1.0, 0.5 * a)
            return x_acc, x_acc + a * dx, dx, a, it + 1, rn, done

        init = (x0, x0, jnp.zeros_like(x0), jnp.array(0.0), 0, jnp.array(jnp.inf), jnp.array(False))
        x_acc, _, _, _, it, rn, done = jax.lax.while_loop(cond, body, init)
        return x_acc, it, rn, done

    def load_step(carry, lf):
        x, failed = carry
        x_new, it, res, ok = newton(x, lf)
        ok = ok & ~failed
        x_out = jnp.where(ok, x_new, x)
        return (x_out, failed | ~ok), (it, res, ok)

    # mass-proportional regularization of the Newton matrix: coordinates with neither
    # stiffness nor load (e.g. the rotation of a body whose joints all act at its
    # centre) would make it singular; the residual, hence the solution, is unchanged
    m = jnp.diag(system.mass_matrix()) * ~system.inactive_mask()
    jqq = jnp.abs(jnp.diag(jax.jacfwd(residual, has_aux=True)(jnp.concatenate([q0, lam0]), 1.0)[0]))[:n]
    eps = regularization * jnp.max(jqq) / jnp.maximum(jnp.max(m), 1e-300)
    reg = jnp.diag(jnp.concatenate([eps * m, jnp.zeros(lam0.shape[0])]))
    x0 = jnp.concatenate([q0, lam0])
    (x, _), (its, res, ok) = jax.lax.scan(load_step, (x0, jnp.array(False)), load_factors)
    return x[:n], x[n:] * fscale, its, res, ok


#: a root finder for the structured static solve (:func:`solve_static` given
#: ``root_finder=STATIC_NEWTON``): full Newton on the structured Newton matrix, converged when
#: the correction is below 1e-10 of the model size (a step rule: the residual of
#: stiff, finely meshed wires stalls at its round-off floor, the step does not)
STATIC_NEWTON = ModifiedNewton(tolerance=1e-10, max_iterations=50, contraction=0.0)


@eqx.filter_jit
def _solve_structured(system: System, q0, lam0, t, load_factors, root_finder: ModifiedNewton,
                      regularization):
    """Load-stepped Newton with the structured Newton matrix of
    :func:`ancf_jax.dae.iteration_matrix` at β' = ε, γ' = 0 (its static
    linearization; ε a mass-proportional regularization, which leaves the residual,
    hence the solution, unchanged): O(elements) per iteration, for wires of thousands
    of elements where the dense Jacobian of :func:`_solve` is O(n³)."""
    n = q0.shape[0]
    zero_v = jnp.zeros_like(q0)
    fscale = _load_scale(system, q0, t)
    lscale = jnp.maximum(jnp.max(jnp.abs(q0)), 1.0)
    # ε: ``regularization`` × (largest stiffness entry of the beams / largest mass entry)
    probe = dae.iteration_matrix(system, q0, zero_v, lam0, t, 0.0, 0.0, system.constraint_jacobian(q0, t))
    kscale = jnp.max(jnp.abs(probe.chain.diagonal)) if probe.chain is not None else jnp.max(jnp.abs(probe.e))
    m = jnp.diag(system.mass_matrix()) if probe.chain is None else jnp.concatenate(
        [jnp.abs(jax.vmap(jnp.diag)(system.beam_mass().diagonal)).reshape(-1), system.border_mass_diagonal()])
    beta_p = regularization * kscale / jnp.maximum(jnp.max(m), 1e-300)

    def load_step(carry, lf):
        y, failed = carry

        def residual(x):
            q, lam = dae.from_solver_order(system, x)
            r, phi = static_residual(system, q, lam, t, lf, q0)
            return dae.to_solver_order(system, r, phi)

        def linearize(x):
            q, lam = dae.from_solver_order(system, x)
            return dae.iteration_matrix(system, q, zero_v, lam, t, beta_p, 0.0,
                                        system.constraint_jacobian(q, t), lf)

        sol = root_finder.solve(residual, linearize, y, size=n, scale=lscale,
                                residual_norm=lambda r: jnp.max(jnp.abs(r[:n])) / fscale)
        ok = sol.converged & ~failed
        y_out = jnp.where(ok, sol.x, y)
        return (y_out, failed | ~ok), (sol.iterations, sol.residual_norm, ok)

    y0 = dae.to_solver_order(system, q0, lam0)
    (y, _), (its, res, ok) = jax.lax.scan(load_step, (y0, jnp.array(False)), load_factors)
    q, lam = dae.from_solver_order(system, y)
    return q, lam, its, res, ok


def solve_static_pure(system: System, state: State, *, load_steps: int = 1,
                      tolerance: float = 1e-9, max_iterations: int = 50,
                      regularization: float = 1e-12,
                      root_finder: ModifiedNewton | None = None) -> StaticSolution:
    """Jittable/vmappable static solve; never raises (check ``converged``)."""
    load_factors = jnp.arange(1, load_steps + 1, dtype=float) / load_steps
    lam0 = jnp.zeros(system.n_constraints)
    if root_finder is not None:
        q, lam, its, res, ok = _solve_structured(system, state.q, lam0, jnp.asarray(state.t, float),
                                                 load_factors, root_finder, regularization)
    else:
        q, lam, its, res, ok = _solve(system, state.q, lam0, jnp.asarray(state.t, float), load_factors,
                                      tolerance, max_iterations, regularization)
    # full Newton steps may turn a body by whole revolutions: report angles in (−π, π]
    theta = 3 * jnp.arange(system.n_bodies) + 2
    q = q.at[theta].set(jnp.pi - jnp.mod(jnp.pi - q[theta], 2 * jnp.pi))
    return StaticSolution(State(q, jnp.zeros_like(q), state.t), lam, its, res, ok, load_factors)


def solve_static(system: System, state: State, *, load_steps: int = 1, tolerance: float = 1e-9,
                 max_iterations: int = 50, regularization: float = 1e-12,
                 root_finder: ModifiedNewton | None = None) -> StaticSolution:
    """Static equilibrium from the initial guess ``state`` (see module docstring).

    Args:
        load_steps: number of equal load increments N (>= 1).
        tolerance: on the residual, scaled by the largest external load entry (also
            converged when the Newton correction falls below 1e-10 of the model size).
        max_iterations: Newton iterations per load step.
        regularization: relative weight of a mass-proportional term added to the Newton
            matrix (not the residual) so that unloaded, unconstrained coordinates do not
            make it singular.
        root_finder: None (default): Newton on the dense Jacobian (O(n³): a few hundred
            elements at most). A :class:`~ancf_jax.newton.ModifiedNewton` (e.g.
            :data:`STATIC_NEWTON`): Newton on the structured (block-tridiagonal,
            bordered) Newton matrix (:func:`_solve_structured`, linear in the element
            count), stopped by the root finder's step rule (``tolerance`` and
            ``max_iterations`` then unused).

    Raises:
        StaticsError: a load step did not converge; names the step, its load factor and
            the residual reached, and carries the last converged state.
    """
    load_steps = check_count("load_steps", load_steps, 1)
    tolerance = check_positive("tolerance", tolerance)
    max_iterations = check_count("max_iterations", max_iterations, 1)
    sol = solve_static_pure(system, state, load_steps=load_steps, tolerance=tolerance,
                            max_iterations=max_iterations, regularization=regularization,
                            root_finder=root_finder)
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
