"""Closed-form beam answers shared by the tests."""

import numpy as np
from scipy.optimize import brentq


def clamped_free_frequencies(ei, rho_a, length, tip_mass=0.0, tip_inertia=0.0, count=4, beta_max=None):
    """Angular frequencies ω [rad/s] of a clamped-free Euler–Bernoulli beam with a tip
    mass M and rotary inertia J at x = L.

    w = A(cos βx − cosh βx) + B(sin βx − sinh βx), β⁴ = ρA ω²/EI; the natural boundary
    conditions at L are EI w'' = J ω² w' and EI w''' = −M ω² w (variational derivation:
    the tip kinetic energy ½ M ẇ(L)² + ½ J ẇ'(L)² enters the boundary terms).
    """
    def det(beta):
        w2 = beta**4 * ei / rho_a
        x = beta * length
        c, s, ch, sh = np.cos(x), np.sin(x), np.cosh(x), np.sinh(x)
        wa, wb = c - ch, s - sh
        d1a, d1b = beta * (-s - sh), beta * (c - ch)
        d2a, d2b = beta**2 * (-c - ch), beta**2 * (-s - sh)
        d3a, d3b = beta**3 * (s - sh), beta**3 * (-c - ch)
        m = np.array([[ei * d2a - tip_inertia * w2 * d1a, ei * d2b - tip_inertia * w2 * d1b],
                      [ei * d3a + tip_mass * w2 * wa, ei * d3b + tip_mass * w2 * wb]])
        return np.linalg.det(m) / (ch * ch)

    beta_max = (4 * count + 3) * np.pi / length if beta_max is None else beta_max
    betas = np.linspace(0.05 / length, beta_max, 8000)
    vals = [det(b) for b in betas]
    roots = [brentq(det, betas[i], betas[i + 1], xtol=1e-14 / length)
             for i in range(len(betas) - 1) if vals[i] * vals[i + 1] < 0]
    return np.array([b**2 * np.sqrt(ei / rho_a) for b in roots[:count]])
