"""Small functions of time shared by the model layer and the scenario format."""

from __future__ import annotations

import abc
from typing import Callable, Optional

import equinox as eqx
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


class AbstractPath(eqx.Module):
    """A prescribed position along a line p(t) [m] whose parameters are data (traced
    leaves of the system, so a run can be differentiated with respect to them and
    batched over them), unlike a plain Python function of time, which is static."""

    @abc.abstractmethod
    def __call__(self, t):
        """p(t) [m] at time t [s] (scalar or array)."""


class ConstantSpeed(AbstractPath):
    """p(t) = start + speed·t + profile(t) [m]: a constant speed [m/s] from ``start``
    [m], plus an optional prescribed deviation ``profile`` (a JAX-traceable t ↦ m,
    static; None: none). ``start`` and ``speed`` are data (differentiable)."""

    start: jnp.ndarray
    speed: jnp.ndarray
    profile: Optional[Callable] = eqx.field(static=True, default=None)

    def __init__(self, start, speed, profile: Optional[Callable] = None):
        self.start = jnp.asarray(start, float)
        self.speed = jnp.asarray(speed, float)
        self.profile = profile

    def __call__(self, t):
        p = self.start + self.speed * t
        return p if self.profile is None else p + self.profile(t)
