"""Cost of derivatives through the solver for damping identification (issue 7/8).

Model M1 (default 2 s, generalized-alpha, h = 1 ms, tip samples at 1 kHz) with 3 and 6
elements. For each: one forward run (output only), the residuals with the full
Jacobian by forward mode (alpha, beta: two tangents; alpha alone: one), the loss with
its gradient by reverse mode, and the agreement of the two gradients; compile and run
times (best of 3). Then derivative checks that the tests do not run: gradients with
respect to E and the tip mass, and the reverse-mode gradient with respect to the initial
velocities, against central differences; and LM against Adam on a noise-free fit.

    python benchmarks/identification_gradients.py [--quick] [--t-end T] [--dt H]

Writes benchmarks/results/identification_gradients.json. The timings are wall-clock
on whatever machine runs it: compare ratios, not seconds (the load average is recorded).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

import ancf_jax  # noqa: F401
from ancf_jax.identification import Problem, fit, synthesize
from ancf_jax.system import State

OUT = Path(__file__).parent / "results" / "identification_gradients.json"
TRUTH = {"alpha": 0.02, "beta": 0.0}
T_END, DT = 2.0, 1e-3


def best_of(fn, n=3):
    """Best of n: wall seconds, or CPU seconds of the process (all threads) when CPU is
    set (wall times on a shared, overloaded machine are meaningless)."""
    t = []
    for _ in range(n):
        t0 = time.process_time() if CPU else time.perf_counter()
        fn()
        t.append((time.process_time() if CPU else time.perf_counter()) - t0)
    return min(t)


CPU = False


def timing(elements: int, one_param: bool = True) -> dict:
    pr = Problem.from_scenario("m1", ("alpha", "beta"), elements=elements, t_end=T_END, dt=DT)
    data, _ = synthesize(pr, TRUTH, noise=0.0, program="values")
    p = np.array([0.03, 1e-5])
    c0 = pr.compile_time_s
    fwd = best_of(lambda: pr.curves(p, [data], program="values"))
    pr.evaluate(p, [data])
    c_jac = pr.compile_time_s - c0
    jac = best_of(lambda: pr.evaluate(p, [data]))
    pr.loss_and_gradient_reverse(p, data)
    c_rev = pr.compile_time_s - c0 - c_jac
    rev = best_of(lambda: pr.loss_and_gradient_reverse(p, data))
    lf, gf, _ = pr.loss_and_gradient(p, data)
    lr, gr, _ = pr.loss_and_gradient_reverse(p, data)
    out = dict(elements=elements, samples=len(data), steps=int(round(T_END / DT)), forward_run_s=fwd,
               forward_compile_wall_s=c0, jacobian_2_params_s=jac, jacobian_2_params_compile_wall_s=c_jac,
               reverse_value_and_grad_s=rev, reverse_compile_wall_s=c_rev,
               ratio_jacobian_2_params=jac / fwd, ratio_reverse=rev / fwd,
               forward_vs_reverse_gradient_rel_diff=float(np.max(np.abs(gf - gr) / np.abs(gr))),
               loss_rel_diff=abs(lf - lr) / lr)
    if one_param:
        pa = Problem.from_scenario("m1", ("alpha",), elements=elements, t_end=T_END, dt=DT)
        pa.evaluate([0.03], [data])
        out["jacobian_1_param_s"] = jac1 = best_of(lambda: pa.evaluate([0.03], [data]))
        out["ratio_jacobian_1_param"] = jac1 / fwd
    print(json.dumps(out, indent=1), flush=True)
    return out


def central(fn, p, k, rel=1e-3):
    e = np.zeros_like(p)
    e[k] = rel * p[k]
    return (fn(p + e) - fn(p - e)) / (2 * e[k])


def other_parameters() -> dict:
    """Gradients w.r.t. E and the tip mass (forward mode) against central differences."""
    pr = Problem.from_scenario("m1", ("alpha", "E", "tip_mass"), elements=3, t_end=T_END, dt=DT)
    data, _ = synthesize(pr, {"alpha": 0.02, "E": 200e9, "tip_mass": 0.02}, noise=0.0, program="jacobian")
    p = np.array([0.03, 190e9, 0.021])
    _, g, _ = pr.loss_and_gradient(p, data)

    def value(x):
        r, *_ = pr.evaluate(x, [data])
        return float(r[0] @ r[0])

    fd = np.array([central(value, p, k) for k in range(3)])
    res = {n: dict(ad=float(a), fd=float(b), rel_diff=float(abs(a - b) / abs(b)))
           for n, a, b in zip(pr.names, g, fd)}
    fitted = fit(pr, data, {"alpha": 0.03, "E": 190e9, "tip_mass": 0.021})
    res["noise_free_fit"] = dict(estimates=dict(zip(pr.names, map(float, fitted.estimates))),
                                 iterations=fitted.iterations, stop_reason=fitted.stop_reason)
    print(json.dumps(res, indent=1), flush=True)
    return res


def initial_state() -> dict:
    """Reverse-mode gradient w.r.t. the initial velocities against a central difference
    along the gradient direction (hundreds of inputs, one loss: reverse mode)."""
    pr = Problem.from_scenario("m1", ("alpha", "beta"), elements=3, t_end=T_END, dt=DT)
    data, _ = synthesize(pr, TRUTH, noise=0.0, program="values")
    p = np.array([0.03, 1e-5])
    t0 = time.perf_counter()
    loss, gq, gv = pr.state_gradient(p, data)
    first = time.perf_counter() - t0
    d = gv / np.linalg.norm(gv)
    h = 1e-4

    def value(eps):
        s = pr.state
        other = Problem(pr.system, State(s.q, s.v + eps * d, s.t), pr.names, pr.output, dt=pr.dt,
                        t_end=pr.t_end - pr.t0, solver=pr.solver)
        r, *_ = other.evaluate(p, [data])
        return float(r[0] @ r[0])

    fd = (value(h) - value(-h)) / (2 * h)
    ad = float(gv @ d)
    res = dict(n_inputs=int(gq.size + gv.size), first_call_s=first, directional_ad=ad, directional_fd=fd,
               rel_diff=abs(ad - fd) / abs(fd))
    print(json.dumps(res, indent=1), flush=True)
    return res


def lm_vs_adam() -> dict:
    """Noise-free alpha-only fit from alpha = 0.005: LM against Adam (lr 0.1 on log alpha)."""
    pr = Problem.from_scenario("m1", ("alpha", "beta"), elements=3, t_end=T_END, dt=DT)
    data, _ = synthesize(pr, TRUTH, noise=0.0, program="jacobian")
    out = {}
    for method, kw in (("lm", {}), ("adam", dict(learning_rate=0.1, max_iterations=150))):
        t0 = time.perf_counter()
        r = fit(pr, data, {"alpha": 0.005, "beta": 0.0}, free=("alpha",), method=method, **kw)
        errs = []
        out[method] = dict(iterations=r.iterations, wall_s=time.perf_counter() - t0,
                           alpha=float(r.estimates[0]), rel_error=abs(r.estimates[0] - 0.02) / 0.02,
                           stop_reason=r.stop_reason, loss_history=r.loss_history)
        del errs
        print(method, {k: v for k, v in out[method].items() if k != "loss_history"}, flush=True)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="3 elements only, skip Adam")
    ap.add_argument("--t-end", type=float, default=2.0, help="simulated span [s] (default 2)")
    ap.add_argument("--dt", type=float, default=1e-3, help="step [s] (default 1e-3)")
    ap.add_argument("--cpu-time", action="store_true",
                    help="time in CPU seconds of the process instead of wall seconds")
    ap.add_argument("--timing-only", action="store_true",
                    help="only the timing part; merged into an existing results file")
    args = ap.parse_args()
    global T_END, DT, CPU
    T_END, DT, CPU = args.t_end, args.dt, args.cpu_time
    if args.timing_only:
        part = dict(clock="process CPU seconds" if CPU else "wall seconds", t_end=T_END, dt=DT,
                    load_average_start=os.getloadavg(), results=[timing(3, one_param=False)],
                    load_average_end=os.getloadavg())
        res = json.loads(OUT.read_text()) if OUT.exists() else {}  # read after the run: merge
        res["timing_cpu" if CPU else "timing"] = part
        OUT.parent.mkdir(exist_ok=True)
        OUT.write_text(json.dumps(res, indent=2))
        print(f"-> {OUT}")
        return
    res = dict(machine=dict(cpus=os.cpu_count(), load_average_start=os.getloadavg()),
               setup=dict(t_end=T_END, dt=DT, samples_hz=1000.0))
    res["timing"] = [timing(n) for n in ((3,) if args.quick else (3, 6))]
    res["other_parameters"] = other_parameters()
    res["initial_state"] = initial_state()
    if not args.quick:
        res["lm_vs_adam"] = lm_vs_adam()
    res["machine"]["load_average_end"] = os.getloadavg()
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps(res, indent=2))
    print(f"-> {OUT}")


if __name__ == "__main__":
    main()
