"""Products of small arrays: ``dot`` or multiply-and-sum, chosen by the batch they run in.

XLA:CPU runs every ``dot`` instruction as a call of its own into Eigen: it fuses with
nothing around it and costs a dispatch of the thunk runtime, however small the
product. A small model's step is made of many tiny products (the Hermite
interpolation of every element, 4 shape functions, and its derivatives; 2×2
rotations; 4×4 blocks), and those calls weighed on it: written as a multiply followed
by a sum, XLA fuses them with the element arithmetic around them. Over many elements,
or many batch members under ``vmap``, it is the other way round: one batched ``dot``
beats the fused sums. The code that maps a computation over a batch (the elements of a
beam, the members of :func:`~ancf_jax.simulation.simulate_batch`) says so with
:func:`batch`; the products below are written as sums while the product of the
enclosing batch sizes is at most :data:`SMALL_BATCH`.

Measured on 2 cores (jaxlib 0.10.2; ``Results.wall_time_s`` of ``simulate``, best of
3 or 5, M1 at single_run's settings), ``dot`` against sums: 6 elements, 0–2 s, 0.101
against 0.069 s; 12 elements 151 against 114 µs per step; 24 elements 262–283 against
262–276 µs (even); 96 elements 930 against 1267 µs and 384 elements 3989 against 5176
(so ``dot`` there); a vmapped batch of 64 M1 variants, 98 against 134 ms per
simulation. Results agree to rounding (another
summation order). Re-checked on 2026-12-08 after Eigen's thread pool was turned off in
``dot`` calls (:mod:`ancf_jax._xla`), which made ``dot`` cheaper: bare steps of M1 at
single_run's settings traced both ways and compiled in one process, medians of 9
interleaved, sums against ``dot``: 12 elements 72.6 against 75.2 µs per step, 24
elements 113.3 against 110.5 µs (even), so the threshold stays.
"""

from __future__ import annotations

import contextlib
import contextvars

import jax.numpy as jnp

#: largest product of the enclosing batch sizes (:func:`batch`) at which the products
#: are written as multiply-and-sum (module docstring)
SMALL_BATCH = 32

_BATCH = contextvars.ContextVar("ancf_jax_products_batch", default=1)


@contextlib.contextmanager
def batch(size: int):
    """Trace the enclosed code as mapped over ``size`` members (nests: sizes multiply)."""
    token = _BATCH.set(_BATCH.get() * max(int(size), 1))
    try:
        yield
    finally:
        _BATCH.reset(token)


def as_sums() -> bool:
    """Whether products are traced as multiply-and-sum here (part of the cache key of
    :func:`ancf_jax._control.traced_once`)."""
    return _BATCH.get() <= SMALL_BATCH


def matmul(a, b):
    """a @ b for a (..., m, k) and b (..., k, n) (leading dimensions broadcast), shape (..., m, n)."""
    if not as_sums():
        return jnp.matmul(a, b)
    return jnp.sum(a[..., :, :, None] * b[..., None, :, :], axis=-2)


def matvec(a, x):
    """a @ x for a (..., m, k) and x (..., k), shape (..., m)."""
    if not as_sums():
        return jnp.matmul(a, x[..., None])[..., 0]
    return jnp.sum(a * x[..., None, :], axis=-1)


def dot(a, b):
    """a @ b for 1-D or 2-D operands, as :func:`jax.numpy.matmul`."""
    if a.ndim == 1 and b.ndim == 1:
        return jnp.sum(a * b) if as_sums() else jnp.dot(a, b)
    if b.ndim == 1:
        return matvec(a, b)
    if a.ndim == 1:
        return matmul(a[None], b)[0]
    return matmul(a, b)
