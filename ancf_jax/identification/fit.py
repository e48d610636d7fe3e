"""Fitting: Levenberg–Marquardt (default) or an optax optimiser on log-parameters.

Both optimisers work on θ = log p (log-parametrisation), so damping coefficients, moduli
and masses stay positive; θ is kept above a floor ten decades below the initial guess,
and a parameter that runs to that floor (its best value is 0 or below, e.g. β fitted to
data made with β = 0) is held there while the gradient pushes it further down (an active
bound), so the fit still converges; the report then calls it not distinguishable from
zero. A free α or β whose initial value is 0 starts at ``ZERO_START`` instead.

Levenberg–Marquardt (Marquardt's scaling, Nielsen's damping update) uses the residual
Jacobian J_θ = ∂r/∂p · diag(p) from one forward-mode pass per evaluation
(:meth:`~.problem.Problem.evaluate`); each iteration costs one simulation with
derivatives. optax (Adam by default) uses the gradient 2 J_θᵀr / loss₀ of the same
evaluation (scaled by the initial loss: losses in m² are far below Adam's ε).
On M1 LM converges in a handful of iterations where Adam needs hundreds (see
``docs/identification.md`` and ``benchmarks/identification_gradients.py``).

Stopping rule (first that holds, per member):

* ``xtol``: the accepted step changes every free θ by less than xtol (relative change
  of p);
* ``ftol``: the accepted step lowers the loss by less than ftol relative;
* ``gtol``: |cos| between every free Jacobian column and r is below gtol (first-order
  optimality, MINPACK's test);
* zero residual: the loss fell below 1e-30 of its initial value, or a step failed to
  lower a loss whose RMS residual is below ``ZERO_RESIDUAL`` (1e-12) of the data's RMS
  value: the simulation reproduces the data to rounding level, and further steps would
  only chase Newton and rounding noise (noise-free synthetic data);
* noise floor (LM): no step lowers the loss although the damping has grown to 1e12;
* ``max_iterations``: not converged.

Batches (several data sets and/or several initial guesses) evaluate all members in one
``vmap``-ed program per iteration; each member keeps its own damping and stopping state.

Why this loop is not optimistix's ``LevenbergMarquardt``: that solver has no bounds (the
floor and active-bound hold above are what lets β fitted to β = 0 data converge), and
its stopping rule is a step/residual tolerance; this one needs MINPACK's gradient test,
the zero-residual and noise-floor rules, a progress line per iteration, and a host loop
whose iterations are single vmapped simulations with their forward-mode Jacobians (the
expensive part, compiled once). The linear algebra of a step is a few-by-few solve.
"""

from __future__ import annotations

import math
import sys
import time
from typing import Callable, Optional, Sequence

import numpy as np

from ..errors import ModelError, SimulationError
from ..validation import check_positive
from .data import Measurements
from .joint import base_name
from .problem import Problem
from .report import (DETERMINED, FIXED, SIGNIFICANCE, UNDETERMINED, ZERO, FitResult, gauss_newton_statistics,
                     misfit_diagnostics)

METHODS = ("lm", "adam")
#: θ stays within this many decades of the initial guess
DECADES = 10.0
#: start of a free parameter whose initial value is 0 (e.g. M1's beta = 0)
ZERO_START = {"alpha": 1e-2, "beta": 1e-5}
#: RMS residual / RMS data value below which the fit has reproduced the data exactly
ZERO_RESIDUAL = 1e-12

# the defaults of fit and fit_batch (the stopping rule of the module docstring)
#: default ``xtol``: relative change of every free p in an accepted step
XTOL = 1e-8
#: default ``ftol``: relative loss decrease of an accepted step
FTOL = 1e-10
#: default ``gtol``: largest |cos| between a free Jacobian column and the residual
GTOL = 1e-10
#: default ``learning_rate`` of Adam (step in log-parameters)
LEARNING_RATE = 0.05
#: default ``max_iterations`` of each method (and of a given optax optimizer: "adam")
MAX_ITERATIONS = {"lm": 50, "adam": 500}


