"""Control-flow helpers of the solver internals (ancf_jax._control): reached_by."""

import jax
import jax.numpy as jnp
import numpy as np

from ancf_jax._control import reached_by


def _loop(mark):
    """a ↦ x after three steps of x ← sin(x) + a·y, y ← y (a scan)."""

    def run(a):
        init = (jnp.zeros(()), jnp.ones(()))  # independent of a, as a model's q0 of its damping
        if mark:
            init = reached_by(init, a)

        def body(c, _):
            x, y = c
            return (jnp.sin(x) + a * y, y), None

        return jax.lax.scan(body, init, None, length=3)[0][0]

    return run


def test_reached_by_ends_the_fixpoint_at_the_first_pass_with_the_same_numbers(monkeypatch):
    """Under jvp, the carry x (zero tangent at the start, non-zero after a step) costs
    JAX's fixpoint a pass (counted: JAX's jvp of the body's jaxpr, which the scan's
    rule calls once per pass); marked, one pass. Values, derivatives (against the
    closed form of the three steps) and batches are the same."""
    from jax._src.interpreters import ad
    calls = []
    jvp_jaxpr = ad.jvp_jaxpr

    def counted(jaxpr, *args, **kwargs):
        if any(e.primitive.name == "sin" for e in jaxpr.jaxpr.eqns):  # the scan's body
            calls.append(1)
        return jvp_jaxpr(jaxpr, *args, **kwargs)

    monkeypatch.setattr(ad, "jvp_jaxpr", counted)
    counts = {}
    for mark in (False, True):
        run = _loop(mark)
        calls.clear()
        value, slope = jax.jvp(run, (0.3,), (1.0,))
        counts[mark] = len(calls)
        x1 = 0.3
        x2 = np.sin(x1) + 0.3
        x3 = np.sin(x2) + 0.3
        d2 = np.cos(x1) + 1.0
        d3 = np.cos(x2) * d2 + 1.0
        np.testing.assert_allclose(value, x3, rtol=1e-15)
        np.testing.assert_allclose(slope, d3, rtol=1e-14)
        batch = jax.vmap(run)(jnp.array([0.3, 0.5]))
        np.testing.assert_array_equal(batch, [run(0.3), run(0.5)])
    assert counts == {False: 2, True: 1}, counts


def test_reached_by_gives_batch_axes_and_no_tangent_when_asked():
    """vmap: a constant marked by a batched input comes out batched (that is the
    mark); ``tangents=False``: no derivative flows; eagerly, the tree itself."""
    out = jax.vmap(lambda a: reached_by({"z": jnp.zeros(3), "k": jnp.zeros((), jnp.int32)}, a))(jnp.ones(2))
    assert out["z"].shape == (2, 3) and out["k"].shape == (2,) and out["k"].dtype == jnp.int32
    assert not np.any(out["z"])
    g = jax.grad(lambda a: jnp.sum(reached_by(jnp.ones(2), a, tangents=False) * a))(2.0)
    assert g == 2.0  # d(a·(1 + 1))/da, nothing through the mark
    tree = (jnp.ones(2),)
    assert reached_by(tree, jnp.ones(3)) is tree
