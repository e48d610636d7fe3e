"""Scenario files: any model as a declarative TOML file (beams, bodies, joints, loads,
initial state, solver and outputs), validated with one-line errors before anything is
built. The format is documented in ``docs/scenario-format.md``.

Modules, one job each: :mod:`.schema` (typed tables), :mod:`.types` (value types),
:mod:`.expressions` (safe time functions), :mod:`.tables` (tabulated functions and the
file-path rule), :mod:`.checks` (names and cross-references), :mod:`.loader` (file →
validated scenario), :mod:`.build` (scenario → model builder), :mod:`.scenario` (the
:class:`Scenario` API), :mod:`.describe` and :mod:`.docs` (what keys accept, docs).

Example::

    from ancf_jax.scenario import load_scenario
    sc = load_scenario("m1", overrides=["solver.t_end=0.5"])
    results = sc.simulate()
"""

from .errors import ScenarioError
from .loader import load_scenario, shipped_scenarios
from .scenario import RunSettings, Scenario

__all__ = ["ScenarioError", "Scenario", "RunSettings", "load_scenario", "shipped_scenarios"]
