"""Coverage of the reported standard errors on foreign data (issue 18).

The record is M1's tip Y-displacement from a *different, finer* discretization
(``--fine-elements``, ``--fine-dt``) than the fitted model (``--elements``, the
scenario's step or ``--dt``), with Gaussian noise of ``--noise`` over ``--seeds`` seeds.
``--reference exudyn`` makes the record with another code: Exudyn's
``ObjectANCFCable2D`` (engineering axial strain, material curvature, its integration
rule 2: 3-point Lobatto axial, 2-point Gauss bending) translated by ``to_exudyn`` and
integrated by Exudyn's generalized-α (ρ∞ = 0.9, full Newton) at the fine step, as in
notebook 06. ``--fit-formulation exudyn`` fits with Exudyn's element instead of the
scenario's.
Two ways of fitting α (β fixed at its true 0) are compared:

1. ``coarse``: the fitted model as given, no discretization check (what ``ancf-jax fit
   --no-refine`` does);
2. ``default``: the default of ``ancf-jax fit``: the fit of seed 0 runs the
   discretization check (step halved, mesh doubled, refine while an estimate moves by
   more than 0.3 SE, budget ``--budget``, 2 by default) and the strain-measure check,
   and all seeds are then fitted on the discretization it ended at; their coverage is
   reported for the Gauss–Newton SE and for the combined standard uncertainty of Eq. U
   (SE of each seed with seed 0's discretization and strain-measure shifts in
   quadrature).

Each set of seeds is one vmapped batch. Reported per way: mean estimate, mean reported
SE, the scatter (std) of the estimates over seeds, scatter / SE (should be 1 ± 0.3),
the fraction of seeds whose ±2 SE interval holds the truth (should be >= 0.9), and
the residual diagnostics (fraction of seeds with white residuals). Then a parametric
bootstrap of seed 0's fit (as many members as seeds, one vmapped batch) is compared with
its Gauss–Newton SE and with the scatter over the noise seeds.

    python benchmarks/identification_coverage.py [--seeds 20] [--elements 6] [--t-end 1] [--axes step,mesh]
                                                 [--reference exudyn]

Writes benchmarks/results/identification_coverage.json.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from ancf_jax.identification import Measurements, Problem, bootstrap, fit, fit_batch, synthesize

OUT = Path(__file__).parent / "results" / "identification_coverage.json"
TRUTH = 0.02


def stats(results, truth=TRUTH, type_b=None):
    """Coverage statistics of α over the seeds; with ``type_b`` (the check's shifts of
    α [1/s]: discretization axes and strain measure, from seed 0) also those of the
    combined standard uncertainty u = sqrt(SE² + Σ shift²) of each seed (Eq. U of
    ancf_jax.identification.discretization)."""
    est = np.array([r.estimates[0] for r in results])
    se = np.array([r.stderr[0] for r in results])
    z = (est - truth) / se
    out = dict(mean=float(est.mean()), mean_se=float(se.mean()), scatter=float(est.std(ddof=1)),
               scatter_over_se=float(est.std(ddof=1) / se.mean()), rms_z=float(np.sqrt(np.mean(z ** 2))),
               coverage_2se=float(np.mean(np.abs(z) <= 2.0)), max_abs_z=float(np.max(np.abs(z))),
               white=float(np.mean([r.diagnostics["white"] for r in results])),
               converged=int(sum(r.converged for r in results)), estimates=est.tolist(), stderr=se.tolist())
    if type_b:
        u = np.sqrt(se ** 2 + sum(v ** 2 for v in type_b.values()))
        zu = (est - truth) / u
        out.update(type_b=type_b, mean_u=float(u.mean()), scatter_over_u=float(est.std(ddof=1) / u.mean()),
                   coverage_2u=float(np.mean(np.abs(zu) <= 2.0)), combined_uncertainty=u.tolist())
    return out


def type_b_shifts(checked) -> dict:
    """Seed 0's shifts of α [1/s] that Eq. U adds to the SE: the last round's
    discretization axes and the strain-measure exchange (None where not checked)."""
    out = {f"discretization_{a}": c["shift"].get("alpha", 0.0)
           for a, c in checked.discretization["rounds"][-1]["checks"].items()}
    if checked.model_form is not None and checked.model_form["checked"]:
        out["strain_measure"] = checked.model_form["shift"].get("alpha", 0.0)
    return out


def formulation_overrides(kind: str) -> tuple[str, ...]:
    """``--set`` items of the fitted model's element (``--fit-formulation``): none for
    the scenario's, every field of ``cable_formulation(2)`` (Exudyn's cable with its
    integration rule 2, the record's element) for ``"exudyn"``."""
    if kind == "default":
        return ()
    from ancf_jax.interop.exudyn import cable_formulation
    f = cable_formulation(2)
    return tuple(f"beams.beam.formulation.{k}={json.dumps(getattr(f, k))}"
                 for k in ("axial_strain", "curvature", "axial_quadrature", "bending_quadrature", "metric"))


