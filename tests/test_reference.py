"""The solver core reproduces the committed reference trajectories (issue 16).

``tests/reference/*.npz`` were made by ``python -m tests.reference.make_reference`` with
the code before the solver-core rewrite (commit stored in each file): M1, M2 and the
flexible pendulum (H1) over 0–0.5 s at their shipped default settings of then
(``make_reference.FORMER_DEFAULTS`` restores those that have changed since). Any change of
the step, the Newton matrix or the linear solvers must reproduce them to 1e-9 m (the
Newton tolerance is 1e-10 on the correction; a different but convergent iteration
matrix changes the iterates at that level only).

The same runs keep the drift bounds stated before the velocity projection became off by
default (``tests/models/test_m2.py`` states the unprojected ones): with it,
max|Φ| < 1e-10 m and max|Φ̇| < 1e-12 m/s (measured ≤ 4e-15 m/s for all three; without
it M2 at 24 elements reaches 5.8e-4 m/s over 0–0.5 s).
"""

from pathlib import Path

import numpy as np
import pytest

from tests.reference.make_reference import MODELS, reference_scenario

HERE = Path(__file__).parent / "reference"


@pytest.mark.parametrize("name", MODELS)
def test_reproduces_reference_trajectory(name):
    ref = np.load(HERE / f"{name}.npz")
    res = reference_scenario(name).simulate(progress=False)
    assert res.status == "ok"
    np.testing.assert_allclose(res.t, ref["t"], rtol=0, atol=1e-12)
    assert res.q.shape == ref["q"].shape
    # positions (m; slopes are dimensionless and of order one) to 1e-9
    np.testing.assert_allclose(res.q, ref["q"], rtol=0, atol=1e-9)
    pos, vel = res.constraint_violation()
    assert pos.max() < 1e-10 and vel.max() < 1e-12, (pos.max(), vel.max())
