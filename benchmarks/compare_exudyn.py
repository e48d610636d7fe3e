"""Cross-check ancf_jax against Exudyn on M1, M2 and H1 (identical discrete problems).

    python -m benchmarks.compare_exudyn [--quick] [--out PATH] [--models M1,M2,H1]
    python -m benchmarks.compare_exudyn --timing

Both codes integrate the same model (Exudyn's twin is translated from the ancf_jax
system, :mod:`benchmarks.exudyn_models`) with the same formulation (|r'| − 1, material
curvature, Exudyn's Gauss rules), the same index-3 generalized-α (ρ∞ = 0.9), the same
fixed step, consistent initial accelerations, no velocity projection, full Newton
iterations to tight tolerances. Printed and written (JSON) per case: the maximum over
the run of the distance between the codes' tip / point-1 / cabin positions (and of
|Δs|, |ΔE|), run and setup times, Newton iterations and failures.

M2 is run twice on the Exudyn side: as shipped, and with the extra term of Exudyn's
sliding joint cancelled (``cancel_sliding_term``; see
:func:`benchmarks.exudyn_models.sliding_term`). The step-size study shows that the
as-shipped difference is first order in h.

Without Exudyn installed the script says so and exits with status 0.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

DEFAULT_OUT = Path(__file__).resolve().parent / "results" / "exudyn_agreement.json"

#: the settings shared by both codes (and the Newton tolerances of each)
SETTINGS = dict(
    dt=1e-3, output_dt=0.01, rho_inf=0.9,
    ancf=dict(newton_tol=1e-10, velocity_projection=False, refresh_every=1, max_iterations=50),
    exudyn=dict(relative_tolerance=1e-8, absolute_tolerance=1e-12, modified_newton=False,
                max_iterations=50, discontinuous_tolerance=1e-12, linear_solver="EXUdense"),
)

FULL = dict(
    M1=[dict(n=n, integration=0, t_end=2.0) for n in (6, 12, 24)]
    + [dict(n=6, integration=k, t_end=2.0) for k in (1, 2)],
    M2=[dict(n=n, integration=0, t_end=3.0) for n in (12, 18, 24)],
    H1=[dict(n=n, integration=0, t_end=1.0) for n in (8, 32)],
)
QUICK = dict(
    M1=[dict(n=6, integration=0, t_end=0.5)],
    M2=[dict(n=12, integration=0, t_end=0.3)],
    H1=[dict(n=8, integration=0, t_end=0.5)],
)
#: step sizes of the M2 study of Exudyn's sliding-joint term (12 elements, 0.5 s)
H_STUDY = (2e-3, 1e-3, 5e-4, 2.5e-4)


def ancf_run(name, system, state, *, t_end, dt, output_dt, rho_inf=0.9, **solver_options):
    """Run ancf_jax's generalized-α and return the compared outputs (failures kept)."""
    from ancf_jax.simulation import make_solver, simulate

    from .exudyn_models import ancf_histories, model_outputs
    res = simulate(system, state, t_end=t_end, dt=dt, output_dt=output_dt, on_failure="return",
                   progress=False, solver=make_solver("generalized-alpha", rho_inf=rho_inf, **solver_options))
    return dict(t=np.asarray(res.t), outputs=model_outputs(name, system, ancf_histories(res)),
                wall_time_s=res.wall_time_s, compile_time_s=res.compile_time_s, status=res.status,
                failure_time=res.failure_time, newton_iterations=int(np.sum(res.iterations)),
                message=res.message)


def differences(a: dict, b: dict, n: int) -> dict:
    """max over the first n output times of |a − b| (Euclidean norm for 2-vectors)."""
    out = {}
    for key in a:
        if key == "nodes":
            out["nodes_max_abs"] = float(np.max(np.abs(a[key][:n] - b[key][:n])))
            continue
        d = np.asarray(a[key][:n]) - np.asarray(b[key][:n])
        d = np.linalg.norm(d, axis=-1) if d.ndim == 2 else np.abs(d)
        out[key] = float(np.max(d))
    return out


