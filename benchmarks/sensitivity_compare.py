"""Sobol indices against local (gradient) sensitivities on the same M1 box.

The sweep of docs/sweeps.md: M1, Rayleigh α ∈ [0.01, 0.1] 1/s and tip mass ∈
[0.015, 0.025] kg, Saltelli design with N base samples (N (d + 2) members), output
min(tip_y) over the run. From the same members: the Sobol indices (S1, ST; SALib) and
the gradients ∂y/∂x_i at every member (``local_sensitivities``, one vmapped forward-mode
program). The derivative-based global sensitivity measure ν_i = E[(∂y/∂x_i)²] bounds
the total index of a uniform input on [a_i, b_i] (Sobol & Kucherenko 2009, Theorem 3):

    ST_i ≤ (b_i − a_i)² ν_i / (π² D),     D = Var(y),

and the local sensitivity at the box centre gives the ranking a one-point study would.
Writes benchmarks/results/sensitivity_compare.json and .md, and the bar chart of the
Sobol indices (``sobol_figure``) that docs/sweeps.md shows, docs/img/sweep_sobol_m1.png
(``--figure``: only the chart, redrawn from the JSON of the last run).

    python -m benchmarks.sensitivity_compare [--quick]    # quick: N = 8, 0.5 s
    python -m benchmarks.sensitivity_compare --figure     # the chart from the results
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from .common import RESULTS, table, write

KEYS = {"beams.beam.alpha": (0.01, 0.1), "bodies.tip.mass": (0.015, 0.025)}
FIGURE = Path(__file__).resolve().parents[1] / "docs" / "img" / "sweep_sobol_m1.png"


def figure(data: dict) -> Path:
    """The Sobol indices of a run's results (the JSON's fields) as docs/img's bar chart."""
    from ancf_jax.sweep.sensitivity import sobol_figure
    indices = {k: {f: v[f] for f in ("S1", "S1_conf", "ST", "ST_conf")} for k, v in data["keys"].items()}
    sobol_figure(indices, FIGURE, title=f"M1: min tip_y over {data['t_end']:g} s\n"
                                        f"Saltelli N = {data['n']} ({data['members']} members)")
    return FIGURE


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--figure", action="store_true", help="only redraw the figure from the last results")
    args = ap.parse_args(argv)
    if args.figure:
        print(figure(json.loads((RESULTS / "sensitivity_compare.json").read_text())))
        return
    n, t_end = (8, 0.5) if args.quick else (32, 2.0)
    from ancf_jax.sweep import run_sweep
    from ancf_jax.sweep.sensitivity import local_sensitivities, scalar, sobol_indices
    overrides = [f"solver.t_end={t_end}"]
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        ds = run_sweep("m1", [f"{k}={a}:{b}" for k, (a, b) in KEYS.items()], design="saltelli", samples=n,
                       overrides=overrides, progress=False, out=Path(tmp) / "s.zarr").load()
        sweep_s = time.perf_counter() - t0
    y = scalar(ds, "tip_y", "min")
    sob = sobol_indices(ds, "tip_y", "min")
    points = np.column_stack([np.asarray(ds[k].values, float) for k in KEYS])
    t0 = time.perf_counter()
    loc = local_sensitivities("m1", list(KEYS), points, "tip_y", "min", overrides=overrides)
    local_s = time.perf_counter() - t0
    centre = np.array([[0.5 * (a + b) for a, b in KEYS.values()]])
    mid = local_sensitivities("m1", list(KEYS), centre, "tip_y", "min", overrides=overrides)
    d = float(np.var(y))
    rows, data = [], {}
    for k, (a, b) in KEYS.items():
        nu = float(np.mean(loc["gradients"][k] ** 2))
        bound = (b - a) ** 2 * nu / (np.pi**2 * d)
        data[k] = dict(S1=sob[k]["S1"], S1_conf=sob[k]["S1_conf"], ST=sob[k]["ST"], ST_conf=sob[k]["ST_conf"],
                       dgsm_nu=nu, ST_bound=bound, gradient_at_centre=float(mid["gradients"][k][0]),
                       normalized_at_centre=float(mid["normalized"][k][0]),
                       gradient_times_range_at_centre=float(mid["gradients"][k][0] * (b - a)))
        rows.append([k, f"{sob[k]['S1']:.3f} ± {sob[k]['S1_conf']:.3f}", f"{sob[k]['ST']:.3f} ± {sob[k]['ST_conf']:.3f}",
                     f"{bound:.3f}", f"{data[k]['gradient_at_centre']:.4g}",
                     f"{data[k]['gradient_times_range_at_centre'] * 1e3:.3f}"])
    md = (f"M1, min tip_y over {t_end} s, Saltelli N = {n} ({len(y)} members), Var(y) = {d:.3e} m²; "
          f"sweep {sweep_s:.0f} s, gradients at every member {local_s:.0f} s (one vmapped jacfwd).\n\n"
          + table(["key", "S1", "ST", "DGSM bound on ST", "∂y/∂x at the centre", "∂y/∂x · (b − a) [mm]"], rows)
          + "\n\n_Command: `python -m benchmarks.sensitivity_compare" + (" --quick" if args.quick else "")
          + "`._\n")
    print(md)
    results = dict(quick=args.quick, n=n, t_end=t_end, members=len(y), variance=d, sweep_s=sweep_s,
                   local_s=local_s, keys=data)
    write("sensitivity_compare", results, md)
    if not args.quick:  # the docs show the full run
        figure(results)


if __name__ == "__main__":
    main()
