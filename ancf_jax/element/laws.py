"""Material laws of a beam, written once: an axial law N(ε, ε̇) and a bending law M(κ, κ̇).

A law maps a generalized strain γ (the axial strain ε, or the curvature change κ − κ₀)
and its rate γ̇ to the generalized stress (the axial force N [N], or the bending moment
M [N·m]) as

    N(γ, γ̇) = W'(γ) + N_d(γ, γ̇),

the derivative of an elastic energy density W(γ) per unit reference length [J/m] plus
a rate part N_d. Only W enters the element energy (Eq. 8 with W in place of
½ EA ε² and ½ EI (κ − κ₀)²), so the elastic forces and the tangent stiffness keep
coming from autodiff of the one element energy
(:func:`~ancf_jax.element.strain_energy.strain_energy`). The rate part is a
dissipation: its generalized force −∫ N_d δγ g dx (the virtual work of Exudyn's cable
damping, δW = ∫ d γ̇ δγ dx) is part of the damping force of the system, so the energy
balance books its power as dissipated; its linearization for the Newton matrix is one
``jax.jacfwd`` (:meth:`ancf_jax.beam.Beam.element_tangent`).

The laws have no history variables. ``stiffness`` passed to a law is the section's EA
(axial) or EI (bending); the linear and strain-rate damped laws use it, the bilinear
and tabulated laws carry their own stiffnesses. A user's law is
:class:`UserLaw`: pure JAX functions W(γ, k) and optionally N_d(γ, γ̇, k).

Default: no law (``None`` on the beam) is the linear elastic law, through the
unchanged energy expression of Eq. 8 (no rate terms are traced).
"""

from __future__ import annotations

import abc
from typing import Callable, Optional

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from ..validation import check_nonnegative, check_positive


class AbstractLaw(eqx.Module):
    """A constitutive law γ, γ̇ → generalized stress (module docstring)."""

    @property
    @abc.abstractmethod
    def has_rate(self) -> bool:
        """Whether :meth:`rate_force` can be non-zero (static: decides what is traced)."""

    @abc.abstractmethod
    def energy(self, strain, stiffness):
        """Elastic energy density W(γ) [J/m] with W(0) = 0, elementwise on arrays.

        Args:
            strain: γ, any shape (ε [-] or κ − κ₀ [1/m]).
            stiffness: the section's EA [N] or EI [N·m²].
        """

    @abc.abstractmethod
    def rate_force(self, strain, rate, stiffness):
        """Rate part N_d(γ, γ̇) [N or N·m], elementwise (zero where :attr:`has_rate` is False)."""


class AbstractElasticLaw(AbstractLaw):
    """A law without rate part: write :meth:`energy`."""

    @property
    def has_rate(self) -> bool:
        return False

    def rate_force(self, strain, rate, stiffness):
        return jnp.zeros_like(strain)


class LinearElastic(AbstractElasticLaw):
    """N = k γ, W = ½ k γ² with k the section's stiffness (the default law, Eq. 8)."""

    def energy(self, strain, stiffness):
        return 0.5 * stiffness * strain**2


#: default natural strain γ₀ of :class:`StrainRateDamped`: stress-free at the reference
NO_REST = 0.0


class StrainRateDamped(AbstractLaw):
    """N = k (γ − γ₀) + d γ̇: Exudyn's cable law (``ObjectANCFCable2D``'s ``axialDamping``
    d_A [N·s] and ``bendingDamping`` d_K [N·m²·s], ``referenceAxialStrain`` ε₀ and
    ``referenceCurvature`` κ₀): linear elastic with the section's stiffness k about a
    natural strain γ₀ (default 0), plus strain-rate damping d (a dissipation). The
    energy W(γ) = ½ k ((γ − γ₀)² − γ₀²) keeps W(0) = 0.

    Attributes:
        damping: d [N·s] (axial) or [N·m²·s] (bending), >= 0.
        rest: γ₀, the strain [-] or curvature change [1/m] at which the law is
            stress-free (a pre-strained or pre-curved beam on a reference that is not).
    """

    damping: jnp.ndarray
    rest: jnp.ndarray

    def __init__(self, damping, rest=NO_REST):
        self.damping = jnp.asarray(check_nonnegative("damping (strain-rate law)", damping, "N*s or N*m^2*s"), float)
        r = np.asarray(rest, float)
        if r.shape != () or not np.isfinite(r):
            raise ModelError(f"rest (natural strain of the strain-rate law) must be a finite number, got {rest!r}")
        self.rest = jnp.asarray(r)

    @property
    def has_rate(self) -> bool:
        return True

    def energy(self, strain, stiffness):
        return 0.5 * stiffness * ((strain - self.rest) ** 2 - self.rest**2)

    def rate_force(self, strain, rate, stiffness):
        return self.damping * rate


