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
generalized-α step (one factorization of a matrix that changes every call, two solves:
M1 takes 2 Newton iterations per step at its chosen settings), in a ``fori_loop`` of
dependent calls, in ``ROUNDS`` interleaved rounds (best and median):

* ``full``: the bordered solver as it runs (factor_saddle, two solve_saddle);
* ``reduced``: what a built elimination would factor and solve where the fixed
  coordinates are a whole node block (M1's clamp): the chain without that block (one
  block shorter) and the border without the fixing multipliers, its matrix given;
* ``eliminated``: an elimination written on the full matrix (:func:`eliminate`:
  identity rows in the chain, every chain block masked; per solve the right-hand side
  reduced and the reactions recovered with products by the whole chain), its own work
  included: what a version without static knowledge of the fixed block costs.

each for one run and per member of a vmapped batch of 256 (the batch benchmark's
size), beside the bare step's time in the same process (``benchmarks.step_profile``'s
bare step, from the model's initial state).

Built once in the solver on 2026-12-07 (README, Performance): the step's extra kernels
for the elimination cost what the smaller factorization saves, so it was reverted.

    python -m benchmarks.border_elimination

Writes results/border_elimination.json (RESULTS.md renders it).
"""

from __future__ import annotations

import time

import numpy as np

from . import cases as C
from .common import write

#: dependent calls per timing, repetitions (best of) per round, interleaved rounds, batch size
N, REPS, ROUNDS, BATCH = 2000, 3, 5, 256


def _per_call(fn, *args, n=N) -> float:
    """Best time [s] per call of ``fn(*args, d)`` over n dependent calls in a fori_loop
    (d a scalar from the previous call: ``fn`` must make its matrix depend on it, or
    XLA computes the factorization once, before the loop)."""
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
    if a.n_aux:
        raise ValueError("fixed_rows: a matrix with auxiliary unknowns (force elements) is not handled")
    c, b, e = np.asarray(a.c), np.asarray(a.b), np.asarray(a.e)
    rows, cols = [], []
    for k in range(n_q_border, e.shape[0]):
        nz = np.flatnonzero(c[k])
        if (len(nz) == 1 and not np.any(e[k]) and not np.any(e[:, k])
                and np.flatnonzero(b[:, k]).tolist() == nz.tolist()):
            rows.append(k)
            cols.append(int(nz[0]))
    if not rows:
        raise ValueError("fixed_rows: no multiplier row selects a single chain coordinate")
    return np.array(rows, int), np.array(cols, int)


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


def drop_block(a, rows, cols):
    """The saddle matrix without the chain block that ``cols`` fix (all of its
    coordinates, in order) and without the fixing multipliers ``rows`` (module docstring):
    what a built elimination would factor. The neighbours of the block lose their
    coupling to it (their blocks no longer couple: a zero block between them)."""
    import jax.numpy as jnp

    from ancf_jax.linalg import BlockTridiagonal, SaddleMatrix

    t = a.chain
    bs, n = t.block_size, t.n_blocks
    k = int(cols[0]) // bs
    if cols.tolist() != list(range(k * bs, (k + 1) * bs)) or n < 3:
        raise ValueError("drop_block: the fixed coordinates are not one whole chain block of a chain of 3 or more")
    zero = jnp.zeros((1, bs, bs))
    def couplings(x):
        parts = [x[:max(k - 1, 0)]] + ([zero] if 0 < k < n - 1 else []) + [x[k + 1:]]
        return jnp.concatenate(parts)
    chain = BlockTridiagonal(jnp.concatenate([t.diagonal[:k], t.diagonal[k + 1:]]), couplings(t.lower),
                             couplings(t.upper))
    keep = np.setdiff1d(np.arange(a.e.shape[0]), rows)
    free = np.setdiff1d(np.arange(a.chain_size), cols)
    return SaddleMatrix(chain, a.b[free][:, keep], a.c[keep][:, free], a.e[np.ix_(keep, keep)])


def free_part(a, keep, cols, x):
    """The free chain entries and the kept border entries of a full solution x."""
    import jax.numpy as jnp
    n_c = a.chain_size
    return jnp.concatenate([x[:n_c][np.setdiff1d(np.arange(n_c), cols)], x[n_c:][keep]])


def solve_dropped(a, factors, keep, rows, cols, r):
    """(free chain and kept border unknowns, fixed coordinates x_F) of A x = r through
    the factors of :func:`drop_block`'s matrix: x_F from the fixing rows, their columns
    moved to the right-hand side."""
    import jax.numpy as jnp

    from ancf_jax.linalg import solve_saddle

    n_c = a.chain_size
    free = np.setdiff1d(np.arange(n_c), cols)
    x_f = r[n_c:][rows] / a.c[rows, cols]
    rc = r[:n_c] - a.chain.matvec(jnp.zeros(n_c).at[cols].set(x_f))
    return solve_saddle(factors, jnp.concatenate([rc[free], r[n_c:][keep] - a.c[keep][:, cols] @ x_f])), x_f


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
    beta_p, gamma_p = solver.newton_factors(h)
    a = dae.iteration_matrix(system, q, v, lam, t, beta_p, gamma_p, system.constraint_jacobian(q, t))
    n_qb = len(system.border_indices())
    rows, cols = fixed_rows(a, n_qb)
    reduced, keep = eliminate(a, rows, cols)
    dropped = drop_block(a, rows, cols)
    rng = np.random.default_rng(0)
    r = jnp.asarray(rng.standard_normal(a.chain_size + a.e.shape[0]))
    x_full = solve_saddle(factor_saddle(a), r)
    x_elim = solve_eliminated(a, factor_saddle(reduced), keep, rows, cols, r)
    # the block-dropped system gives the free chain unknowns and the kept border unknowns
    # (the clamp's reactions are recovered as in solve_eliminated)
    y, _ = solve_dropped(a, factor_saddle(dropped), keep, rows, cols, r)
    agreement = float(max(jnp.max(jnp.abs(x_full - x_elim)), jnp.max(jnp.abs(y - free_part(a, keep, cols, x_full))))
                      / jnp.max(jnp.abs(x_full)))

    def scaled(m, d):
        """The matrix times 1 + d: a new matrix every call (the factorization stays in the loop)."""
        return jax.tree.map(lambda x: x * (1.0 + d), m)

    def direct(m, r, d):
        f = factor_saddle(scaled(m, d))
        rr = r[:m.chain_size + m.e.shape[0]]
        return solve_saddle(f, solve_saddle(f, rr + d) * 1e-3 + rr)

    def elim(a, r, d):
        a = scaled(a, d)
        ar, _ = eliminate(a, rows, cols)
        f = factor_saddle(ar)
        return solve_eliminated(a, f, keep, rows, cols, solve_eliminated(a, f, keep, rows, cols, r + d) * 1e-3 + r)

    cases = (("full", direct, a), ("reduced", direct, dropped), ("eliminated", elim, a))
    single, member = {k: [] for k, _, _ in cases}, {k: [] for k, _, _ in cases}
    for _ in range(ROUNDS):
        for name, fn, m in cases:
            single[name].append(_per_call(fn, m, r))
            batched = jax.tree.map(lambda x: jnp.broadcast_to(x, (BATCH,) + x.shape), (m, r))
            member[name].append(_per_call(jax.vmap(fn, in_axes=(0, 0, None)), *batched, n=N // 100) / BATCH)
    timings = {k: dict(single_s=min(single[k]), single_median_s=float(np.median(single[k])),
                       batch_member_s=min(member[k]), batch_member_median_s=float(np.median(member[k])))
               for k in single}
    bare, carry0, _ = make_bare_step(solver, system, state, h, 400)
    jax.block_until_ready(bare(carry0))
    step = min(_time(bare, carry0) for _ in range(REPS)) / 400
    out = dict(model="M1", elements=6, h=h, options=opts, border=int(a.e.shape[0]), border_reduced=int(len(keep)),
               fixed_chain_positions=cols.tolist(), relative_difference=agreement, timings=timings,
               bare_step_s=step, batch=BATCH, rounds=ROUNDS,
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
