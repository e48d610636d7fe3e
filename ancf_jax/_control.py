"""Control flow for solver internals, shared by the physics and the solvers."""

from __future__ import annotations

import jax
import jax.numpy as jnp


def run_if(pred, fn, operand):
    """``fn(operand)`` where ``pred`` holds, else ``operand`` — as a while loop of at
    most one iteration. Unlike ``lax.cond``, which ``vmap`` turns into a select that
    evaluates both branches for every member, a batched while loop runs only while some
    member needs it. Not reverse-mode differentiable (use it on solver internals)."""

    def body(c):
        _, x = c
        return jnp.zeros_like(pred), fn(x)

    return jax.lax.while_loop(lambda c: c[0], body, (pred, operand))[1]
