"""Common state and interfaces of the solvers: :class:`AbstractSolver`, its fixed-step
:class:`AbstractIntegrator` (init/step, run by the one time loop of
:mod:`ancf_jax.integrate`) and :class:`AbstractAdaptiveSolver` (diffrax), and the
:class:`Carry` of the fixed-step loop."""

from __future__ import annotations

import abc
import dataclasses
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp


class Carry(eqx.Module):
    """What a one-step integrator carries from step to step.

    Attributes:
        t: time [s].
        q: coordinates, shape (n,).
        v: velocities, shape (n,).
        acc: accelerations q̈, shape (n,).
        aux: integrator-specific vector (the generalized-α pseudo-acceleration; zeros
            for the explicit methods), shape (n,). Kept apart from ``memory``: it is
            state of the method, needed to continue a run exactly (saved as
            ``checkpoint_aux`` in NPZ files), where ``memory`` is a cache of the solver
            that a run may leave out (None) or rebuild; one (n,) vector is the whole
            cost for the methods that do not use it.
        lam: Lagrange multipliers λ, shape (m,).
        work: time integrals (dissipated D, external work W_e, constraint work W_c) [J], shape (3,).
        power: their rates at t (:func:`ancf_jax.dae.powers`) [W].
        memory: what the integrator keeps of its solver across steps (a pytree of
            fixed shapes, or None): generalized-α's Newton-matrix factors under
            :class:`~ancf_jax.integrators.generalized_alpha.AcrossSteps`.
    """

    t: jnp.ndarray
    q: jnp.ndarray
    v: jnp.ndarray
    acc: jnp.ndarray
    aux: jnp.ndarray
    lam: jnp.ndarray
    work: jnp.ndarray
    power: jnp.ndarray
    memory: Any = None


class AbstractMemory(eqx.Module):
    """What an integrator keeps of its solver across steps (:attr:`Carry.memory`) when
    it is large: kept by :meth:`select` without copying, where the run loop selects
    between a step's result and the state before it."""

    @abc.abstractmethod
    def select(self, keep, old: "AbstractMemory") -> "AbstractMemory":
        """The memory after a step whose result is kept where ``keep`` (bool, batched
        under vmap) holds and discarded otherwise; ``self`` is the step's, ``old`` the
        one before it."""


def select_carry(keep, new: Carry, old: Carry) -> Carry:
    """``new`` where ``keep`` holds, else ``old`` (a step kept or discarded): every
    field by ``jnp.where``, an :class:`AbstractMemory` by its :meth:`~AbstractMemory.select`.

    Why the memory is apart: a select reads both operands and writes a third array, and
    generalized-α's carried Newton-matrix factors are megabytes (the 10-span
    pantograph–catenary: ~10 MB); the run loop selects carries up to four times per step,
    which cost 1.9 of 18.8 ms per step (the 10-span model of
    ``benchmarks.pantograph_catenary`` at h = 1 ms, ``reuse_factors = 16``, 0–0.2 s, with
    and without this, 2026-12-06; identical results)."""
    memory = new.memory
    if not isinstance(memory, AbstractMemory):
        return jax.tree.map(lambda a, b: jnp.where(keep, a, b), new, old)
    rest = jax.tree.map(lambda a, b: jnp.where(keep, a, b), dataclasses.replace(new, memory=None),
                        dataclasses.replace(old, memory=None))
    return dataclasses.replace(rest, memory=memory.select(keep, old.memory))


class StepInfo(eqx.Module):
    """Per-step diagnostics: Newton iterations (0 for explicit methods) and convergence."""

    iterations: jnp.ndarray
    converged: jnp.ndarray


class AbstractSolver(eqx.Module):
    """Anything :func:`~ancf_jax.simulation.simulate` runs: a fixed-step
    :class:`AbstractIntegrator` or an :class:`AbstractAdaptiveSolver`.

    ``prepare(system)`` returns quantities computed once per run (e.g. the factors of the
    constant beam mass), passed to every step as ``context``.
    """

    @property
    @abc.abstractmethod
    def name(self) -> str:
        """The solver's name in scenario files, results and messages."""

    @property
    @abc.abstractmethod
    def order(self) -> int:
        """Order of accuracy of the method."""

    @abc.abstractmethod
    def prepare(self, system):
        """Quantities computed once per run (e.g. mass factors), passed to every step."""


class AbstractIntegrator(AbstractSolver):
    """A fixed-step one-step method for the constrained equations of motion.

    ``init(system, state, context)`` returns the initial :class:`Carry`;
    ``step(system, carry, h, context)`` advances it by h and returns
    ``(carry, StepInfo)``.
    """

    @abc.abstractmethod
    def forward_only(self) -> "AbstractIntegrator":
        """The same method for runs that are never differentiated (chunked
        :func:`~ancf_jax.simulation.simulate`): an integrator may leave out what only
        derivatives need, which shortens tracing and compilation. Same results."""

    @abc.abstractmethod
    def init(self, system, state, context) -> Carry:
        """The initial :class:`Carry` of a run from ``state`` (consistent accelerations
        and multipliers)."""

    @abc.abstractmethod
    def resume(self, system, carry: Carry, context) -> Carry:
        """``carry`` (of a checkpoint) with the ``memory`` this integrator carries: kept
        where it fits (same structure and shapes, or its leaves as a checkpoint file
        holds them), else fresh; None for an integrator that keeps none."""

    @abc.abstractmethod
    def step(self, system, carry: Carry, h, context):
        """Advance ``carry`` by the step h [s]; returns ``(carry, StepInfo)``."""


class AbstractAdaptiveSolver(AbstractSolver):
    """An adaptive-step solver of the index-1 equations of motion, run between output
    times by :func:`~ancf_jax.simulation.simulate` (not differentiable by
    :func:`~ancf_jax.simulation.trajectory`, not batched).

    The state is y = (q, v, work); ``solve`` integrates from t0 and saves at ``ts``,
    returning ``(ys, result, steps)`` (``result`` a ``diffrax.RESULTS`` item, mapped to a
    :class:`~ancf_jax.failures.Failure` by :func:`ancf_jax.integrate.adaptive_failure`);
    ``multipliers`` gives accelerations and multipliers
    at saved states.
    """

    max_steps: eqx.AbstractVar[int]

    @abc.abstractmethod
    def solve(self, system, context, y0, t0, ts, dt0):
        """((q, v, work) at ``ts``, the solve's ``diffrax.RESULTS``, steps taken)."""

    @abc.abstractmethod
    def multipliers(self, system, context, q, v, t):
        """(accelerations, multipliers) at saved states, vmapped over the leading axis."""
