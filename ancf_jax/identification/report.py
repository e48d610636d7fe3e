"""Fit reports: estimates, Gauss–Newton standard errors and correlations, an honest
verdict on what the data determine, JSON, text and a figure.

Statistics at the optimum (Gauss–Newton approximation): with weighted residuals
r = sqrt(w/Σw)(y_sim − y) and J = ∂r/∂p over the N samples with positive weight and the
n free parameters,

    s² = Σ r² / (N − n),      Cov(p) ≈ s² (JᵀJ)⁻¹,      SE_k = sqrt(Cov_kk),
    ρ_kl = Cov_kl / (SE_k SE_l),

i.e. the measurement variance is estimated from the residuals (weights are relative).

Verdict per parameter (damping coefficients are ≥ 0): *determined* when the estimate
is at least two standard errors from zero; *not distinguishable from zero* otherwise
(the value is not printed; the report gives the 95 % upper bound estimate + 2 SE);
*not determined* when the output does not depend on it or JᵀJ is numerically singular.
Pairs with |ρ| > 0.95 are flagged: the data then fix mainly a combination of the two.
A parameter the fit drove to its floor (ten decades below its start, i.e. 0) is *not
distinguishable from zero* whatever its standard error. ``fit.json`` carries, per
parameter, ``NAME_identifiable`` (true only when determined; null when fixed) and
``NAME_identifiability`` (the reason, from the standard error and the correlations).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Optional

import numpy as np

#: a parameter is "determined" when estimate >= SIGNIFICANCE * standard error
SIGNIFICANCE = 2.0
#: correlations above this (in magnitude) are reported as strong
STRONG_CORRELATION = 0.95
#: condition number of the scaled JᵀJ beyond which the fit is called singular
MAX_CONDITION = 1e12

DETERMINED = "determined"
ZERO = "not distinguishable from zero"
UNDETERMINED = "not determined"
FIXED = "fixed"


def gauss_newton_statistics(r: np.ndarray, jac: np.ndarray, n_samples: int):
    """(standard errors (n,), correlation (n, n), s²) from residuals r (N,) and
    J = ∂r/∂p (N, n) at the optimum; infinite standard errors where JᵀJ is singular."""
    n = jac.shape[1]
    dof = max(1, n_samples - n)
    s2 = float(r @ r) / dof
    a = jac.T @ jac
    d = np.sqrt(np.diag(a))
    se = np.full(n, np.inf)
    corr = np.full((n, n), np.nan)
    live = d > 0
    if np.any(live):
        scaled = a[np.ix_(live, live)] / np.outer(d[live], d[live])
        if np.linalg.cond(scaled) < MAX_CONDITION:
            inv = np.linalg.inv(scaled)
            cov = s2 * inv / np.outer(d[live], d[live])
            se[live] = np.sqrt(np.diag(cov))
            sub = cov / np.outer(se[live], se[live])
            idx = np.nonzero(live)[0]
            corr[np.ix_(idx, idx)] = sub
    np.fill_diagonal(corr, 1.0)
    return se, corr, s2


#: Ljung–Box p-value below which the residuals are called structured (not white)
WHITENESS_LEVEL = 0.01
#: largest lag of the Ljung–Box statistic (fewer for short records: N // 5)
MAX_LAG = 20


def autocorrelation(u: np.ndarray, lags: int) -> np.ndarray:
    """Sample autocorrelation ρ_k, k = 1..lags, of a series u (N,) (Box & Jenkins):

        ρ_k = Σ_{i=k}^{N−1} (u_i − ū)(u_{i−k} − ū) / Σ_i (u_i − ū)²
    """
    u = np.asarray(u, float) - np.mean(u)
    c0 = float(u @ u)
    if c0 == 0.0:
        return np.zeros(lags)
    return np.array([float(u[k:] @ u[:-k]) / c0 for k in range(1, lags + 1)])


def ljung_box(u: np.ndarray, lags: Optional[int] = None) -> tuple[float, float, int]:
    """Ljung–Box whiteness test of a series u (N,): (Q, p-value, lags m) with

        Q = N (N + 2) Σ_{k=1}^{m} ρ_k² / (N − k),     Q ~ χ²(m) for white noise

    (Ljung & Box 1978); the p-value is the χ²(m) upper tail, ``scipy.stats.chi2.sf``.
    Default m = min(20, N // 5)."""
    from scipy.stats import chi2
    n = len(u)
    m = max(1, min(MAX_LAG, n // 5)) if lags is None else int(lags)
    rho = autocorrelation(u, m)
    q = float(n * (n + 2) * np.sum(rho ** 2 / (n - np.arange(1, m + 1))))
    return q, float(chi2.sf(q, m)), m


def misfit_diagnostics(r: np.ndarray, *, noise: Optional[float] = None, n_params: int = 0) -> dict:
    """Does the model explain the data? From the weighted residuals r (N,) of the samples
    with positive weight, in time order (r_i = sqrt(w_i/Σw) e_i):

    * whiteness: Ljung–Box Q over m lags and its p-value (:func:`ljung_box`), and the
      lag-1 autocorrelation; p < :data:`WHITENESS_LEVEL` means structured residuals
      (model error, an unmodelled offset, drift or delay, or coloured noise), and the
      Gauss–Newton standard errors, which assume white noise, are then too small;
    * with a stated noise level σ (the standard deviation of a sample of weight 1):
      RMS/σ and the χ² test of Σ w e²/σ² ~ χ²(N − n): a p-value below 0.01 in the upper
      tail means the residuals are larger than the noise can explain.

    Returns a JSON-ready dict; ``notes`` holds the sentences for the report."""
    from scipy.stats import chi2
    r = np.asarray(r, float)
    n = len(r)
    q, p, m = ljung_box(r)
    rho1 = float(autocorrelation(r, 1)[0]) if n > 1 else 0.0
    rms = math.sqrt(float(r @ r))
    d = dict(n=n, ljung_box_q=q, ljung_box_p=p, ljung_box_lags=m, lag1_autocorrelation=rho1,
             residual_rms=rms, white=bool(p >= WHITENESS_LEVEL), noise=noise, rms_over_noise=None,
             chi2_p_high=None, notes=[])
    if p < WHITENESS_LEVEL:
        d["notes"].append(
            f"the model does not explain the data: the residuals are not white (Ljung–Box Q = {q:.4g} over "
            f"{m} lags, p = {p:.2g}; lag-1 autocorrelation {rho1:+.3f}); look for a model error (mesh, "
            "step, physics), an unmodelled sensor offset, gain or trigger delay, or coloured noise; the "
            "standard errors assume white noise and are too small")
    if noise is not None and noise > 0:
        dof = max(1, n - n_params)
        x = n * rms ** 2 / noise ** 2
        hi, lo = float(chi2.sf(x, dof)), float(chi2.cdf(x, dof))
        d.update(rms_over_noise=rms / noise, chi2_p_high=hi, chi2_p_low=lo)
        if hi < 0.01:
            d["notes"].append(
                f"the model does not explain the data: the residual RMS {rms:.4g} is {rms / noise:.3g} × "
                f"the stated noise {noise:.4g} (χ² test p = {hi:.2g})")
        elif lo < 0.01:
            d["notes"].append(
                f"the residual RMS {rms:.4g} is only {rms / noise:.3g} × the stated noise {noise:.4g} "
                f"(χ² test p = {lo:.2g} in the lower tail): the noise level is overstated or the data "
                "were filtered")
    return d


@dataclasses.dataclass
class FitResult:
    """Outcome of one fit (one data set, one initial guess).

    Attributes:
        names, units: all parameters of the problem; free: which were fitted.
        init: initial values (physical units); estimates: final values (raw optimiser
            output, also for parameters the data do not determine).
        stderr: Gauss–Newton standard errors (NaN for fixed parameters).
        correlation: correlation matrix of the free parameters (n_free × n_free).
        status: per parameter, one of determined / not distinguishable from zero /
            not determined / fixed.
        loss_history: weighted mean squared error [output unit²] at the start and after
            every iteration.
        iterations: optimiser iterations; evaluations: simulations with derivatives.
        converged, stop_reason: the stopping rule that ended the fit.
        residual_rms: sqrt(final loss) [output unit]; n_samples: samples with w > 0.
        output_unit: the unit of the fitted output (of ``residual_rms``, ``noise``).
        wall_time_s: fit time without compilation; compile_time_s: compilation.
        t_grid, y_fit, y_init: the simulated output on the step grid at the estimate and
            at the initial guess; data: the measurements fitted.
        records: a joint fit's records (:func:`~.joint.fit_joint`): per record its
            source, model, samples, residual RMS, stated noise and misfit diagnostics.
        profiles: {name: profile-likelihood interval} (:func:`~.uncertainty.profile_interval`).
        discretization: the discretization check's record (:mod:`.discretization`).
        model_form: the strain-measure check's record, with the combined standard
            uncertainty ``total_stderr`` (Eq. U of :mod:`.discretization`).
    """

    names: tuple
    units: tuple
    free: tuple
    init: np.ndarray
    estimates: np.ndarray
    stderr: np.ndarray
    correlation: np.ndarray
    status: tuple
    loss_history: list
    iterations: int
    evaluations: int
    converged: bool
    stop_reason: str
    residual_rms: float
    n_samples: int
    wall_time_s: float
    compile_time_s: float
    method: str
    t_grid: np.ndarray
    y_fit: np.ndarray
    y_init: np.ndarray
    data: object = None
    model: str = ""
    output: str = ""
    output_unit: str = ""
    nuisance: tuple = ()
    diagnostics: Optional[dict] = None
    residuals: Optional[np.ndarray] = None
    jacobian: Optional[np.ndarray] = None
    dt: Optional[float] = None
    elements: Optional[int] = None
    y_measured: Optional[np.ndarray] = None
    discretization: Optional[dict] = None
    bootstrap: Optional[dict] = None
    records: Optional[list] = None
    profiles: Optional[dict] = None
    model_form: Optional[dict] = None

    # ------------------------------------------------------------------ verdicts
    def value(self, name: str) -> Optional[float]:
        """The estimate if the data determine it (or it was fixed), else None."""
        k = self.names.index(name)
        return float(self.estimates[k]) if self.status[k] in (DETERMINED, FIXED) else None

    def upper_bound(self, name: str) -> Optional[float]:
        """95 % upper bound (estimate + 2 SE) of a parameter not distinguishable from zero."""
        k = self.names.index(name)
        if self.status[k] != ZERO:
            return None
        return float(self.estimates[k] + SIGNIFICANCE * self.stderr[k])

    def identifiable(self, name: str) -> Optional[bool]:
        """Whether the data determine ``name`` (None for a fixed parameter)."""
        s = self.status[self.names.index(name)]
        return None if s == FIXED else s == DETERMINED

    def identifiability(self, name: str) -> str:
        """One sentence: why ``name`` is or is not determined, from its standard error
        and its correlations."""
        k = self.names.index(name)
        s, u, se, est = self.status[k], self.units[k], self.stderr[k], self.estimates[k]
        free = [n for n in self.names if n in self.free]
        corr = ""
        if name in free and len(free) > 1:
            i = free.index(name)
            rhos = [(abs(self.correlation[i, j]), free[j], self.correlation[i, j])
                    for j in range(len(free)) if j != i and np.isfinite(self.correlation[i, j])]
            if rhos:
                _, other, rho = max(rhos)
                corr = f"; correlation with {other} {rho:+.3f}"
        if s == FIXED:
            return "fixed (not fitted)"
        if s == UNDETERMINED:
            return ("the fitted output does not depend on it, or it cannot be separated from the other "
                    "parameters (JᵀJ is singular)")
        if name in self.nuisance:
            return (f"nuisance parameter of the measurement: {est:.6g} ± {se:.2g} {u}"
                    + (f"{corr}" if corr else ""))
        if s == ZERO:
            return (f"not distinguishable from zero: the estimate {est:.3g} {u} is within "
                    f"{SIGNIFICANCE:g} standard errors ({se:.3g} {u}) of 0, so the data cannot tell it "
                    f"from 0; 95 % upper bound {self.upper_bound(name):.3g} {u}{corr}")
        return f"determined: relative standard error {se / abs(est):.2%}{corr}"

    def notes(self) -> list[str]:
        """Sentences on identifiability (strong correlations, undetermined parameters)."""
        out = []
        free = [n for n in self.names if n in self.free]
        for i, a in enumerate(free):
            for j in range(i + 1, len(free)):
                rho = self.correlation[i, j]
                if np.isfinite(rho) and abs(rho) > STRONG_CORRELATION:
                    out.append(f"{a} and {free[j]} are strongly correlated (rho = {rho:+.3f}): the data "
                               f"determine mainly a combination of them, not each one")
        for n, s in zip(self.names, self.status):
            k = self.names.index(n)
            if s == ZERO:
                out.append(f"{n} is not distinguishable from zero: its estimate is within "
                           f"{SIGNIFICANCE:g} standard errors ({self.stderr[k]:.3g} {self.units[k]}) of 0; "
                           f"95 % upper bound {self.upper_bound(n):.3g} {self.units[k]}")
            elif s == UNDETERMINED:
                out.append(f"{n} is not determined by the data (the output does not depend on it, "
                           "or the parameters are not separable: JᵀJ is singular)")
        if self.diagnostics:
            out += self.diagnostics["notes"]
        for rec in self.records or ():
            out += [f"record {rec['record']} ({rec['source']}): {n}" for n in rec["diagnostics"]["notes"]]
        if self.discretization:
            out += self.discretization["notes"]
        if self.model_form:
            out += self.model_form["notes"]
        return out

    # ------------------------------------------------------------------ output
    def units_map(self) -> dict:
        """{key: unit} of the report's numbers whose key does not say its unit: each
        parameter (also as ``NAME_stderr``, ``NAME_upper_95`` and inside ``init``,
        ``raw_estimates``, ``bootstrap``, ``discretization``, ``model_form``, ``profile``), ``residual_rms`` and the
        noise (output unit), ``loss_history`` (output unit squared)."""
        out_u = self.output_unit or "output unit"
        units = {}
        for n, u in zip(self.names, self.units):
            units.update({n: u, f"{n}_stderr": u, f"{n}_upper_95": u})
        units.update(residual_rms=out_u, noise=out_u, sigma=out_u, loss_history=f"({out_u})^2", loss=f"({out_u})^2")
        return units

    def to_dict(self) -> dict:
        """JSON-ready report; ``NAME`` is null unless the data determine it. Keys of
        dimensional numbers end in their unit (``dt_s``, ``wall_time_s``) or are in the
        ``units`` map (:meth:`units_map`)."""
        d = dict(model=self.model, output=self.output, method=self.method,
                 data=getattr(self.data, "source", None), params=list(self.names), free=list(self.free))
        for k, n in enumerate(self.names):
            d[n] = self.value(n)
            d[f"{n}_stderr"] = _num(self.stderr[k]) if self.status[k] != FIXED else None
            d[f"{n}_status"] = self.status[k]
            d[f"{n}_identifiable"] = self.identifiable(n)
            d[f"{n}_identifiability"] = self.identifiability(n)
            d[f"{n}_unit"] = self.units[k]
            if self.status[k] == ZERO:
                d[f"{n}_upper_95"] = self.upper_bound(n)
        d["init"] = {n: float(v) for n, v in zip(self.names, self.init)}
        d["raw_estimates"] = {n: float(v) for n, v in zip(self.names, self.estimates)}
        d["correlation"] = {"params": [n for n in self.names if n in self.free],
                            "matrix": [[_num(x) for x in row] for row in self.correlation]}
        d["nuisance"] = list(self.nuisance)
        d["notes"] = self.notes()
        d["diagnostics"] = None if self.diagnostics is None else {
            k: v for k, v in self.diagnostics.items() if k != "notes"}
        d["discretization"] = None if self.discretization is None else {
            k: v for k, v in self.discretization.items() if k != "notes"}
        d["model_form"] = None if self.model_form is None else {
            k: v for k, v in self.model_form.items() if k != "notes"}
        d["bootstrap"] = self.bootstrap
        if self.profiles is not None:
            d["profile"] = self.profiles
        if self.records is not None:
            d["records"] = [{k: ({a: b for a, b in v.items() if a != "notes"} if k == "diagnostics" else v)
                             for k, v in rec.items() if not k.startswith("_")} for rec in self.records]
        d["dt_s"] = self.dt
        d["elements"] = self.elements
        d.update(residual_rms=self.residual_rms, n_samples=self.n_samples,
                 loss_history=[float(x) for x in self.loss_history], iterations=self.iterations,
                 evaluations=self.evaluations, converged=self.converged, stop_reason=self.stop_reason,
                 wall_time_s=self.wall_time_s, compile_time_s=self.compile_time_s)
        d["units"] = self.units_map()
        return d

    def save_json(self, path) -> dict:
        d = self.to_dict()
        Path(path).write_text(json.dumps(d, indent=2))
        return d

    def summary(self) -> str:
        """A few lines for the terminal."""
        head = (f"{self.model or 'model'}: fit of {self.output or 'output'} to "
                f"{getattr(self.data, 'source', 'data')} ({self.n_samples} samples), {self.method}: "
                f"{'converged' if self.converged else 'NOT converged'} after {self.iterations} iterations "
                f"({self.stop_reason}); {self.wall_time_s:.1f} s + {self.compile_time_s:.1f} s compile")
        lines = [head]
        width = max(len(n) for n in self.names)
        for k, n in enumerate(self.names):
            u = self.units[k]
            s = self.status[k]
            if s == DETERMINED:
                tag = " (nuisance)" if n in self.nuisance else ""
                lines.append(f"  {n:<{width}} = {self.estimates[k]:.6g} ± {self.stderr[k]:.2g} {u}{tag}")
            elif s == FIXED:
                lines.append(f"  {n:<{width}} = {self.estimates[k]:.6g} {u} (fixed)")
            elif s == ZERO:
                lines.append(f"  {n:<{width}} : not distinguishable from zero (SE {self.stderr[k]:.2g} {u}); "
                             f"< {self.upper_bound(n):.3g} {u} at 95 %")
            else:
                lines.append(f"  {n:<{width}} : not determined by the data")
        free = [n for n in self.names if n in self.free]
        for i, a in enumerate(free):
            for j in range(i + 1, len(free)):
                lines.append(f"  correlation({a}, {free[j]}) = {self.correlation[i, j]:+.3f}")
        lines.append(f"  residual RMS {self.residual_rms:.4g} (loss {self.loss_history[0]:.3g} -> "
                     f"{self.loss_history[-1]:.3g})")
        if self.diagnostics:
            lines.append(f"  residuals {_whiteness(self.diagnostics)}")
        for rec in self.records or ():
            lines.append(f"  record {rec['record']} ({rec['source']}, {rec['model']}): {rec['n_samples']} samples, "
                         f"residual RMS {rec['residual_rms']:.4g}; residuals {_whiteness(rec['diagnostics'])}")
        dz = self.discretization
        if dz:
            lines.append(f"  discretization: {dz['summary']}")
        if self.model_form:
            lines.append(f"  strain measure: {self.model_form['summary']}")
        for n, iv in (self.profiles or {}).items():
            u = self.units[self.names.index(n)]
            low = "0 (its bound)" if iv["lower_at_bound"] else f"{iv['lower']:.6g}"
            lines.append(f"  profile likelihood {n} (Δ = {iv['level']:g}): [{low}, {iv['upper']:.6g}] {u}; "
                         f"Gauss–Newton ±{math.sqrt(iv['level']):g} SE [{iv['gn_lower']:.6g}, {iv['gn_upper']:.6g}]")
        bs = self.bootstrap
        if bs:
            lines.append("  bootstrap (" + str(bs["members"]) + " members): " + ", ".join(
                f"{n} sd {bs['std'][n]:.2g} (GN SE {bs['gn_stderr'][n]:.2g})" for n in bs["std"]))
        lines += [f"  note: {n}" for n in self.notes()]
        return "\n".join(lines)

    def figure(self, path=None, *, ylabel: str = "tip y [m]"):
        """Data, fitted and initial curves, and the residuals (saved if ``path``)."""
        from ..plotting import _finish, plt
        fig, (ax, ax2) = plt.subplots(2, 1, figsize=(7.5, 5.2), sharex=True,
                                      gridspec_kw=dict(height_ratios=[3, 1.3]))
        if self.records:
            return self._records_figure(fig, ax, ax2, ylabel, path)
        d = self.data
        if d is not None:
            ax.plot(d.t, d.y, ".", ms=2.0, color="0.55", label=f"data ({len(d)} samples)")
        init = ", ".join(f"{n} = {v:.3g}" for n, v in zip(self.names, self.init))
        ax.plot(self.t_grid, self.y_init, "--", color="tab:orange", lw=1.1, label=f"initial ({init})")
        def label(k, n):
            if self.status[k] in (DETERMINED, FIXED):
                return f"{n} = {self.estimates[k]:.4g}"
            if self.status[k] == ZERO:
                return f"{n} < {self.upper_bound(n):.3g} (95 %, not identifiable)"
            return f"{n} not identifiable"
        fit = ", ".join(label(k, n) for k, n in enumerate(self.names))
        if self.nuisance and self.y_measured is not None and d is not None:
            ax.plot(d.t, self.y_measured, color="tab:blue", lw=1.3, label=f"fitted ({fit})")
        else:
            ax.plot(self.t_grid, self.y_fit, color="tab:blue", lw=1.3, label=f"fitted ({fit})")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_title(f"{self.model} {self.output}: residual RMS {self.residual_rms:.3g}", fontsize=10)
        if d is not None:
            model = self.y_measured if self.y_measured is not None else np.interp(d.t, self.t_grid, self.y_fit)
            ax2.plot(d.t, model - d.y, ".", ms=1.5, color="tab:blue")
        _residual_axis(ax2)
        return _finish(fig, path)

    def _records_figure(self, fig, ax, ax2, ylabel, path):
        """A joint fit's figure: each record's data and the fitted model at its samples,
        and the residuals (model − data)."""
        from ..plotting import _finish
        for rec in self.records:
            label = f"record {rec['record']} ({rec['source']})"
            dots = ax.plot(rec["_t"], rec["_y"], ".", ms=2.0, alpha=0.5, label=f"{label}: data")[0]
            ax.plot(rec["_t"], rec["_model"], color=dots.get_color(), lw=1.2, label=f"{label}: fitted")
            ax2.plot(rec["_t"], rec["_model"] - rec["_y"], ".", ms=1.5, color=dots.get_color())
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        ax.set_title(f"joint fit of {len(self.records)} records: residual RMS {self.residual_rms:.3g}", fontsize=10)
        _residual_axis(ax2)
        return _finish(fig, path)


def _residual_axis(ax2) -> None:
    """Label the residual axis of a fit figure."""
    ax2.axhline(0.0, color="k", lw=0.6)
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("fit − data")
    ax2.grid(alpha=0.3)


def _whiteness(dg: dict) -> str:
    """``white: Ljung–Box p = …`` (or STRUCTURED) and RMS / stated noise, for a summary line."""
    noise = f"; RMS / stated noise {dg['rms_over_noise']:.3g}" if dg.get("rms_over_noise") is not None else ""
    return (f"{'white' if dg['white'] else 'STRUCTURED'}: Ljung–Box p = {dg['ljung_box_p']:.2g} "
            f"({dg['ljung_box_lags']} lags), lag-1 autocorrelation {dg['lag1_autocorrelation']:+.3f}{noise}")


def _num(x) -> Optional[float]:
    x = float(x)
    return x if math.isfinite(x) else None
