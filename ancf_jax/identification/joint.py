"""Several experiments fitted jointly: one parameter set for records of different
experiments (other initial conditions, loads or masses, given as separate problems with
the same parameters).

Each experiment e has its own :class:`~.problem.Problem` and record (N_e samples with
weights w). The joint residual vector stacks the experiments' residuals, each sample
weighted against the weight of all records together,

    r = [sqrt(Σw_1 / Σw) r_1, ..., sqrt(Σw_E / Σw) r_E],     r_e,i = sqrt(w_e,i / Σw_e) e_e,i

so that Σ r² = Σ_e Σ_i w_e,i e_e,i² / Σw (the weighted mean square over all samples,
as for one record), and its Jacobian stacks theirs. Everything downstream — the
Levenberg–Marquardt loop, the Gauss–Newton statistics, the misfit diagnostics — sees one
record of Σ N_e samples. Experiments whose systems differ only in values (a mass, a
load, an initial state of the same shapes) share one compiled program.

A noise level per record. With ``noise=[σ_1, ..., σ_E]`` (σ_e the standard deviation of
a sample of weight 1 in record e, in its output unit) each record's weights become
w_e,i / σ_e², so a record is weighted by its inverse noise variance (records of
different sensors or noise levels: without it the record with the larger numbers
dominates). The misfit diagnostics (:func:`~.report.misfit_diagnostics`: Ljung–Box
whiteness, RMS against σ_e with the χ² test) then run per record on its own residuals
r_e (``FitResult.records``), as well as over the stacked residuals, where the stated
noise is the one of the weights w/σ², sqrt(N / Σ w_e,i/σ_e²), so that the χ² statistic
is Σ_e Σ_i w_e,i e_e,i² / σ_e². The per-record χ² tests count every free parameter
against each record's samples (conservative: the parameters are shared).

Nuisance parameters per record. Problems with nuisance parameters (time offset τ,
sensor offset c, gain g; Eq. M of :func:`~.problem.measured`) keep them per record: the
joint parameter vector is the shared physical parameters followed by each record's
nuisance parameters, named ``NAME@e`` (``offset@2``: the offset of record 2), and
record e's residuals depend on the shared parameters and its own nuisance parameters
only (its Jacobian columns of the other records' nuisance parameters are zero). Two
sensors of one experiment thus each get their own offset and gain, and records of
different experiments their own trigger delay.
"""

from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np

from ..errors import ModelError
from ..validation import check_positive
from .data import Measurements
from .problem import Problem
from .report import misfit_diagnostics


class JointData(Measurements):
    """The records of a joint fit, concatenated (times restart per experiment)."""


def joint_name(name: str, record: int) -> str:
    """The joint parameter name of a record's nuisance parameter (record counted from 1)."""
    return f"{name}@{record}"


def base_name(name: str) -> str:
    """A parameter's name without a joint fit's record suffix (``offset@2`` -> ``offset``)."""
    return name.split("@", 1)[0]


