"""RK4 convergence across node crossings of a sliding joint, with and without
``simulate(..., options=RunOptions(locate_crossings=True))``.

A body slides without friction on a clamped circular track (radius 1 m, 8 elements
with angles alternating 0.2/0.4 rad, so the curvature of the cubic interpolation
jumps at every node), released 0.85 rad from the bottom, for 1.2 s (7 crossings).
The sliding coordinate is compared with the motion on the same curve computed by
SciPy with the crossings as events (tests/dynamics.py: curve_motion).

Run from the repository root: ``python -m benchmarks.locate_crossings``; writes
benchmarks/results/locate_crossings.{json,md}. Expect a few minutes.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ancf_jax.integrate import RunOptions  # noqa: E402
from ancf_jax.simulation import simulate  # noqa: E402
from tests.dynamics import curve_motion, track_model, uneven_arc  # noqa: E402

from .common import table, write  # noqa: E402

S0, T_END = 0.35, 1.2
STEPS = (0.02, 0.01, 0.005, 0.0025, 0.00125)


def main() -> None:
    track = uneven_arc(8, 1.0, 1.2)
    n = int(track.n_elements)
    nodes, lengths = np.asarray(track.reference_nodes)[: n + 1], np.asarray(track.element_lengths)[:n]
    system, state = track_model(track, S0).build()
    errors = {False: [], True: []}
    for h in STEPS:
        for locate in (False, True):
            res = simulate(system, state, t_end=T_END, dt=h, solver="rk4",
                           options=RunOptions(locate_crossings=locate), progress=False)
            ref, _ = curve_motion(nodes, lengths, S0, 0.0, res.t)
            errors[locate].append(float(np.max(np.abs(res.sliding("slider") - ref[:, 0]))))
        print(f"h = {h:g} s: plain {errors[False][-1]:.3e}, located {errors[True][-1]:.3e}", flush=True)

    def orders(e):
        return [None] + [float(np.log2(a / b)) for a, b in zip(e[:-1], e[1:])]

    o_plain, o_loc = orders(errors[False]), orders(errors[True])
    fmt = lambda o: "" if o is None else f"{o:.2f}"  # noqa: E731
    rows = [[f"{h:g}", f"{ep:.3e}", fmt(op), f"{el:.3e}", fmt(ol)]
            for h, ep, op, el, ol in zip(STEPS, errors[False], o_plain, errors[True], o_loc)]
    md = (f"RK4 on a clamped circular track (8 elements, uneven), released at s0 = {S0} m, "
          f"t in [0, {T_END}] s: maximum error of the sliding coordinate against the motion "
          "on the same curve with the crossings as events (SciPy).\n\n"
          + table(["h [s]", "error, plain [m]", "order", "error, crossings located [m]", "order"], rows))
    path = write("locate_crossings", dict(steps=list(STEPS), error_plain_m=errors[False],
                                          error_located_m=errors[True], order_plain=o_plain,
                                          order_located=o_loc), md)
    print(md)
    print(f"written {path}")


if __name__ == "__main__":
    main()
