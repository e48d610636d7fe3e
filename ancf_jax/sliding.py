"""Drives and friction of the sliding joint (paper §4.1 made lossy and driven).

The sliding joint (:class:`~ancf_jax.joints.SlidingJoint`) keeps a body point on a beam
at the sliding coordinate s (Eq. 21, s without mass). A tangential force F [N] between
body and beam (positive: on the body along +s, its reaction on the beam's material
point under it) is a generalized force on s alone,

    Q_s = |r'(s)| F,

because the s-row of the equations of motion, r'(s)·λ = Q_s, then gives the joint
reaction λ (the force on the body) the tangential component λ·t̂ = F, t̂ = r'/|r'|,
and −λ acts on the beam. Its power Q_s ṡ = F u is the force times the sliding speed
u = |r'(s)| ṡ [m/s] of the body relative to the material of the beam.

* :class:`SlidingDriveForce`: a prescribed tangential force F f(t) (a haul rope, a
  motor); external work.
* :class:`SlidingServo`: a velocity servo with a force limit,
  F = F_max tanh(k (u*(t) − u) / F_max): k the gain [N·s/m] at small errors, |F| < F_max;
  external work.
* Prescribed arc length s(t): a :class:`~ancf_jax.joints.PrescribedCoordinate` on s
  (``Model.slider_drive(position=...)``); its multiplier λ_d is the drive: the drive's
  tangential force on the body is −λ_d / |r'|, its work the constraint work W_c.
* :class:`SlidingFriction`: regularized Coulomb friction μ N tanh(u / v_ε) with the
  normal reaction N = |λ·n̂| of the joint (plus an optional viscous part c u),
  opposing u; it depends on λ, so it is an
  :class:`~ancf_jax.forces.AbstractReactionForce` (in the implicit residual with its
  exact linearization in λ). Regularization: under a tangential load F below μN the
  body creeps at the steady speed u = v_ε artanh(F / (μ N)) (e.g. 0.55 v_ε at half the
  sticking limit); the default v_ε = :data:`DEFAULT_REGULARIZATION`. Its one event is
  the reversal of u, where the force swings from ∓μN to ±μN within a speed band of a
  few v_ε (a near-jump a fixed step blurs): with ``locate_crossings`` steps are split
  there (:meth:`SlidingFriction.kinks`).
"""

from __future__ import annotations

from typing import Callable, Optional

import abc

import equinox as eqx
import jax.numpy as jnp

from .element.strain_energy import cross2
from .forces import AbstractForce, AbstractKinked, AbstractReactionForce
from .points import SlidingPoint

#: default regularization speed v_ε of sliding friction [m/s]: a body held by friction
#: creeps at most at v_ε artanh(F/(μN)) (0.55 mm/s at half the sticking limit)
DEFAULT_REGULARIZATION = 1e-3

#: friction reversals (:meth:`SlidingFriction.kinks`) are zero crossings of the sliding
#: speed u beyond a dead band |u| < REVERSAL_BAND v_ε: a step that stays inside it
#: (creep, a body at rest with round-off in u) sees a smooth law and is not split
REVERSAL_BAND = 1e-2


def regularized_coulomb(normal, speed, mu, regularization, viscous):
    """Regularized Coulomb friction F = −μ N tanh(u / v_ε) − c u [N] against the sliding
    speed u [m/s] under the normal force N [N] >= 0 (module docstring: v_ε the
    regularization speed [m/s], c the viscous part [N·s/m]); its power F u <= 0. The law
    of :class:`SlidingFriction` and of friction at a unilateral contact
    (:class:`~ancf_jax.contact.ContactFriction`)."""
    return -mu * normal * jnp.tanh(speed / regularization) - viscous * speed


def reversal_kink(speed, regularization):
    """The kink value of a friction reversal: the sliding speed u [m/s] outside the dead
    band ±REVERSAL_BAND·v_ε, zero inside (module docstring)."""
    band = REVERSAL_BAND * regularization
    return speed - jnp.clip(speed, -band, band)


def sliding_slope(system, beam: int, sliding: int, q):
    """r'(s) of beam ``beam`` at sliding coordinate ``sliding``, shape (2,)."""
    return SlidingPoint(beam, sliding).direction(system, q)


def sliding_speed(system, beam: int, sliding: int, q, v):
    """u = |r'(s)| ṡ [m/s]: speed of the body along the beam relative to its material."""
    return jnp.linalg.norm(sliding_slope(system, beam, sliding, q)) * v[system.sliding_offset + sliding]


def tangential_load(system, beam: int, sliding: int, q, force):
    """Generalized force of a tangential force F [N] on the body (reaction on the beam):
    Q_s = |r'(s)| F on the sliding coordinate, zero elsewhere, shape (n,)."""
    scale = jnp.linalg.norm(sliding_slope(system, beam, sliding, q))
    return jnp.zeros_like(q).at[system.sliding_offset + sliding].set(scale * force)