def _progress_line(it: int, cost: np.ndarray, p: np.ndarray, names, active: np.ndarray) -> str:
    best = int(np.argmin(cost))
    vals = " ".join(f"{n}={v:.6g}" for n, v in zip(names, p[best]))
    batch = f" [{int(active.sum())}/{len(cost)} running, best member {best}]" if len(cost) > 1 else ""
    return f"  iter {it:3d}  loss {cost[best]:.6e}  rms {math.sqrt(max(cost[best], 0.0)):.4g}  {vals}{batch}"


class _Member:
    """Optimiser state of one batch member (host side)."""

    def __init__(self, p, r, jac, y):
        self.p, self.r, self.jac, self.y = p, r, jac, y
        self.cost = float(r @ r)
        self.cost0 = self.cost
        self.history = [self.cost]
        self.active, self.converged = True, False
        self.reason = "max_iterations reached"
        self.iterations = 0
        self.lam, self.nu = 1e-3, 2.0
        self.pred = 0.0
        self.opt_state = None

    def stop(self, reason: str, converged: bool = True):
        self.active, self.converged, self.reason = False, converged, reason

    def take(self, p, r, jac, y, cost):
        self.p, self.r, self.jac, self.y, self.cost = p, r, jac, y, cost


def _gradient_test(m: _Member, mask, gtol, held) -> bool:
    """First-order optimality: |cos(J_k, r)| <= gtol for every free parameter not held
    at its bound (MINPACK's gtol)."""
    jf = m.jac[:, mask]
    g = jf.T @ m.r
    col = np.linalg.norm(jf, axis=0)
    live = ~held & (col > 0)
    if not live.any():
        return True
    cos = np.abs(g[live]) / (col[live] * math.sqrt(max(m.cost, 1e-300)))
    return bool(np.max(cos) <= gtol)


def _lm_trial(m: _Member, mask, lo, islog, bound) -> tuple[np.ndarray, np.ndarray]:
    """Levenberg–Marquardt step: (trial p, held).

    Physical parameters (``islog``) are stepped in θ = log p, nuisance parameters
    (time offset, sensor offset and gain, which may be 0 or negative) in p itself: with
    s_k = p_k (log) or 1 (linear) and J_s = J_p diag(s), the step δ solves
    (J_sᵀJ_s + λ diag(J_sᵀJ_s)) δ = −J_sᵀr (Marquardt's scaling: the step does not depend
    on the parameters' units). A log parameter is updated as p ← p (1 + δ), i.e.
    θ ← θ + log(1 + δ): the same first-order step, but exact for the Gauss–Newton model
    linear in p. So a parameter whose best value is 0 (β on data made with β = 0:
    δ → −1) reaches its floor in one or two steps instead of losing a constant factor e
    per iteration, and no step raises a parameter by more than the linear model asks.
    θ stays at or above its floor ``lo``; a parameter at the floor that the gradient
    pushes further down is held (an active bound). A linear parameter is updated as
    p ← p + δ and kept within ``bound`` (|p| <= bound; inf: unbounded)."""
    pf = m.p[mask]
    lg = islog[mask]
    scale = np.where(lg, pf, 1.0)
    theta = np.where(lg, np.log(np.where(lg, pf, 1.0)), 0.0)
    jt = m.jac[:, mask] * scale[None, :]
    g = jt.T @ m.r
    a = jt.T @ jt
    held = lg & (theta <= lo + 1e-9) & (g > 0.0)
    live = ~held & (np.diag(a) > 0)
    step = np.zeros_like(pf)
    if live.any():
        al = a[np.ix_(live, live)]
        d = np.diag(al)
        step[live] = np.linalg.solve(al + m.lam * np.diag(d), -g[live])
    # a parameter the step lowers by more than a factor 1e6 goes to its floor (its best
    # value is 0 or below)
    new = np.where(1.0 + step < 1e-6, lo, np.maximum(theta + np.log(np.maximum(1.0 + step, 1e-300)), lo))
    lin = np.clip(pf + step, -bound[mask], bound[mask])
    trial = m.p.copy()
    trial[mask] = np.where(lg, np.exp(new), lin)
    # predicted decrease of the model linear in p
    m.pred = m.cost - float(np.sum((m.r + m.jac[:, mask] @ (trial[mask] - pf)) ** 2))
    return trial, held


