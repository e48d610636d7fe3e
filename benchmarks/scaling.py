"""Per-step cost against element count for both codes.

M1 with 6 to 384 elements (quick: up to 48), h = 1 ms, each code with its default
settings (ancf_jax: generalized-α defaults; Exudyn: modified Newton, EigenSparse, or
full Newton where modified Newton fails; Exudyn only up to 192 elements: from 48
elements on neither of its Newton methods converges at h = 1 ms, its rows say so, and
at 192 its failing step already costs ~25 times ancf_jax's), a short span of ``t_end``. Per-step cost = run
time / steps (median of ``reps`` interleaved runs; ancf_jax compiles once per element
count, reported separately). The growth exponent p of cost ∝ n^p is fitted by least
squares on log-log over n ≥ 24. A fixed per-step overhead would make p look smaller
than the growth of the work, so the marginal cost is reported too: the slope b of
cost = a + b n fitted over n ≥ 24 (seconds per element and step; a is the fixed
part), and the local exponent between the two largest counts, where the fixed part
matters least. The steps of the two largest counts are profiled
(:func:`benchmarks.step_profile.profile`: residual, Newton matrix, factorization,
solve and powers each timed alone, and what the step adds to them).

    python -m benchmarks.scaling [--quick]
"""

from __future__ import annotations


import numpy as np

from . import cases as C
from .common import write

FULL = dict(counts=(6, 12, 24, 48, 96, 192, 384), t_end=0.5, reps=3)
QUICK = dict(counts=(6, 12, 24, 48), t_end=0.1, reps=1)
DT = 1e-3
FIT_FROM = 24
EXUDYN_MAX = 192  # elements (module docstring)


def fit_exponent(counts, costs, n_min=FIT_FROM):
    pts = [(n, c) for n, c in zip(counts, costs) if n >= n_min and c and np.isfinite(c)]
    if len(pts) < 2:
        return None
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def fit_marginal(counts, costs, n_min=FIT_FROM):
    """The marginal cost (module docstring): {"per_element_s": b, "fixed_s": a,
    "last_exponent": log(c₂/c₁) / log(n₂/n₁) of the two largest counts}, or None."""
    pts = sorted((n, c) for n, c in zip(counts, costs) if n >= n_min and c and np.isfinite(c))
    if len(pts) < 2:
        return None
    n, c = np.array(pts, float).T
    b, a = np.polyfit(n, c, 1)
    return dict(per_element_s=float(b), fixed_s=float(a),
                last_exponent=float(np.log(c[-1] / c[-2]) / np.log(n[-1] / n[-2])),
                last_counts=[int(n[-2]), int(n[-1])])


def _ok_costs(rows, code):
    """Per-step costs of completed runs (a failed run's cost is not fitted)."""
    return [r[code]["per_step_s"] if r[code]["status"] == "ok" else None for r in rows]


def main(argv=None, *, quick=None, exudyn=None):
    quick, exudyn = C.section_options(__doc__, argv, quick, exudyn)
    plan = QUICK if quick else FULL
    rows = []
    for n in plan["counts"]:
        system, state = C.m1(n)
        first = C.run_ancf("M1", system, state, t_end=plan["t_end"], dt=DT)  # compiles
        funcs = dict(ancf_jax=lambda: C.run_ancf("M1", system, state, t_end=plan["t_end"], dt=DT))
        with_exudyn = exudyn and n <= EXUDYN_MAX
        if with_exudyn:
            # Exudyn's fastest choice (modified Newton) fails on fine M1 meshes at 1 ms
            # (Newton does not converge); then full Newton, recorded in the row
            probe = C.run_exudyn("M1", system, state, t_end=plan["t_end"], dt=DT)
            exu_opts = {} if probe.status == "ok" else dict(modified_newton=False)
            funcs["exudyn"] = lambda: C.run_exudyn("M1", system, state, t_end=plan["t_end"], dt=DT,
                                                   options=exu_opts)
        timed = C.interleaved(funcs, plan["reps"])
        row = dict(elements=n, steps=first.steps, ancf_compile_s=first.setup_s)
        if with_exudyn:
            row["exudyn_newton"] = "modified" if not exu_opts else "full (modified failed)"
        for code, runs in timed.items():
            med = C.median([r.run_s for r in runs])
            row[code] = dict(run_s=[r.run_s for r in runs], median_run_s=med,
                             per_step_s=med / max(1, runs[0].steps), status=runs[0].status,
                             iterations_per_step=runs[0].iterations / max(1, runs[0].steps))
        rows.append(row)
        msg = f"scaling n={n}: ancf_jax {row['ancf_jax']['per_step_s'] * 1e3:.3f} ms/step"
        if "exudyn" in row:
            msg += f", Exudyn {row['exudyn']['per_step_s'] * 1e3:.3f} ms/step"
        print(msg + f" (compile {first.setup_s:.1f} s)", flush=True)
    counts = [r["elements"] for r in rows]
    # what grows: the step of the two largest counts taken apart (their last half second)
    from .step_profile import profile
    profiles = []
    for n in counts[-2:] if not quick else ():
        system, state = C.m1(n)
        p = profile(system, state, DT, {}, t_end=plan["t_end"], t_parts=plan["t_end"] / 2)
        profiles.append(dict(elements=n, **p))
        print(f"profile n={n}: step {p['bare_step_s'] * 1e3:.3f} ms = parts {p['model_s'] * 1e3:.3f} ms "
              f"+ the rest {p['control_flow_s'] * 1e3:.3f} ms", flush=True)
    out = dict(section="scaling", quick=quick, exudyn=exudyn, t_end=plan["t_end"], dt=DT, model="M1",
               rows=rows, fit_from=FIT_FROM, exudyn_max=EXUDYN_MAX, profiles=profiles,
               exponent=dict(ancf_jax=fit_exponent(counts, _ok_costs(rows, "ancf_jax"))),
               marginal=dict(ancf_jax=fit_marginal(counts, _ok_costs(rows, "ancf_jax"))),
               command="python -m benchmarks.run" + (" --quick" if quick else "") + " --only scaling")
    if exudyn:
        ex_rows = [r for r in rows if "exudyn" in r]
        ex_counts = [r["elements"] for r in ex_rows]
        out["exponent"]["exudyn"] = fit_exponent(ex_counts, _ok_costs(ex_rows, "exudyn"))
        out["marginal"]["exudyn"] = fit_marginal(ex_counts, _ok_costs(ex_rows, "exudyn"))
    else:
        out["exudyn_missing"] = C.exudyn_missing_reason()
    return write("scaling", out)


if __name__ == "__main__":
    import sys
    print(main(sys.argv[1:]))
