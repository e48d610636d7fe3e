"""Velocity projection after each generalized-α step: does it buy accuracy? (issue 17)

Generalized-α at index 3 solves Φ(q_{n+1}) = 0 with the equations of motion; its
velocities satisfy the velocity constraints Φ_q v + Φ_t = 0 only to the order of the
method. ``GeneralizedAlpha(velocity_projection=True)`` projects them onto the velocity
constraints after every step in the mass metric, at the cost of one more saddle-point
factorization per step. This study measures, for each model and step h, with and
without the projection:

* the error of the compared output against a converged reference (the same mesh at
  h_ref, projection on; the reference's own on/off difference is reported), and that
  of the multipliers (joint reactions, relative to each one's largest value);
* the drift of the velocity constraints max_t |Φ_q v + Φ_t| [m/s] and of the position
  constraints max_t |Φ| [m] on the output grid;
* the run time (best of ``REPS``, interleaved) and the Newton iterations.

Models: M1 (6 elements, 0–2 s, h from 2.5 ms), M2 (12 elements, the shipped solver
options, 0–1 s), H1 (16 elements, 0–1 s) and the reduced pantograph–catenary of
tests/test_catenary.py (3 spans of 10 m, 0.5 m elements, 250 km/h; compared output:
the 20-Hz filtered contact force over the evaluated span, RMS [N]).

Run from the repository root: ``python -m benchmarks.velocity_projection [--quick]``
(about 10 minutes on the 2-core machine); writes
benchmarks/results/velocity_projection.{json,md}.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import cases as C  # noqa: E402
from benchmarks.common import table, write  # noqa: E402

REPS = 3

#: (model, elements, t_end [s], steps h [s], reference step [s])
CASES = [("M1", 6, 2.0, (2.5e-3, 1.25e-3, 6.25e-4), 1.5625e-4),
         ("M2", 12, 1.0, (2e-3, 1e-3, 5e-4), 1.25e-4),
         ("H1", 16, 1.0, (2e-3, 1e-3, 5e-4), 1.25e-4)]
QUICK = [("M1", 6, 0.5, (2.5e-3, 1.25e-3), 3.125e-4)]


def drift(system, res):
    """(max |Φ_q v + Φ_t| [m/s], max |Φ| [m]) over the output rows."""
    import jax
    import jax.numpy as jnp
    if not system.n_constraints:
        return 0.0, 0.0
    q, v, t = jnp.asarray(res.q), jnp.asarray(res.v), jnp.asarray(res.t)
    dv = jax.vmap(system.constraint_velocity)(q, v, t)
    dq = jax.vmap(system.constraint)(q, t)
    return float(jnp.max(jnp.abs(dv))), float(jnp.max(jnp.abs(dq)))


def multiplier_error(res, ref) -> float:
    """max over the common output rows and the multipliers of |λ − λ_ref| / max_t |λ_ref|
    (per multiplier; those that stay below 1e-9 of the largest are left out)."""
    k, a = C.on_grid(res.t, np.asarray(res.lam))
    kr, b = C.on_grid(ref.t, np.asarray(ref.lam))
    if not b.size:
        return 0.0
    index = {int(v): i for i, v in enumerate(k)}
    a = a[[index[int(v)] for v in kr]]
    scale = np.max(np.abs(b), axis=0)
    keep = scale > 1e-9 * np.max(scale)
    return float(np.max(np.abs(a - b)[:, keep] / scale[keep]))


def model_rows(name, n, t_end, steps, h_ref):
    from ancf_jax.simulation import make_solver, simulate
    system, state = C.model(name, n)
    base = C.ancf_settings(name)

    def run(h, projection):
        solver = make_solver("generalized-alpha", **base, velocity_projection=projection)
        return simulate(system, state, t_end=t_end, dt=h, output_dt=C.GRID, solver=solver,
                        on_failure="return", progress=False)

    ref = run(h_ref, True)
    ref_off = run(h_ref, False)
    y_ref = C.ancf_output(name, ref)
    rows = []
    for h in steps:
        first = {p: run(h, p) for p in (True, False)}
        walls = {p: [] for p in first}
        for _ in range(REPS):
            for p in first:
                walls[p].append(run(h, p).wall_time_s)
        for p, r in first.items():
            dv, dq = drift(system, r)
            rows.append(dict(model=name, elements=n, h=h, projection=p, status=r.status,
                             error=C.error(name, r.t, C.ancf_output(name, r), ref.t, y_ref),
                             multiplier_error=multiplier_error(r, ref),
                             velocity_drift=dv, position_drift=dq, run_s=min(walls[p]),
                             newton_per_step=float(np.sum(r.iterations)) * h / t_end))
        on, off = first[True], first[False]
        rows[-1]["on_off_difference"] = C.error(name, off.t, C.ancf_output(name, off), on.t,
                                                C.ancf_output(name, on))
        rows[-1]["multiplier_on_off"] = multiplier_error(off, on)
        print(rows[-2], rows[-1], sep="\n", flush=True)
    return dict(model=name, elements=n, t_end=t_end, h_ref=h_ref,
                reference_on_off_difference=C.error(name, ref_off.t, C.ancf_output(name, ref_off), ref.t, y_ref),
                reference_velocity_drift_off=drift(system, ref_off)[0], rows=rows)


def catenary_rows(steps=(1e-3, 5e-4), h_ref=1.25e-4):
    from ancf_jax.models.catenary import CatenaryDesign, run_pantograph_catenary
    from ancf_jax.simulation import make_solver
    from benchmarks.pantograph_catenary import RUN

    def run(h, projection):
        t0 = time.perf_counter()
        r = run_pantograph_catenary(CatenaryDesign(element_length=0.5, **RUN), speed_kmh=250, dt=h, output_dt=1e-3,
                                    pad_to=240, spans=(2, 2),
                                    solver=make_solver("generalized-alpha", velocity_projection=projection))
        return r, time.perf_counter() - t0

    ref, _ = run(h_ref, True)
    sel = (ref.x >= ref.window[0]) & (ref.x <= ref.window[1])

    def rms(r):
        return float(np.sqrt(np.mean((r.filtered[sel] - ref.filtered[sel]) ** 2)))

    ref_off, _ = run(h_ref, False)
    rows = []
    for h in steps:
        runs = {p: run(h, p) for p in (True, False)}
        again = {p: run(h, p)[1] for p in (True, False)}  # the program is compiled now
        for p, (r, _) in runs.items():
            rows.append(dict(model="catenary", h=h, projection=p, error_rms_N=rms(r),
                             std_N=r.statistics["std_N"], wall_s=again[p]))
        rows[-1]["on_off_rms_N"] = float(np.sqrt(np.mean((runs[True][0].filtered[sel]
                                                          - runs[False][0].filtered[sel]) ** 2)))
        print(rows[-2], rows[-1], sep="\n", flush=True)
    return dict(model="catenary", h_ref=h_ref, reference_on_off_rms_N=rms(ref_off), rows=rows)


def markdown(data) -> str:
    out = ["# Velocity projection after each generalized-α step\n",
           "Command: `python -m benchmarks.velocity_projection`. Error: max over the 10-ms grid of the "
           "compared output against the same mesh at h_ref (projection on).\n"]
    for m in data["models"]:
        out.append(f"\n## {m['model']}, {m['elements']} elements, 0–{m['t_end']} s (h_ref = {m['h_ref']} s; "
                   f"on/off difference there {m['reference_on_off_difference']:.3g} m)\n")
        out.append(table(["h [s]", "projection", "status", "error [m]", "max \\|Φ_q v + Φ_t\\| [m/s]", "max \\|Φ\\| [m]",
                          "λ error (rel.)", "λ on − off (rel.)", "run [s]", "Newton it./step"],
                         [[r["h"], r["projection"], r["status"], f"{r['error']:.3g}", f"{r['velocity_drift']:.2g}",
                           f"{r['position_drift']:.2g}", f"{r['multiplier_error']:.2g}",
                           f"{r['multiplier_on_off']:.2g}" if "multiplier_on_off" in r else "",
                           f"{r['run_s']:.3g}", f"{r['newton_per_step']:.2f}"]
                          for r in m["rows"]]))
    c = data.get("catenary")
    if c:
        out.append(f"\n## reduced pantograph–catenary (contact force RMS error [N] against h_ref = {c['h_ref']} s; "
                   f"on/off difference there {c['reference_on_off_rms_N']:.3g} N)\n")
        out.append(table(["h [s]", "projection", "RMS error [N]", "σ [N]", "wall [s]"],
                         [[r["h"], r["projection"], f"{r['error_rms_N']:.3g}", f"{r['std_N']:.4g}",
                           f"{r['wall_s']:.3g}"] for r in c["rows"]]))
    return "".join(out)


def main(argv=None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    quick = "--quick" in argv
    data = dict(models=[model_rows(*c) for c in (QUICK if quick else CASES)])
    if not quick:
        data["catenary"] = catenary_rows()
    write("velocity_projection" + ("_quick" if quick else ""), data, markdown(data))
    print(markdown(data))


if __name__ == "__main__":
    main()