class AbstractSlidingDrive(AbstractForce):
    """A tangential drive force F(q, v, t) [N] on a sliding joint (module docstring);
    prescribed work (external), no potential, no damping.

    Attributes:
        beam, sliding: the joint's beam and sliding coordinate (indices).
    """

    beam: eqx.AbstractVar[int]
    sliding: eqx.AbstractVar[int]

    @abc.abstractmethod
    def tangential_force(self, system, q, v, t):
        """F [N] on the body along +s (its reaction on the beam)."""

    def potential(self, system, q, t):
        return jnp.zeros(())

    def dissipative_force(self, system, q, v):
        return jnp.zeros_like(q)

    def applied_force(self, system, q, v, t):
        return tangential_load(system, self.beam, self.sliding, q, self.tangential_force(system, q, v, t))

    def coordinates(self, system, q, t):
        return SlidingPoint(self.beam, self.sliding).coordinates(system, q)


class SlidingDriveForce(AbstractSlidingDrive):
    """A prescribed tangential force F f(t) [N] (``time_function`` None: constant)."""

    beam: int = eqx.field(static=True)
    sliding: int = eqx.field(static=True)
    force: jnp.ndarray
    time_function: Optional[Callable] = eqx.field(static=True, default=None)

    def tangential_force(self, system, q, v, t):
        return self.force if self.time_function is None else self.force * self.time_function(t)


class SlidingServo(AbstractSlidingDrive):
    """A velocity servo with a force limit: F = F_max tanh(k (u*(t) − u) / F_max) [N].

    Attributes:
        speed: u*(t) [m/s], a JAX-traceable function of t.
        gain: k [N·s/m] > 0 (the slope at zero error).
        max_force: F_max [N] > 0.
    """

    beam: int = eqx.field(static=True)
    sliding: int = eqx.field(static=True)
    speed: Callable = eqx.field(static=True)
    gain: jnp.ndarray
    max_force: jnp.ndarray

    def tangential_force(self, system, q, v, t):
        error = self.speed(t) - sliding_speed(system, self.beam, self.sliding, q, v)
        return self.max_force * jnp.tanh(self.gain * error / self.max_force)


class SlidingFriction(AbstractReactionForce, AbstractKinked):
    """Regularized Coulomb friction (plus an optional viscous part) on sliding joint
    ``joint`` (index into ``system.constraints``, a
    :class:`~ancf_jax.joints.SlidingJoint`):

        F = −μ N tanh(u / v_ε) − c u  [N],   N = |λ·n̂|,

    N the normal reaction of the joint (λ its multipliers, the force on the body; n̂ ⊥
    r'(s)), u the sliding speed (:func:`sliding_speed`). Smooth in q, v and λ except
    where N passes through zero (|·|); its power F u ≤ 0 is dissipation.

    Attributes:
        joint: index of the sliding joint in the system's constraints (static).
        mu: friction coefficient μ >= 0.
        regularization: v_ε [m/s] > 0 (module docstring: the creep speed it allows).
        viscous: c [N·s/m] >= 0.
    """

    joint: int = eqx.field(static=True)
    mu: jnp.ndarray
    regularization: jnp.ndarray
    viscous: jnp.ndarray

    def _joint(self, system):
        return system.constraints[self.joint]

    def normal_force(self, system, q, lam):
        """N = |λ·n̂| [N], the normal reaction of the joint."""
        c = self._joint(system)
        r1 = sliding_slope(system, c.beam, c.sliding, q)
        o = system.constraint_offset(self.joint)
        return jnp.abs(cross2(r1 / jnp.linalg.norm(r1), lam[o:o + 2]))

    def tangential_force(self, system, q, v, lam):
        """F [N] on the body along +s (class docstring)."""
        c = self._joint(system)
        u = sliding_speed(system, c.beam, c.sliding, q, v)
        return regularized_coulomb(self.normal_force(system, q, lam), u, self.mu, self.regularization, self.viscous)

    def generalized_force(self, system, q, v, t, lam):
        c = self._joint(system)
        return tangential_load(system, c.beam, c.sliding, q, self.tangential_force(system, q, v, lam))

    def coordinates(self, system, q, t):
        c = self._joint(system)
        return SlidingPoint(c.beam, c.sliding).coordinates(system, q)

    def multiplier_indices(self, system):
        return system.constraint_offset(self.joint) + jnp.arange(2)

    def kinks(self, system, q, v):
        """The reversal of the sliding speed u [m/s] (the law's near-jump from ∓μN to
        ±μN): u outside the dead band ±REVERSAL_BAND·v_ε, zero inside, shape (1,)."""
        c = self._joint(system)
        u = sliding_speed(system, c.beam, c.sliding, q, v)
        return jnp.reshape(reversal_kink(u, self.regularization), (1,))
