"""Same-machine A/B of two checkouts of ancf_jax: M1 (6 elements, 0–2 s) as a single run
at the full-mode equal-accuracy settings (h = 1.25 ms, refresh_first, contraction 0.1,
dense LU) and as a vmapped batch of 64 (α, E) variants (block-tridiagonal solver), one
checkout per process, so a change of the solver core can be checked against the code
before it without a full benchmark run.

    git worktree add /tmp/before <rev>
    python benchmarks/revision_ab.py /tmp/before old     # a checkout from before issue 16
    python benchmarks/revision_ab.py . new

``old`` passes the linear solver as the pre-issue-16 ``dense`` option. Prints one JSON
line: compile and median run time of the single run (7 repetitions), Newton iterations,
and the batch's per-simulation cost (median of 3) and compile time.
"""

import json
import statistics
import sys

sys.path.insert(0, sys.argv[1])
legacy = sys.argv[2] == "old"

import ancf_jax  # noqa: E402
from ancf_jax.models.m1 import m1_model  # noqa: E402
from ancf_jax.simulation import make_solver, simulate  # noqa: E402
from benchmarks.batch import m1_batch_row  # noqa: E402

system, state = m1_model(6).build()
base = dict(refresh_first=True, contraction=0.1)
single = dict(base, **({"dense": True} if legacy else {"linear_solver": "dense"}))
kw = dict(t_end=2.0, dt=1.25e-3, output_dt=0.01, solver=make_solver("generalized-alpha", **single), progress=False)
r = simulate(system, state, **kw)
walls = [simulate(system, state, **kw).wall_time_s for _ in range(7)]
out = dict(checkout=sys.argv[2], package=ancf_jax.__file__, single_compile_s=r.compile_time_s,
           single_run_s=statistics.median(walls), single_iterations=int(r.iterations.sum()))
row, _ = m1_batch_row(system, state, 64, dict(t_end=2.0, reps=3), 1.25e-3, base)
out["batch64_per_sim_s"] = row["ancf_jax"]["per_simulation_s"]
out["batch64_compile_s"] = row["ancf_jax"]["compile_s"]
print(json.dumps(out))
