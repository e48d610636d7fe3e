"""The format page documents every key of the schema and is up to date with it."""

from pathlib import Path

import pytest

from ancf_jax.integrators.diffrax_solvers import DiffraxSolver
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha
from ancf_jax.integrators.explicit import RK4, ExplicitEuler
from ancf_jax.scenario import docs, schema
from ancf_jax.scenario.expressions import FUNCTIONS
from ancf_jax.errors import ModelError
from ancf_jax.linalg import AutoSaddleSolver, BorderedChainSolver, DenseLUSolver
from ancf_jax.newton import ModifiedNewton
from ancf_jax.simulation import ROOT_FINDER_OPTIONS, make_solver
from ancf_jax.statics import StaticSolver

PAGE = Path(__file__).resolve().parents[2] / "docs" / "scenario-format.md"


def test_page_is_generated_from_the_current_schema():
    text = PAGE.read_text(encoding="utf-8")
    assert docs.splice(text) == text, "run: python -m ancf_jax.scenario.docs docs/scenario-format.md"


def test_every_table_and_key_is_documented():
    text = PAGE.read_text(encoding="utf-8")
    classes = {c for _, c in docs.TABLES}
    documented = {name for name in dir(schema) if isinstance(getattr(schema, name), type)
                  and issubclass(getattr(schema, name), schema.Table) and getattr(schema, name) is not schema.Table}
    assert documented == {c.__name__ for c in classes}
    for cls in classes:
        for key, field in cls.model_fields.items():
            assert f"| `{key}` |" in text, (cls.__name__, key)
            assert field.description, (cls.__name__, key)
    for name in FUNCTIONS:
        assert f"| `{name}` |" in text


def test_solver_options_are_options_of_the_solvers():
    classes = {"generalized-alpha": GeneralizedAlpha, "rk4": RK4, "explicit-euler": ExplicitEuler, "tsit5": DiffraxSolver,
               "dopri5": DiffraxSolver, "kvaerno5": DiffraxSolver}
    assert set(schema.SOLVER_TABLES) == set(classes)
    for name, table in schema.SOLVER_TABLES.items():
        options = schema.SolverSpec.model_fields[table].annotation.model_fields
        # fields of the integrator, of its root finder (generalized-α) and the linear solver
        known = set(classes[name].__dataclass_fields__) | {"linear_solver"}
        if name == "generalized-alpha":
            # index: the constraint level; reuse_factors: AcrossSteps(max_age) (make_solver)
            known |= set(ROOT_FINDER_OPTIONS) | {"index", "reuse_factors"}
        assert set(options) <= known, (name, set(options) - known)
    assert set(ROOT_FINDER_OPTIONS.values()) <= set(ModifiedNewton.__dataclass_fields__)


def test_flat_solver_options_configure_the_composed_solver():
    """make_solver is the one translation from the scenario's flat options."""
    ga = make_solver("generalized-alpha", newton_tol=1e-8, refresh_first=True, contraction=0.1,
                     linear_solver="dense", rho_inf=0.5)
    assert ga.rho_inf == 0.5 and ga.root_finder.tolerance == 1e-8 and ga.root_finder.refresh_first
    assert ga.root_finder.contraction == 0.1 and isinstance(ga.linear_solver, DenseLUSolver)
    assert isinstance(make_solver("rk4", linear_solver="bordered").linear_solver, BorderedChainSolver)
    assert isinstance(make_solver("generalized-alpha").linear_solver, AutoSaddleSolver)
    assert make_solver("generalized-alpha", index=2).constraints.index == 2
    assert make_solver("generalized-alpha").constraints.index == 3
    with pytest.raises(ModelError, match="index .constraint level. of generalized-alpha must be one of .2, 3."):
        make_solver("generalized-alpha", index=1)
    with pytest.raises(ModelError, match="linear_solver must be one of auto, bordered, dense"):
        make_solver("rk4", linear_solver="sparse")


