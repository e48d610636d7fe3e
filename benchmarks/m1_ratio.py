# python benchmarks/m1_ratio.py  (from the repository root, PYTHONPATH=.)
"""M1 single run ratio against Exudyn at the equal-accuracy settings that
benchmarks/results/single_run.json chose for each code (0-2 s), interleaved, one process."""
import json, statistics, time
from benchmarks import cases as C
from benchmarks import exudyn_models as em
from ancf_jax.simulation import make_solver, simulate
system, state = C.m1(6)
dt, opts = C.chosen_settings("M1")
e_dt, e_opts = C.chosen_settings("M1", "exudyn")
kw = dict(t_end=2.0, dt=dt, output_dt=C.GRID, solver=make_solver("generalized-alpha", **opts), progress=False)
r = simulate(system, state, **kw)
a_t, e_t = [], []
for _ in range(5):
    a_t.append(simulate(system, state, **kw).wall_time_s)
    model = em.build_exudyn(system, state, name="M1")
    t0 = time.perf_counter()
    er = em.run(model, t_end=2.0, dt=e_dt, output_dt=C.GRID, **e_opts)
    e_t.append(time.perf_counter() - t0)
a, x = statistics.median(a_t), statistics.median(e_t)
out = dict(ancf_options=opts, ancf_dt=kw["dt"], exudyn_dt=e_dt, ancf_run_s=a, exudyn_run_s=x, ratio=a / x, ancf_compile_s=r.compile_time_s,
           exudyn_status=er.status, ancf_status=r.status)
print(json.dumps(out))
# kept for benchmarks/RESULTS.md (report.sec_single: the latest re-measurement)
from benchmarks.common import write  # noqa: E402
write("m1_ratio", out)