class JointProblem:
    """Experiments (problems with the same physical parameters; each may have its own
    nuisance parameters, module docstring) and their records, fitted with one physical
    parameter set (:func:`fit_joint`).

    ``noise``: None, one σ for every record, or one σ per record (output units; module
    docstring); the records' weights are then divided by σ_e². ``window``: (t_start,
    t_end) [s] applied to every record."""

    def __init__(self, problems: Sequence[Problem], records: Sequence[Measurements],
                 noise: Optional[float | Sequence[float]] = None, window: Optional[tuple] = None):
        if len(problems) < 2 or len(problems) != len(records):
            raise ModelError(f"a joint fit needs at least two experiments with one record each, got "
                             f"{len(problems)} problems and {len(records)} records")
        physical = problems[0].names[:problems[0].n_physical]
        for p in problems:
            if p.names[:p.n_physical] != physical:
                raise ModelError(f"joint fit: every experiment must have the parameters {', '.join(physical)}; "
                                 f"one has {', '.join(p.names[:p.n_physical])}")
        self.problems = list(problems)
        #: the noise level of each record (None: not stated)
        self.noise = record_noise(noise, len(records))
        self.records = [p.prepare(d, window) for p, d in zip(problems, records)]
        if self.noise is not None:
            self.records = [Measurements(d.t, d.y, d.w / s ** 2, d.lines, d.source)
                            for d, s in zip(self.records, self.noise)]
        self.sizes = [len(d) for d in self.records]
        first = self.problems[0]
        k = first.n_physical
        #: the joint vector's index of each record's parameters (physical, then its nuisance)
        self.columns, nuisance, units = [], [], list(first.units[:k])
        for e, pr in enumerate(self.problems):
            start = k + len(nuisance)
            self.columns.append(np.r_[np.arange(k), start + np.arange(len(pr.nuisance))].astype(int))
            nuisance += [joint_name(n, e + 1) for n in pr.nuisance]
            units += list(pr.units[k:])
        self.system, self.params, self.output, self.nuisance = first.system, first.params, first.output, tuple(nuisance)
        if len({p.max_time_offset for p in self.problems}) > 1:
            raise ModelError("joint fit: every experiment must have the same max_time_offset")
        self.max_time_offset, self.dt, self.elements = first.max_time_offset, first.dt, first.elements
        self.name = " + ".join(p.name for p in problems)
        self.names, self.units, self.n_physical = physical + self.nuisance, tuple(units), k
        self.log_scaled = np.r_[first.log_scaled[:k], np.zeros(len(nuisance), bool)]
        self.data = JointData(np.concatenate([d.t for d in self.records]),
                              np.concatenate([d.y for d in self.records]),
                              np.concatenate([d.w for d in self.records]), None,
                              " + ".join(d.source for d in self.records))

    @property
    def compile_time_s(self) -> float:
        return sum(p.compile_time_s for p in self.problems)

    def vector(self, values=None) -> np.ndarray:
        """The joint parameter vector from {name: value} (nuisance parameters by their
        joint names ``NAME@e``) or a sequence in :attr:`names` order; missing names keep
        the first system's values and the nuisance parameters' neutral values."""
        if values is not None and not isinstance(values, dict):
            arr = np.asarray(values, float).reshape(-1)
            if arr.shape != (len(self.names),):
                raise ModelError(f"expected {len(self.names)} parameter values ({', '.join(self.names)}), "
                                 f"got {arr.size}")
            values = dict(zip(self.names, arr))
        values = dict(values or {})
        unknown = set(values) - set(self.names)
        if unknown:
            raise ModelError(f"unknown parameter(s) {sorted(unknown)}; this joint fit has {', '.join(self.names)}")
        p = np.zeros(len(self.names))
        # the first record last: its system's values of the physical parameters stand
        for e, (pr, cols) in reversed(list(enumerate(zip(self.problems, self.columns)))):
            own = {n: values[j] for n, j in zip(pr.names, (self.names[c] for c in cols)) if j in values}
            p[cols] = pr.vector(own)  # each record's checks (ranges, bounds) with its own names
        return p

    def prepare(self, data, window=None):
        if window is not None:
            raise ModelError("joint fit: give each record already restricted to its window")
        return data

    def evaluate(self, p, datasets):
        """Stacked residuals and Jacobians of the experiments (shapes as
        :meth:`Problem.evaluate`, the first experiment's output curve and layout)."""
        total = float(sum(np.sum(d.w) for d in self.records))
        p = np.atleast_2d(np.asarray(p, float))
        rs, js, oks = [], [], []
        first = None
        for pr, d, cols in zip(self.problems, self.records, self.columns):
            r, jac_e, yg, ok, layout, _ = pr.evaluate(p[:, cols], [d])
            jac = np.zeros(jac_e.shape[:2] + (p.shape[1],))
            jac[:, :, cols] = jac_e
            f = np.sqrt(np.sum(d.w) / total)
            rs.append(f * r)
            js.append(f * jac)
            oks.append(ok)
            if first is None:
                first = (yg, layout)
        return (np.concatenate(rs, axis=1), np.concatenate(js, axis=1), first[0], np.all(oks, axis=0),
                first[1], 0.0)


    @property
    def stacked_noise(self) -> Optional[float]:
        """The noise level of a sample of weight 1 in the stacked record (weights
        w/σ_e²): sqrt(N / Σ w_e,i/σ_e²) over the N samples of positive weight."""
        if self.noise is None:
            return None
        w = self.data.w[self.data.w > 0]
        return math.sqrt(len(w) / float(np.sum(w)))

    def per_record(self, result) -> list[dict]:
        """Per-record residual RMS and misfit diagnostics of a joint fit's result, from
        its stacked residuals (no new simulation): r_e = (stacked slice) / sqrt(Σw_e/Σw),
        i.e. r_e,i = sqrt(w_e,i/Σw_e) e_e,i, and the model at the samples y + e."""
        total = float(sum(np.sum(d.w) for d in self.records))
        n_free = len(result.free)
        out, start = [], 0
        for k, (pr, d) in enumerate(zip(self.problems, self.records)):
            r = result.residuals[start:start + len(d)] / math.sqrt(float(np.sum(d.w)) / total)
            start += len(d)
            pos = d.w > 0
            sigma = None if self.noise is None else self.noise[k]
            diag = misfit_diagnostics(r[pos], noise=sigma, n_params=n_free)
            e = np.where(pos, r / np.sqrt(np.where(pos, d.w / float(np.sum(d.w)), 1.0)), 0.0)
            out.append(dict(record=k + 1, source=d.source, model=pr.name, n_samples=int(np.sum(pos)),
                            residual_rms=math.sqrt(float(r @ r)), noise=sigma, diagnostics=diag,
                            _t=d.t, _y=d.y, _model=d.y + e))
        return out

    def fit(self, init=None, **options):
        """The joint fit from ``init`` (:func:`fit_joint`; options as
        :func:`~.fit.fit_batch`, without ``noise`` and ``window``, given to the problem)."""
        from .fit import fit_batch
        result = fit_batch(self, [self.data], [init], noise=self.stacked_noise, **options)[0]
        result.records = self.per_record(result)
        return result


