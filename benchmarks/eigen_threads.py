"""Eigen's thread pool in XLA:CPU's ``dot`` calls, on and off (issue 17: "XLA CPU
flags chosen by measurement and documented").

XLA:CPU runs a ``dot`` that it does not fuse as a call into Eigen. With
``xla_cpu_multi_thread_eigen`` on (XLA's default) that call splits the product over the
process's intra-op thread pool; off, it runs on the calling thread. The products of
ancf_jax are small and many: per element and quadrature point (a few 5×8 by 8×2 per
element in a batched ``dot`` over the elements of a large beam, :mod:`ancf_jax._products`),
and per member of a vmapped batch. Since 2026-12-08 ancf_jax sets the flag off
(:data:`ancf_jax._xla.DEFAULT_FLAGS`) from this measurement.

Each case is compiled twice in this one process, with the option on and off as a
per-program XLA compiler option (:func:`ancf_jax.compiler_options`, which takes
precedence over ``XLA_FLAGS``), and the two programs run interleaved, ``reps`` rounds:

* ``M1``: the 2 s run of M1 (6 elements) at single_run's equal-accuracy settings
  (``simulate``'s ``wall_time_s``): a control, its element products are traced as
  multiply-and-sum (6 elements are below :data:`ancf_jax._products.SMALL_BATCH`), so it
  has no element ``dot`` for the option to act on;
* ``M2``: the 3 s run of M2 (24 elements) at its settings;
* ``bare 96``, ``bare 384``: 100 steps of the generalized-α step of M1 with 96 and
  384 elements at h = 1 ms (``benchmarks.step_profile``'s bare step; the scaling
  target's meshes);
* ``batch 64``: a vmapped ``simulate_batch`` of the first 64 M1 variants of
  ``benchmarks.batch`` (0–0.5 s, one chunk), per simulation (its ``batch_wall_time_s``;
  every member must complete).

The two programs differ only in how Eigen schedules a product, so their results agree
to rounding (reported: the largest difference in q of the single runs). Measured on
this project's 2-core machine; a machine with many cores may gain from the pool in
large products (``XLA_FLAGS=--xla_cpu_multi_thread_eigen=true`` restores XLA's default).

    python -m benchmarks.eigen_threads [--quick]

Writes results/eigen_threads.json (RESULTS.md renders it).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from . import cases as C
from .common import write

OPTION = "xla_cpu_multi_thread_eigen"
#: the two settings compared, in the order they run in each round
SETTINGS = {"on": {OPTION: True}, "off": {OPTION: False}}
FULL = dict(reps=9, batch=64, batch_t_end=0.5, bare=(96, 384), bare_steps=100)
QUICK = dict(reps=2, batch=8, batch_t_end=0.05, bare=(48,), bare_steps=20)
#: rounds of the batch case (each runs the whole batch once per setting)
BATCH_REPS = 3


def _interleaved(run, reps) -> dict:
    """``{setting: [seconds, ...]}`` of ``run(setting)`` over ``reps`` interleaved rounds
    (:func:`benchmarks.cases.interleaved`)."""
    return C.interleaved({k: (lambda k=k: run(k)) for k in SETTINGS}, reps)


def _row(case, times, per, unit, **extra) -> dict:
    med = {k: C.median(v) / per for k, v in times.items()}
    return dict(case=case, unit=unit, times_s={k: [t / per for t in v] for k, v in times.items()},
                median_s=med, min_s={k: min(v) / per for k, v in times.items()},
                speedup=med["on"] / med["off"], **extra)


def main(argv=None):
    import jax

    from ancf_jax import compiler_options
    from ancf_jax.integrate import RunLimits
    from ancf_jax.simulation import make_solver, simulate, simulate_batch

    from .batch import variants, with_parameters
    from .step_profile import make_bare_step

    argv = sys.argv[1:] if argv is None else argv
    quick = "--quick" in argv
    plan = QUICK if quick else FULL
    rows = []

    # single runs: M1 and M2 at their equal-accuracy settings
    for name, n, t_end in (("M1", 6, 2.0), ("M2", 24, 3.0)):
        h, opts = C.chosen_settings(name)
        system, state = C.model(name, n)
        t_end = 0.1 if quick else t_end
        kw = dict(t_end=t_end, dt=h, output_dt=C.GRID, solver=make_solver("generalized-alpha", **opts).forward_only(),
                  progress=False)

        def run(k, system=system, state=state, kw=kw):
            with compiler_options(**SETTINGS[k]):
                return simulate(system, state, **kw)

        first = {k: run(k) for k in SETTINGS}  # compiles both
        dq = float(np.max(np.abs(np.asarray(first["on"].q) - np.asarray(first["off"].q))))
        times = _interleaved(lambda k: run(k).wall_time_s, plan["reps"])
        rows.append(_row(f"{name} ({n} el.), 0–{t_end:g} s", times, 1, "ms per run", max_dq_m=dq))
        print(f"eigen_threads: {rows[-1]['case']}: on {rows[-1]['median_s']['on'] * 1e3:.1f} ms, "
              f"off {rows[-1]['median_s']['off'] * 1e3:.1f} ms (max |dq| {dq:.1e} m)", flush=True)

    # bare steps of large meshes
    for n in plan["bare"]:
        system, state = C.m1(n)
        bare, carry, _ = make_bare_step(make_solver("generalized-alpha").forward_only(), system, state, 1e-3,
                                        plan["bare_steps"])
        progs = {k: bare.lower(carry).compile(compiler_options=o) for k, o in SETTINGS.items()}
        carry, its = jax.block_until_ready(progs["on"](carry))
        jax.block_until_ready(progs["off"](carry))  # both warm before the clock

        def timed(k, progs=progs, carry=carry):
            t0 = time.perf_counter()
            jax.block_until_ready(progs[k](carry))
            return time.perf_counter() - t0

        times = _interleaved(timed, plan["reps"])
        rows.append(_row(f"bare step, M1 with {n} el., h = 1 ms", times, plan["bare_steps"], "ms per step",
                         iterations_per_step=float(np.mean(np.asarray(its)))))
        print(f"eigen_threads: {rows[-1]['case']}: on {rows[-1]['median_s']['on'] * 1e3:.3f} ms, "
              f"off {rows[-1]['median_s']['off'] * 1e3:.3f} ms per step", flush=True)

    # a vmapped batch of M1 variants
    h, opts = C.chosen_settings("M1")
    system, state = C.m1(6)
    n = plan["batch"]
    systems = [with_parameters(system, *p) for p in variants(n)]
    kw = dict(t_end=plan["batch_t_end"], dt=h, output_dt=C.GRID, on_failure="return", progress=False,
              solver=make_solver("generalized-alpha", **opts).forward_only(), limits=RunLimits(chunks=1))

    def batch(k):
        with compiler_options(**SETTINGS[k]):
            res = simulate_batch(systems, [state] * n, **kw)
        failed = [r.status for r in res if r.status != "ok"]
        if failed:
            raise RuntimeError(f"eigen_threads: {len(failed)} of {n} batch members failed ({failed[0]})")
        return res[0].info["batch_wall_time_s"]

    for k in SETTINGS:
        batch(k)  # compiles
    batch_reps = BATCH_REPS if not quick else 1
    times = _interleaved(batch, batch_reps)
    rows.append(_row(f"vmapped batch of {n} M1 variants, 0–{plan['batch_t_end']:g} s", times, n,
                     "ms per simulation", rounds=batch_reps))
    print(f"eigen_threads: {rows[-1]['case']}: on {rows[-1]['median_s']['on'] * 1e3:.1f} ms, "
          f"off {rows[-1]['median_s']['off'] * 1e3:.1f} ms per simulation", flush=True)
    return write("eigen_threads", dict(section="eigen_threads", quick=quick, option=OPTION, reps=plan["reps"],
                                       rows=rows, command="python -m benchmarks.eigen_threads"
                                       + (" --quick" if quick else "")))


if __name__ == "__main__":
    print(main())
