"""Small functions of time shared by the model layer and the scenario format."""

from __future__ import annotations

import jax.numpy as jnp


class Constant:
    """f(t) = value, hashable by value: as a static field of a model (a drive's speed, a
    scenario's constant time function) it does not re-trigger compilation when the
    model is rebuilt with the same value."""

    def __init__(self, value: float):
        self.value = float(value)

    def __call__(self, t):
        return jnp.full(jnp.shape(t), self.value)

    def __eq__(self, other):
        return isinstance(other, Constant) and other.value == self.value

    def __hash__(self):
        return hash(("constant", self.value))