def record_noise(noise, count: int) -> Optional[list[float]]:
    """The noise level of each of ``count`` records from None, one σ or a sequence of
    ``count`` σ (each > 0, output units); ModelError naming the entry otherwise."""
    if noise is None:
        return None
    if np.ndim(noise) == 0:
        return [check_positive("noise", noise, "output units")] * count
    noise = list(noise)
    if len(noise) != count:
        raise ModelError(f"noise: give one level per record ({count}), got {len(noise)}")
    return [check_positive(f"noise[{k}]", s, "output units") for k, s in enumerate(noise)]


def fit_joint(problems: Sequence[Problem], records: Sequence[Measurements], init=None, *,
              noise: Optional[float | Sequence[float]] = None, window: Optional[tuple] = None, **options):
    """One parameter set fitted to several experiments' records (module docstring).

    Args:
        problems: one problem per experiment or sensor (the same parameters).
        records: the record of each problem, in the same order.
        init: initial values {name: value} (one start).
        noise: None, one σ for all records, or one σ per record (the standard deviation
            of a sample of weight 1, each record's output unit): weights w/σ_e² and the
            per-record χ² test of the residual RMS against σ_e.
        window: (t_start, t_end) [s] applied to every record.
        **options: as :func:`~.fit.fit_batch` (no discretization check).

    Returns a :class:`~.report.FitResult` over all samples (``data`` the concatenated
    records; ``t_grid``/``y_fit`` the first experiment's curve; ``records`` the
    per-record residual RMS and misfit diagnostics, :meth:`JointProblem.per_record`)."""
    return JointProblem(problems, records, noise, window).fit(init, **options)
