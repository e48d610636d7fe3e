"""Common state and interface of the one-step integrators."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp


class Carry(eqx.Module):
    """What a one-step integrator carries from step to step.

    Attributes:
        t: time [s].
        q: coordinates, shape (n,).
        v: velocities, shape (n,).
        acc: accelerations q̈, shape (n,).
        aux: integrator-specific vector (the generalized-α pseudo-acceleration), shape (n,).
        lam: Lagrange multipliers λ, shape (m,).
        work: time integrals (dissipated D, external work W_e, constraint work W_c) [J], shape (3,).
        power: their rates at t (:func:`ancf_jax.dae.powers`) [W].
    """

    t: jnp.ndarray
    q: jnp.ndarray
    v: jnp.ndarray
    acc: jnp.ndarray
    aux: jnp.ndarray
    lam: jnp.ndarray
    work: jnp.ndarray
    power: jnp.ndarray


class StepInfo(eqx.Module):
    """Per-step diagnostics: Newton iterations (0 for explicit methods) and convergence."""

    iterations: jnp.ndarray
    converged: jnp.ndarray


class AbstractIntegrator(eqx.Module):
    """A fixed-step one-step method for the constrained equations of motion.

    ``init(system, state, context)`` returns the initial :class:`Carry`;
    ``step(system, carry, h, context)`` advances it by h and returns
    ``(carry, StepInfo)``. ``context`` holds quantities computed once per run
    (:meth:`prepare`), e.g. the factors of the constant beam mass.
    """

    def prepare(self, system):
        """Quantities computed once per run (e.g. mass factors), passed to every step."""
        return None

    def forward_only(self) -> "AbstractIntegrator":
        """The same method for runs that are never differentiated (chunked
        :func:`~ancf_jax.simulation.simulate`): an integrator may leave out what only
        derivatives need, which shortens tracing and compilation. Same results."""
        return self

    def init(self, system, state, context) -> Carry:
        """The initial :class:`Carry` of a run from ``state`` (consistent accelerations
        and multipliers)."""
        raise NotImplementedError

    def step(self, system, carry: Carry, h, context):
        """Advance ``carry`` by the step h [s]; returns ``(carry, StepInfo)``."""
        raise NotImplementedError

    @property
    def order(self) -> int:
        """Order of accuracy of the method."""
        raise NotImplementedError
