"""Modal analysis: K φ = ω² M φ about a configuration, with the constraints eliminated.

The stiffness is the Jacobian of the static residual (see :mod:`ancf_jax.statics`)
by forward-mode autodiff: the Hessian of the strain energy plus, when multipliers are
given (about a static equilibrium), the geometric stiffness of the current stresses
and the constraint Hessian λ·Φ_qq. About the stress-free reference (no multipliers)
it is the Hessian of the strain energy alone. The joints are eliminated with an
orthonormal basis N of the null space of Φ_q: K_r = Nᵀ K N, M_r = Nᵀ M N. Padding
coordinates are removed first.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from .errors import ModelError
from .statics import static_residual
from .system import System


@dataclasses.dataclass(frozen=True)
class ModalResult:
    """Natural frequencies and mode shapes.

    Attributes:
        frequencies_hz: natural frequencies f = ω / 2π [Hz], ascending, shape (k,)
            (negative where ω² < 0: an unstable configuration).
        angular_frequencies: ω [rad/s], shape (k,).
        mode_shapes: mass-normalized modes in system coordinates, shape (k, n).
    """

    frequencies_hz: np.ndarray
    angular_frequencies: np.ndarray
    mode_shapes: np.ndarray


@jax.jit
def _tangent(system: System, q, lam, t):
    def force_residual(qq):
        return static_residual(system, qq, lam, t, 1.0, q)[0]

    return jax.jacfwd(force_residual)(q), system.constraint_jacobian(q, t), system.mass_matrix()


def _reduced(system: System, q, lam, t):
    """(K_r = Nᵀ K N, M, N, active mask): the tangent stiffness about ``q`` with the
    joints eliminated by an orthonormal basis N of the null space of Φ_q, the mass
    matrix, both on the active (unpadded) coordinates."""
    k, jac, mass = (np.asarray(a) for a in _tangent(system, jnp.asarray(q, float), lam,
                                                    jnp.asarray(t, float)))
    keep = ~np.asarray(system.inactive_mask())
    k, mass = k[np.ix_(keep, keep)], mass[np.ix_(keep, keep)]
    jac = jac[:, keep]
    if system.n_constraints:
        _, sv, vt = np.linalg.svd(jac)
        rank = int(np.sum(sv > 1e-10 * sv[0]))
        basis = vt[rank:].T
    else:
        basis = np.eye(k.shape[0])
    kr = basis.T @ k @ basis
    return 0.5 * (kr + kr.T), mass, basis, keep


@jax.jit
def _unit_normal_load(system: System, contact, q):
    return contact.unit_normal_load(system, q)


def contact_point_stiffness(system: System, q, contact, *, t: float = 0.0) -> float:
    """Static stiffness k_b [N/m] of the structure at the point where ``contact`` (a
    :class:`~ancf_jax.contact.UnilateralContact` of ``system``) touches its beam:
    F / w for a force F along the beam's normal on the material point closest to the
    contact's point, w the displacement of that point along the force, with the joints
    and every other force element (the contact's own stiffness excluded: give it 0)
    about the configuration ``q`` (unloaded: the Hessian of the strain energy, the
    stresses of a pre-tensioned ``q`` included, as :func:`modal_analysis` without
    multipliers). Linear: 1 / (fᵀ K_r⁻¹ f), f the load's generalized force reduced to
    the joints' null space. ``inf`` where the joints hold that point (a clamped track);
    0 where nothing holds it against such a force (a free beam)."""
    kr, _, basis, keep = _reduced(system, q, jnp.zeros(system.n_constraints), t)
    load = np.asarray(_unit_normal_load(system, contact, jnp.asarray(q, float)))
    f = basis.T @ load[keep]
    if np.linalg.norm(f) <= 1e-10 * np.linalg.norm(load):
        return np.inf
    x, *_ = np.linalg.lstsq(kr, f, rcond=None)
    if np.linalg.norm(kr @ x - f) > 1e-8 * np.linalg.norm(f):
        return 0.0
    return float(1.0 / (f @ x))


def degrees_of_freedom(system: System) -> int:
    """Number of modes of ``system``: its active coordinates less its constraint
    equations (independent after assembly, :func:`~ancf_jax.model.check_constraint_rank`)."""
    return int(np.sum(~np.asarray(system.inactive_mask()))) - int(system.n_constraints)


def modal_analysis(system: System, q, multipliers=None, *, n_modes: int | None = None,
                   t: float = 0.0) -> ModalResult:
    """Natural frequencies and mode shapes about configuration ``q``.

    Args:
        system: the system.
        q: configuration, shape (n,) (e.g. the reference, or a static equilibrium).
        multipliers: Lagrange multipliers at ``q`` (from :func:`~ancf_jax.statics.solve_static`)
            to include the stress and constraint-force stiffness; None about an unloaded
            configuration.
        n_modes: number of lowest modes to return (default all; at most the number of
            degrees of freedom, :func:`degrees_of_freedom`).

    Raises:
        ModelError: ``n_modes`` outside 1 .. the number of degrees of freedom.
    """
    m = system.n_constraints
    lam = jnp.zeros(m) if multipliers is None else jnp.asarray(multipliers, float)
    if lam.shape != (m,):
        raise ModelError(f"multipliers must have shape ({m},), got {lam.shape}")
    kr, mass, basis, keep = _reduced(system, q, lam, t)
    mr = basis.T @ mass @ basis
    mr = 0.5 * (mr + mr.T)
    chol = np.linalg.cholesky(mr)
    linv = np.linalg.inv(chol)
    a = linv @ kr @ linv.T
    w2, y = np.linalg.eigh(0.5 * (a + a.T))
    modes_r = linv.T @ y
    modes = np.zeros((keep.size, w2.size))
    modes[keep] = basis @ modes_r
    omega = np.sign(w2) * np.sqrt(np.abs(w2))
    if n_modes is not None:
        if not 1 <= n_modes <= w2.size:
            raise ModelError(f"n_modes must be in 1 .. {w2.size} (the degrees of freedom), got {n_modes}")
        omega, modes = omega[:n_modes], modes[:, :n_modes]
    return ModalResult(omega / (2.0 * np.pi), omega, modes.T)
