# python -m benchmarks.batch_threads [N]  (from the repository root; N members, default 256)
"""Is one vmapped program the fastest way to run a CPU batch of M1 variants?

The batch rows of RESULTS.md (benchmarks/batch.py) show a vmapped member costing more
than a single run (94-100 against 76 ms per simulation): on the CPU, vmap adds no
arithmetic units and the batched small factorizations are slower than unbatched ones.
This measures, in one process, the same first ``N`` variants of benchmarks/batch.py
(M1, 6 elements, 0-2 s, h = 1.25 ms, Newton tolerance 1e-5: single_run's equal-accuracy
settings) three ways, each compiled before the clock starts:

* ``simulate_batch``: one vmapped program, one chunk (as benchmarks/batch.py);
* ``simulate`` member after member (one compiled program reused);
* ``simulate_each`` with two threads (XLA releases the GIL while a program runs),

against one Exudyn run (median of 5) at its equal-accuracy settings. An exploration for
a CPU batch strategy, not a target row: writes benchmarks/results/batch_threads.json, or
batch_threads_loop_kernels.json when the process runs with XLA's loop kernels
(``ANCF_JAX_LOOP_KERNELS=1 python -m benchmarks.batch_threads``; :mod:`ancf_jax._xla`),
which single runs of M1 gain from and vmapped batches do not.
"""

from __future__ import annotations

import json
import sys
import statistics
import time

import numpy as np

from benchmarks import cases as C
from benchmarks import exudyn_models as em
from benchmarks.batch import variants, with_parameters
from benchmarks.common import write

N = 256  # the batch target's size


def main(argv=None):
    n = int((argv if argv is not None else sys.argv[1:] or [N])[0])
    from ancf_jax import _xla
    from ancf_jax.integrate import RunLimits
    from ancf_jax.simulation import make_solver, simulate, simulate_batch, simulate_each

    system, state = C.m1(6)
    dt, opts = C.chosen_settings("M1")
    e_dt, e_opts = C.chosen_settings("M1", "exudyn")
    systems = [with_parameters(system, a, e) for a, e in variants(n)]
    kw = dict(t_end=2.0, dt=dt, output_dt=C.GRID, solver=make_solver("generalized-alpha", **opts),
              on_failure="return", progress=False)

    simulate_batch(systems, [state] * n, limits=RunLimits(chunks=1), **kw)  # compiles
    t0 = time.perf_counter()
    batch = simulate_batch(systems, [state] * n, limits=RunLimits(chunks=1), **kw)
    vmapped = time.perf_counter() - t0

    simulate(systems[0], state, **kw)  # compiles
    t0 = time.perf_counter()
    serial = [simulate(s, state, **kw) for s in systems]
    sequential = time.perf_counter() - t0

    t0 = time.perf_counter()
    threaded = simulate_each(systems, [state] * n, workers=2, **kw)  # compiled above
    two_threads = time.perf_counter() - t0

    exudyn = []
    for _ in range(5):
        model = em.build_exudyn(system, state, name="M1")
        t0 = time.perf_counter()
        em.run(model, t_end=2.0, dt=e_dt, output_dt=C.GRID, **e_opts)
        exudyn.append(time.perf_counter() - t0)
    one = statistics.median(exudyn)

    def diff(a, b):
        return max(float(np.max(np.abs(np.asarray(x.q) - np.asarray(y.q)))) for x, y in zip(a, b))

    kernels = _xla.loop_kernels()
    out = dict(members=n, loop_kernels=kernels, ancf_dt=dt, ancf_options=opts, exudyn_dt=e_dt, exudyn_run_s=one,
               per_simulation_s=dict(vmapped=vmapped / n, sequential=sequential / n, two_threads=two_threads / n),
               ratio_to_one_exudyn_run=dict(vmapped=vmapped / n / one, sequential=sequential / n / one,
                                            two_threads=two_threads / n / one),
               max_q_difference=dict(vmapped_vs_threads=diff(batch, threaded), serial_vs_threads=diff(serial, threaded)),
               ok=sum(r.status == "ok" for r in threaded))
    print(json.dumps(out, indent=1))
    write("batch_threads_loop_kernels" if kernels else "batch_threads", out)


if __name__ == "__main__":
    main()