def exudyn_record(elements: int, dt: float, t_end: float):
    """M1's tip Y-displacement [m] at times [s] by Exudyn (module docstring)."""
    import exudyn as exu

    from ancf_jax.interop.exudyn import cable_formulation, to_exudyn
    from ancf_jax.models.m1 import m1_model
    system, state = m1_model(elements, formulation=cable_formulation(2), alpha=TRUTH, beta=0.0).build()
    # full Newton to 1e-6 of each step's initial residual (notebook 06: Exudyn's 1e-8
    # stalls at the round-off of a stiff fine wire)
    t_ref, q_ref = to_exudyn(system, state).solve_dynamic(t_end=t_end, h=dt, modified_newton=False,
                                                          relative_tolerance=1e-6, max_iterations=50)
    return np.asarray(t_ref), np.array([system.beam_nodes(q, 0)[-1, 1] for q in q_ref]), exu.__version__


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--elements", type=int, default=6)
    ap.add_argument("--dt", type=float, default=None, help="step of the fitted model (default: the scenario's)")
    ap.add_argument("--fine-elements", type=int, default=12)
    ap.add_argument("--fine-dt", type=float, default=2.5e-4)
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--rate", type=float, default=500.0)
    ap.add_argument("--noise", type=float, default=2e-4)
    ap.add_argument("--bootstrap", action=argparse.BooleanOptionalAction, default=True,
                    help="also a parametric bootstrap of seed 0's fit (default on)")
    ap.add_argument("--axes", default="step,mesh", help="refinement axes of the check (default step,mesh)")
    ap.add_argument("--budget", type=int, default=2, help="refinements the check may make (default 2, "
                    "as ancf-jax fit)")
    ap.add_argument("--reference", choices=("ancf_jax", "exudyn"), default="ancf_jax",
                    help="the code that makes the foreign record (default ancf_jax)")
    ap.add_argument("--fit-formulation", choices=("default", "exudyn"), default="default",
                    help="the fitted model's element: the scenario's (default) or Exudyn's cable "
                    "(engineering strain, material curvature, its integration rule 2)")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args()
    setup = vars(args).copy()
    setup["out"] = str(args.out)
    res = dict(setup=setup, truth=dict(alpha=TRUTH, beta=0.0),
               machine=dict(cpus=os.cpu_count(), load_average_start=os.getloadavg()))
    t0 = time.perf_counter()
    if args.reference == "exudyn":
        t_ref, tip_ref, version = exudyn_record(args.fine_elements, args.fine_dt, args.t_end)
        t = np.arange(int(round(args.t_end * args.rate)) + 1) / args.rate
        clean = np.interp(t, t_ref, tip_ref)
        res["reference"] = f"Exudyn {version}"
    else:
        fine = Problem.from_scenario("m1", ("alpha", "beta"), elements=args.fine_elements, t_end=args.t_end,
                                     dt=args.fine_dt)
        _, clean = synthesize(fine, {"alpha": TRUTH, "beta": 0.0}, noise=0.0, rate=args.rate)
        t = np.arange(len(clean)) / args.rate
        res["reference"] = "ancf_jax"
    sets = [Measurements.from_arrays(t, clean + args.noise * np.random.default_rng(s).standard_normal(len(t)),
                                     source=f"seed {s}") for s in range(args.seeds)]
    res["foreign_data_s"] = time.perf_counter() - t0
    coarse = Problem.from_scenario("m1", ("alpha", "beta"), elements=args.elements, t_end=args.t_end, dt=args.dt,
                                   overrides=formulation_overrides(args.fit_formulation))
    init = {"alpha": 0.01, "beta": 0.0}
    t1 = time.perf_counter()
    checked = fit(coarse, sets[0], init, free=("alpha",), noise=args.noise, discretization=True,
                  refine_axes=tuple(a for a in args.axes.split(",") if a), refine_budget=args.budget)
    res["check_s"] = time.perf_counter() - t1
    res["discretization"] = {k: v for k, v in checked.discretization.items() if k != "notes"}
    res["discretization"]["notes"] = checked.discretization["notes"]
    res["model_form"] = checked.model_form
    type_b = type_b_shifts(checked)
    ways = {"coarse": coarse}
    dz = checked.discretization
    final = coarse.refined(step=int(round(coarse.dt / dz["final_dt_s"])),
                           mesh=(dz["final_elements"] // args.elements) if dz["final_elements"] else 1)
    ways["default"] = final
    for name, pr in ways.items():
        t2 = time.perf_counter()
        results = fit_batch(pr, sets, [init], free=("alpha",), noise=args.noise)
        res[name] = dict(dt=pr.dt, elements=pr.elements, **stats(results, type_b=type_b if name == "default" else None),
                         wall_s=time.perf_counter() - t2)
        s = res[name]
        combined = (f"; combined u {s['mean_u']:.5f}: scatter/u {s['scatter_over_u']:.2f}, within 2 u "
                    f"{s['coverage_2u']:.0%}" if "mean_u" in s else "")
        print(f"{name:8s} h = {pr.dt:g} s, {pr.elements} elements: mean {s['mean']:.5f}, SE {s['mean_se']:.5f}, "
              f"scatter/SE {s['scatter_over_se']:.2f}, within 2 SE {s['coverage_2se']:.0%}, "
              f"white {s['white']:.0%}{combined} ({s['wall_s']:.0f} s)", flush=True)
    print("check:", dz["summary"])
    if checked.model_form is not None:
        print("strain measure:", checked.model_form["summary"])
    if args.bootstrap:
        # the parametric bootstrap of seed 0's fit: one vmapped batch of as many members as
        # seeds on the final discretization (the program of the batch above)
        t3 = time.perf_counter()
        bs = bootstrap(coarse, checked, args.seeds, seed=1000)
        res["bootstrap"] = dict(bs, wall_s=time.perf_counter() - t3,
                                seed_scatter=res["default"]["scatter"])
        print(f"bootstrap of seed 0: sd {bs['std']['alpha']:.5f} against GN SE {bs['gn_stderr']['alpha']:.5f} "
              f"and the scatter over noise seeds {res['default']['scatter']:.5f}")
    res["machine"]["load_average_end"] = os.getloadavg()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(res, indent=1))
    print(f"-> {args.out}")


if __name__ == "__main__":
    main()
