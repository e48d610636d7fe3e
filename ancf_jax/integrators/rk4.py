"""Classical fourth-order Runge–Kutta on the index-1 form (the paper's integrator, §3.1).

The paper integrates Eq. 14/21 with RK4 at a fixed step. Here the state is
(q, v, D, W_e, W_c): the energy-balance integrals are integrated with the same order
as the motion. After each step the state can be projected back onto the position and
velocity constraint manifolds (``projection=True``, default), or drift can be
controlled by Baumgarte terms (``baumgarte`` = ω [rad/s]).

Explicit: the stable step is bounded by the highest (axial) frequency of the beams,
about 2.8/ω_max; for a steel wire that is microseconds. Use it for validation and for
soft beams; the generalized-α method is the default for stiff ones.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import dae
from ..linalg import AbstractSaddleSolver, AutoSaddleSolver
from .base import AbstractIntegrator, Carry, StepInfo


class RK4(AbstractIntegrator):
    """Classical RK4 at a fixed step.

    Attributes:
        projection: project q and v onto Φ = 0, Φ̇ = 0 after every step.
        baumgarte: Baumgarte ω [rad/s] on the acceleration constraints (0: none).
        linear_solver: solver of the saddle systems (accelerations, projections).
    """

    projection: bool = eqx.field(static=True, default=True)
    baumgarte: float = eqx.field(static=True, default=0.0)
    linear_solver: AbstractSaddleSolver = AutoSaddleSolver()

    @property
    def name(self) -> str:
        return "rk4"

    @property
    def order(self) -> int:
        return 4

    def prepare(self, system):
        return dae.mass_chain_factor(system)

    def forward_only(self) -> "RK4":
        return self

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
        k1 = (v, carry.acc, carry.power)

        # stages 2–4 in one scan: the rate function (a saddle solve with the constraint
        # Jacobian and γ) is traced and compiled once instead of three times
        def stage(k, dt):
            qq, vv = q + dt * k[0], v + dt * k[1]
            a, _, p = self._rates(system, qq, vv, t + dt, context)
            k_next = (vv, a, p)
            return k_next, k_next

        _, ks = jax.lax.scan(stage, k1, jnp.stack([0.5 * h, 0.5 * h, h]))
        comb = jax.tree.map(lambda a, k: h / 6.0 * (a + 2.0 * k[0] + 2.0 * k[1] + k[2]), k1, ks)
        q1, v1, work = q + comb[0], v + comb[1], carry.work + comb[2]
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
