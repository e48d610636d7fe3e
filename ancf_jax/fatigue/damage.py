"""Palmgren–Miner damage and life.

D = Σᵢ nᵢ / N(Δσ_eq,i): each cycle i (count nᵢ, 1 or ½) uses up 1/N of the life at its
(mean-corrected) range; failure at D = 1. A simulated history with damage D repeated R
times has damage R·D, so its life is 1/D repetitions of the history (and 1/D times
whatever one run represents: hours of service, passes of a trolley).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .rainflow import cycles
from .sn import SNCurve, equivalent_range


def miner(ranges, counts, curve: SNCurve, means=None, correction="none", ultimate_strength=None):
    """Miner sum Σ nᵢ/N(Δσ_eq,i) (dimensionless) of cycles (ranges [Pa], counts)."""
    means = jnp.zeros_like(jnp.asarray(ranges, float)) if means is None else means
    s = equivalent_range(ranges, means, correction, ultimate_strength)
    return jnp.sum(jnp.asarray(counts, float) * curve.damage_per_cycle(s))


@eqx.filter_jit
def _miner_jit(ranges, counts, curve, means, correction, ultimate_strength):
    return miner(ranges, counts, curve, means, correction, ultimate_strength)


def _padded(a, size):
    return np.concatenate([a, np.zeros(size - a.size)])


def rainflow_damage(series, curve: SNCurve, correction="none", ultimate_strength=None) -> float:
    """Miner damage of one 1-D stress history [Pa] by rainflow counting (half cycles
    of the residue count ½, see :mod:`ancf_jax.fatigue.rainflow`).

    The cycles are padded with zero counts to a power of two, so that one compiled
    Miner sum serves records of similar length."""
    r, m, c = cycles(series)
    if r.size == 0:
        return 0.0
    size = 1 << int(np.ceil(np.log2(max(r.size, 16))))
    return float(_miner_jit(_padded(r, size), _padded(c, size), curve, _padded(m, size),
                            correction, ultimate_strength))


def life(damage):
    """Repetitions of the history to failure, 1/D (∞ where D = 0), NumPy array or float."""
    d = np.asarray(damage, float)
    with np.errstate(divide="ignore"):
        out = np.where(d > 0.0, 1.0 / np.where(d > 0.0, d, 1.0), np.inf)
    return float(out) if out.ndim == 0 else out