def _fit(problem: Problem, datasets: Sequence[Measurements], p0: np.ndarray, free: Sequence[str], *,
         method: str, max_iterations: int, xtol: float, ftol: float, gtol: float,
         learning_rate: float, optimizer, progress, noise: Optional[float] = None) -> list[FitResult]:
    names = problem.names
    for f in free:
        if f not in names:
            raise ModelError(f"free parameter {f!r} is not one of the problem's ({', '.join(names)})")
    mask = np.array([n in free for n in names])
    if not mask.any():
        raise ModelError("no free parameters to fit")
    use_optax = optimizer is not None or method == "adam"
    if method not in METHODS and optimizer is None:
        raise ModelError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    B = len(p0)
    islog = problem.log_scaled
    # (a joint fit's time offsets are named time_offset@e)
    bound = np.array([problem.max_time_offset if base_name(n) == "time_offset" else math.inf for n in names])
    if use_optax and not islog[mask].all():
        raise ModelError("nuisance parameters (time_offset, offset, gain) and parameters at values <= 0 "
                         "are fitted by method 'lm' only (optax steps log p)")
    bad = np.argwhere(p0[:, mask & islog] <= 0)
    if bad.size:
        n = [x for x, k in zip(names, mask & islog) if k][bad[0][1]]
        raise ModelError(f"initial value of {n} must be > 0 (the fit works on log {n})")
    say: Optional[Callable[[str], None]] = progress if callable(progress) else None
    bar = None
    if progress is True:
        from tqdm.auto import tqdm
        label = f"fit ({'optax' if optimizer is not None else method})"
        bar = tqdm(total=max_iterations, desc=f"{label}, compiling", unit="it", file=sys.stderr, leave=True,
                   dynamic_ncols=True, bar_format="{desc}: {n}/{total} it [{elapsed}]{postfix}")

    compile0 = problem.compile_time_s
    tw = time.perf_counter()
    r, jac, yg, ok, layout, _ = problem.evaluate(p0, datasets)
    if not ok.all():
        b = int(np.argmin(ok))
        raise SimulationError(f"the simulation fails at the initial guess {dict(zip(names, p0[b]))}; "
                              "choose another", time=float("nan"), reason="initial")
    members = [_Member(p0[b].copy(), r[b], jac[b], yg[b]) for b in range(B)]
    y_init = yg.copy()
    data_of = (lambda b: datasets[b]) if len(datasets) == B else (lambda b: datasets[0])
    # loss (weighted mean square, m²) at which the residual is at rounding level
    zero = [ZERO_RESIDUAL ** 2 * float(np.sum(d.w * d.y ** 2) / np.sum(d.w)) for d in map(data_of, range(B))]
    evaluations = 1
    lo = np.log(np.where(mask & islog, p0, 1.0)) - DECADES * math.log(10)
    if use_optax:
        import optax
        opt = optimizer if optimizer is not None else optax.adam(learning_rate)
        best = [(m.cost, m.p, m.r, m.jac, m.y) for m in members]
        stall = np.zeros(B, int)
        for m in members:
            m.opt_state = opt.init(np.log(m.p[mask]))

    def line(it):
        text = _progress_line(it, np.array([m.cost for m in members]), np.stack([m.p for m in members]),
                              names, np.array([m.active for m in members]))
        if say:
            say(text)
        if bar is not None:
            if it == 0:
                bar.set_description(label, refresh=False)
            bar.n = it
            bar.set_postfix_str("loss" + text.split("loss", 1)[1], refresh=True)

    line(0)
    for it in range(1, max_iterations + 1):
        if not any(m.active for m in members):
            break
        trials = np.stack([m.p for m in members])
        for b, m in enumerate(members):
            if not m.active:
                continue
            if use_optax:
                theta = np.log(m.p[mask])
                jt = m.jac[:, mask] * m.p[mask][None, :]
                held = (theta <= lo[b, mask] + 1e-9) & (jt.T @ m.r > 0)
                if _gradient_test(m, mask, gtol, held):
                    m.stop("gradient below gtol")
                    continue
                # gradient of loss / (initial loss): losses in m² are ~1e-9, below Adam's eps
                grad = np.where(held, 0.0, 2.0 * jt.T @ m.r / m.cost0)
                upd, m.opt_state = opt.update(grad, m.opt_state, theta)
                trials[b, mask] = np.exp(np.maximum(theta + np.asarray(upd), lo[b, mask]))
            else:
                trial, held = _lm_trial(m, mask, lo[b, mask], islog, bound)
                if _gradient_test(m, mask, gtol, held):
                    m.stop("gradient below gtol" + (" (a parameter held at its floor, i.e. 0)"
                                                     if held.any() else ""))
                    continue
                trials[b] = trial
        if not any(m.active for m in members):
            break
        r, jac, yg, ok, _, _ = problem.evaluate(trials, datasets)
        evaluations += 1
        for b, m in enumerate(members):
            if not m.active:
                continue
            m.iterations = it
            cost = float(r[b] @ r[b]) if ok[b] else math.inf
            dp = trials[b, mask] - m.p[mask]
            small = bool(np.all(np.abs(dp) <= xtol * np.maximum(np.abs(m.p[mask]), np.abs(trials[b, mask]))))
            if use_optax:
                if not ok[b]:
                    raise SimulationError(f"the simulation failed at {dict(zip(names, trials[b]))} during the "
                                          "fit; lower the learning rate", time=float("nan"), reason="fit")
                improved = cost < best[b][0] * (1.0 - ftol)
                if cost < best[b][0]:
                    best[b] = (cost, trials[b].copy(), r[b], jac[b], yg[b])
                m.take(trials[b].copy(), r[b], jac[b], yg[b], cost)
                stall[b] = 0 if improved else stall[b] + 1
                m.history.append(best[b][0])
                if best[b][0] <= 1e-30 * m.cost0:
                    m.stop("zero residual")
                elif stall[b] >= 20:
                    m.stop("no relative loss decrease above ftol in 20 iterations")
                continue
            if cost < m.cost:
                rho = (m.cost - cost) / m.pred if m.pred > 0 else 0.0
                rel = (m.cost - cost) / m.cost
                m.take(trials[b].copy(), r[b], jac[b], yg[b], cost)
                m.lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                m.nu = 2.0
                if cost <= 1e-30 * m.cost0:
                    m.stop("zero residual")
                elif small:
                    m.stop("step below xtol")
                elif rel <= ftol:
                    m.stop("relative loss decrease below ftol")
            elif m.cost <= zero[b]:
                m.stop("zero residual (rounding level)")
            else:
                m.lam *= m.nu
                m.nu *= 2.0
                if m.lam > 1e12 or small:
                    m.stop("no decrease possible (numerical noise floor)")
            m.history.append(m.cost)
        line(it)
    if bar is not None:
        bar.close()
    if use_optax:
        for b, m in enumerate(members):
            m.cost, m.p, m.r, m.jac, m.y = best[b]
    compile_s = problem.compile_time_s - compile0
    wall = max(0.0, time.perf_counter() - tw - compile_s)

    out = []
    for b, m in enumerate(members):
        data = data_of(b)
        n_eff = int(np.sum(data.w > 0))
        se_free, corr, _ = gauss_newton_statistics(m.r, m.jac[:, mask], n_eff)
        se = np.full(len(names), np.nan)
        se[mask] = se_free
        # a parameter at (within two decades of) its floor, ten decades below its start,
        # is at its bound 0
        at_floor = mask & islog & (np.log(np.maximum(m.p, 1e-300)) <= lo[b] + 2.0 * math.log(10.0))
        status = []
        for k in range(len(names)):
            if not mask[k]:
                status.append(FIXED)
            elif not np.isfinite(se[k]):
                status.append(UNDETERMINED)
            elif islog[k] and (at_floor[k] or m.p[k] < SIGNIFICANCE * se[k]):
                status.append(ZERO)
            else:  # a nuisance parameter with a finite standard error is determined (it may be ~0)
                status.append(DETERMINED)
        r_data = m.r[:len(data.t)]  # without the zero-weight padding of a batch
        diag = misfit_diagnostics(r_data[data.w > 0], noise=noise, n_params=int(mask.sum()))
        out.append(FitResult(
            names=names, units=problem.units, free=tuple(n for n, k in zip(names, mask) if k),
            init=p0[b].copy(), estimates=m.p.copy(), stderr=se, correlation=corr, status=tuple(status),
            loss_history=m.history, iterations=m.iterations, evaluations=evaluations,
            converged=m.converged, stop_reason=m.reason, residual_rms=math.sqrt(max(m.cost, 0.0)),
            n_samples=n_eff, wall_time_s=wall / B, compile_time_s=compile_s,
            method="optax" if optimizer is not None else method, t_grid=layout.grid, y_fit=m.y.copy(),
            y_init=y_init[b].copy(), data=data, model=problem.name, output=problem.output.name,
            output_unit=problem.output.unit,
            nuisance=problem.nuisance, diagnostics=diag, residuals=r_data.copy(),
            jacobian=m.jac[:len(data.t)].copy(), dt=problem.dt, elements=problem.elements,
            y_measured=np.asarray(measured_host(problem, layout, m.p, data.t, m.y))))
    return out


