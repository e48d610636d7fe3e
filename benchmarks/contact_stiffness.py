"""Effect of a contact's stiffness on its force, about the default stiffness
(``Model.contact`` without ``stiffness``: 100 times the beam's static stiffness where the
point touches it, docs/moving-loads.md "Contact stiffness").

The one-mass current collector of tests/test_moving_loads.py (``pantograph_model``:
0.1 kg head pushed up by 1 N against the taut string, T = 100 N, 8 elements, contact
damping 1 N·s/m) running from x = 0.2 m at 2 m/s for 0.2 s, generalized-α at h = 0.1 ms,
with k = f × default, f = 0.1, 1, 10, 100, each starting in static contact (penetration
1 N / k). Reported: mean and standard deviation of the normal force, whether contact
was lost, the largest penetration, and the standard deviation's difference from the
stiffest run's (the rigid-contact limit).

Run from the repository root: ``python -m benchmarks.contact_stiffness``; writes
benchmarks/results/contact_stiffness.{json,md}. Expect a few minutes of CPU.
"""

from __future__ import annotations

import sys
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ancf_jax.functions import ConstantSpeed  # noqa: E402
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha  # noqa: E402
from ancf_jax.model import CONTACT_STIFFNESS_FACTOR, body_point  # noqa: E402
from tests.dynamics import run_fixed  # noqa: E402
from tests.test_moving_loads import taut_string  # noqa: E402

from .common import table, write  # noqa: E402

FACTORS = (0.1, 1.0, 10.0, 100.0)


def main() -> None:
    m = taut_string(8, 1e-6)
    head = m.lumped_chain("collector", base=(0.2, -0.5), heights=[0.501], masses=[0.1], stiffness=[0.0],
                          forces=[1.0], path=ConstantSpeed(0.2, 2.0))[0]
    m.contact("contact", body_point(head), "string", damping=1.0, side=-1)
    system, state = m.build()
    kc = next(i for i, f in enumerate(system.forces) if f.name == "contact")
    default = float(system.forces[kc].stiffness)
    y_head = system.body_offset(system.body_names.index(head)) + 1
    forces, data = {}, []
    for f in FACTORS:
        sys_ = eqx.tree_at(lambda s: s.forces[kc].stiffness, system, jnp.asarray(f * default))
        start = eqx.tree_at(lambda s: s.q, state, state.q.at[y_head].set(1.0 / (f * default)))
        run = run_fixed(sys_, start, GeneralizedAlpha().forward_only(), 1e-4, 0.2)
        assert run.status == 0
        contact = sys_.forces[kc]
        normal = jax.jit(jax.vmap(lambda q, v: contact.normal_force(sys_, q, v)))
        gap = jax.jit(jax.vmap(lambda q: contact.gap(sys_, q)))
        forces[f] = np.asarray(normal(run.q, run.v))
        data.append(dict(factor=f, stiffness=f * default, mean_force=float(forces[f].mean()),
                         std_force=float(forces[f].std()), lost_contact=bool(forces[f].min() == 0.0),
                         max_penetration=float(-np.asarray(gap(run.q)).min())))
        print(data[-1], flush=True)
    stiffest = forces[FACTORS[-1]].std()
    rows = []
    for row in data:
        row["std_vs_stiffest"] = row["std_force"] / stiffest - 1
        rows.append([f"{row['factor']:g}", f"{row['stiffness']:.4g}", f"{row['mean_force']:.5f}",
                     f"{row['std_force']:.4f}", f"{row['std_vs_stiffest']:+.2%}", "yes" if row["lost_contact"] else "no",
                     f"{row['max_penetration']:.2e}"])
    md = (f"Collector (0.1 kg, 1 N) on the taut string at 2 m/s, 0.2 s: contact stiffness k = f × default "
          f"({CONTACT_STIFFNESS_FACTOR:g} k_b = {default:.4g} N/m).\n\n"
          + table(["f", "k [N/m]", "mean F_n [N]", "std F_n [N]", "std vs f = 100", "contact lost",
                   "max penetration [m]"], rows))
    path = write("contact_stiffness", dict(default_stiffness=default, runs=data), md)
    print(md)
    print(f"written {path}")


if __name__ == "__main__":
    main()
