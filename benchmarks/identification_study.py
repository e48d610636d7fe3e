"""Damping identification on synthetic M1 data: recovery and honest standard errors.

Model M1 (3 elements, generalized-alpha at h = 2 ms, the paper's 2 s, tip Y-displacement
sampled at 1 kHz: 2001 samples), truth alpha = 0.02 1/s, beta = 0. Three studies, each
one vmapped batch of 20 members (one compiled program for all of them):

1. noise-free data, 20 initial guesses alpha log-spaced from 0.005 to 0.08 (beta free,
   starting at 1e-5 s): relative error of alpha, iterations, beta's verdict;
2. 1 mm of Gaussian noise, 20 seeds, alpha free and beta fixed at 0: estimates, reported
   standard errors, fraction within 1 and 3 standard errors, and the scatter of the
   estimates against the mean reported standard error (their ratio should be near 1);
3. the same 20 noisy data sets with alpha and beta both free: beta's verdict and the
   alpha-beta correlation.

    python benchmarks/identification_study.py [--seeds 20] [--elements 3]

Writes benchmarks/results/identification_study.json (wall times are for whatever machine
runs it; the load average is recorded).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from ancf_jax.identification import Measurements, Problem, fit_batch, synthesize

OUT = Path(__file__).parent / "results" / "identification_study.json"
TRUTH = {"alpha": 0.02, "beta": 0.0}
SIGMA = 1e-3


def summary(results, names=("alpha", "beta")):
    return [dict(estimates=dict(zip(names, map(float, r.estimates))),
                 stderr={n: (None if not np.isfinite(s) else float(s)) for n, s in zip(names, r.stderr)},
                 status=dict(zip(names, r.status)), iterations=r.iterations, converged=r.converged,
                 stop_reason=r.stop_reason, residual_rms=r.residual_rms,
                 correlation=None if len(r.free) < 2 else float(r.correlation[0, 1]))
            for r in results]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--elements", type=int, default=3)
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--dt", type=float, default=2e-3)
    ap.add_argument("--rate", type=float, default=1000.0)
    args = ap.parse_args()
    n = args.seeds
    res = dict(setup=dict(model="m1", elements=args.elements, t_end=args.t_end, dt=args.dt, rate_hz=args.rate,
                          truth=TRUTH, noise_m=SIGMA, members=n, solver="generalized-alpha"),
               machine=dict(cpus=os.cpu_count(), load_average_start=os.getloadavg()))
    pr = Problem.from_scenario("m1", ("alpha", "beta"), elements=args.elements, t_end=args.t_end, dt=args.dt)
    t0 = time.perf_counter()
    clean, _ = synthesize(pr, TRUTH, noise=0.0, rate=args.rate, program="values")
    res["synth_s"] = time.perf_counter() - t0

    # 1. noise-free, 20 initial guesses
    guesses = np.geomspace(0.005, 0.08, n)
    t0 = time.perf_counter()
    out = fit_batch(pr, [clean], [{"alpha": a, "beta": 1e-5} for a in guesses])
    rel = np.array([abs(r.estimates[0] - 0.02) / 0.02 for r in out])
    res["noise_free"] = dict(
        initial_alpha=guesses.tolist(), max_rel_error_alpha=float(rel.max()),
        all_within_1e_4=bool(np.all(rel <= 1e-4)), iterations=[r.iterations for r in out],
        beta_status=sorted({r.status[1] for r in out}), all_converged=all(r.converged for r in out),
        wall_s=time.perf_counter() - t0, compile_s=out[0].compile_time_s, fits=summary(out))
    print(json.dumps({k: v for k, v in res["noise_free"].items() if k != "fits"}), flush=True)

    # 2. 1 mm noise, 20 seeds, alpha only
    sets = [Measurements.from_arrays(clean.t, clean.y + SIGMA * np.random.default_rng(s).standard_normal(len(clean)),
                                     source=f"seed {s}") for s in range(n)]
    t0 = time.perf_counter()
    out = fit_batch(pr, sets, [{"alpha": 0.01, "beta": 0.0}], free=("alpha",))
    est = np.array([r.estimates[0] for r in out])
    se = np.array([r.stderr[0] for r in out])
    z = (est - 0.02) / se
    res["noisy_alpha_only"] = dict(
        estimates=est.tolist(), stderr=se.tolist(), mean_estimate=float(est.mean()),
        scatter_std=float(est.std(ddof=1)), mean_stderr=float(se.mean()),
        scatter_over_stderr=float(est.std(ddof=1) / se.mean()),
        rms_z=float(np.sqrt(np.mean(z ** 2))), within_1_se=float(np.mean(np.abs(z) <= 1)),
        within_3_se=float(np.mean(np.abs(z) <= 3)), max_abs_z=float(np.max(np.abs(z))),
        residual_rms_over_sigma=[r.residual_rms / SIGMA for r in out],
        iterations=[r.iterations for r in out], all_converged=all(r.converged for r in out),
        wall_s=time.perf_counter() - t0)
    print(json.dumps({k: v for k, v in res["noisy_alpha_only"].items()
                      if k not in ("estimates", "stderr", "residual_rms_over_sigma")}), flush=True)

    # 3. the same data, alpha and beta free
    t0 = time.perf_counter()
    out = fit_batch(pr, sets, [{"alpha": 0.01, "beta": 1e-5}])
    res["noisy_alpha_beta"] = dict(
        beta_status=[r.status[1] for r in out], alpha_status=[r.status[0] for r in out],
        correlation=[float(r.correlation[0, 1]) for r in out],
        beta_stderr=[float(r.stderr[1]) for r in out], alpha_stderr=[float(r.stderr[0]) for r in out],
        beta_identifiable=[r.identifiable("beta") for r in out],
        example_reason=out[0].identifiability("beta"),
        iterations=[r.iterations for r in out], wall_s=time.perf_counter() - t0, fits=summary(out))
    print(json.dumps({k: v for k, v in res["noisy_alpha_beta"].items() if k != "fits"}), flush=True)
    res["machine"]["load_average_end"] = os.getloadavg()
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps(res, indent=2))
    print(f"-> {OUT}")


if __name__ == "__main__":
    main()
