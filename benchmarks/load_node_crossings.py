"""Effect on accuracy of locating the node crossings of moving loads and contact
points (``RunOptions(locate_load_nodes=True)``, issue 20), against a run at a 16 times
finer step on the same mesh (so that only the time discretization is compared).

Cases (generalized-α, ρ∞ = 0.9 default, fixed steps h = 0.4, 0.2, 0.1 ms):

* ``force``: a force entering the pinned taut string of tests/test_moving_loads.py
  (8 elements, T = 100.15 N, c = 10.0 m/s) at x = −0.0123 m and crossing it at 0.5c
  (7 node crossings; entry and exit are no crossings); error: max |y| of the nodes against the
  reference, relative to the reference's max |y|.
* ``contact``: the current collector of tests/test_moving_loads.py (0.1 kg, 1 N uplift,
  k = 1e3 N/m, c = 1 N·s/m) pressed against that string (8 elements) and moving at
  2 m/s for 0.2 s (3 crossings, contact closed throughout); error: max |F_n| against
  the reference, relative to its max.
* ``exit``: a force of 1 N leaving the free end of a cantilever (4 elements, EI = 1e-2
  N·m², 1 kg/m) from its middle at 8.09 m/s, along its arc length (1 node crossing;
  the exit at t = 0.061831 s, a jump of the force between the steps of every run, is
  not located: with the ends counted as crossings, commit 27c14e9, located runs were
  1.2 to 2.6 times less accurate, docs/moving-loads.md); error: max |y_tip| against
  the reference, relative to its max.
* ``mass``: contrast, a 0.3 kg moving mass on the string at 0.5c along x (gravity on
  it): its node crossings are sliding-joint crossings, located by ``locate_crossings``
  (6 crossings); error: max |y| of the nodes.

"plain" runs locate nothing; "located" runs locate the case's crossings (the mass:
``locate_crossings``; the others: ``locate_load_nodes``). Each located crossing costs
``crossing_iterations`` + 1 = 7 extra implicit steps.

Run from the repository root: ``python -m benchmarks.load_node_crossings``; writes
benchmarks/results/load_node_crossings.{json,md}. Expect three minutes.
"""

from __future__ import annotations

import sys
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ancf_jax import mesh  # noqa: E402
from ancf_jax.functions import ConstantSpeed  # noqa: E402
from ancf_jax.integrate import RunOptions  # noqa: E402
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha  # noqa: E402
from ancf_jax.model import Model, node  # noqa: E402
from ancf_jax.section import Section  # noqa: E402
from tests.dynamics import run_fixed  # noqa: E402
from tests.test_moving_loads import C, EA, EPS0, L, P, RHOA, pantograph_model  # noqa: E402

from .common import table, write  # noqa: E402

STEPS = (4e-4, 2e-4, 1e-4)
FINE = 16


def string(n: int, gravity: float = 0.0) -> Model:
    m = Model(gravity=(0.0, -gravity))
    track = mesh.straight((0.0, 0.0), (1.0, 0.0), L, n)
    nodes = np.asarray(track.reference_nodes).copy()
    nodes[:, 0] *= 1 + EPS0
    nodes[:, 2] = 1 + EPS0
    m.add_beam("string", track, Section(1e9, EA / 1e9, 1e-15, RHOA), initial_nodes=nodes, gravity=False)
    m.pin("a", node("string", 0))
    m.pin("b", node("string", -1))
    return m


def cases():
    """{name: (system, state, t_end, located options, error function(run, ref, stride))}."""
    out = {}
    n = 8
    beam_y = slice(1, 4 * (n + 1), 4)

    def nodes_error(run, ref, k):
        y, yr = run.q[:, beam_y], ref.q[::k, beam_y]
        return np.max(np.abs(y - yr)) / np.max(np.abs(yr))

    m = string(n)
    m.moving_force("P", "string", (0.0, -P), path=ConstantSpeed(-0.0123, 0.5 * C))
    out["force"] = (*m.build(), 0.24, RunOptions(locate_load_nodes=True), nodes_error)

    system, state = pantograph_model()
    kp = next(i for i, c in enumerate(system.constraints) if c.name == "collector.1.x")
    kc = next(i for i, f in enumerate(system.forces) if f.name == "contact")
    system = eqx.tree_at(lambda s: s.constraints[kp].path.speed, system, jnp.asarray(2.0))
    normal = jax.jit(jax.vmap(lambda q, v: system.forces[kc].normal_force(system, q, v)))

    def force_error(run, ref, k):
        f, fr = np.asarray(normal(run.q, run.v)), np.asarray(normal(ref.q[::k], ref.v[::k]))
        return np.max(np.abs(f - fr)) / np.max(np.abs(fr))

    out["contact"] = (system, state, 0.2, RunOptions(locate_load_nodes=True), force_error)

    m = Model(gravity=(0.0, 0.0))
    m.add_beam("board", mesh.straight((0.0, 0.0), (1.0, 0.0), 1.0, 4), Section(1e7, 1e-3, 1e-9, 1.0))
    m.clamp("c", "board", 0)
    m.moving_force("P", "board", (0.0, -1.0), path=ConstantSpeed(0.5, 0.5 / 0.061831), along="arc_length")

    def tip_error(run, ref, k):
        y, yr = run.q[:, 4 * 4 + 1], ref.q[::k, 4 * 4 + 1]
        return np.max(np.abs(y - yr)) / np.max(np.abs(yr))

    out["exit"] = (*m.build(), 0.1, RunOptions(locate_load_nodes=True), tip_error)

    m = string(n, gravity=9.81)
    m.moving_mass("M", "string", mass=0.3, path=ConstantSpeed(0.01, 0.5 * C))
    out["mass"] = (*m.build(), 0.16, RunOptions(locate_crossings=True), nodes_error)
    return out


def main() -> None:
    rows, data = [], []
    solver = GeneralizedAlpha().forward_only()
    for name, (system, state, t_end, located, error) in cases().items():
        h_ref = STEPS[-1] / FINE
        ref = run_fixed(system, state, solver, h_ref, t_end, options=located)
        assert ref.status == 0
        for h in STEPS:
            row = {"case": name, "h": h}
            for label, options in (("plain", RunOptions()), ("located", located)):
                run = run_fixed(system, state, solver, h, t_end, options=options)
                assert run.status == 0
                row[label] = float(error(run, ref, int(round(h / h_ref))))
                row[f"{label}_crossings"] = int(run.crossings.sum())
            data.append(row)
            rows.append([name, f"{h:g}", f"{row['plain']:.3e}", f"{row['located']:.3e}",
                         f"{row['located'] / row['plain']:.3f}", str(row["located_crossings"])])
            print(rows[-1], flush=True)
    md = ("Time-discretization error against a 16× finer step on the same mesh, generalized-α, "
          "node crossings located or not (benchmarks/load_node_crossings.py docstring).\n\n"
          + table(["case", "h [s]", "error, plain", "error, located", "located / plain", "crossings"], rows))
    path = write("load_node_crossings", dict(runs=data), md)
    print(md)
    print(f"written {path}")


if __name__ == "__main__":
    main()
