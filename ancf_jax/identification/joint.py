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
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import ModelError
from .data import Measurements
from .problem import Problem


class JointData(Measurements):
    """The records of a joint fit, concatenated (times restart per experiment)."""


class JointProblem:
    """Experiments (problems with the same parameter names, without nuisance
    parameters) and their records, fitted with one parameter set (:func:`fit_joint`)."""

    def __init__(self, problems: Sequence[Problem], records: Sequence[Measurements]):
        if len(problems) < 2 or len(problems) != len(records):
            raise ModelError(f"a joint fit needs at least two experiments with one record each, got "
                             f"{len(problems)} problems and {len(records)} records")
        names = problems[0].names
        for p in problems:
            if p.names != names:
                raise ModelError(f"joint fit: every experiment must have the parameters {', '.join(names)}; "
                                 f"one has {', '.join(p.names)}")
            if p.nuisance:
                raise ModelError("joint fit: nuisance parameters are not supported across experiments")
        self.problems = list(problems)
        self.records = [p.prepare(d) for p, d in zip(problems, records)]
        self.sizes = [len(d) for d in self.records]
        first = self.problems[0]
        self.system, self.params, self.output, self.nuisance = first.system, first.params, first.output, ()
        self.max_time_offset, self.dt, self.elements = first.max_time_offset, first.dt, first.elements
        self.name = " + ".join(p.name for p in problems)
        self.names, self.units, self.n_physical = names, first.units, first.n_physical
        self.log_scaled = first.log_scaled
        self.data = JointData(np.concatenate([d.t for d in self.records]),
                              np.concatenate([d.y for d in self.records]),
                              np.concatenate([d.w for d in self.records]), None,
                              " + ".join(d.source for d in self.records))

    @property
    def compile_time_s(self) -> float:
        return sum(p.compile_time_s for p in self.problems)

    def vector(self, values=None) -> np.ndarray:
        return self.problems[0].vector(values)

    def prepare(self, data, window=None):
        if window is not None:
            raise ModelError("joint fit: give each record already restricted to its window")
        return data

    def evaluate(self, p, datasets):
        """Stacked residuals and Jacobians of the experiments (shapes as
        :meth:`Problem.evaluate`, the first experiment's output curve and layout)."""
        total = float(sum(np.sum(d.w) for d in self.records))
        rs, js, oks = [], [], []
        first = None
        for pr, d in zip(self.problems, self.records):
            r, jac, yg, ok, layout, _ = pr.evaluate(p, [d])
            f = np.sqrt(np.sum(d.w) / total)
            rs.append(f * r)
            js.append(f * jac)
            oks.append(ok)
            if first is None:
                first = (yg, layout)
        return (np.concatenate(rs, axis=1), np.concatenate(js, axis=1), first[0], np.all(oks, axis=0),
                first[1], 0.0)


def fit_joint(problems: Sequence[Problem], records: Sequence[Measurements], init=None, **options):
    """One parameter set fitted to several experiments' records (module docstring).
    Options as :func:`~.fit.fit` (without ``window`` and the discretization check).

    Returns a :class:`~.report.FitResult` over all samples (``data`` the concatenated
    records; ``t_grid``/``y_fit`` the first experiment's curve)."""
    from .fit import fit_batch
    joint = JointProblem(problems, records)
    return fit_batch(joint, [joint.data], [init], **options)[0]
