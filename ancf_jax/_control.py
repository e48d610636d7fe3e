"""Control flow for solver internals, shared by the physics and the solvers."""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp

from . import _products


def run_if(pred, fn, operand):
    """``fn(operand)`` where ``pred`` holds, else ``operand`` — as a while loop of at
    most one iteration. Unlike ``lax.cond``, which ``vmap`` turns into a select that
    evaluates both branches for every member, a batched while loop runs only while some
    member needs it. Not reverse-mode differentiable (use it on solver internals)."""

    def body(c):
        _, x = c
        return jnp.zeros_like(pred), fn(x)

    return jax.lax.while_loop(lambda c: c[0], body, (pred, operand))[1]


def traced_once(method):
    """A method of an ``eqx.Module`` whose body is traced once per argument shapes while
    a program is being traced: inside a trace it runs as a nested, inlined ``jax.jit``
    (arrays dynamic, everything else static), so its second and later calls with the
    same shapes (the constraint under ``vjp``, ``jacrev`` and ``jvp`` in one step, the
    beam mass in the residual and the Newton matrix) replay the cached jaxpr instead of
    tracing the Python code again. The program is the same (the jaxpr is inlined where
    it is called). Called eagerly (no tracer among the arguments), it is the plain
    method: nothing is compiled for one evaluation."""

    @functools.partial(jax.jit, static_argnums=0, inline=True)
    def call(static, dynamic):
        self, args, kwargs = eqx.combine(dynamic, static.tree)
        return method(self, *args, **kwargs)

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        tree = (self, args, kwargs)
        if not any(isinstance(a, jax.core.Tracer) for a in jax.tree.leaves(tree)):
            return method(self, *args, **kwargs)
        dynamic, static = eqx.partition(tree, eqx.is_array)
        # how small products are written depends on the enclosing batch (_products)
        return call(_Static(static, _products.as_sums()), dynamic)

    return wrapper


class _Static:
    """A pytree of static leaves, hashed and compared by its structure and leaves."""

    __slots__ = ("tree", "_key")

    def __init__(self, tree, *extra):
        leaves, treedef = jax.tree.flatten(tree)
        self.tree, self._key = tree, (treedef, tuple(leaves), extra)

    def __hash__(self):
        return hash(self._key)

    def __eq__(self, other):
        return isinstance(other, _Static) and self._key == other._key


def reached_by(tree, inputs, *, tangents: bool = True):
    """``tree`` with every leaf marked as depending on every floating-point leaf of
    ``inputs``: the same values, but JAX sees a batch axis (under ``vmap``) and, with
    ``tangents``, a tangent (under ``jvp``) in each leaf wherever any input has one.

    For the initial carry of a loop. Differentiating or batching ``scan`` or
    ``while_loop``, JAX finds which carries have a tangent or a batch axis by a
    fixpoint, transforming the body again for every carry it promotes, and nested loops
    multiply the passes: a carry that starts independent of the inputs but depends on
    them after one iteration (a model's initial q and v, which its damping does not
    change; the Newton matrix's factors, zeros before the first iteration) costs a
    pass. Marked, a loop's first pass is its last, with the body JAX's fixpoint would
    have reached. The mark is ``select(True, x, anchor)``, which XLA folds away: the
    compiled program computes the same numbers. ``tangents=False`` for what is held
    constant in derivatives (factors): a batch axis only. Eagerly (no tracer in
    ``tree`` or ``inputs``), ``tree`` itself."""
    leaves = [x for x in jax.tree.leaves(inputs) if eqx.is_inexact_array(x)]
    if not any(isinstance(x, jax.core.Tracer) for x in leaves + jax.tree.leaves(tree)):
        return tree
    anchor = sum(jnp.sum(x).astype(float) for x in leaves)
    if not tangents:
        anchor = jax.lax.stop_gradient(anchor)

    def mark(x):
        shape = jnp.shape(x)
        return jax.lax.select(jnp.ones(shape, bool), x, jnp.broadcast_to(anchor, shape).astype(jnp.result_type(x)))

    return jax.tree.map(mark, tree)
