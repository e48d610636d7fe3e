"""Diffrax's adaptive explicit (Tsit5, Dopri5) and implicit (Kvaerno5) solvers on the
index-1 form of the equations of motion.

The state is y = (q, v, D, W_e, W_c) and ẏ = (v, q̈(q, v, t), powers), with q̈ from the
augmented system of :func:`ancf_jax.dae.accelerations` (Baumgarte ω optional, default
on: adaptive steps do not allow a projection between steps). These solvers are
differentiable through diffrax's adjoints and serve as independent references; for
stiff steel beams they are slow (the axial modes force tiny explicit steps, and the
implicit Kvaerno5 has to build a dense Jacobian of the acceleration map), which the
benchmarks quantify.
"""

from __future__ import annotations

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx

from .. import dae
from ..linalg import AbstractSaddleSolver, AutoSaddleSolver
from .base import AbstractAdaptiveSolver

KINDS = ("tsit5", "dopri5", "kvaerno5")


class DiffraxSolver(AbstractAdaptiveSolver):
    """An adaptive diffrax solver for the index-1 equations of motion.

    Attributes:
        kind: ``"tsit5"``, ``"dopri5"`` or ``"kvaerno5"``.
        rtol: relative tolerance of the step-size controller.
        atol: absolute tolerance of the step-size controller.
        max_steps: steps allowed per output chunk.
        baumgarte: Baumgarte ω [rad/s] against constraint drift.
        linear_solver: solver of the saddle system of the accelerations.
    """

    kind: str = eqx.field(static=True, default="tsit5")
    rtol: float = eqx.field(static=True, default=1e-6)
    atol: float = eqx.field(static=True, default=1e-8)
    max_steps: int = eqx.field(static=True, default=10_000_000)
    baumgarte: float = eqx.field(static=True, default=50.0)
    linear_solver: AbstractSaddleSolver = AutoSaddleSolver()

    @property
    def name(self) -> str:
        return self.kind

    @property
    def order(self) -> int:
        return 5

    def diffrax_solver(self):
        if self.kind == "tsit5":
            return diffrax.Tsit5()
        if self.kind == "dopri5":
            return diffrax.Dopri5()
        return diffrax.Kvaerno5(root_finder=optx.Newton(rtol=self.rtol, atol=self.atol))

    def prepare(self, system):
        return dae.mass_chain_factor(system)

    def vector_field(self, system, context):
        def f(t, y, args):
            q, v, _ = y
            acc, lam = dae.accelerations(system, q, v, t, baumgarte=self.baumgarte,
                                         chain_factor=context, linear_solver=self.linear_solver)
            return v, acc, dae.powers(system, q, v, t, lam)
        return f

    def solve(self, system, context, y0, t0, ts, dt0):
        """Integrate from t0 and save at ``ts``: ((q, v, work) at ``ts`` (not finite
        past a failure), diffrax's ``RESULTS``, steps taken)."""
        term = diffrax.ODETerm(self.vector_field(system, context))
        sol = diffrax.diffeqsolve(
            term, self.diffrax_solver(), t0=t0, t1=ts[-1], dt0=dt0, y0=y0,
            saveat=diffrax.SaveAt(ts=ts),
            stepsize_controller=diffrax.PIDController(rtol=self.rtol, atol=self.atol),
            max_steps=self.max_steps, throw=False)
        return sol.ys, sol.result, sol.stats["num_steps"]

    def multipliers(self, system, context, q, v, t):
        """Accelerations and multipliers at saved states (vmapped), for the outputs."""
        return jax.vmap(lambda qq, vv, tt: dae.accelerations(
            system, qq, vv, tt, baumgarte=self.baumgarte, chain_factor=context,
            linear_solver=self.linear_solver))(q, v, t)

