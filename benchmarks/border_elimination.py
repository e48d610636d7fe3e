"""What eliminating coordinates fixed by a joint from the Newton solve would save
(issue 17: "constraints that fix coordinates ... eliminated from the unknowns").

M1's clamp fixes its beam's four coordinates at node 0 (x, y and the slope): its rows
of Φ_q select them, so the Newton system's border (3 body coordinates and 7 multipliers:
clamp 4, fixed joint 3) could lose the clamp's 4 multipliers. With those coordinates
x_F known from the clamp's rows, the chain block keeps identity rows and columns there
(its known columns go to the right-hand side), the Schur complement shrinks from 10×10
to 6×6 and the block Thomas solve of the border columns from 10 to 6 columns; the
clamp's reactions come back from the chain rows at F afterwards:

    x_F = r_λF / s,   λ_F = (r_F − (T x)_F − B_F,o x_o) / s'   (s, s' the entries of Φ_q).

This benchmark builds that elimination on the iteration matrix of a state of M1's run
(:func:`ancf_jax.dae.iteration_matrix`), checks that it solves the same system (the
solution and the reactions equal the full solve's to rounding), and times, per
generalized-α step (one factorization and two solves: M1 takes 2 Newton iterations per
step at its chosen settings), in a ``fori_loop`` of dependent calls (best of 5):

* ``full``: the bordered solver as it runs (factor_saddle, two solve_saddle);
* ``reduced``: the reduced system alone (factor and two solves, its matrix given), a
  bound on what elimination can save, as the reduction and the recovery are not in it;
* ``eliminated``: the elimination as it would run in the step: reduce the matrix,
  factor, and per solve reduce the right-hand side, solve, recover the reactions.

each for one run and per member of a vmapped batch of 256 (the batch benchmark's
size), beside the bare step's time in the same process (``benchmarks.step_profile``).

    python -m benchmarks.border_elimination

Writes results/border_elimination.json (RESULTS.md renders it).
"""

from __future__ import annotations

import time

import numpy as np

from . import cases as C
from .common import write

#: dependent calls per timing, repetitions (best of), batch size
N, REPS, BATCH = 200, 5, 256


def _per_call(fn, *args, n=N) -> float:
    """Best time [s] per call of ``fn(*args, x)`` over n dependent calls in a fori_loop."""
    import jax
    import jax.numpy as jnp

    def loop(*a):
        def body(i, acc):
            out = fn(*a, acc * 1e-30)
            return acc + 1e-30 * sum(jnp.sum(leaf) for leaf in jax.tree.leaves(out))
        return jax.lax.fori_loop(0, n, body, jnp.zeros(()))

    g = jax.jit(loop)
    jax.block_until_ready(g(*args))
    best = np.inf
    for _ in range(REPS):
        t0 = time.perf_counter()
        jax.block_until_ready(g(*args))
        best = min(best, time.perf_counter() - t0)
    return best / n


def fixed_rows(a, n_q_border: int):
    """(border rows of fixing multipliers, the chain positions they fix) of a saddle
    matrix ``a``: multiplier rows of C whose only nonzero entry is one chain column and
    whose border entries are zero (a selection row of Φ_q), with a matching column of B."""
    c, b, e = np.asarray(a.c), np.asarray(a.b), np.asarray(a.e)
    rows, cols = [], []
    for k in range(n_q_border, e.shape[0]):
        nz = np.flatnonzero(c[k])
        if len(nz) == 1 and not np.any(e[k]) and np.flatnonzero(b[:, k]).tolist() == nz.tolist():
            rows.append(k)
            cols.append(int(nz[0]))
    return np.array(rows), np.array(cols)


def eliminate(a, rows, cols):
    """The reduced saddle matrix (module docstring) and what recovery needs."""
    import jax.numpy as jnp

    from ancf_jax.linalg import BlockTridiagonal, SaddleMatrix

    t = a.chain
    n, bs = t.n_blocks, t.block_size
    keep = np.setdiff1d(np.arange(a.e.shape[0]), rows)
    m = np.ones(n * bs)
    m[cols] = 0.0
    mb = jnp.asarray(m.reshape(n, bs))
    ident = jnp.asarray((1.0 - m).reshape(n, bs))
    diag = t.diagonal * mb[:, :, None] * mb[:, None, :] + jax_diag(ident)
    chain = BlockTridiagonal(diag, t.lower * mb[1:, :, None] * mb[:-1, None, :],
                             t.upper * mb[:-1, :, None] * mb[1:, None, :])
    mj = jnp.asarray(m)
    reduced = SaddleMatrix(chain, a.b[:, keep] * mj[:, None], a.c[keep] * mj[None, :], a.e[np.ix_(keep, keep)])
    return reduced, keep


def jax_diag(d):
    import jax
    import jax.numpy as jnp
    return jax.vmap(jnp.diag)(d)


