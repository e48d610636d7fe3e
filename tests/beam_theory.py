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


def moving_load_series(t, x, v, tension, mu, ei, length, force, modes=4000):
    """Deflection w(x, t) (along the load) of a pinned taut string or beam (tension T,
    mass per current length μ, bending stiffness EI, current length ℓ) under a force P
    entering at t = 0 and moving at speed v, by its modal series:
    qₙ = 2P [sin Ωₙt − (Ωₙ/ωₙ) sin ωₙt] / (μ ℓ (ωₙ² − Ωₙ²)), ωₙ² = ((nπ/ℓ)² T + (nπ/ℓ)⁴ EI) / μ,
    Ωₙ = nπv/ℓ."""
    n = np.arange(1, modes + 1)[:, None]
    k = n * np.pi / length
    w = np.sqrt((k**2 * tension + k**4 * ei) / mu)
    om = k * v
    q = 2 * force * (np.sin(om * t) - om / w * np.sin(w * t)) / (mu * length * (w**2 - om**2))
    return np.sum(q * np.sin(k * np.asarray(x)), 0)
