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

**Strain measure (model form).** Refinement cannot remove a difference of constitutive
model: the beam's strain measures (Green–Lagrange axial strain and exact curvature by
default; engineering strain and material curvature in Exudyn's cable) are different
models at finite strain, and measured data follow neither exactly. On foreign data made
with the other measures (Exudyn's M1 at 48 elements) the estimates of α sat 0.54 SE from
the truth with the reported SE, and 17 of 20 seeds held it within 2 SE
(docs/identification.md). After the refinement loop the model is therefore evaluated
once more, at the final discretization, with each beam's strain measures exchanged
(:data:`OTHER_MEASURE`), and Eq. D gives the shift δp_form of the estimates. It is not
refined away: it is a model-form (type B) uncertainty, reported with the combined
standard uncertainty

    u_k = sqrt(SE_k² + Σ_axes δp_disc,k² + δp_form,k²)              (Eq. U)

(δp_disc: the last round's discretization shifts, within ``limit`` SE after a
successful refinement), and a note when δp_form exceeds ``limit`` SE: the estimate
depends on the assumed strain measure, and the Gauss–Newton SE alone understates its
uncertainty unless the structure's strain measure is known. Cost: one more compilation
and run without derivatives.
"""

from __future__ import annotations

from typing import Optional, Sequence

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
#: the model-form check's exchange of strain measures: {Formulation field: {value: other value}}
#: (a small-strain curvature has no finite-strain counterpart and is kept)
OTHER_MEASURE = {"axial_strain": {"green_lagrange": "engineering", "engineering": "green_lagrange"},
                 "curvature": {"exact": "material", "material": "exact"}}


def shift_of_estimate(result, residuals_fine: np.ndarray) -> np.ndarray:
    """δp of Eq. D (all parameters; 0 for fixed ones) from the residuals of a finer model
    at the estimate, with the fit's residuals and Jacobian."""
    free = np.array([n in result.free for n in result.names])
    jac = result.jacobian[:, free]
    dr = np.asarray(residuals_fine, float)[:len(result.residuals)] - result.residuals
    delta = np.zeros(len(result.names))
    delta[free] = -np.linalg.lstsq(jac, dr, rcond=None)[0]
    return delta


def _shift(other: Problem, result, data: Measurements, what: str) -> dict:
    """Eq. D for the model ``other`` at the estimate: {dt_s, elements, shift, shift_se,
    max_shift_se, worst} over the free parameters with a finite SE."""
    se = np.where(np.isfinite(result.stderr) & (result.stderr > 0), result.stderr, np.nan)
    (r, _, ok), _, _ = other._batch(_values_jit, result.estimates[None], [data])
    if not bool(ok[0]):
        raise SimulationError(f"the {what} model (dt = {other.dt:g} s, {other.elements} elements) fails at "
                              "the estimate; fit again with --no-refine (discretization=False) or a smaller step",
                              time=float("nan"), reason="refined_model_failed")
    delta = shift_of_estimate(result, r[0])
    z = delta / se
    free = [k for k, n in enumerate(result.names) if n in result.free and np.isfinite(z[k])]
    worst = max(free, key=lambda k: abs(z[k])) if free else None
    return dict(dt_s=other.dt, elements=other.elements,
                shift={result.names[k]: float(delta[k]) for k in free},
                shift_se={result.names[k]: float(z[k]) for k in free},
                max_shift_se=float(abs(z[worst])) if worst is not None else 0.0,
                worst=None if worst is None else result.names[worst])


def check(problem: Problem, result, data: Measurements, axes: Sequence[str] = AXES) -> dict:
    """Eq. D for each refinement axis (``step``: h/2; ``mesh``: elements × 2, only for a
    problem built from a scenario with one beam). Returns {axis: {dt, elements, shift,
    shift_se, max_shift_se, worst}}; axes that cannot be refined are left out."""
    out = {}
    for axis in axes:
        if axis not in AXES:
            raise ModelError(f"discretization axis must be one of {', '.join(AXES)}, got {axis!r}")
        if axis == "mesh" and problem.elements is None:
            continue
        fine = problem.refined(step=2) if axis == "step" else problem.refined(mesh=2)
        out[axis] = _shift(fine, result, data, f"discretization check's refined ({axis})")
    return out


def other_measures(problem: Problem) -> dict:
    """{beam name: {Formulation field: the other value}} of the model-form check
    (:data:`OTHER_MEASURE`); empty where nothing can be exchanged."""
    out = {}
    for name, beam in zip(problem.system.beam_names, problem.system.beams):
        f = {k: alt[getattr(beam.formulation, k)] for k, alt in OTHER_MEASURE.items()
             if getattr(beam.formulation, k) in alt}
        if f:
            out[name] = f
    return out


def strain_measure_check(problem: Problem, result, data: Measurements, discretization_shifts: dict,
                         limit: float = SHIFT_LIMIT) -> Optional[dict]:
    """The model-form check (module docstring, Eq. D with the strain measures exchanged,
    and Eq. U). Returns None where the problem's strain measures cannot be exchanged (not
    built from a scenario, or no beam with a finite-strain measure)."""
    other = other_measures(problem)
    if problem.recipe is None or not other:
        return None
    try:
        reformulated = problem.reformulated(other)
    except ModelError as e:  # a scenario whose other measures cannot be built (its laws, its checks)
        return dict(exchanged=other, checked=False, notes=[], summary=f"not checked: {e}")
    chk = _shift(reformulated, result, data, "model-form check's (strain measures exchanged)")
    free = [k for k, n in enumerate(result.names) if n in result.free]
    total = {}
    for k in free:
        n = result.names[k]
        parts = [result.stderr[k] ** 2, chk["shift"].get(n, 0.0) ** 2]
        parts += [c["shift"].get(n, 0.0) ** 2 for c in discretization_shifts.values()]
        total[n] = float(np.sqrt(sum(parts)))
    exchanged = "; ".join(f"{b}: " + ", ".join(f"{k} {v}" for k, v in f.items()) for b, f in other.items())
    ok = chk["max_shift_se"] <= limit
    summary = (f"with the other strain measures ({exchanged}) {chk['worst']} moves by "
               f"{chk['max_shift_se']:.2g} SE ({'within' if ok else 'ABOVE'} the limit {limit:g} SE); standard "
               "uncertainty with discretization and strain measure: "
               + ", ".join(f"{n} ± {u:.2g}" for n, u in total.items()))
    notes = [] if ok else [
        f"the estimate of {chk['worst']} depends on the assumed strain measure: the other measures ({exchanged}) "
        f"move it by {chk['max_shift_se']:.2g} standard errors, and no refinement removes that; unless the "
        f"structure's strain measure is known, quote the combined uncertainty "
        + ", ".join(f"{n} ± {u:.2g}" for n, u in total.items()) + " (Gauss–Newton SE, discretization and "
        "strain-measure shifts in quadrature) rather than the SE alone"]
    return dict(exchanged=other, checked=True, limit_se=limit, within_limit=ok, total_stderr=total, summary=summary,
                notes=notes, **chk)


def controlled_fit(fit_fn, problem: Problem, data: Measurements, init, *, refine: bool = True,
                   budget: int = REFINE_BUDGET, limit: float = SHIFT_LIMIT, axes: Sequence[str] = AXES,
                   strain_measure: bool = True, **options):
    """Fit, check the discretization (Eq. D) and, while an estimate moves by more than
    ``limit`` standard errors and fewer than ``budget`` refinements were made, refine the
    axes that moved it and fit again from the estimate; then (``strain_measure``) the
    model-form check at the final discretization. Returns (result, the final problem);
    ``result.discretization`` holds the record, ``result.model_form`` the model-form
    check (None where it was not made)."""
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
    if strain_measure:
        result.model_form = strain_measure_check(problem, result, data, chk, limit)
    return result, problem
