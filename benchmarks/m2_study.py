"""Mesh and step study of model M2 (issue 5): the paper's conclusion in numbers.

Element counts 12, 18, 24, 36, 48 run as ONE vmapped batch (padded to 48) at the
reference step; 24 elements also at halved steps and with ρ∞ = 0.9. Reported: the
maximum distance of the point-1 trajectory to the finest mesh (whole run and up to
1.3 s, the paper's "largest deformable area"), the final arc length, and the step
convergence at 24 elements.

    python -m benchmarks.m2_study [--quick]

Writes benchmarks/results/m2_study.{json,md}.
"""

from __future__ import annotations

import argparse

import numpy as np

from ancf_jax.models.m2 import OUTPUTS, RUN, m2_initial
from ancf_jax.outputs import evaluate
from ancf_jax.simulation import make_solver, simulate, simulate_batch

from .common import table, write


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="1 s instead of 3 s; 12/24/36 elements")
    args = ap.parse_args(argv)
    t_end = 1.0 if args.quick else 3.0
    counts = (12, 24, 36) if args.quick else (12, 18, 24, 36, 48)
    dt_ref = 5e-4
    opts = dict(RUN["solver_options"])
    kw = dict(t_end=t_end, output_dt=1e-2, progress=False, on_failure="return")
    built = [m2_initial(n, pad_to=max(counts)) for n in counts]
    runs = simulate_batch([b[0] for b in built], [b[1] for b in built], dt=dt_ref,
                          solver=make_solver("generalized-alpha", **opts), **kw)
    cols = {n: evaluate(r, OUTPUTS) for n, r in zip(counts, runs)}
    print(f"mesh batch {counts}: {runs[0].info['batch_wall_time_s']:.1f} s "
          f"(compile {runs[0].compile_time_s:.1f} s)", flush=True)
    ref = cols[max(counts)]
    t = ref["t"]
    mesh_rows, mesh_rec = [], []
    for n in counts[:-1]:
        d = np.hypot(cols[n]["point1_x"] - ref["point1_x"], cols[n]["point1_y"] - ref["point1_y"])
        rec = dict(elements=n, max_distance_m=float(d.max()), max_distance_to_1_3s_m=float(d[t <= 1.3].max()),
                   s_final_m=float(cols[n]["s"][-1]), status=runs[counts.index(n)].status)
        mesh_rec.append(rec)
        mesh_rows.append([n, f"{rec['max_distance_m'] * 1e3:.2f}", f"{rec['max_distance_to_1_3s_m'] * 1e3:.2f}",
                          f"{rec['s_final_m']:.4f}"])
    mesh_rows.append([max(counts), "(reference)", "", f"{ref['s'][-1]:.4f}"])
    pairs = {}
    for a, b in ((12, 24), (18, 24), (12, 18)):
        if a in cols and b in cols:
            d = np.hypot(cols[a]["point1_x"] - cols[b]["point1_x"], cols[a]["point1_y"] - cols[b]["point1_y"])
            pairs[f"{a}_vs_{b}"] = float(d.max())
    # step study at 24 elements
    system, state, _ = m2_initial(24)
    steps = {}
    for dt, rho in ((1e-3, opts["rho_inf"]), (5e-4, opts["rho_inf"]), (2.5e-4, opts["rho_inf"]), (2.5e-4, 0.9)):
        r = simulate(system, state, dt=dt, solver=make_solver("generalized-alpha", **{**opts, "rho_inf": rho}), **kw)
        steps[(dt, rho)] = evaluate(r, OUTPUTS)
        print(f"24 elements, dt = {dt:g} s, rho_inf = {rho}: {r.status}, run {r.wall_time_s:.1f} s", flush=True)
    sref = steps[(2.5e-4, 0.9)]
    step_rows, step_rec = [], []
    for (dt, rho), c in steps.items():
        if (dt, rho) == (2.5e-4, 0.9):
            continue
        d = np.hypot(c["point1_x"] - sref["point1_x"], c["point1_y"] - sref["point1_y"])
        step_rec.append(dict(dt=dt, rho_inf=rho, max_distance_m=float(d.max())))
        step_rows.append([f"{dt:g}", rho, f"{d.max() * 1e3:.3f}"])
    md = (f"Model M2 (24-element default, generalized-alpha), t in [0, {t_end:g}] s.\n\n"
          f"Mesh study at dt = {dt_ref:g} s, rho_inf = {opts['rho_inf']}: distance of the point-1 "
          f"trajectory to {max(counts)} elements.\n\n"
          + table(["elements", "max distance [mm]", "max distance, t <= 1.3 s [mm]", "s(t_end) [m]"], mesh_rows)
          + "\nPairwise maximum distances: "
          + ", ".join(f"{k.replace('_vs_', ' vs ')}: {v * 1e3:.2f} mm" for k, v in pairs.items())
          + f"\n\nStep study, 24 elements: distance to dt = 2.5e-4 s, rho_inf = 0.9.\n\n"
          + table(["dt [s]", "rho_inf", "max distance [mm]"], step_rows))
    path = write("m2_study" + ("_quick" if args.quick else ""),
                 dict(t_end=t_end, counts=counts, dt_reference=dt_ref, mesh=mesh_rec, pairs=pairs,
                      steps=step_rec), md)
    print(md)
    print(f"written {path}")


if __name__ == "__main__":
    main()
