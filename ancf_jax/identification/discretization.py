"""Discretization control: does the model's own discretization error bias the estimates?

Measured data carry no discretization error; the model does (mesh and time step). At
the optimum p̂ of a fit the model is re-evaluated with the time step halved, and (for a
problem built from a scenario with one beam) with the element count doubled, each
without derivatives. The change of the residuals Δr = r_fine(p̂) − r(p̂) moves the
least-squares estimate by, to first order (one Gauss–Newton step with the fit's
Jacobian J = ∂r/∂p of the free parameters),

    δp = −(JᵀJ)⁻¹ Jᵀ Δr,            shift_k = δp_k / SE_k            (Eq. D)

in units of the Gauss–Newton standard error SE_k. The discretization error of a
second-order scheme falls by about 4 per halving of the step, so δp from one halving is
about 3/4 of the whole bias of the coarse model; the check asks that the refinement
moves no estimate by more than ``limit`` (0.3) standard errors. If it does, the axis
that moved it (step, mesh, or both) is refined, the fit is repeated from p̂, and the
check runs again, at most ``budget`` times (default 2); the report says what was
refined, the final step and mesh and the remaining shift, and warns when the budget
ran out first.

Cost: one run without derivatives per checked axis and round, plus a new compilation
for each new discretization (the refined programs are cached in-process like every
other).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import ModelError, SimulationError
from .data import Measurements
from .problem import Problem, _values_jit

#: an estimate that moves by more than this many standard errors when the model is refined
#: is called biased by the discretization
SHIFT_LIMIT = 0.3
#: default number of refinement rounds
REFINE_BUDGET = 2
AXES = ("step", "mesh")


def shift_of_estimate(result, residuals_fine: np.ndarray) -> np.ndarray:
    """δp of Eq. D (all parameters; 0 for fixed ones) from the residuals of a finer model
    at the estimate, with the fit's residuals and Jacobian."""
    free = np.array([n in result.free for n in result.names])
    jac = result.jacobian[:, free]
    dr = np.asarray(residuals_fine, float)[:len(result.residuals)] - result.residuals
    delta = np.zeros(len(result.names))
    delta[free] = -np.linalg.lstsq(jac, dr, rcond=None)[0]
    return delta


def check(problem: Problem, result, data: Measurements, axes: Sequence[str] = AXES) -> dict:
    """Eq. D for each refinement axis (``step``: h/2; ``mesh``: elements × 2, only for a
    problem built from a scenario with one beam). Returns {axis: {dt, elements, shift,
    shift_se, max_shift_se, worst}}; axes that cannot be refined are left out."""
    out = {}
    se = np.where(np.isfinite(result.stderr) & (result.stderr > 0), result.stderr, np.nan)
    for axis in axes:
        if axis not in AXES:
            raise ModelError(f"discretization axis must be one of {', '.join(AXES)}, got {axis!r}")
        if axis == "mesh" and problem.elements is None:
            continue
        fine = problem.refined(step=2) if axis == "step" else problem.refined(mesh=2)
        (r, _, ok), _, _ = fine._batch(_values_jit, result.estimates[None], [data])
        if not bool(ok[0]):
            raise SimulationError(f"the discretization check's refined model ({axis}: dt = {fine.dt:g} s, "
                                  f"{fine.elements} elements) fails at the estimate; fit again with "
                                  "--no-refine (discretization=False) or a smaller step",
                                  time=float("nan"), reason="refined_model_failed")
        delta = shift_of_estimate(result, r[0])
        z = delta / se
        free = [k for k, n in enumerate(result.names) if n in result.free and np.isfinite(z[k])]
        worst = max(free, key=lambda k: abs(z[k])) if free else None
        out[axis] = dict(dt_s=fine.dt, elements=fine.elements,
                         shift={result.names[k]: float(delta[k]) for k in free},
                         shift_se={result.names[k]: float(z[k]) for k in free},
                         max_shift_se=float(abs(z[worst])) if worst is not None else 0.0,
                         worst=None if worst is None else result.names[worst])
    return out


def controlled_fit(fit_fn, problem: Problem, data: Measurements, init, *, refine: bool = True,
                   budget: int = REFINE_BUDGET, limit: float = SHIFT_LIMIT, axes: Sequence[str] = AXES,
                   **options):
    """Fit, check the discretization (Eq. D) and, while an estimate moves by more than
    ``limit`` standard errors and fewer than ``budget`` refinements were made, refine the
    axes that moved it and fit again from the estimate. Returns (result, the final
    problem); ``result.discretization`` holds the record."""
    if budget < 0:
        raise ModelError(f"refine budget must be >= 0, got {budget}")
    if not limit > 0:
        raise ModelError(f"shift limit must be > 0 standard errors, got {limit}")
    result = fit_fn(problem, data, init, **options)
    rounds, refined = [], []
    while True:
        chk = check(problem, result, data, axes)
        rounds.append(dict(dt_s=problem.dt, elements=problem.elements, checks=chk,
                           estimates={n: float(v) for n, v in zip(result.names, result.estimates)}))
        over = [a for a in chk if chk[a]["max_shift_se"] > limit]
        if not over or not refine or len(refined) >= budget:
            break
        step, mesh = (2 if "step" in over else 1), (2 if "mesh" in over else 1)
        problem = problem.refined(step=step, mesh=mesh)
        refined.append(dict(step_divided_by=step, elements_multiplied_by=mesh, dt_s=problem.dt,
                            elements=problem.elements))
        start = {n: float(v) for n, v in zip(result.names, result.estimates)}
        result = fit_fn(problem, data, start, **options)
    remaining = max((c["max_shift_se"] for c in chk.values()), default=0.0)
    ok = remaining <= limit
    mesh = "" if problem.elements is None else f", {problem.elements} elements"
    what = ("nothing refined" if not refined else "refined " + ", then ".join(
        " and ".join(([f"step /{r['step_divided_by']}"] if r["step_divided_by"] > 1 else [])
                     + ([f"mesh ×{r['elements_multiplied_by']}"] if r["elements_multiplied_by"] > 1 else []))
        for r in refined))
    per_axis = "; ".join(f"{a} refinement moves {c['worst']} by {c['max_shift_se']:.2g} SE" for a, c in chk.items())
    summary = (f"{what}; final h = {problem.dt:g} s{mesh}; {per_axis or 'no axis checked'} "
               f"({'within' if ok else 'ABOVE'} the limit {limit:g} SE)")
    notes = []
    if not ok:
        worst = max(chk.values(), key=lambda c: c["max_shift_se"])
        why = ("refinement is off" if not refine else f"the refinement budget ({budget}) is spent")
        notes.append(f"the model does not explain the data at this discretization: refining it moves "
                     f"{worst['worst']} by {remaining:.2g} standard errors (limit {limit:g}) and {why}; the "
                     f"estimates are biased by the discretization: refine further (--dt, --elements)")
    result.discretization = dict(limit_se=limit, budget=budget, refine=refine, axes=list(chk),
                                 refined=refined, final_dt_s=problem.dt, final_elements=problem.elements,
                                 remaining_shift_se=remaining, within_limit=ok, rounds=rounds,
                                 summary=summary, notes=notes)
    return result, problem