def _case(name, n, integration, t_end, initial, *, dt, output_dt, cancel=False, ancf=None,
          exudyn_options=None):
    from . import exudyn_models as em
    system, state = initial
    if ancf is None:
        ancf = ancf_run(name, system, state, t_end=t_end, dt=dt, output_dt=output_dt,
                        rho_inf=SETTINGS["rho_inf"], **SETTINGS["ancf"])
    model = em.build_exudyn(system, state, name=name, cancel_sliding_term=cancel)
    options = {**SETTINGS["exudyn"], **(exudyn_options or {})}
    exu_run = em.run(model, t_end=t_end, dt=dt, output_dt=output_dt, rho_inf=SETTINGS["rho_inf"],
                     on_failure="return", **options)
    # compare the leading output times both codes reached (after a failure ancf_jax may
    # return one more row at the failure time, off the output grid)
    n_min = min(len(ancf["t"]), len(exu_run.t))
    same = np.abs(np.asarray(ancf["t"][:n_min]) - exu_run.t[:n_min]) < 1e-9
    common = int(np.argmin(same)) if not np.all(same) else n_min
    row = dict(
        model=name, n_elements=n, integration=integration, t_end=t_end, dt=dt,
        exudyn_variant="sliding term cancelled" if cancel else "as shipped",
        t_compared=float(exu_run.t[common - 1]), max_difference=differences(ancf["outputs"], exu_run.outputs, common),
        ancf=dict(status=ancf["status"], failure_time=ancf["failure_time"], wall_time_s=ancf["wall_time_s"],
                  compile_time_s=ancf["compile_time_s"], newton_iterations=ancf["newton_iterations"]),
        exudyn=dict(status=exu_run.status, failure_time=exu_run.failure_time, wall_time_s=exu_run.wall_time_s,
                    setup_time_s=exu_run.setup_time_s, newton_iterations=exu_run.newton_iterations,
                    jacobians=exu_run.jacobians, steps=exu_run.steps),
    )
    return row, ancf


def _print_row(row):
    d = ", ".join(f"{k}={v:.2e}" for k, v in row["max_difference"].items())
    fail = ""
    for code in ("ancf", "exudyn"):
        if row[code]["status"] != "ok":
            fail += f"  [{code} failed at t={row[code]['failure_time']}]"
    print(f"{row['model']} n={row['n_elements']:>2} rule={row['integration']} "
          f"{row['exudyn_variant']:<23} t<={row['t_compared']:.2f} s: {d}  "
          f"(ancf {row['ancf']['wall_time_s']:.2f} s + compile {row['ancf']['compile_time_s']:.1f} s, "
          f"exudyn {row['exudyn']['wall_time_s']:.2f} s){fail}", flush=True)


