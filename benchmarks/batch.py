"""Batch throughput: many M1 variants (α, E) in one vmapped ancf_jax program against
Exudyn run serially and with a multiprocessing pool on all cores; and M2 variants of
the trolley's start s₀ (each its own static equilibrium) against Exudyn run serially.

Variants: M1 with 6 elements, α uniform in [0.01, 0.05] 1/s and E uniform in
[180, 220] GPa (seeded). Each code runs with its equal-accuracy settings from
``results/single_run.json`` when that exists (else h = 1 ms, default tolerances); the
vmapped batch always uses the block-tridiagonal solver (``linear_solver`` dropped from the
chosen options: the same equations, and batched dense LU is slower under vmap).
M2 s₀ variants: 12 elements, s₀ uniform in [0.4, 1.2] m, h = 1 ms (M2's step), both
codes from the same static states (solved per variant before the clock starts).

Per batch size: ancf_jax compile time (once per size) and the median over ``reps`` of
the batch run time, and per-simulation cost = batch time / size; Exudyn serial
(model build + run, per simulation, measured on up to ``serial_cap`` variants and
extrapolated beyond, flagged) and pool (``Pool(cpu_count)``, spawn; pool start-up
reported separately, batch wall time measured).

    python -m benchmarks.batch [--quick]
    python -m benchmarks.batch --s0-only [--quick]   (only the M2 s₀ rows, into batch.json)
"""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import time

import numpy as np

from . import cases as C
from .common import RESULTS, write

FULL = dict(sizes=(1, 8, 64, 256, 1024), t_end=2.0, reps=3, serial_cap=64,
            s0=dict(sizes=(1, 8, 32), t_end=0.5, n=12, dt=1e-3))
QUICK = dict(sizes=(1, 8, 64), t_end=0.5, reps=1, serial_cap=8,
             s0=dict(sizes=(1, 8), t_end=0.1, n=12, dt=1e-3))
DEFAULT = dict(dt=1e-3, options={})


POOL = 1024


def variants(n, seed=0):
    """The first n of one fixed, seeded list of (α, E): every batch size shares its
    leading members (so the serial Exudyn runs compare with the batch members)."""
    rng = np.random.default_rng(seed)
    par = np.column_stack([rng.uniform(0.01, 0.05, max(n, POOL)), rng.uniform(180e9, 220e9, max(n, POOL))])
    return par[:n]


def chosen_settings(quick):
    """Equal-accuracy settings of both codes from single_run.json (same mode)."""
    path = RESULTS / "single_run.json"
    out = dict(ancf_jax={**DEFAULT, "source": "default"},
               exudyn={**DEFAULT, "options": dict(C.EXUDYN_FAST), "source": "default"})
    if path.exists():
        data = json.loads(path.read_text())
        if bool(data.get("quick")) == bool(quick):
            for row in data.get("rows", []):
                if row["model"] != "M1":
                    continue
                for code in ("ancf_jax", "exudyn"):
                    c = row.get(code, {}).get("chosen")
                    if c:
                        options = C.ancf_options(c["options"]) if code == "ancf_jax" else c["options"]
                        out[code] = dict(dt=c["dt"], options=options, source="single_run.json")
    return out


def with_parameters(system, alpha, youngs):
    import equinox as eqx
    import jax.numpy as jnp
    return eqx.tree_at(lambda s: (s.beams[0].alpha, s.beams[0].section.youngs_modulus), system,
                       (jnp.asarray(alpha, float), jnp.asarray(youngs, float)))


# ------------------------------------------------------------------ Exudyn workers
_BASE = {}


def _init_worker(t_end, dt, options):
    import os
    os.environ.setdefault("JAX_PLATFORMS", "cpu")
    _BASE["sys"] = C.m1(6)
    _BASE["run"] = dict(t_end=t_end, dt=dt, options=options, output_dt=C.GRID)


def _exudyn_task(params):
    system, state = _BASE["sys"]
    r = C.run_exudyn("M1", with_parameters(system, *params), state, **_BASE["run"])
    return r.run_s, r.setup_s, r.status, float(r.y[-1]) if len(r.y) else float("nan")


def _noop(_):
    return os.getpid()


def s0_variants(n, seed=1):
    """The first n of a fixed, seeded list of trolley starts s₀ [m]."""
    return np.random.default_rng(seed).uniform(0.4, 1.2, max(n, POOL))[:n]


