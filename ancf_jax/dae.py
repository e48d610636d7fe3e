"""The index-reduced DAE of the system (paper Eqs. 12–14, 21) and its linear algebra.

Equations of motion with Lagrange multipliers::

    M q̈ + Φ_qᵀ λ = Q(q, q̇, t),      Φ(q, t) = 0.

Differentiating the constraints twice gives the acceleration-level (index-1) form
solved by the explicit integrators (Eq. 13/14/21)::

    [ M    Φ_qᵀ ] [ q̈ ]   [ Q ]
    [ Φ_q  0    ] [ λ  ] = [ γ − 2 ξ ω Φ̇ − ω² Φ ]

with γ from Eq. 12 (nested JVPs in :meth:`ancf_jax.system.System.constraint_rhs`) and
optional Baumgarte terms (ω [rad/s], ξ = 1) against drift. The sliding coordinates
have no mass; the matrix stays regular because Φ_q has the beam tangent in their
columns (Eq. 21).

All matrices here are in bordered form (:class:`~ancf_jax.linalg.SaddleMatrix`): the
beam coordinates form the block-tridiagonal chain; rigid-body coordinates, sliding
coordinates and multipliers form the border. Solves cost O(elements).
"""

from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np

from .linalg import (AbstractSaddleSolver, AutoSaddleSolver, BlockTridiagonal, SaddleFactor, SaddleMatrix,
                     factor_chain, solve_symmetric_implicit)
from .errors import InexactNewtonMatrixWarning
from .forces import AbstractForceSet, force_tangent, force_tangent_local, reaction_force_tangent
from .joints import nonlinear_joints
from .newton import ModifiedNewton
from .system import System


def border_indices(system: System) -> np.ndarray:
    """Indices in q of the coordinates outside the beam chain (bodies, sliding coordinates)."""
    return system.border_indices()


def solver_permutation(system: System) -> np.ndarray:
    """Indices of q in solver order: chain (beam) coordinates in the system's chain
    layout, then the border."""
    return np.concatenate([system.chain_indices(), border_indices(system)]).astype(int)


def to_solver_order(system: System, vec_q, vec_lam):
    """[chain part of vec_q, border part of vec_q, vec_lam] (leading axis)."""
    return jnp.concatenate([vec_q[solver_permutation(system)], vec_lam], axis=0)


def from_solver_order(system: System, x):
    """Inverse of :func:`to_solver_order`: returns (vector in q order, λ part).

    A gather with the inverse permutation (its transpose is a scatter-add, so reverse
    mode differentiates through it)."""
    n = system.n_coordinates
    inverse = np.argsort(solver_permutation(system))
    return x[:n][inverse], x[n:]


def saddle_matrix(system: System, chain: BlockTridiagonal | None, border_block, jac,
                  coupling=None) -> SaddleMatrix:
    """Bordered matrix [[K, Φ_qᵀ], [Φ_q, 0]] for a chain block K_cc (block tridiagonal),
    a border block K_bb (dense, (n_b, n_b)) and an optional symmetric chain–border
    coupling K_cb (dense, (n_c, n_b))."""
    c = system.chain_selector()
    bi = border_indices(system)
    jc, jb = jac[:, c], jac[:, bi]
    n_c, n_bc, m = system.chain_size, len(bi), jac.shape[0]
    k_cb = jnp.zeros((n_c, n_bc)) if coupling is None else coupling
    b = jnp.concatenate([k_cb, jc.T], axis=1)
    e = jnp.block([[border_block, jb.T], [jb, jnp.zeros((m, m))]]) if m else border_block
    return SaddleMatrix(chain if n_c else None, b, b.T, e)


def mass_chain_factor(system: System):
    """Factors of the (constant) beam mass; None without beams."""
    return factor_chain(system.beam_mass()) if system.chain_size else None


def mass_saddle_matrix(system: System, jac) -> SaddleMatrix:
    """[[M, Φ_qᵀ], [Φ_q, 0]] at the current Φ_q (symmetric), in bordered form."""
    return saddle_matrix(system, system.beam_mass() if system.chain_size else None,
                         jnp.diag(system.border_mass_diagonal()), jac)