def measured_host(problem: Problem, layout, p, t, y_grid) -> np.ndarray:
    """The model of the measurement (Eq. M) at times t from an output curve on the grid."""
    from .problem import measured
    return np.asarray(measured(layout, np.asarray(p, float), np.asarray(t, float), np.asarray(y_grid)))


def _initial(problem: Problem, init, free) -> np.ndarray:
    """Initial values; a free alpha or beta whose value is 0 (given, or the model's)
    starts at ZERO_START instead (log-parameters cannot start at 0)."""
    p = problem.vector(init)
    for k, par in enumerate(problem.params):
        if par.name in free and p[k] == 0.0 and par.kind in ZERO_START:
            p[k] = ZERO_START[par.kind]
    return p


def fit(problem: Problem, data: Measurements, init: dict | Sequence[float] | None = None, *,
        free: Sequence[str] | None = None, window: tuple | None = None, method: str = "lm",
        max_iterations: int | None = None, xtol: float = XTOL, ftol: float = FTOL, gtol: float = GTOL,
        learning_rate: float = LEARNING_RATE, optimizer=None, progress=False, noise: Optional[float] = None,
        discretization: bool = False, refine: bool = True, refine_budget: int = 2,
        shift_limit: float = 0.3, refine_axes: Sequence[str] = ("step", "mesh"),
        strain_measure: bool = True) -> FitResult:
    """Fit the problem's parameters to one data set.

    Args:
        problem: model, parameters and output (:class:`~.problem.Problem`).
        data: measurements (:func:`~.data.read_csv`, :meth:`~.data.Measurements.from_arrays`).
        init: initial values {name: value} (physical units; missing names: the model's
            values); every free physical parameter must start > 0.
        free: the parameters to fit (default all of the problem's); the others stay at
            their initial values (which may be 0), using the same compiled program.
        window: (t_start, t_end) [s]: fit only the samples in this time window.
        method: ``"lm"`` (Levenberg–Marquardt, default) or ``"adam"`` (optax).
        max_iterations: default :data:`MAX_ITERATIONS` of the method (50 for LM, 500
            for adam or a given optimizer).
        xtol: stopping tolerance on the change of the log-parameters θ (module docstring).
        ftol: stopping tolerance on the relative loss decrease (module docstring).
        gtol: stopping tolerance on |cos| between Jacobian columns and residuals (module docstring).
        learning_rate: Adam's step in log-parameters.
        optimizer: any optax GradientTransformation (overrides ``method``).
        progress: True prints one line per iteration to stderr; a callable receives them.
        noise: the measurement's noise level σ (standard deviation of a sample of weight
            1, output units), if known: the report compares the residual RMS with it
            (:func:`~.report.misfit_diagnostics`).
        discretization: check at the optimum how far the estimates move when the step is
            halved and the mesh doubled (:mod:`.discretization`); off by default here,
            on by default in ``ancf-jax fit``.
        refine: with ``discretization``, refine and fit again while an estimate moves by
            more than ``shift_limit`` standard errors, at most ``refine_budget`` times.
        refine_axes: which refinements the check makes: ``"step"`` (h/2) and/or
            ``"mesh"`` (elements × 2; problems built from a scenario with one beam).
        strain_measure: with ``discretization``, also the model-form check: the estimate
            re-evaluated with the beams' strain measures exchanged, reported with the
            combined uncertainty (``result.model_form``; scenario-built problems).

    Returns:
        :class:`~.report.FitResult`.
    """
    options = dict(free=free, method=method, max_iterations=max_iterations, xtol=xtol, ftol=ftol, gtol=gtol,
                   learning_rate=learning_rate, optimizer=optimizer, progress=progress, noise=noise)
    data = problem.prepare(data, window)

    def one(pr, d, i, **kw):
        return fit_batch(pr, [d], [i], **kw)[0]

    if not discretization:
        return one(problem, data, init, **options)
    from .discretization import controlled_fit
    result, _ = controlled_fit(one, problem, data, init, refine=refine, budget=refine_budget,
                               limit=shift_limit, axes=tuple(refine_axes), strain_measure=strain_measure,
                               **options)
    return result


