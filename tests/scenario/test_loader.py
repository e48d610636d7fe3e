"""Loading: shipped names, --set overrides, run settings, outputs and summaries."""

import dataclasses

import pytest

from ancf_jax.integrate import RunOptions
from ancf_jax.scenario import ScenarioError, load_scenario, shipped_scenarios
from ancf_jax.scenario.loader import parse_override

from .conftest import BASE, write

SHIPPED = ["cable_car", "cantilever_tip_load", "flexible_pendulum", "hanging_chain", "hauled_cabin", "m1", "m2",
           "pantograph_catenary"]


def test_shipped_names():
    assert shipped_scenarios() == SHIPPED


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_scenario_validates_without_building(name, no_build):
    with no_build():
        sc = load_scenario(name)
        text = sc.summary()
    assert sc.name == name and sc.path.name == f"{name}.toml"
    assert "\n" not in text and text.startswith(f"{sc.path}: valid scenario '{name}'")
    assert sc.description


def test_shipped_file_by_path_is_the_same(no_build):
    with no_build():
        by_name = load_scenario("m1")
        by_path = load_scenario(str(by_name.path))
    assert by_name.spec == by_path.spec


@pytest.mark.parametrize("item,path,value", [
    ("solver.dt=1e-4", ("solver", "dt"), 1e-4),
    ("solver.name=rk4", ("solver", "name"), "rk4"),
    ('solver.name="rk4"', ("solver", "name"), "rk4"),
    ("gravity=[0, -1.62]", ("gravity",), [0, -1.62]),
    ("beams.cable.elements=12", ("beams", "cable", "elements"), 12),
    ("joints.slider.hold=true", ("joints", "slider", "hold"), True),
    ("beams.cable.initial={ shape = 'reference' }", ("beams", "cable", "initial"), {"shape": "reference"}),
])
def test_parse_override(item, path, value):
    assert parse_override(item) == (path, value)


@pytest.mark.parametrize("item", ["solver", "=1", "solver..dt=1", "solver.d t=1", "solver.dt=1\nname = 'x'"])
def test_bad_overrides(item):
    with pytest.raises(ValueError):
        parse_override(item)


def test_overrides_reach_the_settings(no_build):
    with no_build():
        sc = load_scenario("m2", ["beams.cable.elements=12", "solver.t_end=0.5", "solver.generalized_alpha.rho_inf=0.8",
                                  "outputs.dt=0.05", "joints.slider.s=1.0"])
    assert sc.beam_elements == {"cable": 12}
    assert sc.spec.joints["slider"].s == 1.0
    run = sc.solver
    assert dataclasses.asdict(run) == dict(t_end=0.5, dt=1e-3, solver="generalized-alpha", output_dt=0.05,
                                           solver_options={"rho_inf": 0.8, "max_iterations": 30},
                                           drift_tolerance=1e-6, locate_crossings=False)
    kw = run.simulate_kwargs()  # the composed solver and the run options they describe
    assert (kw["solver"].rho_inf, kw["solver"].root_finder.max_iterations) == (0.8, 30)
    assert kw["options"] == RunOptions(drift_tolerance=1e-6, locate_crossings=False)
    assert {k: kw[k] for k in ("t_end", "dt", "output_dt")} == dict(t_end=0.5, dt=1e-3, output_dt=0.05)
    assert "beams.cable.elements=12" in sc.summary()


def test_switching_solver_keeps_each_solvers_options(no_build):
    with no_build():
        sc = load_scenario("m2", ["solver.name=rk4", "solver.rk4.baumgarte=10"])
    assert sc.solver.solver == "rk4" and sc.solver.solver_options == {"baumgarte": 10.0}
    assert sc.spec.solver.generalized_alpha.rho_inf == 0.5


def test_override_creates_missing_tables(tmp_path, no_build):
    with no_build():
        sc = load_scenario(str(write(tmp_path, BASE)), ["statics.load_steps=3", "modal.about=equilibrium"])
    assert sc.statics.load_steps == 3 and sc.modal_settings.about == "equilibrium"
    with pytest.raises(ScenarioError, match=r"solver\.dt: --set solver\.dt\.x=1: this key is not a table"):
        load_scenario(str(write(tmp_path, BASE)), ["solver.dt.x=1"])


def test_m1_and_m2_output_columns(no_build):
    with no_build():
        m1, m2 = load_scenario("m1"), load_scenario("m2")
    assert [o.name for o in m1.outputs] == ["tip_x", "tip_y", "sigma_e1_mid"]
    stress = m1.outputs[2]
    # a fixed material point, s = L/12 (E1's midpoint with 6 elements), the built-in
    # model's column too
    assert (stress.kind, stress.target, stress.s, stress.element, stress.fibre, stress.measure) == \
        ("stress", "beam", 0.0335, None, 0.5e-3, "exact")
    from ancf_jax.models.m1 import OUTPUTS
    assert stress == OUTPUTS[2]
    assert [(o.name, o.kind, o.target, o.component) for o in m1.outputs[:2]] == \
        [("tip_x", "node", "beam", "x"), ("tip_y", "node", "beam", "y")]
    assert all(o.node == -1 for o in m1.outputs[:2])
    assert [(o.name, o.kind, o.target, o.component) for o in m2.outputs] == [
        ("s", "sliding", "slider", "s"), ("point1_x", "sliding_point", "slider", "x"),
        ("point1_y", "sliding_point", "slider", "y"), ("rb2_x", "body", "cabin", "x"),
        ("rb2_y", "body", "cabin", "y")]


def test_m1_and_m2_run_settings(no_build):
    with no_build():
        m1, m2 = load_scenario("m1").solver, load_scenario("m2").solver
    assert (m1.solver, m1.dt, m1.t_end, m1.output_dt, m1.solver_options) == \
        ("generalized-alpha", 1e-3, 2.0, 1e-3, {})
    assert (m2.solver, m2.dt, m2.t_end, m2.output_dt, m2.solver_options) == \
        ("generalized-alpha", 1e-3, 3.0, 1e-2, {"rho_inf": 0.5, "max_iterations": 30})
    assert load_scenario("m2").beam_elements == {"cable": 24}
