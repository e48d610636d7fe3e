"""Static equilibrium: Newton's method on the total potential with load stepping.

Solves, for load factors μ = 1/N, 2/N, …, 1,

    −Q(q, 0, t; μ) + Φ_q(q, t)ᵀ λ = 0,     Φ(q, t) = 0,

where Q holds the elastic forces (−∂U/∂q), μ·(gravity + applied loads) and the
force elements, and λ are the Lagrange multipliers of the joints (clamps, pins,
prescribed points, sliding joints, holds). The root finder is the one of the time
integration and the position projection (:class:`~ancf_jax.newton.ModifiedNewton`,
here as full Newton with a retreat from non-finite residuals), and the Newton matrix
the same structured linearization (:func:`ancf_jax.dae.iteration_matrix` at rest: the
tangent stiffness from the element energies including the geometric stiffness of the
current stresses, the constraint Hessian λ·Φ_qq, and the force elements' local
linearizations), solved by the linear solver chosen from its structure (the bordered
block-tridiagonal solver for beams), so a static iteration costs O(elements) like a
time step. The settings and their defaults are
those of :class:`StaticSolver`.

The solver is written in JAX (``lax.scan`` over load steps, the root finder's
``lax.while_loop`` for Newton), so it is jittable and vmappable; :func:`solve_static`
is the host wrapper that raises a :class:`~ancf_jax.errors.StaticsError` naming the
failed load step.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import dae
from .errors import StaticsError
from .linalg import AbstractSaddleSolver, AutoSaddleSolver
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
        residuals: scaled residual (:class:`StaticSolver` ``tolerance``) at the state
            reached in each load step, shape (N,).
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


class StaticSolver(eqx.Module):
    """The settings of a static solve, with their defaults written once:
    :func:`solve_static`, :func:`~ancf_jax.model.build_in_equilibrium`, the shipped
    models and the scenario schema's ``[statics]`` table read them from here.

    Attributes:
        load_steps: equal load increments N (>= 1).
        tolerance: converged when the residual, scaled by the largest external load
            entry (forces) and the model size (constraints), is at most this [-].
        max_iterations: Newton iterations per load step (retreats from non-finite
            residuals included).
        regularization: relative weight r of the mass-proportional term ε M added to
            the Newton matrix (not the residual) [-], ε = r · (largest stiffness entry)
            / (largest mass entry), over the beam chain for its block and over the
            whole matrix for the border: coordinates with neither stiffness nor load
            (e.g. the rotation of a body whose joints all act at its centre), and the
            rigid-body modes of beams held by joints only (the bordered solver factors
            the chain block alone), would make it singular.
        step_tolerance: also converged when the Newton correction is at most this
            fraction of the model size [-]: with quadratic convergence the error is
            then ~1e-20, and the residual is at its round-off floor (which the axial
            stiffness EA sets, whatever the size of the load).
        linear_solver: solver of the Newton systems (default chosen from the structure:
            the bordered block-tridiagonal solver for beams, O(elements)).
    """

    load_steps: int = eqx.field(static=True, default=10)
    tolerance: float = eqx.field(static=True, default=1e-9)
    max_iterations: int = eqx.field(static=True, default=50)
    regularization: float = eqx.field(static=True, default=1e-12)
    step_tolerance: float = eqx.field(static=True, default=1e-10)
    linear_solver: AbstractSaddleSolver = AutoSaddleSolver()

    def root_finder(self) -> ModifiedNewton:
        """The root finder of the static solve: full Newton (the matrix refactored at
        every iteration) with the residual and step stopping rules above, and a retreat
        halfway towards the last iterate while the residual is not finite. No
        monotone line search: the residual of a slender beam may grow by orders of
        magnitude after the first (linear) step and still converge quadratically."""
        return ModifiedNewton(tolerance=self.step_tolerance, max_iterations=self.max_iterations,
                              contraction=0.0, residual_tolerance=self.tolerance,
                              max_backtracks=self.max_iterations, linear_solver=self.linear_solver)


#: the default settings (:class:`StaticSolver`)
DEFAULTS = StaticSolver()

#: a root finder for the structured static solve stopped by the step rule alone (the
#: residual of stiff, finely meshed wires stalls at its round-off floor, the step does
#: not): :func:`~ancf_jax.models.catenary.moving_equilibrium`
STATIC_NEWTON = ModifiedNewton(tolerance=DEFAULTS.step_tolerance, max_iterations=DEFAULTS.max_iterations,
                               contraction=0.0)


@eqx.filter_jit
def _solve(system: System, q0, lam0, t, load_factors, root_finder: ModifiedNewton, regularization):
    """Load-stepped Newton on the structured Newton matrix of
    :func:`ancf_jax.dae.iteration_matrix` at rest (β' = γ' = 0: the tangent stiffness
    with the geometric stiffness of the current stresses, the constraint Hessian
    (λ·Φ)_qq and the force elements) plus ε M, with identity rows for the padding
    coordinates (residual q − q_fixed there). With the default linear solver it costs
    O(elements) per iteration. Returns (q (n,), λ (m,), iterations (N,), scaled
    residuals (N,), converged (N,))."""
    n = q0.shape[0]
    zero_v = jnp.zeros_like(q0)
    fscale = _load_scale(system, q0, t)
    lscale = jnp.maximum(jnp.max(jnp.abs(q0)), 1.0)
    inactive = system.inactive_mask()
    border_mass = system.border_mass_diagonal()
    n_border = border_mass.shape[0]
    m_border = jnp.max(border_mass, initial=0.0)
    if system.chain_size:
        pad = inactive[system.chain_indices()]  # chain order
        beam_mass = system.beam_mass()
        m_chain = jnp.max(jax.vmap(jnp.diagonal)(beam_mass.diagonal).ravel() * ~pad)
        m_max = jnp.maximum(m_chain, m_border)
    else:
        m_max = m_border

    def residual(y, lf):
        q, lam = dae.from_solver_order(system, y)
        r, phi = static_residual(system, q, lam, t, lf, q0)
        return dae.to_solver_order(system, r, phi)

    def norm(r):
        # forces scaled by the largest external load, constraints by the model size
        rc = jnp.max(jnp.abs(r[n:]), initial=0.0) / lscale
        return jnp.maximum(jnp.max(jnp.abs(r[:n])) / fscale, rc)

    def tangent(y, lf):
        # ε M: ε = regularization · max|diag K| / max(m), from the matrix being built (so
        # the tangent is traced once); the residual, hence the solution, is unchanged.
        # The chain takes ε from its own stiffness and masses: the bordered solver
        # factors the chain block alone, whose rigid-body modes (a beam held by joints
        # only) ε M must lift above round-off however light the beams are beside the
        # bodies
        q, lam = dae.from_solver_order(system, y)
        a = dae.iteration_matrix(system, q, zero_v, lam, t, 0.0, 0.0,
                                 system.constraint_jacobian(q, t), load_factor=lf)
        k_max = jnp.max(jnp.abs(jnp.diagonal(a.e))[:n_border], initial=0.0)
        if system.chain_size:
            k_chain = jnp.max(jnp.abs(jax.vmap(jnp.diagonal)(a.chain.diagonal)).ravel() * ~pad)
            k_max = jnp.maximum(k_max, k_chain)
            eps_chain = regularization * k_chain / jnp.maximum(m_chain, 1e-300)
            # the beam mass has a unit dummy mass on padding nodes: those rows become I
            a = eqx.tree_at(lambda s: s.chain, a, (a.chain + beam_mass.scale(eps_chain)).add_diagonal(
                pad.astype(q.dtype) * (1.0 - eps_chain)))
        eps = regularization * k_max / jnp.maximum(m_max, 1e-300)
        idx = jnp.arange(n_border)
        return eqx.tree_at(lambda s: s.e, a, a.e.at[idx, idx].add(eps * border_mass))

    def load_step(carry, lf):
        y, failed = carry
        sol = root_finder.solve(lambda x: residual(x, lf), lambda x: tangent(x, lf), y, size=n,
                                scale=lscale, residual_norm=norm)
        ok = sol.converged & ~failed
        y_out = jnp.where(ok, sol.x, y)
        # sol.residual_norm: at the iterate returned (the root finder's last pass)
        return (y_out, failed | ~ok), (sol.iterations, sol.residual_norm, ok)

    y0 = dae.to_solver_order(system, q0, lam0)
    (y, _), (its, res, ok) = jax.lax.scan(load_step, (y0, jnp.array(False)), load_factors)
    q, lam = dae.from_solver_order(system, y)
    return q, lam, its, res, ok


def solve_static_pure(system: System, state: State, *, load_steps: int = DEFAULTS.load_steps,
                      tolerance: float = DEFAULTS.tolerance,
                      max_iterations: int = DEFAULTS.max_iterations,
                      regularization: float = DEFAULTS.regularization,
                      root_finder: ModifiedNewton | None = None) -> StaticSolution:
    """Jittable/vmappable static solve (arguments of :func:`solve_static`); never
    raises (check ``converged``)."""
    if root_finder is None:
        root_finder = StaticSolver(tolerance=tolerance, max_iterations=max_iterations).root_finder()
    load_factors = jnp.arange(1, load_steps + 1, dtype=float) / load_steps
    lam0 = jnp.zeros(system.n_constraints)
    q, lam, its, res, ok = _solve(system, state.q, lam0, jnp.asarray(state.t, float), load_factors,
                                  root_finder, jnp.asarray(regularization, float))
    # full Newton steps may turn a body by whole revolutions: report angles in (−π, π]
    theta = 3 * jnp.arange(system.n_bodies) + 2
    q = q.at[theta].set(jnp.pi - jnp.mod(jnp.pi - q[theta], 2 * jnp.pi))
    return StaticSolution(State(q, jnp.zeros_like(q), state.t), lam, its, res, ok, load_factors)


def solve_static(system: System, state: State, *, load_steps: int = DEFAULTS.load_steps,
                 tolerance: float = DEFAULTS.tolerance, max_iterations: int = DEFAULTS.max_iterations,
                 regularization: float = DEFAULTS.regularization,
                 root_finder: ModifiedNewton | None = None) -> StaticSolution:
    """Static equilibrium from the initial guess ``state`` (see module docstring).

    Args (defaults: :class:`StaticSolver`):
        load_steps: number of equal load increments N (>= 1).
        tolerance: on the residual, scaled by the largest external load entry (forces)
            and the model size (constraints); also converged when the Newton correction
            falls below 1e-10 of the model size.
        max_iterations: Newton iterations per load step.
        regularization: relative weight of a mass-proportional term added to the Newton
            matrix (not the residual) so that unloaded, unconstrained coordinates do not
            make it singular.
        root_finder: None (default): ``StaticSolver(tolerance=tolerance,
            max_iterations=max_iterations).root_finder()``, full Newton on the
            structured (block-tridiagonal, bordered) Newton matrix, linear in the
            element count. A :class:`~ancf_jax.newton.ModifiedNewton` is used as given,
            with its own stopping rule (``tolerance`` and ``max_iterations`` then
            unused), e.g. ``StaticSolver(linear_solver=DenseLUSolver()).root_finder()``
            for dense LU solves, or :data:`STATIC_NEWTON` (the step rule alone).

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
        rule = (f"tolerance {tolerance:g}" if root_finder is None else
                f"tolerance {root_finder.residual_tolerance:g}" if root_finder.residual_tolerance > 0 else
                f"step tolerance {root_finder.tolerance:g} of the model size")
        raise StaticsError(
            f"static Newton solver did not converge in load step {k + 1} of {load_steps} "
            f"(load factor {lf:.3g}): scaled residual {res:.3g} after "
            f"{int(sol.iterations[k])} iterations ({rule}); "
            "try more load_steps or a better initial guess",
            load_step=k, load_factor=lf, residual=res, state=sol.state)
    return sol