def s0_batch(plan, exudyn, dense=False) -> dict:
    """M2 variants of s₀: one vmapped ancf_jax program per size against Exudyn serially
    (each variant's static equilibrium is solved, or read from the cache, untimed)."""
    from ancf_jax.integrate import RunLimits
    from ancf_jax.simulation import make_solver, simulate_batch
    opts = C.ancf_settings("M2")
    if dense:
        opts = {**opts, "linear_solver": "dense"}
    built = [C.m2(plan["n"], s0=float(s)) for s in s0_variants(max(plan["sizes"]))]
    rows = []
    for n in plan["sizes"]:
        kw = dict(t_end=plan["t_end"], dt=plan["dt"], output_dt=C.GRID,
                  solver=make_solver("generalized-alpha", **opts), on_failure="return", progress=False,
                  limits=RunLimits(chunks=1))
        systems, states = [b[0] for b in built[:n]], [b[1] for b in built[:n]]
        res = simulate_batch(systems, states, **kw)  # compiles
        compile_s = res[0].compile_time_s
        res = simulate_batch(systems, states, **kw)
        wall = res[0].info["batch_wall_time_s"]
        s0s = s0_variants(n)
        failed = [dict(s0=float(s), status=r.status, time_s=float(r.failure_time))
                  for s, r in zip(s0s, res) if r.status != "ok"]
        row = dict(size=n, ancf_jax=dict(compile_s=compile_s, batch_run_s=wall, per_simulation_s=wall / n,
                                         ok=sum(r.status == "ok" for r in res), failed=failed))
        final = [np.asarray(C.ancf_output("M2", r))[-1] for r in res]
        if exudyn:
            ex = [C.run_exudyn("M2", b[0], b[1], t_end=plan["t_end"], dt=plan["dt"], output_dt=C.GRID)
                  for b in built[:n]]
            per = C.median([r.run_s for r in ex])
            # a failed member's output stops at its failure: compare members ok in both codes
            both = [i for i in range(n) if res[i].status == "ok" and ex[i].status == "ok"]
            row["exudyn"] = dict(serial_total_s=sum(r.run_s + r.setup_s for r in ex), median_run_s=per,
                                 ok=sum(r.status == "ok" for r in ex), compared=len(both),
                                 final_point1_max_difference_to_ancf_m=float(max(
                                     (np.max(np.abs(np.asarray(ex[i].y)[-1] - final[i])) for i in both),
                                     default=float("nan"))))
            row["per_simulation_ratio_vs_one_exudyn_run"] = row["ancf_jax"]["per_simulation_s"] / per
        rows.append(row)
        print(f"s0 batch {n}: ancf_jax {wall:.2f} s ({wall / n * 1e3:.1f} ms/sim, compile {compile_s:.1f} s)"
              + (f"; Exudyn {row['exudyn']['median_run_s'] * 1e3:.1f} ms/run" if exudyn else ""), flush=True)
    return dict(model=f"M2, {plan['n']} elements", parameters="s0 ~ U(0.4, 1.2) m, seed 1",
                t_end=plan["t_end"], dt=plan["dt"], solver_options=opts, rows=rows)


def m1_batch_row(system, state, n, plan, dt, options, label="batch"):
    """One ancf_jax batch row: the first n variants in one vmapped program (compiled
    once, then ``plan["reps"]`` timed runs). Returns (row, final tip Y of every member)."""
    from ancf_jax.integrate import RunLimits
    from ancf_jax.simulation import make_solver, simulate_batch
    systems = [with_parameters(system, al, e) for al, e in variants(n)]
    # outputs on the 10 ms grid and ONE chunk for the whole run: under vmap the frozen
    # steps past t_end in a last, partly used 500-step chunk are not skipped (cond
    # becomes select) and would cost as much as real ones
    kw = dict(t_end=plan["t_end"], dt=dt, output_dt=C.GRID, solver=make_solver("generalized-alpha", **options),
              on_failure="return", progress=False, limits=RunLimits(chunks=1))
    res = simulate_batch(systems, [state] * n, **kw)  # compiles
    compile_s = res[0].compile_time_s
    walls = []
    for _ in range(plan["reps"]):
        res = simulate_batch(systems, [state] * n, **kw)
        walls.append(res[0].info["batch_wall_time_s"])
    ok = sum(r.status == "ok" for r in res)
    final = [float(C.ancf_output("M1", r)[-1]) for r in res]
    row = dict(size=n, ancf_jax=dict(compile_s=compile_s, batch_run_s=walls, median_batch_run_s=C.median(walls),
                                     per_simulation_s=C.median(walls) / n, ok=ok))
    print(f"{label} {n}: ancf_jax {C.median(walls):.2f} s ({C.median(walls) / n * 1e3:.2f} ms/sim, "
          f"compile {compile_s:.1f} s, {ok}/{n} ok)", flush=True)
    return row, final


