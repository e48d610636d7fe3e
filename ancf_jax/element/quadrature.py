"""Quadrature rules on the unit interval [0, 1].

Rules are computed once on the host (NumPy) and become constants in traced code.
"""

from __future__ import annotations

import functools

import numpy as np

from ..validation import check_choice, check_count


@functools.lru_cache(maxsize=None)
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n-point Gauss–Legendre rule on [0, 1]: (points, weights), exact to degree 2n−1."""
    n = check_count("quadrature points", n, 1)
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


@functools.lru_cache(maxsize=None)
def gauss_lobatto(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n-point Gauss–Lobatto rule on [0, 1] (end points included): exact to degree 2n−3."""
    n = check_count("Lobatto quadrature points", n, 2)
    if n == 2:
        x = np.array([-1.0, 1.0])
    else:
        # interior points: roots of P'_{n-1}
        p = np.polynomial.legendre.Legendre.basis(n - 1).deriv()
        x = np.concatenate([[-1.0], np.sort(p.roots().real), [1.0]])
    pn1 = np.polynomial.legendre.Legendre.basis(n - 1)(x)
    w = 2.0 / (n * (n - 1) * pn1**2)
    return 0.5 * (x + 1.0), 0.5 * w


RULES = ("gauss", "lobatto")


def rule(kind: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A named rule on [0, 1]: ``kind`` is ``"gauss"`` or ``"lobatto"``."""
    check_choice("quadrature kind", kind, RULES)
    return gauss_legendre(n) if kind == "gauss" else gauss_lobatto(n)