def timing() -> list:
    """Exudyn run times under its own solver choices (no agreement check): modified vs
    full Newton, dense vs sparse LU, on M1 (24 elements, 2 s), M2 (24, 3 s, as shipped)
    and H1 (32, 1 s), h = 1 ms, ρ∞ = 0.9, default Newton tolerances."""
    from . import exudyn_models as em
    rows = []
    for name, n, t_end in (("M1", 24, 2.0), ("M2", 24, 3.0), ("H1", 32, 1.0)):
        initial = em.ancf_system(name, n)
        for modified in (True, False):
            for solver in ("EXUdense", "EigenSparse"):
                model = em.build_exudyn(*initial, name=name)
                r = em.run(model, t_end=t_end, dt=SETTINGS["dt"], output_dt=SETTINGS["output_dt"],
                           modified_newton=modified, linear_solver=solver, max_iterations=50,
                           on_failure="return")
                rows.append(dict(model=name, n_elements=n, t_end=t_end, modified_newton=modified,
                                 linear_solver=solver, status=r.status, wall_time_s=r.wall_time_s,
                                 setup_time_s=r.setup_time_s, newton_iterations=r.newton_iterations,
                                 jacobians=r.jacobians))
                print(f"{name} n={n} {'modified' if modified else 'full':>8} Newton, {solver:<11}: "
                      f"{r.wall_time_s:6.2f} s ({r.newton_iterations} iterations, {r.jacobians} "
                      f"Jacobians, {r.status})", flush=True)
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short spans, smallest meshes")
    parser.add_argument("--out", type=Path, default=None,
                        help=f"JSON output (default {DEFAULT_OUT}; --quick: not written unless given)")
    parser.add_argument("--models", default="M1,M2,H1", help="comma-separated subset of M1,M2,H1")
    parser.add_argument("--timing", action="store_true",
                        help="only time Exudyn's solver options (printed, not written)")
    args = parser.parse_args(argv)
    try:
        import exudyn
    except ImportError:
        print("exudyn is not installed: nothing to compare (pip install 'ancf_jax[bench]').")
        return 0
    if args.timing:
        timing()
        return 0
    from . import exudyn_models as em

    plan = QUICK if args.quick else FULL
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    dt, output_dt = SETTINGS["dt"], SETTINGS["output_dt"]
    rows, study, crossing = [], [], []
    t_start = time.perf_counter()
    for name in models:
        for case in plan[name]:
            n, integ, t_end = case["n"], case["integration"], case["t_end"]
            t0 = time.perf_counter()
            initial = em.ancf_system(name, n, integration=integ)
            init_s = time.perf_counter() - t0
            row, ancf = _case(name, n, integ, t_end, initial, dt=dt, output_dt=output_dt)
            row["ancf"]["initial_state_s"] = init_s
            rows.append(row)
            _print_row(row)
            if name == "M2":
                row, _ = _case(name, n, integ, t_end, initial, dt=dt, output_dt=output_dt,
                               cancel=True, ancf=ancf)
                rows.append(row)
                _print_row(row)
                if n == 12 and not args.quick:
                    for h in H_STUDY:
                        ra, _ = _case(name, n, integ, 0.5, initial, dt=h, output_dt=output_dt)
                        rc, _ = _case(name, n, integ, 0.5, initial, dt=h, output_dt=output_dt,
                                      cancel=True)
                        study.append(dict(dt=h, t_compared=min(ra["t_compared"], rc["t_compared"]),
                                          as_shipped=ra["max_difference"],
                                          cancelled=rc["max_difference"],
                                          status=[ra["ancf"]["status"], ra["exudyn"]["status"],
                                                  rc["exudyn"]["status"]]))
                        print(f"  M2 n=12 h={h:g} over {study[-1]['t_compared']:.2f} s: as shipped point1 "
                              f"{ra['max_difference']['point1']:.2e} m, s {ra['max_difference']['s']:.2e} m;"
                              f" cancelled point1 {rc['max_difference']['point1']:.2e} m "
                              f"(status ancf/exudyn/exudyn-cancelled: {study[-1]['status']})", flush=True)
                    # node crossings: Exudyn's default discontinuous.iterationTolerance
                    # (1 m) keeps the crossing step on the extrapolated old element
                    for tol in (1e-12, 1.0):
                        rd, _ = _case(name, n, integ, 1.0, initial, dt=dt, output_dt=output_dt,
                                      cancel=True, exudyn_options=dict(discontinuous_tolerance=tol))
                        crossing.append(dict(discontinuous_tolerance=tol, t_compared=rd["t_compared"],
                                             max_difference=rd["max_difference"]))
                        print(f"  M2 n=12 cancelled, discontinuous tolerance {tol:g}, over "
                              f"{rd['t_compared']:.2f} s: point1 {rd['max_difference']['point1']:.2e} m, "
                              f"s {rd['max_difference']['s']:.2e} m", flush=True)
    report = dict(
        command="python -m benchmarks.compare_exudyn" + (" --quick" if args.quick else ""),
        exudyn_version=exudyn.__version__, python=platform.python_version(),
        machine=platform.machine(), settings=SETTINGS, exudyn_rules=em.EXUDYN_RULES,
        cases=rows, sliding_term_step_study=study, node_crossing_study=crossing,
        total_time_s=time.perf_counter() - t_start,
    )
    out = args.out if args.out is not None else (None if args.quick else DEFAULT_OUT)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(report, indent=1, default=float))
        print(f"written {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