def test_defaults_are_written_once():
    """The schema's defaults are read from the classes and functions they configure
    (and the functions that share a default read one constant)."""
    import importlib
    import inspect

    from ancf_jax.element.strain_energy import Formulation
    from ancf_jax.fatigue.sn import SNCurve
    fitting = importlib.import_module("ancf_jax.identification.fit")  # the module (the package exports fit)
    from ancf_jax.integrate import DEFAULT_DT, RunOptions
    from ancf_jax.model import Model, assemble_state
    from ancf_jax.models import catenary
    from ancf_jax.simulation import DEFAULT_SOLVER, simulate
    from ancf_jax.sliding import DEFAULT_REGULARIZATION

    def default(function, name):
        return inspect.signature(function).parameters[name].default

    solver = schema.SolverSpec.model_fields
    assert solver["name"].default == DEFAULT_SOLVER == default(simulate, "solver")
    assert solver["dt"].default == DEFAULT_DT
    for name in ("drift_tolerance", "locate_crossings"):
        assert solver[name].default == getattr(RunOptions(), name) == getattr(default(simulate, "options"), name)
    assert schema.FormulationSpec().model_dump() == {k: getattr(Formulation(), k) for k in Formulation.__dataclass_fields__}
    assert schema.FrictionSpec.model_fields["regularization"].default == DEFAULT_REGULARIZATION
    curve = SNCurve.eurocode(schema.SNCurveSpec().reference_range)
    assert schema.SNCurveSpec().model_dump() == {k: float(getattr(curve, k)) for k in schema.SNCurveSpec.model_fields}
    cutoff = schema.PantographSpec.model_fields["cutoff"].default
    for function in (catenary.run_pantograph_catenary, catenary.analyse_pantograph_run, catenary.contact_statistics):
        assert default(function, "cutoff") == cutoff
    assert default(catenary.run_pantograph_catenary, "solver") == DEFAULT_SOLVER
    assert schema.PantographSpec.model_fields["trailing"].default is None  # none: the functions' ()
    assert default(catenary.pantograph_catenary, "trailing") == default(catenary.run_pantograph_catenary, "trailing") \
        == default(catenary.analyse_pantograph_run, "trailing") == default(catenary.pantograph_run_time, "trailing") \
        == ()
    assert default(Model.build, "tolerance") == default(assemble_state, "tolerance")
    from ancf_jax.element.laws import StrainRateDamped
    assert schema.StrainRateDampedLawSpec.model_fields["rest"].default == default(StrainRateDamped.__init__, "rest")
    for name in ("xtol", "ftol", "gtol", "learning_rate"):
        assert default(fitting.fit, name) == default(fitting.fit_batch, name) == getattr(fitting, name.upper())
    from ancf_jax.fatigue.analysis import FatigueSettings
    from ancf_jax.fatigue.stress import points_along
    fatigue = schema.FatigueSpec.model_fields
    for key, field in (("method", "method"), ("mean_stress", "correction"), ("measure", "measure"),
                       ("scf", "scf"), ("layout", "layout"), ("points_per_element", "points_per_element"),
                       ("t_start", "t_start")):
        assert fatigue[key].default == getattr(FatigueSettings, field), key
    assert default(points_along, "points_per_element") == FatigueSettings.points_per_element
    assert default(points_along, "layout") == FatigueSettings.layout


def test_statics_defaults_are_the_static_solvers():
    """The [statics] table's defaults are read from statics.StaticSolver (written once),
    as are build_in_equilibrium's, solve_static's and M2's."""
    import inspect

    from ancf_jax.model import build_in_equilibrium
    from ancf_jax.models.m2 import m2_initial
    from ancf_jax.statics import solve_static, solve_static_pure

    fields = {f.name: f.default for f in StaticSolver.__dataclass_fields__.values()}
    spec = schema.StaticsSpec()
    assert (spec.load_steps, spec.tolerance) == (fields["load_steps"], fields["tolerance"])
    for fn in (solve_static, solve_static_pure, build_in_equilibrium, m2_initial):
        for name, p in inspect.signature(fn).parameters.items():
            if name in fields and name != "linear_solver":
                assert p.default == fields[name], (fn.__name__, name)