def mass_saddle_factor(system: System, jac, chain_factor=None, *,
                       linear_solver: AbstractSaddleSolver = AutoSaddleSolver()) -> SaddleFactor:
    """Factors of [[M, Φ_qᵀ], [Φ_q, 0]] at the current Φ_q (``chain_factor``: the
    constant beam mass's, :func:`mass_chain_factor`)."""
    return linear_solver.init(mass_saddle_matrix(system, jac), chain_factor)


def powers(system: System, q, v, t, lam):
    """Rates of the energy-balance terms, shape (3,):
    [dissipation −v·Q_damping ≥ 0, external power v·Q_applied, constraint power λ·Φ_t].

    With T + V + U the mechanical energy, d/dt (T + V + U) = −P_d + P_e + P_c, so
    T + V + U + D − W_e − W_c stays constant (D, W_e, W_c the time integrals).
    """
    p_d = -jnp.dot(v, system.damping_force(q, v))
    if system.reaction_forces:
        p_d = p_d - jnp.dot(v, system.reaction_force(q, v, t, lam))
    p_e = jnp.dot(v, system.applied_force(q, v, t))
    p_c = jnp.dot(lam, system.constraint_time_derivative(q, t)) if system.n_constraints else jnp.zeros(())
    return jnp.stack([p_d, p_e, p_c])


#: fixed-point iterations on λ of the index-1 accelerations of systems with
#: reaction-dependent forces (friction). A fixed count, not a loop to a tolerance, so
#: that the accelerations stay reverse-differentiable and vmappable at a fixed cost.
#: The map λ ↦ solve(Q + Q_r(λ)) contracts by the coupling of a tangential friction
#: force to the normal reaction, which is small: a tangential force on a beam point
#: moves it along the beam only (the ANCF mass is the same in x and y), so only the
#: bodies couple it. Measured (hauled_cabin, the frictional eyelets of
#: benchmarks/eyelets.py, M2's trolley and cabin, μ from 0.05 to 3, mid-run states):
#: exact after one iteration where the force acts on a beam or a driven body, a
#: contraction of ~1e-3 per iteration for M2's swinging cabin at μ = 3, so 12 reach
#: rounding (tests/models/test_m2.py::test_friction_reaction_fixed_point_converges).
#: A body whose coupling contracts by more than ~0.05 (a sliding point far from a
#: light body's centre) would leave a λ error of that factor to the 12th power, and a
#: coupling of 1 or more diverges to a "nan" failure.
REACTION_ITERATIONS = 12


def accelerations(system: System, q, v, t, *, baumgarte: float = 0.0, chain_factor=None,
                  linear_solver: AbstractSaddleSolver = AutoSaddleSolver(),
                  reaction_iterations: int = REACTION_ITERATIONS):
    """Accelerations q̈ and multipliers λ of the index-1 form (module docstring).

    Args:
        baumgarte: ω [rad/s] of the critically damped Baumgarte stabilization
            (0: none).
        chain_factor: precomputed factors of the beam mass (it is constant).
        linear_solver: solver of the saddle system.
        reaction_iterations: fixed-point iterations on λ where forces depend on it
            (friction; :data:`REACTION_ITERATIONS`).

    Returns:
        (q̈ (n,), λ (m,)).
    """
    jac = system.constraint_jacobian(q, t)
    rhs_q = system.generalized_force(q, v, t)
    gamma = system.constraint_rhs(q, v, t)
    if system.n_constraints and baumgarte:
        w = baumgarte
        gamma = gamma - 2.0 * w * system.constraint_velocity(q, v, t) - w * w * system.constraint(q, t)
    f = mass_saddle_factor(system, jac, chain_factor, linear_solver=linear_solver)
    x = linear_solver.compute(f, to_solver_order(system, rhs_q, gamma))
    if system.reaction_forces:
        # friction depends on λ: fixed-point iteration λ ↦ Q_r(λ) ↦ solve, with the same
        # factors (REACTION_ITERATIONS of them: why that suffices is written there)
        def again(_, x):
            _, lam = from_solver_order(system, x)
            return linear_solver.compute(f, to_solver_order(
                system, rhs_q + system.reaction_force(q, v, t, lam), gamma))
        x = jax.lax.fori_loop(0, reaction_iterations, again, x)
    return from_solver_order(system, x)


