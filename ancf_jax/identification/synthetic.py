"""Synthetic measurements: a model's output at a sample rate, with Gaussian noise.

The samples are the simulation of the identification problem itself (same solver, same
step, linear interpolation between steps), so noise-free synthetic data are reproduced
exactly by the true parameters: a fit's error then measures the optimiser and the
statistics, not a model mismatch.
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..errors import ModelError
from ..validation import check_nonnegative, check_positive
from .data import Measurements
from .problem import Problem


def sample_times(t0: float, t_end: float, rate: float) -> np.ndarray:
    """t0, t0 + 1/rate, ... up to t_end [s] (inclusive to 1e-9 of a sample)."""
    rate = check_positive("rate", rate, "Hz")
    n = int(math.floor((t_end - t0) * rate + 1e-9))
    return t0 + np.arange(n + 1) / rate


def synthesize(problem: Problem, values: dict | None = None, *, noise: float = 0.0, rate: float = 1000.0,
               t_end: Optional[float] = None, seed: int = 0,
               program: str = "auto") -> tuple[Measurements, np.ndarray]:
    """Synthetic data of ``problem``'s output.

    Args:
        values: parameter values {name: value} (physical units; missing: the model's).
        noise: standard deviation σ of the additive Gaussian noise (output units, m for
            a displacement).
        rate: sample rate [Hz]; samples at t0 + k/rate.
        t_end: last sample time [s] (default: the end of the problem's span).
        seed: seed of the noise (NumPy ``default_rng``).
        program: which compiled program simulates (:meth:`~.problem.Problem.curves`):
            ``"jacobian"`` reuses a fit's program when a fit on the same samples runs
            in the same process.

    Returns:
        (measurements, the noise-free values at the sample times).
    """
    sigma = check_nonnegative("noise", noise, "m")
    t_end = problem.t_end if t_end is None else check_positive("t_end", t_end, "s") + problem.t0
    if t_end > problem.t_end + 1e-12:
        raise ModelError(f"t_end = {t_end - problem.t0:g} s is beyond the problem's span "
                         f"({problem.t_end - problem.t0:g} s)")
    t = sample_times(problem.t0, t_end, rate)
    if len(t) < 10:
        raise ModelError(f"{len(t)} samples at {rate:g} Hz over {t_end - problem.t0:g} s; at least 10 are "
                         "needed (raise --rate or --t-end)")
    probe = Measurements.from_arrays(t, np.zeros_like(t), source="samples")
    grid, y, ok = problem.curves(problem.vector(values), [probe], program=program)
    if not ok[0]:
        raise ModelError("the simulation failed for these parameter values")
    clean = np.interp(t, grid, y[0])
    noisy = clean + sigma * np.random.default_rng(seed).standard_normal(len(t))
    return Measurements.from_arrays(t, noisy, source="synthetic"), clean
