"""Effect of located contact events on a mass bouncing on a penalty contact
(issue 20), with and without ``locate_crossings``.

The model and closed form are those of tests/test_moving_loads.py: a 1 kg point mass
hits a rigid track at 1 m/s through a contact k = 1e4 N/m (ζ = 0 and 0.1, no gravity);
contact time and restitution against the closed form of a mass on a spring-damper that
cannot pull, with generalized-α at h = 1, 0.5, 0.25, 0.125 ms (step retries on).

Run from the repository root: ``python -m benchmarks.contact_events``; writes
benchmarks/results/contact_events.{json,md}. Expect about a minute.
"""

from __future__ import annotations

import sys
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ancf_jax.integrate import RunOptions  # noqa: E402
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha  # noqa: E402
from tests.dynamics import run_fixed  # noqa: E402
from tests.test_moving_loads import K_C, M_BALL, T_BOUNCE, bounce_errors, bounce_model  # noqa: E402

from .common import table, write  # noqa: E402

STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4)


def main() -> None:
    system, state = bounce_model()
    rows, data = [], []
    for zeta in (0.0, 0.1):
        sys_ = eqx.tree_at(lambda s: s.forces[0].damping, system,
                           jnp.asarray(2 * zeta * np.sqrt(K_C * M_BALL), float))
        for h in STEPS:
            row = {"zeta": zeta, "h": h}
            for locate in (False, True):
                run = run_fixed(sys_, state, GeneralizedAlpha().forward_only(), h, T_BOUNCE, chunk=60,
                                options=RunOptions(locate_crossings=locate))
                t_err, e_err = bounce_errors(run, zeta)
                row["located" if locate else "plain"] = dict(contact_time_error_s=float(t_err),
                                                              restitution_error=float(e_err))
            data.append(row)
            rows.append([f"{zeta:g}", f"{h:g}", f"{row['plain']['contact_time_error_s']:.2e}",
                         f"{row['located']['contact_time_error_s']:.2e}",
                         f"{row['plain']['restitution_error']:.2e}", f"{row['located']['restitution_error']:.2e}"])
            print(rows[-1], flush=True)
    md = ("A point mass bouncing on a penalty contact (k = 1e4 N/m, 1 kg, 1 m/s): errors against "
          "the closed form, generalized-α, events located or not.\n\n"
          + table(["ζ", "h [s]", "contact time, plain [s]", "contact time, located [s]",
                   "restitution, plain", "restitution, located"], rows))
    path = write("contact_events", dict(runs=data), md)
    print(md)
    print(f"written {path}")


if __name__ == "__main__":
    main()
