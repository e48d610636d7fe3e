"""Reference trajectories of the solver core (issue 16), made with the code as it was
before the solver-core rewrite and committed, so that any later change of the step,
the Newton matrix or the linear solvers is checked against them
(``tests/test_reference.py``, to 1e-9 m).

Run from the repository root::

    python -m tests.reference.make_reference

Each file holds the shipped scenario over 0–0.5 s at its own default settings
(solver, step, output interval): ``t``, ``q``, ``v``, ``lam`` at the output times,
and the git commit that made it.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

from ancf_jax.scenario import load_scenario

HERE = Path(__file__).parent
MODELS = ("m1", "m2", "flexible_pendulum")
T_END = 0.5


#: settings the references were made with that are no longer the defaults: the velocity
#: projection of generalized-α (off by default since 2026-12-04; without it M2 moves by
#: 1.6e-7 m over 0–0.5 s, M1 and H1 by under 1e-9 m; benchmarks/velocity_projection.py
#: measures the effect against converged references)
FORMER_DEFAULTS = ("solver.generalized_alpha.velocity_projection=true",)


def reference_scenario(name: str):
    """The shipped scenario ``name`` over 0–T_END s, everything else as shipped, at the
    settings the references were made with (:data:`FORMER_DEFAULTS`)."""
    return load_scenario(name, [f"solver.t_end={T_END!r}", *FORMER_DEFAULTS])


def main():
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                            cwd=HERE).stdout.strip()
    for name in MODELS:
        res = reference_scenario(name).simulate(progress=False)
        assert res.status == "ok", (name, res.status)
        np.savez_compressed(HERE / f"{name}.npz", t=res.t, q=res.q, v=res.v, lam=res.lam,
                            commit=np.array(commit))
        print(name, res.q.shape, res.summary() if hasattr(res, "summary") else "")


if __name__ == "__main__":
    main()