class Bilinear(AbstractElasticLaw):
    """Different stiffness in tension and compression: N = k_t γ for γ ≥ 0, k_c γ for
    γ < 0 (W = ½ k γ², continuous force, stiffness jumps at γ = 0). The section's
    stiffness is not used.

    Attributes:
        tension: k_t [N] (axial) or [N·m²] (bending), > 0.
        compression: k_c, > 0 (e.g. a cable that buckles: k_c ≪ k_t).
    """

    tension: jnp.ndarray
    compression: jnp.ndarray

    def __init__(self, tension, compression):
        self.tension = jnp.asarray(check_positive("tension (bilinear law)", tension, "N or N*m^2"), float)
        self.compression = jnp.asarray(check_positive("compression (bilinear law)", compression,
                                                      "N or N*m^2"), float)

    def energy(self, strain, stiffness):
        return 0.5 * jnp.where(strain >= 0.0, self.tension, self.compression) * strain**2


class Tabulated(AbstractElasticLaw):
    """A nonlinear elastic law given as a table of (γ_i, N_i): N piecewise linear
    between the points, extended linearly with the end slopes; W(γ) = ∫₀^γ N its
    exact integral (piecewise quadratic). The table must contain the stress-free
    state (N = 0 at γ = 0) and have positive slopes. The section's stiffness is not
    used.

    Attributes:
        strains: γ_i, strictly increasing, shape (p,), p >= 2.
        forces: N_i [N or N·m], shape (p,).
    """

    strains: jnp.ndarray
    forces: jnp.ndarray

    def __init__(self, strains, forces):
        g = np.asarray(strains, float)
        n = np.asarray(forces, float)
        if g.ndim != 1 or g.shape != n.shape or g.size < 2 or not np.all(np.isfinite(g)) \
                or not np.all(np.isfinite(n)):
            raise ModelError("tabulated law: strains and forces must be finite arrays of equal length >= 2, "
                             f"got shapes {g.shape} and {n.shape}")
        if np.any(np.diff(g) <= 0.0):
            raise ModelError("tabulated law: strains must be strictly increasing")
        if np.any(np.diff(n) <= 0.0):
            raise ModelError("tabulated law: forces must increase with the strain (positive stiffness)")
        if not g[0] <= 0.0 <= g[-1]:
            raise ModelError(f"tabulated law: the strains must include 0 (the stress-free reference), "
                             f"got {g[0]:.6g} .. {g[-1]:.6g}")
        n0 = float(np.interp(0.0, g, n))
        if abs(n0) > 1e-12 * np.max(np.abs(n)):
            raise ModelError(f"tabulated law: the force at zero strain must be 0 (stress-free "
                             f"reference), the table gives {n0:.6g}")
        self.strains = jnp.asarray(g)
        self.forces = jnp.asarray(n)

    def _antiderivative(self, strain):
        """C(γ) = ∫_{γ₀}^γ N, exact for the piecewise linear N."""
        g, n = self.strains, self.forces
        slopes = jnp.diff(n) / jnp.diff(g)
        cumulative = jnp.concatenate([jnp.zeros(1), jnp.cumsum(0.5 * (n[1:] + n[:-1]) * jnp.diff(g))])
        k = jnp.clip(jnp.searchsorted(g, strain, side="right") - 1, 0, g.shape[0] - 2)
        d = strain - g[k]
        return cumulative[k] + n[k] * d + 0.5 * slopes[k] * d * d

    def energy(self, strain, stiffness):
        return self._antiderivative(strain) - self._antiderivative(jnp.zeros_like(strain))


class UserLaw(AbstractLaw):
    """A user's law as pure JAX functions (elementwise on arrays, traceable):
    ``energy(γ, k)`` → W [J/m] with W(0) = 0 and optionally ``rate_force(γ, γ̇, k)`` →
    N_d (k the section's EA or EI). N = ∂W/∂γ + N_d; forces and the Newton matrix
    follow by autodiff."""

    energy_function: Callable = eqx.field(static=True)
    rate_function: Optional[Callable] = eqx.field(static=True, default=None)

    @property
    def has_rate(self) -> bool:
        return self.rate_function is not None

    def energy(self, strain, stiffness):
        return self.energy_function(strain, stiffness)

    def rate_force(self, strain, rate, stiffness):
        if self.rate_function is None:
            return jnp.zeros_like(strain)
        return self.rate_function(strain, rate, stiffness)


def check_law(what: str, law) -> Optional[AbstractLaw]:
    """``law`` if it is None or an :class:`AbstractLaw`, else a one-line ModelError."""
    if law is not None and not isinstance(law, AbstractLaw):
        raise ModelError(f"{what} must be a law from ancf_jax.element.laws (LinearElastic, StrainRateDamped, "
                         f"Bilinear, Tabulated, UserLaw) or None, got {law!r}")
    return law
