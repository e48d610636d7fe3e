"""Small products written as dot or as multiply-and-sum by the enclosing batch
(ancf_jax._products): same values either way, and the choice reaches traced_once."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax import _products
from ancf_jax._control import traced_once


@pytest.mark.parametrize("size, sums", [(1, True), (_products.SMALL_BATCH, True), (_products.SMALL_BATCH + 1, False)])
def test_products_match_matmul_in_both_forms(size, sums):
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(5, 3, 4)), rng.normal(size=(5, 4, 2))
    m, x, y = rng.normal(size=(3, 4)), rng.normal(size=4), rng.normal(size=4)
    with _products.batch(size):
        assert _products.as_sums() is sums
        np.testing.assert_allclose(_products.matmul(a, b), a @ b, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(_products.matvec(a, b[..., 0]), (a @ b[..., :1])[..., 0], rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(_products.dot(m, x), m @ x, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(_products.dot(x, m.T), x @ m.T, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(_products.dot(x, y), x @ y, rtol=1e-14)
        np.testing.assert_allclose(_products.dot(m, b[0]), m @ b[0], rtol=1e-14, atol=1e-14)
        jaxpr = str(jax.make_jaxpr(lambda p, q: _products.matmul(p, q))(a, b))
    assert ("dot_general" in jaxpr) is not sums


def test_batches_nest_and_reset():
    assert _products.as_sums()
    with _products.batch(8):
        with _products.batch(4):
            assert _products.as_sums() is (32 <= _products.SMALL_BATCH)
            with _products.batch(2):
                assert not _products.as_sums()
        assert _products.as_sums()
    assert _products.as_sums()


class _Holder(eqx.Module):
    w: jnp.ndarray

    @traced_once
    def apply(self, x):
        return _products.matvec(self.w, x)


def test_traced_once_keys_on_the_form():
    """A traced_once method traced in a small batch and then in a large one is traced
    again (its cached jaxpr would otherwise keep the first form)."""
    h = _Holder(jnp.ones((3, 4)))
    small = str(jax.make_jaxpr(h.apply)(jnp.ones(4)))
    with _products.batch(10 * _products.SMALL_BATCH):
        large = str(jax.make_jaxpr(h.apply)(jnp.ones(4)))
    assert "dot_general" not in small and "dot_general" in large
