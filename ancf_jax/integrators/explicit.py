"""Explicit fixed-step methods on the index-1 form: the paper's classical RK4 (§3.1)
and, for parity with Exudyn's ``ExplicitEuler``, the explicit (forward) Euler method.

The paper integrates Eq. 14/21 with RK4 at a fixed step. Here the state is
(q, v, D, W_e, W_c): the energy-balance integrals are integrated with the same method
as the motion. After each step the state can be projected back onto the position and
velocity constraint manifolds (``projection=True``, default), or drift can be
controlled by Baumgarte terms (``baumgarte`` = ω [rad/s]).

Both are explicit: the stable step is bounded by the highest (axial) frequency of the
beams, about 2.8/ω_max for RK4; forward Euler is unstable for undamped oscillations at
any step (its amplification factor is |1 + iωh| > 1), so over a run of many periods it
needs a step far below the period of the fastest mode, or damping. For a steel wire
that is microseconds. Use them for validation, for parity studies and for soft beams;
the generalized-α method is the default for stiff ones.
"""

from __future__ import annotations

import abc
import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import dae
from ..linalg import AbstractSaddleSolver, AutoSaddleSolver
from .base import AbstractIntegrator, Carry, StepInfo


class AbstractExplicit(AbstractIntegrator):
    """An explicit one-step method: ``increment`` gives h·Φ (the increments of q, v
    and the work integrals) from the rates at the start of the step; then the optional
    projection and the rates at the end of the step (carried to the next one).

    Attributes:
        projection: project q and v onto Φ = 0, Φ̇ = 0 after every step.
        baumgarte: Baumgarte ω [rad/s] on the acceleration constraints (0: none).
        linear_solver: solver of the saddle systems (accelerations, projections).
    """

    projection: eqx.AbstractVar[bool]
    baumgarte: eqx.AbstractVar[float]
    linear_solver: eqx.AbstractVar[AbstractSaddleSolver]

    @abc.abstractmethod
    def increment(self, rates, t, q, v, k1, h):
        """(Δq, Δv, Δwork) of a step of size h from (t, q, v), whose rates
        (v, q̈, powers) are ``k1``; ``rates(q, v, t)`` gives the rates elsewhere."""

    def prepare(self, system):
        return dae.mass_chain_factor(system)

    def forward_only(self):
        return self

    def resume(self, system, carry, context):
        return dataclasses.replace(carry, memory=None)

    def _rates(self, system, q, v, t, chain_factor):
        acc, lam = dae.accelerations(system, q, v, t, baumgarte=self.baumgarte,
                                     chain_factor=chain_factor, linear_solver=self.linear_solver)
        return acc, lam, dae.powers(system, q, v, t, lam)

    def init(self, system, state, context) -> Carry:
        t = jnp.asarray(state.t, float)
        acc, lam = dae.accelerations(system, state.q, state.v, t, baumgarte=self.baumgarte,
                                     chain_factor=context, linear_solver=self.linear_solver)
        return Carry(t, state.q, state.v, acc, jnp.zeros_like(state.q), lam, jnp.zeros(3),
                     dae.powers(system, state.q, state.v, t, lam))

    def step(self, system, carry: Carry, h, context):
        t, q, v = carry.t, carry.q, carry.v

        def rates(qq, vv, tt):
            a, _, p = self._rates(system, qq, vv, tt, context)
            return vv, a, p

        dq, dv, dwork = self.increment(rates, t, q, v, (v, carry.acc, carry.power), h)
        q1, v1, work = q + dq, v + dv, carry.work + dwork
        t1 = t + h
        if self.projection and system.n_constraints:
            newton = eqx.tree_at(lambda r: r.linear_solver, dae.PROJECTION_NEWTON, self.linear_solver)
            q1 = dae.project_position(system, q1, t1, chain_factor=context, root_finder=newton)
            jac = system.constraint_jacobian(q1, t1)
            f = dae.mass_saddle_factor(system, jac, context, linear_solver=self.linear_solver)
            v1 = dae.project_velocity(system, q1, v1, t1, f, jac)
        acc, lam, power = self._rates(system, q1, v1, t1, context)
        info = StepInfo(jnp.zeros((), jnp.int32), jnp.array(True))
        return Carry(t1, q1, v1, acc, carry.aux, lam, work, power), info


class RK4(AbstractExplicit):
    """Classical RK4 at a fixed step (fourth order)."""

    projection: bool = eqx.field(static=True, default=True)
    baumgarte: float = eqx.field(static=True, default=0.0)
    linear_solver: AbstractSaddleSolver = AutoSaddleSolver()

    @property
    def name(self) -> str:
        return "rk4"

    @property
    def order(self) -> int:
        return 4

    def increment(self, rates, t, q, v, k1, h):
        # stages 2–4 in one scan: the rate function (a saddle solve with the constraint
        # Jacobian and γ) is traced and compiled once instead of three times
        def stage(k, dt):
            k_next = rates(q + dt * k[0], v + dt * k[1], t + dt)
            return k_next, k_next

        _, ks = jax.lax.scan(stage, k1, jnp.stack([0.5 * h, 0.5 * h, h]))
        return jax.tree.map(lambda a, k: h / 6.0 * (a + 2.0 * k[0] + 2.0 * k[1] + k[2]), k1, ks)


class ExplicitEuler(AbstractExplicit):
    """Explicit (forward) Euler at a fixed step (first order), as Exudyn's
    ``ExplicitEuler``: q₁ = q₀ + h v₀, v₁ = v₀ + h q̈₀, with q̈₀ and λ₀ from the index-1
    system at the start of the step."""

    projection: bool = eqx.field(static=True, default=True)
    baumgarte: float = eqx.field(static=True, default=0.0)
    linear_solver: AbstractSaddleSolver = AutoSaddleSolver()

    @property
    def name(self) -> str:
        return "explicit-euler"

    @property
    def order(self) -> int:
        return 1

    def increment(self, rates, t, q, v, k1, h):
        return jax.tree.map(lambda k: h * k, k1)