def project_velocity(system: System, q, v, t, factor: SaddleFactor, jac=None):
    """Project v onto Φ_q v + Φ_t = 0 in the mass metric (minimum-norm correction).

    ``factor``: :func:`mass_saddle_factor` at ``jac`` (= Φ_q(q, t)). The solve is
    differentiated implicitly (:func:`~ancf_jax.linalg.solve_symmetric_implicit`):
    gradients and tangents through a step reuse these factors instead of
    differentiating the factorization."""
    if not system.n_constraints:
        return v
    jac = system.constraint_jacobian(q, t) if jac is None else jac
    viol = jac @ v + system.constraint_time_derivative(q, t)
    x = solve_symmetric_implicit(mass_saddle_matrix(system, jac), factor,
                                 to_solver_order(system, jnp.zeros_like(v), -viol))
    dv, _ = from_solver_order(system, x)
    return v + dv


#: root finder of the position projection: full Newton (Φ_q refreshed at every
#: iteration) to 1e-12 m; usually two iterations after an explicit step
PROJECTION_NEWTON = ModifiedNewton(tolerance=1e-12, max_iterations=4, contraction=0.0)


def project_position(system: System, q, t, *, chain_factor=None,
                     root_finder: ModifiedNewton = PROJECTION_NEWTON, implicit: bool = True):
    """Project q onto Φ(q, t) = 0 in the mass metric (``chain_factor``: the constant
    beam mass's factors, reused in every iteration): the nearest point
    argmin ½ |p − q|²_M subject to Φ(p, t) = 0, as the root of its optimality conditions

        M (p − q) + Φ_p(p)ᵀ μ = 0,   Φ(p, t) = 0,

    by ``root_finder`` on the matrix [[M, Φ_pᵀ], [Φ_p, 0]] (the curvature term μ·Φ_pp
    is left out: μ vanishes at the solution when q is on the manifold, and it is of
    the size of the drift otherwise). Differentiated implicitly when ``implicit``
    (otherwise the iterations are not meant to be differentiated, and nothing of the
    implicit derivative is traced)."""
    if not system.n_constraints:
        return q
    n = system.n_coordinates

    def residual(y):
        p, mu = from_solver_order(system, y)
        phi, vjp = jax.vjp(lambda z: system.constraint(z, t), p)
        return to_solver_order(system, system.mass_times(p - q) + vjp(mu)[0], phi)

    def linearize(y):
        p, _ = from_solver_order(system, y)
        return mass_saddle_matrix(system, system.constraint_jacobian(p, t))

    y0 = to_solver_order(system, q, jnp.zeros(system.n_constraints, q.dtype))
    sol = root_finder.root(residual, linearize, y0, size=n, chain_factor=chain_factor, implicit=implicit)
    return from_solver_order(system, sol.x)[0]