def fit_batch(problem: Problem, datasets: Sequence[Measurements], inits: Sequence | None = None, *,
              free: Sequence[str] | None = None, window: tuple | None = None, method: str = "lm",
              max_iterations: int | None = None, xtol: float = XTOL, ftol: float = FTOL,
              gtol: float = GTOL, learning_rate: float = LEARNING_RATE, optimizer=None,
              progress=False, noise: Optional[float] = None) -> list[FitResult]:
    """Several fits under one ``vmap``: several data sets (one initial guess), several
    initial guesses (one data set), or pairs of both (equal counts). Data sets may have
    different lengths (padded with zero-weight samples). Arguments as :func:`fit`.

    Returns:
        one :class:`~.report.FitResult` per member.
    """
    datasets = [problem.prepare(d, window) for d in datasets]
    inits = [None] if inits is None or len(inits) == 0 else list(inits)
    free = problem.names if free is None else tuple(free)
    p0 = np.stack([_initial(problem, i, free) for i in inits])
    if len(datasets) > 1 and len(p0) > 1 and len(datasets) != len(p0):
        raise ModelError(f"{len(datasets)} data sets and {len(p0)} initial guesses: give one of either, "
                         "or equally many (paired)")
    b = max(len(datasets), len(p0))
    p0 = np.broadcast_to(p0, (b, p0.shape[1])).copy()
    if max_iterations is None:
        # (an unknown method is refused by _fit)
        max_iterations = MAX_ITERATIONS.get("adam" if optimizer is not None else method, MAX_ITERATIONS["lm"])
    return _fit(problem, datasets, p0, free, method=method, max_iterations=int(max_iterations),
                xtol=xtol, ftol=ftol, gtol=gtol, learning_rate=learning_rate, optimizer=optimizer,
                progress=progress, noise=None if noise is None else check_positive("noise", noise, "output units"))
