"""Where the time of one M1 step goes (issue 17: "what dominates, with a profile").

M1 (6 elements, Exudyn's formulation) at the settings ``single_run.json`` chose for
ancf_jax (h, Newton options, linear solver), 0–2 s, in one process:

* ``simulate``: wall time per step of the user-facing run (chunks, status checks,
  outputs every 10 ms), best of ``REPS``;
* ``bare step``: a ``lax.scan`` of the integrator's step alone, best of ``REPS``;
* the parts of a step, each jitted in a ``fori_loop`` of ``N`` calls whose input
  changes with every call (so nothing is hoisted), best of ``REPS``: the step's
  residual (M q̈ − Q + Φ_qᵀλ, Φ), the Newton matrix (Φ_q and
  :func:`ancf_jax.dae.iteration_matrix`), its factorization
  (``linear_solver.init``), one Newton solve with the factors
  (``linear_solver.compute``) and the energy-balance powers
  (:func:`ancf_jax.dae.powers`);
* the model of a step from the parts: iterations/step × (residual + solve) +
  factorizations/step × (matrix + factorization) + powers; what it leaves of the bare
  step is control flow (the Newton while loop, the step's bookkeeping), and
  ``simulate`` − bare step is the run loop's.

Run from the repository root: ``python -m benchmarks.step_profile`` (about a minute);
writes benchmarks/results/step_profile.json (RESULTS.md renders it).
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import cases as C  # noqa: E402
from benchmarks.common import write  # noqa: E402

REPS = 5
N = 2000
T_END = 2.0


def per_call(f, x) -> float:
    """Best per-call time [s] of f over N dependent calls (inputs perturbed each call)."""
    import jax
    import jax.numpy as jnp

    def loop(x):
        def body(i, c):
            # every output leaf enters the carry: XLA drops what no output needs, and a
            # part summed through its first leaf only was timed without the rest
            return c + 1e-30 * sum(jnp.sum(leaf) for leaf in jax.tree.leaves(f(x + c)))
        return jax.lax.fori_loop(0, N, body, jnp.zeros((), x.dtype))

    g = jax.jit(loop)
    g(x).block_until_ready()
    best = np.inf
    for _ in range(REPS):
        t0 = time.perf_counter()
        g(x).block_until_ready()
        best = min(best, time.perf_counter() - t0)
    return best / N


def make_bare_step(solver, system, state, h, steps):
    """(program, initial carry, context): ``steps`` steps of size h [s] of ``solver``
    (an integrator) from ``state`` as a jitted ``lax.scan`` of its step alone, returning
    the final carry and the Newton iterations of every step."""
    import jax
    ctx = solver.prepare(system)
    carry0 = solver.init(system, state, ctx)

    @jax.jit
    def bare(c):
        def body(c, _):
            c2, info = solver.step(system, c, h, ctx)
            return c2, info.iterations
        return jax.lax.scan(body, c, None, length=steps)

    return bare, carry0, ctx


def profile(system, state, h, opts, t_end=T_END, *, t_parts=1.0) -> dict:
    """The profile of a generalized-α step (module docstring) of ``system`` at step h
    [s] with the solver options ``opts`` over 0–``t_end`` [s], its parts timed at the
    state of the run nearest ``t_parts`` [s]. Returns the figures (times in seconds)."""
    import jax
    import jax.numpy as jnp

    from ancf_jax import dae
    from ancf_jax.integrators.generalized_alpha import AcrossSteps
    from ancf_jax.simulation import make_solver, simulate

    solver = make_solver("generalized-alpha", **opts).forward_only()
    ls = solver.linear_solver
    steps = int(round(t_end / h))

    # the run and the bare step
    kw = dict(t_end=t_end, dt=h, output_dt=C.GRID, solver=solver, progress=False)
    res = simulate(system, state, **kw)
    sim = min(simulate(system, state, **kw).wall_time_s for _ in range(REPS)) / steps
    bare, carry0, _ = make_bare_step(solver, system, state, h, steps)
    jax.block_until_ready(bare(carry0))
    best = np.inf
    for _ in range(REPS):
        t0 = time.perf_counter()
        _, its = jax.block_until_ready(bare(carry0))
        best = min(best, time.perf_counter() - t0)
    bare_step = best / steps
    iterations = float(np.sum(res.iterations)) / steps

    # the parts, at a state of the run (t = t_parts)
    k = int(np.argmin(np.abs(np.asarray(res.t) - t_parts)))
    q, v, lam, t = (jnp.asarray(res.q[k]), jnp.asarray(res.v[k]), jnp.asarray(res.lam[k]),
                    float(res.t[k]))
    beta_p, gamma_p = solver.newton_factors(h)

    def residual(qq):
        _, vjp = jax.vjp(lambda z: system.constraint(z, t), qq)
        r_q = system.mass_times(qq) - system.generalized_force(qq, v, t) + vjp(lam)[0]
        return dae.to_solver_order(system, r_q, system.constraint(qq, t))

    def matrix(qq):
        jac = system.constraint_jacobian(qq, t)
        return dae.iteration_matrix(system, qq, v, lam, t, beta_p, gamma_p, jac)

    a0 = matrix(q)
    fac0 = ls.init(a0, None)
    rhs = residual(q)
    parts = dict(
        residual=per_call(residual, q),
        newton_matrix=per_call(lambda qq: jax.tree.leaves(matrix(qq)), q),
        # the factorization's input changes with every call: the matrix scaled by 1 + d
        factorization=per_call(lambda d: jax.tree.leaves(ls.init(
            jax.tree.map(lambda a: a * (1.0 + d[0]), a0), None)), jnp.zeros(1)),
        solve=per_call(lambda r: ls.compute(fac0, r), rhs),
        powers=per_call(lambda qq: dae.powers(system, qq, v, t, lam), q),
    )
    # factorizations per step, counted by the factor memory of AcrossSteps(max_age=1),
    # which factors exactly as PerStep does
    counting = dataclasses.replace(solver, factor_reuse=AcrossSteps(max_age=1))
    counted = simulate(system, state, **dict(kw, solver=counting))
    factorizations = float(counted.checkpoint.carry.memory.factorizations) / steps
    model = (iterations * (parts["residual"] + parts["solve"])
             + factorizations * (parts["newton_matrix"] + parts["factorization"]) + parts["powers"])
    return dict(h=h, options=opts, steps=steps, t_end=t_end,
                coordinates=system.n_coordinates, multipliers=system.n_constraints,
                iterations_per_step=iterations, factorizations_per_step=factorizations,
                simulate_per_step_s=sim, bare_step_s=bare_step, parts_s=parts, model_s=model,
                control_flow_s=bare_step - model, run_loop_s=sim - bare_step)


def main() -> dict:
    h, opts = C.chosen_settings("M1")
    system, state = C.m1(6)
    out = dict(model="M1", elements=6, **profile(system, state, h, opts))
    print(json.dumps(out, indent=1, default=float))
    write("step_profile", out)
    return out


if __name__ == "__main__":
    main()
