"""Uncertainty beyond Gauss–Newton: a parametric bootstrap as one vmapped batch, and
the profile likelihood of one parameter (:func:`profile`) and its interval
(:func:`profile_interval`).

The Gauss–Newton standard errors (:func:`~.report.gauss_newton_statistics`) linearise
the model at the estimate and assume white noise of the size of the residual RMS. Near
a bound (a damping coefficient near 0) or where the output depends strongly
nonlinearly on a parameter they can be wrong. The parametric bootstrap does not
linearise: from the fitted model of the measurement m(p̂) at the sample times (Eq. M of
:func:`~.problem.measured`, with its nuisance parameters) it draws B synthetic records

    y^(b)_i = m_i(p̂) + σ̂ sqrt(w̄ / w_i) ε^(b)_i,      ε ~ N(0, 1),

with σ̂ the residual RMS of the fit (or the stated noise level) and w̄ the mean positive
weight, fits all B of them as one ``vmap``-ed batch (:func:`~.fit.fit_batch`, starting
at p̂), and reports per free parameter the standard deviation of the B estimates, their
2.5 % and 97.5 % quantiles, and the fraction of members whose own interval ±2 SE holds
p̂ (coverage of the Gauss–Newton interval, on data the model made).
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from ..errors import ModelError
from .data import Measurements
from .problem import Problem


def final_problem(problem: Problem, result) -> Problem:
    """The problem on the result's final discretization: ``problem`` itself, or its
    refined copy where the fit refined the step or mesh (``fit(..., discretization=True)``)."""
    if result.dt is not None and problem.dt / result.dt > 1.5 or (
            result.elements is not None and problem.elements is not None and result.elements != problem.elements):
        return problem.refined(step=int(round(problem.dt / result.dt)),
                               mesh=int(round(result.elements / problem.elements)) if result.elements else 1)
    return problem


def bootstrap(problem: Problem, result, members: int = 20, *, seed: int = 0, noise: Optional[float] = None,
              max_iterations: Optional[int] = None) -> dict:
    """Parametric bootstrap of a fit (module docstring). Returns a JSON-ready dict, also
    stored as ``result.bootstrap``:

    members, seed, sigma, estimates {name: [B values]}, mean, std, q025, q975,
    gn_stderr (the fit's), std_over_stderr, coverage_2se, converged (count)."""
    from .fit import fit_batch
    problem = final_problem(problem, result)
    if int(members) < 2:
        raise ModelError(f"bootstrap members must be >= 2, got {members}")
    data = result.data
    if not isinstance(data, Measurements) or result.y_measured is None:
        raise ModelError("bootstrap needs a FitResult of fit() (with its data)")
    sigma = result.residual_rms if noise is None else float(noise)
    if not sigma > 0:
        raise ModelError("bootstrap: the residual RMS is 0 (noise-free data); give noise=")
    wpos = data.w > 0
    wbar = float(np.mean(data.w[wpos]))
    scale = np.where(wpos, sigma * np.sqrt(wbar / np.where(wpos, data.w, 1.0)), 0.0)
    rng = np.random.default_rng(seed)
    sets = [Measurements(data.t, result.y_measured + scale * rng.standard_normal(len(data.t)), data.w,
                         None, f"bootstrap {b}") for b in range(int(members))]
    start = {n: float(v) for n, v in zip(result.names, result.estimates)}
    fits = fit_batch(problem, sets, [start], free=result.free, max_iterations=max_iterations)
    free = [n for n in result.names if n in result.free]
    idx = [result.names.index(n) for n in free]
    est = np.array([[f.estimates[k] for k in idx] for f in fits])
    se = np.array([[f.stderr[k] for k in idx] for f in fits])
    p_hat = result.estimates[idx]
    gn = result.stderr[idx]
    std = est.std(axis=0, ddof=1)
    cover = np.mean(np.abs(est - p_hat) <= 2.0 * se, axis=0)
    out = dict(members=int(members), seed=int(seed), sigma=float(sigma),
               estimates={n: est[:, j].tolist() for j, n in enumerate(free)},
               mean={n: float(est[:, j].mean()) for j, n in enumerate(free)},
               std={n: float(std[j]) for j, n in enumerate(free)},
               q025={n: float(np.quantile(est[:, j], 0.025)) for j, n in enumerate(free)},
               q975={n: float(np.quantile(est[:, j], 0.975)) for j, n in enumerate(free)},
               gn_stderr={n: float(gn[j]) for j, n in enumerate(free)},
               std_over_stderr={n: float(std[j] / gn[j]) for j, n in enumerate(free)},
               coverage_2se={n: float(cover[j]) for j, n in enumerate(free)},
               converged=int(sum(f.converged for f in fits)))
    result.bootstrap = out
    return out


def profile(problem: Problem, result, name: str, steps=(-1.5, 1.5), *,
            max_iterations: Optional[int] = None) -> dict:
    """Profile likelihood of one free parameter: at p_k = p̂_k + s·SE_k for each s in
    ``steps`` the other free parameters are fitted again with p_k held (the same
    compiled program: only the set of free parameters changes), and

        Δ(p_k) = (loss(p_k) − loss(p̂)) / s²,      s² = loss(p̂) / (N − n)

    (Gaussian noise: Δ is the χ²(1) likelihood-ratio statistic; for a model linear in
    p, Δ = (p_k − p̂_k)² / SE_k² exactly). Returned per point: the value, Δ and the
    profile standard error |p_k − p̂_k| / sqrt(Δ), which equals the Gauss–Newton SE
    where the linearisation holds
    (the result is not changed)."""
    from .fit import fit
    if name not in result.free:
        raise ModelError(f"profile: {name!r} is not a free parameter of the fit ({', '.join(result.free)})")
    k = result.names.index(name)
    se = float(result.stderr[k])
    if not np.isfinite(se) or se <= 0:
        raise ModelError(f"profile: {name} has no finite standard error")
    others = tuple(n for n in result.free if n != name)
    n, nfree = result.n_samples, len(result.free)
    loss0 = result.residual_rms ** 2
    s2 = loss0 / max(1, n - nfree)  # Gauss–Newton's s² for the normalised residuals (Σ r² = loss)
    points = []
    for s in steps:
        value = float(result.estimates[k] + s * se)
        if problem.log_scaled[k] and value <= 0:
            continue
        start = {m: float(v) for m, v in zip(result.names, result.estimates)}
        start[name] = value
        if others:
            r = fit(problem, result.data, start, free=others, max_iterations=max_iterations)
            loss = r.residual_rms ** 2
        else:
            rr, *_ = problem.evaluate(problem.vector(start), [result.data])
            loss = float(rr[0] @ rr[0])
        delta = (loss - loss0) / s2
        points.append(dict(step_se=float(s), value=value, delta=float(delta),
                           profile_stderr=float(abs(value - result.estimates[k]) / np.sqrt(delta))
                           if delta > 0 else float("inf")))
    return dict(name=name, estimate=float(result.estimates[k]), gn_stderr=se, points=points)


#: default level of :func:`profile_interval`: Δ = 4 is the likelihood-ratio counterpart of
#: the Gauss–Newton interval p̂ ± 2 SE (χ²(1): 95.4 %)
PROFILE_LEVEL = 4.0


def profile_interval(problem: Problem, result, name: str, *, level: float = PROFILE_LEVEL, tol: float = 0.01,
                     max_evaluations: int = 12, max_iterations: Optional[int] = None) -> dict:
    """Profile-likelihood interval of one free parameter: on each side of p̂_k the value
    where Δ(p_k) of :func:`profile` reaches ``level`` (default 4, the counterpart of
    p̂ ± 2 SE). Each side starts at sqrt(level) Gauss–Newton standard errors, steps out
    by factors of 2 until Δ ≥ level, and then solves sqrt(Δ) = sqrt(level) in that
    bracket by Brent's method (``scipy.optimize.brentq``) on sqrt(Δ), which is linear in
    p_k where the linearisation holds, to a step of 0.05 ``tol`` SE (|sqrt(Δ) −
    sqrt(level)| well within ``tol``) in at most ``max_evaluations`` evaluations per side
    (else ModelError). For a positive parameter
    (fitted on log p) whose profile stays below the level down to 1e-8 p̂, the lower end
    is its bound 0 (``lower_at_bound``). Every side costs a few refits of the other
    free parameters (the fit's compiled program).

    Returns {name, estimate, gn_stderr, level, lower, upper, lower_at_bound,
    gn_lower, gn_upper, evaluations: [{value, delta}]} in the parameter's unit; the
    result is not changed. A fit that refined its discretization is profiled on its
    final step and mesh (:func:`final_problem`)."""
    if not level > 0:
        raise ModelError(f"profile_interval: level must be > 0 (Δ, a χ²(1) value), got {level}")
    if int(max_evaluations) < 2:
        raise ModelError(f"profile_interval: max_evaluations must be >= 2, got {max_evaluations}")
    if name not in result.free:
        raise ModelError(f"profile_interval: {name!r} is not a free parameter of the fit ({', '.join(result.free)})")
    k = result.names.index(name)
    p_hat, se = float(result.estimates[k]), float(result.stderr[k])
    if not np.isfinite(se) or se <= 0:
        raise ModelError(f"profile_interval: {name} has no finite standard error")
    problem = final_problem(problem, result)
    positive = bool(problem.log_scaled[k])
    evaluations = []
    known = {p_hat: -float(np.sqrt(level))}  # Δ = 0 at the estimate; each value refitted once

    def root(x: float) -> float:  # sqrt(Δ) − sqrt(level) at p_k = x
        x = float(x)
        if x not in known:
            (pt,) = profile(problem, result, name, steps=((x - p_hat) / se,),
                            max_iterations=max_iterations)["points"]
            evaluations.append(dict(value=pt["value"], delta=pt["delta"]))
            known[x] = float(np.sqrt(max(pt["delta"], 0.0)) - np.sqrt(level))
        return known[x]

    def side(sign: int):
        """(end, at_bound) on one side."""
        a, b = p_hat, p_hat + sign * np.sqrt(level) * se
        first = len(evaluations)
        while True:
            if sign < 0 and positive and b <= 1e-8 * p_hat:
                b = 1e-8 * p_hat
                gb = root(b)
                if gb < 0:
                    return 0.0, True
                break
            gb = root(b)
            if gb >= 0:
                break
            if len(evaluations) - first >= max_evaluations:
                raise ModelError(f"profile_interval: Δ of {name} stays below {level:g} out to {b:g} "
                                 f"({max_evaluations} evaluations)")
            a, b = b, p_hat + 2 * (b - p_hat)
        if abs(gb) <= tol:
            return b, False
        # the root of sqrt(Δ) − sqrt(level) in the bracket (a, b): Brent's method (scipy),
        # to a step far below what |sqrt(Δ) − sqrt(level)| <= tol needs (its slope is ~1/SE)
        from scipy.optimize import brentq
        try:
            end = brentq(root, min(a, b), max(a, b), xtol=0.05 * tol * se, rtol=1e-12,
                         maxiter=max(1, max_evaluations - (len(evaluations) - first)))
        except RuntimeError:
            raise ModelError(f"profile_interval: Δ of {name} = {level:g} not solved to {tol:g} in "
                             f"{max_evaluations} evaluations (between {a:g} and {b:g})") from None
        return float(end), False

    lower, at_bound = side(-1)
    upper, _ = side(+1)
    return dict(name=name, estimate=p_hat, gn_stderr=se, level=float(level), lower=float(lower),
                upper=float(upper), lower_at_bound=at_bound, gn_lower=p_hat - np.sqrt(level) * se,
                gn_upper=p_hat + np.sqrt(level) * se, evaluations=evaluations)
