# python benchmarks/m1_ratio.py [M2]  (from the repository root, PYTHONPATH=.)
"""M1 (or, with the argument M2, M2 with 24 elements, 0-3 s) single run ratio against Exudyn
at the equal-accuracy settings that benchmarks/results/single_run.json chose for each code
(M1 0-2 s), interleaved, one process: REPS pairs of runs (one of each code), the medians'
ratio, and the median and quartiles of the pairs' own ratios (how much the machine's speed
moved during the measurement; with a skewed spread the medians' ratio can lie outside
them), and every run's time."""
import json, statistics, sys, time
from benchmarks import cases as C
from benchmarks import exudyn_models as em
from ancf_jax.simulation import make_solver, simulate
NAME = sys.argv[1] if len(sys.argv) > 1 else "M1"
system, state = C.m2(24) if NAME == "M2" else C.m1(6)
T_END = 3.0 if NAME == "M2" else 2.0
dt, opts = C.chosen_settings(NAME)
e_dt, e_opts = C.chosen_settings(NAME, "exudyn")
kw = dict(t_end=T_END, dt=dt, output_dt=C.GRID, solver=make_solver("generalized-alpha", **opts), progress=False)
r = simulate(system, state, **kw)
REPS = 15  # was 5 until 2026-12-07: three runs of 5 pairs gave 0.37, 0.43 and 0.50 in one hour
a_t, e_t = [], []
for _ in range(REPS):
    a_t.append(simulate(system, state, **kw).wall_time_s)
    model = em.build_exudyn(system, state, name=NAME)
    t0 = time.perf_counter()
    er = em.run(model, t_end=T_END, dt=e_dt, output_dt=C.GRID, **e_opts)
    e_t.append(time.perf_counter() - t0)
a, x = statistics.median(a_t), statistics.median(e_t)
pairs = sorted(p / q for p, q in zip(a_t, e_t))
quartiles = statistics.quantiles(pairs, n=4)
out = dict(ancf_options=opts, ancf_dt=kw["dt"], exudyn_dt=e_dt, ancf_run_s=a, exudyn_run_s=x, ratio=a / x, ancf_compile_s=r.compile_time_s,
           exudyn_status=er.status, ancf_status=r.status, reps=REPS, pair_ratio_quartiles=[quartiles[0], quartiles[2]],
           pair_ratio_median=statistics.median(pairs), ancf_runs_s=a_t, exudyn_runs_s=e_t)
print(json.dumps(out))
# kept for benchmarks/RESULTS.md (report.sec_single: the latest re-measurement)
from benchmarks.common import write  # noqa: E402
write("m1_ratio" if NAME == "M1" else "m2_ratio", out)
