"""Rainflow cycle counting (ASTM E1049-85, §5.4.4) of a stress history.

A thin wrapper over the `rainflow <https://pypi.org/project/rainflow/>`_ library
(``rainflow.extract_cycles``, the four-point/three-point algorithm of the standard);
no counting is written here.

Residue. After the full cycles are extracted, what is left (the residue: a
sequence of diverging then converging ranges) is counted as **half cycles, 0.5 each**,
as ASTM E1049-85 §5.4.4 prescribes for the last reversals of a record. The residue is
not closed by repeating the history: a record simulated once and repeated R times
therefore gets R times its own damage, which is slightly less than the damage of the
R-fold concatenated history (whose largest range would close into one full cycle).
For long records the difference is one half cycle of the largest range per record.
"""

from __future__ import annotations

import numpy as np
import rainflow as _rainflow


def reversals(series) -> np.ndarray:
    """The turning points (peaks and valleys) of a 1-D history, first and last sample
    kept, by NumPy (equal neighbours merged first). Counting the cycles of these alone
    gives the same cycles as counting the whole history (rainflow only looks at
    reversals), and the library's pure-Python loop then runs over a few points per
    vibration period instead of every sample."""
    x = np.asarray(series, float).ravel()
    if x.size < 3:
        return x.copy()
    x = x[np.r_[True, np.diff(x) != 0.0]]
    if x.size < 3:
        return x
    d = np.diff(x)
    turn = np.sign(d[1:]) != np.sign(d[:-1])
    return x[np.r_[True, turn, True]]


def cycles(series) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rainflow cycles of a 1-D stress history (ASTM E1049-85).

    Args:
        series: stress history, shape (T,) [Pa] (any unit; ranges and means have it).

    Returns:
        ``(ranges, means, counts)``, each shape (C,): the range Δσ = σ_max − σ_min and
        mean (σ_max + σ_min)/2 of every extracted cycle, and its count, 1.0 for a full
        cycle and 0.5 for a half cycle of the residue (see the module docstring). A
        history with fewer than two reversals gives empty arrays. NaN samples are an
        error (they come from padded elements; evaluate active points only).
    """
    x = np.asarray(series, float).ravel()
    if np.isnan(x).any():
        raise ValueError("cycles(): the stress history contains NaN")
    if x.size < 2:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    out = [(r, m, c) for r, m, c, _, _ in _rainflow.extract_cycles(reversals(x))]
    if not out:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    r, m, c = (np.asarray(a, float) for a in zip(*out))
    return r, m, c
