"""S–N curves (stress range against cycles to failure) and mean-stress corrections.

One curve shape covers the Eurocode 3 detail categories and the power laws users
bring for wire ropes (EN 1993-1-9:2005, Fig. 7.1; EN 1993-1-11 for tension
components): with the stress range Δσ [Pa] and N the cycles to failure,

    N = N_C (Δσ_C / Δσ)^m₁                 for Δσ ≥ Δσ_D          (first slope)
    N = N_D (Δσ_D / Δσ)^m₂                 for Δσ_L ≤ Δσ < Δσ_D   (second slope)
    N = ∞                                  for Δσ < Δσ_L          (cut-off)

where the knee Δσ_D lies on the first slope at N_D cycles and the cut-off Δσ_L on the
second slope at N_L cycles:

    Δσ_D = Δσ_C (N_C / N_D)^(1/m₁),    Δσ_L = Δσ_D (N_D / N_L)^(1/m₂).

Eurocode 3 (EN 1993-1-9 Fig. 7.1): Δσ_C is the detail category at N_C = 2·10⁶,
m₁ = 3, knee at N_D = 5·10⁶ (constant-amplitude fatigue limit Δσ_D = (2/5)^(1/3) Δσ_C
= 0.737 Δσ_C), m₂ = 5, cut-off at N_L = 10⁸ (Δσ_L = (5/100)^(1/5) Δσ_D = 0.549 Δσ_D).
A plain power law N = K Δσ^(−m) has no knee (N_D = ∞) and no cut-off; a power law with
an endurance limit has its knee there and m₂ = ∞ (no damage below it).

Mean-stress corrections give the equivalent fully reversed range of a cycle with mean
σ_m (ultimate strength σ_u):

* ``"none"``:    Δσ_eq = Δσ
* ``"goodman"``: Δσ_eq = Δσ / (1 − σ_m/σ_u)
* ``"gerber"``:  Δσ_eq = Δσ / (1 − (σ_m/σ_u)²)

applied to tensile means only (σ_m > 0); compressive means are not credited
(Δσ_eq = Δσ, the conservative convention), and σ_m ≥ σ_u gives Δσ_eq = ∞. Welded
details in Eurocode 3 are assessed on the range alone (``"none"``).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp

from ..errors import ModelError

#: mean-stress corrections
CORRECTIONS = ("none", "goodman", "gerber")

#: the shape of the Eurocode 3 curves (EN 1993-1-9 Fig. 7.1; :meth:`SNCurve.eurocode`):
#: slope 3 through N_C = 2·10⁶, slope 5 from the knee at 5·10⁶, cut-off at 10⁸ cycles
EUROCODE = dict(reference_cycles=2e6, m1=3.0, knee_cycles=5e6, m2=5.0, cutoff_cycles=1e8)


class SNCurve(eqx.Module):
    """An S–N curve with two slopes, a knee and a cut-off (module docstring; final).

    Attributes:
        reference_range: Δσ_C [Pa], the range at ``reference_cycles``.
        reference_cycles: N_C (Eurocode: 2·10⁶).
        m1: first slope m₁ (−).
        knee_cycles: N_D, where the second slope starts; ``inf``: one slope for ever.
        m2: second slope m₂; ``inf``: endurance limit at the knee (no damage below).
        cutoff_cycles: N_L, below whose range no damage counts; ``inf``: no cut-off.
    """

    reference_range: jnp.ndarray
    reference_cycles: jnp.ndarray
    m1: jnp.ndarray
    knee_cycles: jnp.ndarray
    m2: jnp.ndarray
    cutoff_cycles: jnp.ndarray

    def __init__(self, reference_range, reference_cycles=2e6, m1=3.0, knee_cycles=math.inf,
                 m2=math.inf, cutoff_cycles=math.inf):
        values = dict(reference_range=reference_range, reference_cycles=reference_cycles, m1=m1,
                      knee_cycles=knee_cycles, m2=m2, cutoff_cycles=cutoff_cycles)
        for name, v in values.items():
            try:
                ok = float(v) > 0.0
            except TypeError:  # traced (under jit/grad): checked where it was concrete
                ok = True
            if not ok:
                raise ModelError(f"S-N curve: {name} must be > 0, got {v!r}")
        try:
            if float(knee_cycles) < float(reference_cycles) or float(cutoff_cycles) < float(knee_cycles):
                raise ModelError("S-N curve: need reference_cycles <= knee_cycles <= cutoff_cycles, got "
                                 f"{reference_cycles:g}, {knee_cycles:g}, {cutoff_cycles:g}")
        except TypeError:
            pass
        for name, v in values.items():
            setattr(self, name, jnp.asarray(v, float))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def eurocode(cls, detail_category):
        """Eurocode 3 curve of detail category Δσ_C [Pa] (EN 1993-1-9 Fig. 7.1): m = 3
        to 5·10⁶ cycles, m = 5 to the cut-off at 10⁸ cycles."""
        return cls(detail_category, **EUROCODE)

    @classmethod
    def power_law(cls, m, k, endurance_limit=None):
        """N = K Δσ^(−m) (K in Pa^m), optionally with no damage below an endurance
        limit Δσ_e [Pa] (knee there, m₂ = ∞). The reference is taken at N_C = 2·10⁶."""
        s_c = (float(k) / 2e6) ** (1.0 / float(m))
        if endurance_limit is None:
            return cls(s_c, 2e6, m)
        n_e = float(k) * float(endurance_limit) ** (-float(m))
        if n_e < 2e6:
            return cls(endurance_limit, n_e, m, n_e, math.inf)
        return cls(s_c, 2e6, m, n_e, math.inf)

    # ------------------------------------------------------------------ shape
    @property
    def knee_range(self):
        """Δσ_D [Pa]: the range at the knee (0 without a knee)."""
        return jnp.where(jnp.isinf(self.knee_cycles), 0.0,
                         self.reference_range * (self.reference_cycles / self.knee_cycles) ** (1.0 / self.m1))

    @property
    def cutoff_range(self):
        """Δσ_L [Pa]: the cut-off range (Δσ_D for an endurance limit, 0 without a cut-off)."""
        finite = ~(jnp.isinf(self.knee_cycles) | jnp.isinf(self.m2) | jnp.isinf(self.cutoff_cycles))
        n_d = jnp.where(finite, self.knee_cycles, 1.0)
        ratio = (n_d / jnp.where(finite, self.cutoff_cycles, 1.0)) ** (1.0 / jnp.where(finite, self.m2, 1.0))
        return jnp.where(jnp.isinf(self.knee_cycles), 0.0,
                         jnp.where(jnp.isinf(self.m2), self.knee_range,
                                   jnp.where(jnp.isinf(self.cutoff_cycles), 0.0, self.knee_range * ratio)))

    def damage_per_cycle(self, stress_range):
        """1/N(Δσ): the Miner damage of one cycle of range Δσ [Pa] (any shape); zero
        below the cut-off, differentiable in Δσ away from the knee and the cut-off."""
        s = jnp.abs(jnp.asarray(stress_range, float))
        s_d = self.knee_range
        s_l = self.cutoff_range
        first = (s / self.reference_range) ** self.m1 / self.reference_cycles
        s_d_safe = jnp.where(s_d > 0.0, s_d, 1.0)
        m2 = jnp.where(jnp.isinf(self.m2), 1.0, self.m2)
        second = jnp.where(jnp.isinf(self.m2), 0.0,
                           (s / s_d_safe) ** m2 / jnp.where(jnp.isinf(self.knee_cycles), 1.0, self.knee_cycles))
        return jnp.where(s >= s_d, first, jnp.where(s >= s_l, second, 0.0))

    def cycles_to_failure(self, stress_range):
        """N(Δσ) (∞ below the cut-off), any shape."""
        d = self.damage_per_cycle(stress_range)
        return jnp.where(d > 0.0, 1.0 / jnp.where(d > 0.0, d, 1.0), jnp.inf)

    def to_dict(self) -> dict:
        """JSON-ready parameters (None for ∞) with the derived ranges [Pa]."""
        def f(x):
            x = float(x)
            return None if math.isinf(x) else x
        return dict(reference_range_Pa=f(self.reference_range), reference_cycles=f(self.reference_cycles),
                    m1=f(self.m1), knee_cycles=f(self.knee_cycles), m2=f(self.m2),
                    cutoff_cycles=f(self.cutoff_cycles), knee_range_Pa=f(self.knee_range),
                    cutoff_range_Pa=f(self.cutoff_range))


def equivalent_range(ranges, means, correction="none", ultimate_strength=None):
    """Mean-stress corrected range Δσ_eq [Pa] (module docstring), same shape as ranges.

    Args:
        ranges: cycle ranges Δσ [Pa].
        means: cycle means σ_m [Pa] (broadcast against ranges).
        correction: ``"none"``, ``"goodman"`` or ``"gerber"``.
        ultimate_strength: σ_u [Pa] (needed unless ``"none"``).
    """
    if correction not in CORRECTIONS:
        raise ModelError(f"mean-stress correction must be one of {CORRECTIONS}, got {correction!r}")
    ranges = jnp.asarray(ranges, float)
    if correction == "none":
        return ranges
    if ultimate_strength is None:
        raise ModelError(f"the {correction} mean-stress correction needs the ultimate strength")
    r = jnp.maximum(jnp.asarray(means, float), 0.0) / ultimate_strength
    factor = 1.0 - (r if correction == "goodman" else r * r)
    safe = jnp.where(factor > 0.0, factor, 1.0)
    return jnp.where(factor > 0.0, ranges / safe, jnp.inf)