def solve_eliminated(a, factors, keep, rows, cols, r):
    """x with A x = r through the reduced system's factors (module docstring)."""
    import jax.numpy as jnp

    from ancf_jax.linalg import solve_saddle

    n_c = a.chain_size
    rc, rb = r[:n_c], r[n_c:]
    xf = rb[rows] / a.c[rows, cols]
    xfull = jnp.zeros(n_c).at[cols].set(xf)
    rc2 = (rc - a.chain.matvec(xfull)).at[cols].set(xf)
    rb2 = rb[keep] - a.c[keep][:, cols] @ xf
    y = solve_saddle(factors, jnp.concatenate([rc2, rb2]))
    xc, xo = y[:n_c], y[n_c:]
    lam_f = (rc[cols] - a.chain.matvec(xc)[cols] - a.b[cols][:, keep] @ xo) / a.b[cols, rows]
    xb = jnp.zeros(rb.shape[0]).at[keep].set(xo).at[rows].set(lam_f)
    return jnp.concatenate([xc, xb])


def main() -> dict:
    import jax
    import jax.numpy as jnp

    from ancf_jax import dae
    from ancf_jax.linalg import factor_saddle, solve_saddle
    from ancf_jax.simulation import make_solver, simulate

    from .step_profile import make_bare_step

    h, opts = C.chosen_settings("M1")
    system, state = C.m1(6)
    solver = make_solver("generalized-alpha", **opts).forward_only()
    res = simulate(system, state, t_end=1.0, dt=h, output_dt=C.GRID, solver=solver, progress=False)
    q, v, lam, t = (jnp.asarray(res.q[-1]), jnp.asarray(res.v[-1]), jnp.asarray(res.lam[-1]), float(res.t[-1]))
    am, af, gamma, beta = solver.coefficients
    beta_p = (1.0 - am) / (h * h * beta * (1.0 - af))
    gamma_p = gamma / (h * beta)
    a = dae.iteration_matrix(system, q, v, lam, t, beta_p, gamma_p, system.constraint_jacobian(q, t))
    n_qb = len(system.border_indices())
    rows, cols = fixed_rows(a, n_qb)
    reduced, keep = eliminate(a, rows, cols)
    rng = np.random.default_rng(0)
    r = jnp.asarray(rng.standard_normal(a.chain_size + a.e.shape[0]))
    x_full = solve_saddle(factor_saddle(a), r)
    x_elim = solve_eliminated(a, factor_saddle(reduced), keep, rows, cols, r)
    agreement = float(jnp.max(jnp.abs(x_full - x_elim)) / jnp.max(jnp.abs(x_full)))

    def full(a, r, d):
        f = factor_saddle(a)
        return solve_saddle(f, solve_saddle(f, r + d) * 1e-3 + r)

    def red(ar, r, d):
        f = factor_saddle(ar)
        rr = r[:ar.chain_size + ar.e.shape[0]]
        return solve_saddle(f, solve_saddle(f, rr + d) * 1e-3 + rr)

    def elim(a, r, d):
        ar, _ = eliminate(a, rows, cols)
        f = factor_saddle(ar)
        return solve_eliminated(a, f, keep, rows, cols, solve_eliminated(a, f, keep, rows, cols, r + d) * 1e-3 + r)

    timings = {}
    batched = jax.tree.map(lambda x: jnp.broadcast_to(x, (BATCH,) + x.shape), (a, reduced, r))
    for name, fn, mat in (("full", full, 0), ("reduced", red, 1), ("eliminated", elim, 0)):
        single = _per_call(fn, (a, reduced)[mat], r)
        vm = jax.vmap(fn, in_axes=(0, 0, None))
        member = _per_call(vm, batched[mat], batched[2], n=N // 10) / BATCH
        timings[name] = dict(single_s=single, batch_member_s=member)
    bare, carry0, _ = make_bare_step(solver, system, state, h, 400)
    jax.block_until_ready(bare(carry0))
    step = min(_time(bare, carry0) for _ in range(REPS)) / 400
    out = dict(model="M1", elements=6, h=h, options=opts, border=int(a.e.shape[0]), border_reduced=int(len(keep)),
               fixed_chain_positions=cols.tolist(), relative_difference=agreement, timings=timings,
               bare_step_s=step, batch=BATCH,
               saving_single_s=timings["full"]["single_s"] - timings["eliminated"]["single_s"],
               saving_bound_single_s=timings["full"]["single_s"] - timings["reduced"]["single_s"],
               saving_batch_member_s=timings["full"]["batch_member_s"] - timings["eliminated"]["batch_member_s"],
               command="python -m benchmarks.border_elimination")
    print(f"border {out['border']} -> {out['border_reduced']}, solution agrees to {agreement:.1e}; per step: "
          + ", ".join(f"{k} {v['single_s'] * 1e6:.2f} µs ({v['batch_member_s'] * 1e6:.2f} µs per batch member)"
                      for k, v in timings.items()) + f"; bare step {step * 1e6:.1f} µs")
    write("border_elimination", out)
    return out


def _time(fn, x) -> float:
    import jax
    t0 = time.perf_counter()
    jax.block_until_ready(fn(x))
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