def main(argv=None, *, quick=None, exudyn=None):
    quick, exudyn = C.section_options(__doc__, argv, quick, exudyn)
    plan = QUICK if quick else FULL
    settings = chosen_settings(quick)
    system, state = C.m1(6)
    a = settings["ancf_jax"]
    rows = []
    final_ancf = {}
    options = {k: v for k, v in a["options"].items() if k not in ("dense", "linear_solver")}
    for n in plan["sizes"]:
        row, final_ancf[n] = m1_batch_row(system, state, n, plan, a["dt"], options)
        rows.append(row)
    out = dict(section="batch", quick=quick, exudyn=exudyn, t_end=plan["t_end"], model="M1, 6 elements",
               parameters="alpha ~ U(0.01, 0.05) 1/s, E ~ U(180, 220) GPa, seed 0",
               settings=settings, rows=rows,
               command="python -m benchmarks.run" + (" --quick" if quick else "") + " --only batch")
    out["s0"] = s0_batch(plan["s0"], exudyn)
    if not exudyn:
        out["exudyn_missing"] = C.exudyn_missing_reason()
        return write("batch", out)
    e = settings["exudyn"]
    # serial: per-simulation cost on up to serial_cap variants
    cap = min(plan["serial_cap"], max(plan["sizes"]))
    par = variants(cap)
    serial = []
    for al, ym in par:
        r = C.run_exudyn("M1", with_parameters(system, al, ym), state, t_end=plan["t_end"], dt=e["dt"],
                         options=e["options"], output_dt=C.GRID)
        serial.append((r.run_s, r.setup_s, r.status, float(r.y[-1])))
    per_run = C.median([s[0] for s in serial])
    per_total = C.median([s[0] + s[1] for s in serial])
    n_cmp = min(cap, max(plan["sizes"]))
    diff = float(np.max(np.abs(np.array(final_ancf[max(plan["sizes"])][:n_cmp]) -
                               np.array([s[3] for s in serial[:n_cmp]]))))
    out["exudyn_serial"] = dict(measured=cap, median_run_s=per_run, median_run_plus_build_s=per_total,
                                ok=sum(s[2] == "ok" for s in serial),
                                final_tip_y_max_difference_to_ancf_m=diff)
    print(f"Exudyn serial: {per_run:.3f} s run, {per_total:.3f} s with build per simulation "
          f"(final tip Y vs ancf_jax batch: max {diff:.2e} m)", flush=True)
    # pool
    cores = os.cpu_count() or 1
    ctx = mp.get_context("spawn")
    t0 = time.perf_counter()
    with ctx.Pool(cores, initializer=_init_worker, initargs=(plan["t_end"], e["dt"], e["options"])) as pool:
        pool.map(_noop, range(cores), chunksize=1)
        startup = time.perf_counter() - t0
        for row in rows:
            n = row["size"]
            measured = n <= cap
            serial_total = (sum(s[0] + s[1] for s in serial[:n]) if measured else n * per_total)
            t1 = time.perf_counter()
            got = pool.map(_exudyn_task, [tuple(p) for p in variants(n)], chunksize=1)
            pool_s = time.perf_counter() - t1
            row["exudyn"] = dict(serial_total_s=serial_total, serial_extrapolated=not measured,
                                 serial_per_simulation_s=serial_total / n, pool_total_s=pool_s,
                                 pool_per_simulation_s=pool_s / n, pool_workers=cores,
                                 pool_ok=sum(g[2] == "ok" for g in got))
            row["per_simulation_ratio_vs_one_exudyn_run"] = row["ancf_jax"]["per_simulation_s"] / per_run
            print(f"batch {n}: Exudyn serial {serial_total:.2f} s{' (extrapolated)' if not measured else ''}, "
                  f"pool {pool_s:.2f} s; ancf_jax per simulation / one Exudyn run = "
                  f"{row['per_simulation_ratio_vs_one_exudyn_run']:.3f}", flush=True)
    out["exudyn_pool"] = dict(workers=cores, startup_s=startup, start_method="spawn")
    return write("batch", out)


def rerun_s0(argv=None):
    """``python -m benchmarks.batch --s0-only [--quick]``: run the M2 s₀ rows again and
    replace them in an existing batch.json of the same mode (the M1 rows, which take
    half an hour in full mode, are kept)."""
    quick, exudyn = C.section_options(__doc__, argv, None, None)
    path = RESULTS / "batch.json"
    data = json.loads(path.read_text())
    if bool(data.get("quick")) != quick:
        raise SystemExit(f"{path} holds a {'quick' if data.get('quick') else 'full'} run: run the whole section")
    data["s0"] = s0_batch((QUICK if quick else FULL)["s0"], exudyn)
    data["s0"]["command"] = "python -m benchmarks.batch --s0-only" + (" --quick" if quick else "")
    return write("batch", data)


if __name__ == "__main__":
    import sys
    if "--s0-only" in sys.argv:
        print(rerun_s0([a for a in sys.argv[1:] if a != "--s0-only"]))
    else:
        print(main(sys.argv[1:]))
