"""Rayleigh damping coefficients (paper Eq. 11).

C = α M + β K gives mode i the damping ratio ξᵢ = α / (2 ωᵢ) + β ωᵢ / 2. Eq. 11 inverts
this for two modes: given (ω₁, ξ₁) and (ω₂, ξ₂),

    α = 2 ω₁ ω₂ (ξ₁ ω₂ − ξ₂ ω₁) / (ω₂² − ω₁²),   β = 2 (ξ₂ ω₂ − ξ₁ ω₁) / (ω₂² − ω₁²).

Angular frequencies in rad/s.
"""

from __future__ import annotations

import numpy as np

from .errors import ModelError
from .validation import check_nonnegative, check_positive


def rayleigh_coefficients(omega1, omega2, xi1, xi2):
    """α [1/s] and β [s] from two angular frequencies [rad/s] and damping ratios (Eq. 11)."""
    w1 = check_positive("omega1", omega1, "rad/s")
    w2 = check_positive("omega2", omega2, "rad/s")
    x1 = check_nonnegative("xi1", xi1)
    x2 = check_nonnegative("xi2", xi2)
    if w1 == w2:
        raise ModelError("omega1 and omega2 must differ to determine both alpha and beta")
    d = w2 * w2 - w1 * w1
    alpha = 2.0 * w1 * w2 * (x1 * w2 - x2 * w1) / d
    beta = 2.0 * (x2 * w2 - x1 * w1) / d
    return alpha, beta


def modal_damping_ratios(alpha, beta, omega):
    """Damping ratio ξ = α/(2ω) + βω/2 of modes with angular frequencies ω [rad/s]."""
    w = np.asarray(omega, float)
    if np.any(w <= 0):
        raise ModelError("omega must be > 0 rad/s")
    return alpha / (2.0 * w) + beta * w / 2.0
