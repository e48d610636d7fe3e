"""Identification of model parameters from measured outputs (issue 7): fit Rayleigh α,
β (and E, body masses) of a model — M1 by default — to measured samples of a named
output (M1: the tip Y-displacement ``tip_y``) with exact derivatives through the solver.

Modules, one job each: :mod:`.data` (reading and checking ``t,y`` data),
:mod:`.parameters` (which parameters, how they are set), :mod:`.problem` (the loss,
forward-mode Jacobian, reverse-mode gradients), :mod:`.fit` (Levenberg–Marquardt and
optax), :mod:`.report` (standard errors, correlation, identifiability, JSON, figure),
:mod:`.synthetic` (synthetic measurements), :mod:`.discretization` (is the model's
discretization error below the noise? refine if not), :mod:`.uncertainty` (parametric
bootstrap, profile likelihood), :mod:`.joint` (several experiments, one parameter set). The method and measurements are in
``docs/identification.md``.

Example::

    from ancf_jax.identification import Problem, synthesize, fit
    problem = Problem.from_scenario("m1", ("alpha", "beta"), elements=3)
    data, _ = synthesize(problem, {"alpha": 0.02, "beta": 0.0}, noise=1e-3, seed=1)
    result = fit(problem, data, {"alpha": 0.01, "beta": 1e-5})
    print(result.summary())
"""

from .data import DataError, Measurements, read_csv, write_csv
from .fit import fit, fit_batch
from .joint import JointProblem, fit_joint
from .parameters import Parameter
from .problem import NUISANCE, Problem
from .report import FitResult, ljung_box, misfit_diagnostics
from .synthetic import synthesize
from .uncertainty import bootstrap, profile, profile_interval

__all__ = ["DataError", "Measurements", "read_csv", "write_csv", "Parameter", "Problem", "NUISANCE", "fit",
           "fit_batch", "fit_joint", "JointProblem", "FitResult", "synthesize", "bootstrap", "profile", "profile_interval", "ljung_box", "misfit_diagnostics"]
