"""RK4 convergence across node crossings of a sliding joint, with and without
``simulate(..., locate_crossings=True)``.

A body slides without friction on a clamped circular track (radius 1 m, 8 elements
with angles alternating 0.2/0.4 rad, so the curvature of the cubic interpolation
jumps at every node), released 0.85 rad from the bottom, for 1.2 s (7 crossings).
The sliding coordinate is compared with the motion on the same curve computed by
SciPy with the crossings as events (tests/dynamics.py: curve_motion).

Run from the repository root: ``python benchmarks/locate_crossings.py``. Each step
size compiles once (simulate treats the step as static); expect a few minutes.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ancf_jax.simulation import simulate  # noqa: E402
from tests.dynamics import curve_motion, track_model, uneven_arc  # noqa: E402

S0, T_END = 0.35, 1.2
STEPS = (0.02, 0.01, 0.005, 0.0025, 0.00125)


def main() -> None:
    track = uneven_arc(8, 1.0, 1.2)
    n = int(track.n_elements)
    nodes, lengths = np.asarray(track.reference_nodes)[: n + 1], np.asarray(track.element_lengths)[:n]
    system, state = track_model(track, S0).build()
    print(f"{'h [s]':>8} {'error (plain)':>14} {'order':>6} {'error (located)':>16} {'order':>6}")
    last = {}
    for h in STEPS:
        row = [f"{h:8.5f}"]
        for locate in (False, True):
            res = simulate(system, state, t_end=T_END, dt=h, solver="rk4", locate_crossings=locate,
                           progress=False)
            ref, _ = curve_motion(nodes, lengths, S0, 0.0, res.t)
            err = float(np.max(np.abs(res.sliding("slider") - ref[:, 0])))
            order = f"{np.log2(last[locate] / err):6.2f}" if locate in last else " " * 6
            last[locate] = err
            row += [f"{err:14.3e}" if not locate else f"{err:16.3e}", order]
        print(" ".join(row), flush=True)


if __name__ == "__main__":
    main()