def iteration_matrix(system: System, q, v, lam, t, beta_p, gamma_p, jac, load_factor=1.0) -> SaddleMatrix:
    """Newton matrix of implicit integrators: the exact linearization of the residual

        r(q, λ) = M q̈ − Q(q, v, t) + Φ_q(q)ᵀ λ,   Φ(q, t),

    with q̈ = q̈⁰ + β' Δq and v = v⁰ + γ' Δq along a correction Δq (β' = γ' = 0:
    statics), in bordered form::

        [[M β' − ∂Q/∂q − γ' ∂Q/∂v + (λ·Φ)_qq, Φ_qᵀ], [Φ_q, 0]]

    Written from the physics once, by autodiff, keeping the structure:

    * beam blocks: M_b (β' + α_b γ') plus, per element, the Jacobian of the elastic
      and stiffness-proportional damping force along (δe, γ' δe)
      (:meth:`ancf_jax.beam.Beam.element_tangent`: K (1 + β_b γ') + β_b ∂(K ė)/∂e);
    * border block: M_border β' and the constraint Hessian (λ·Φ)_qq in the border rows
      and columns, by one ``jacfwd`` over the few border coordinates (rigid-body and
      sliding coordinates). The joints are linear in the beam coordinates (Eqs. 19–20
      are linear in e), so its chain–chain block is zero; the coupling of a massless
      sliding coordinate to the cable through λ·S'(s) is essential for Newton;
    * reaction-dependent forces (friction): their exact linearization in q, v and λ
      (:func:`ancf_jax.forces.reaction_force_tangent`), a non-symmetric low-rank term;
    * force elements: each element's exact local linearization
      (:func:`ancf_jax.forces.force_tangent`) over the coordinates it acts on: in the
      chain where they lie in two neighbouring chain blocks (``system.banded_forces``:
      droppers between interleaved wires, support springs), otherwise as a low-rank
      term (auxiliary unknowns of :class:`SaddleMatrix`), so a spring between any two
      points, or a user-written law, is in the matrix.

    ``load_factor`` scales the applied loads (statics' load stepping). Warns
    (:class:`~ancf_jax.errors.InexactNewtonMatrixWarning`, while tracing, before
    compilation) for a joint not declared linear in the beam coordinates
    (:class:`~ancf_jax.joints.AbstractConstraint`), whose chain–chain Hessian block this
    matrix leaves out: exact for a user's joint between rigid bodies, inexact (slower
    Newton, never a different solution) for one nonlinear in beam coordinates.
    """
    for c in nonlinear_joints(system):
        warnings.warn(f"joint {c.name!r} ({type(c).__name__}) is not declared linear in the beam coordinates: "
                      "the Newton matrix leaves out its Hessian between beam coordinates (exact if it does "
                      "not depend on them nonlinearly; then set linear_in_beam_coordinates = True on its class "
                      "and its points'; see ancf_jax.joints.AbstractConstraint)",
                      InexactNewtonMatrixWarning, stacklevel=2)
    chain = None
    if system.chain_size:
        def beam_block(b, nodes, vel):
            k = BlockTridiagonal.from_element_matrices(b.element_tangent(nodes, vel, gamma_p))
            return b.mass().scale(beta_p + b.alpha * gamma_p) + k

        beams = range(len(system.beams))
        parts = system.map_beams(beam_block, [system.beam_nodes(q, i) for i in beams],
                                 [system.beam_nodes(v, i) for i in beams])
        chain = system.layout.assemble(parts)
        if system.banded_forces:
            position = np.argsort(solver_permutation(system))  # q index → solver row
            for i in system.banded_forces:
                f = system.forces[i]
                if isinstance(f, AbstractForceSet):  # one local matrix per member
                    idx, a = f.member_tangents(system, q, v, t, gamma_p, load_factor)
                    chain = chain.add_local_many(jnp.asarray(position)[idx], a)
                else:
                    idx, a = force_tangent_local(f, system, q, v, t, gamma_p, load_factor)
                    chain = chain.add_local(jnp.asarray(position)[idx], a)
    bi = border_indices(system)
    border = jnp.diag(system.border_mass_diagonal() * beta_p)
    coupling = None
    if system.n_constraints and len(bi):
        def grad_lam_phi(xb):
            qq = q.at[bi].set(xb)
            return jax.grad(lambda z: jnp.dot(lam, system.constraint(z, t)))(qq)
        h = jax.jacfwd(grad_lam_phi)(q[bi])  # (n, n_b): ∂²(λ·Φ)/∂q ∂q_border
        border = border + h[bi]
        coupling = h[system.chain_selector()]
    matrix = saddle_matrix(system, chain, border, jac, coupling)
    others = [f for i, f in enumerate(system.forces) if i not in system.banded_forces]
    if others:
        perm = solver_permutation(system)
        m = system.n_constraints
        ps, as_ = [], []
        for f in others:
            p, a = force_tangent(f, system, q, v, t, gamma_p, load_factor)
            ps.append(jnp.concatenate([p[:, perm], jnp.zeros((p.shape[0], m), p.dtype)], axis=1))
            as_.append(a)
        matrix = matrix.with_low_rank(jnp.concatenate(ps), jax.scipy.linalg.block_diag(*as_))
    if system.reaction_forces:
        # friction: ∂Q_r/∂(q, v, λ), non-symmetric, over its coordinates and multipliers
        perm = solver_permutation(system)
        n = system.n_coordinates
        ps, as_ = [], []
        for f in system.reaction_forces:
            p, a = reaction_force_tangent(f, system, q, v, lam, t, gamma_p)
            ps.append(jnp.concatenate([p[:, :n][:, perm], p[:, n:]], axis=1))
            as_.append(a)
        matrix = matrix.with_low_rank(jnp.concatenate(ps), jax.scipy.linalg.block_diag(*as_))
    return matrix
