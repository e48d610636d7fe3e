"""Shipped scenarios: each builds and runs (a few steps), M1 and M2 are exactly the
built-in models, and the examples give the physics they claim (elastica, catenary,
cantilever frequencies, a hanging cabin)."""

import math

import jax
import numpy as np
import pytest

from ancf_jax import mesh
from ancf_jax.models.m1 import m1_model
from ancf_jax.models.m2 import m2_initial
from ancf_jax.outputs import evaluate
from ancf_jax.scenario import load_scenario, shipped_scenarios

pytestmark = pytest.mark.slow


def assert_identical(a, b):
    """Same tree structure (static fields included) and bit-identical array leaves."""
    leaves_a, tree_a = jax.tree.flatten(a)
    leaves_b, tree_b = jax.tree.flatten(b)
    assert tree_a == tree_b
    assert len(leaves_a) == len(leaves_b) > 0
    for x, y in zip(leaves_a, leaves_b):
        x, y = np.asarray(x), np.asarray(y)
        assert x.dtype == y.dtype and x.shape == y.shape
        np.testing.assert_array_equal(x, y)


def short(name, steps=5):
    """The shipped scenario with a span of a few solver steps, sampled every step."""
    dt = load_scenario(name).solver.dt
    return load_scenario(name, [f"solver.t_end={steps * dt!r}", f"outputs.dt={dt!r}"])


#: run elsewhere: the full pantograph_catenary (2 × 1200 elements) is a benchmark;
#: tests/test_catenary.py runs it reduced to three short spans through the same path;
#: hauled_cabin's round trip is its first second (test_hauled_cabin_first_second)
ROUND_TRIP = [n for n in shipped_scenarios() if n not in ("pantograph_catenary", "hauled_cabin")]


_ROUND_TRIPS = {}


def round_trip(name, steps=5):
    """Run ``short(name, steps)``; check its output columns (every step, finite) and
    its constraints; returns the scenario, results and columns (kept for the module: a
    later test of the same run gets it without building and running it again)."""
    if (name, steps) in _ROUND_TRIPS:
        return _ROUND_TRIPS[name, steps]
    sc = short(name, steps)
    results = sc.simulate(progress=False)
    assert results.status == "ok"
    columns = evaluate(results, sc.outputs)
    assert list(columns) == ["t"] + [o.name for o in sc.outputs]
    assert len(columns["t"]) == steps + 1
    np.testing.assert_allclose(columns["t"], np.arange(steps + 1) * sc.solver.dt, atol=1e-12)
    for key, values in columns.items():
        assert np.all(np.isfinite(values)), key
    pos, _ = results.constraint_violation()
    assert pos.max() < 1e-8
    _ROUND_TRIPS[name, steps] = sc, results, columns
    return sc, results, columns


@pytest.mark.parametrize("name", ROUND_TRIP)
def test_round_trip_validates_builds_and_runs(name):
    round_trip(name)


@pytest.mark.study
def test_hauled_cabin_first_second():
    """The shipped hauled cabin's round trip over its first second (500 steps, the same
    program as a few steps): the energy balance with the drive's constraint work and
    the friction dissipation closes to 1.1e-8 of the largest energy term (measured;
    the full 5 s run: 1.25e-7, docs/cable-machinery.md), the constraints hold to
    round-off, and once the trolley slides (u > 10 v_ε, tanh > 1 − 1e-8) the friction
    output is −μN of the normal output (hauled uphill: +s)."""
    sc, results, columns = round_trip("hauled_cabin", 500)
    assert results.energy_balance_error() < 3e-8
    assert results.energy()["constraint"][-1] > 0.5  # the haul does work (measured 0.68 J)
    assert results.constraint_violation()[0].max() < 1e-12  # measured 1.3e-15 m
    friction = results.system.reaction_forces[0]
    u = results.v[:, results.system.sliding_offset]  # ṡ; |r'| = 1 to the cable's strain
    sliding = u > 10 * float(friction.regularization)
    assert sliding[-1] and not sliding[0]
    np.testing.assert_allclose(columns["friction"][sliding], -float(friction.mu) * columns["normal"][sliding],
                               rtol=1e-8)


def test_m1_scenario_is_the_builtin_model():
    system, state = load_scenario("m1").build()
    ref_system, ref_state = m1_model().build()
    assert_identical(system, ref_system)
    assert_identical(state, ref_state)


@pytest.fixture(scope="module")
def m2_built():
    return load_scenario("m2").build(), m2_initial()


def test_m2_scenario_is_the_builtin_model(m2_built):
    (system, state), (ref_system, ref_state, _) = m2_built
    assert_identical(system, ref_system)
    assert_identical(state, ref_state)
    assert system.sliding_names == ("slider",) and not any(c.name.endswith(".hold") for c in system.constraints)
    labels = system.coordinate_labels()  # the NPZ's column labels of q
    assert len(labels) == system.n_coordinates and labels[-1] == "sliding:slider.s [m]"
    assert labels[3:6] == ("body:cabin.x [m]", "body:cabin.y [m]", "body:cabin.theta [rad]")


def test_m2_starts_at_rest_with_the_cabin_hanging_below_the_trolley(m2_built):
    (system, state), _ = m2_built
    q = np.asarray(state.q)
    trolley, cabin = q[0:3], q[3:6]
    assert np.all(np.asarray(state.v) == 0.0)
    assert q[system.sliding_offset] == 0.6
    np.testing.assert_allclose(cabin[:2], trolley[:2] + [0.0, -0.5], atol=1e-9)
    assert abs(cabin[2]) < 1e-9


def test_m2_with_the_trolley_held_for_the_run(m2_built):
    (_, state), _ = m2_built
    system, held_state = load_scenario("m2", ["joints.slider.hold=true"]).build()
    assert [c.name for c in system.constraints][-1] == "slider.hold"
    assert_identical(held_state, state)  # the same equilibrium: it is always found with the hold


def elastica_tip(load_ratio: float):
    """Tip (x, y)/L of a clamped elastica under a transverse tip load with PL²/EI =
    ``load_ratio`` (shooting on EI θ'' = P cos θ, θ(0) = 0, θ'(L) = 0)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    def shoot(k):
        sol = solve_ivp(lambda s, y: [y[1], load_ratio * math.cos(y[0]), math.cos(y[0]), math.sin(y[0])],
                        (0.0, 1.0), [0.0, -k, 0.0, 0.0], rtol=1e-12, atol=1e-12)
        return sol.y[:, -1]

    k = brentq(lambda k: shoot(k)[1], 1e-6, load_ratio)
    return shoot(k)[2:]


def test_cantilever_static_is_the_elastica():
    sc = load_scenario("cantilever_tip_load")
    columns = evaluate(sc.static_results(), sc.outputs)
    x_ref, y_ref = elastica_tip(5.0 * 1.0**2 / (2.0e11 * 1.25e-11))
    assert y_ref == pytest.approx(-0.4934, abs=2e-4)  # Bisshopp & Drucker's table
    assert columns["tip_y"][0] == pytest.approx(y_ref, rel=2e-3)
    assert columns["tip_x"][0] == pytest.approx(x_ref, rel=2e-3)
    assert columns["root_fy"][0] == pytest.approx(-5.0, rel=1e-9)  # the clamp's force on the beam, −λ, is +P


def test_cantilever_modal_is_euler_bernoulli():
    sc = load_scenario("cantilever_tip_load")
    _, _, modes = sc.modal()
    ei, rho_a = 2.0e11 * 1.25e-11, 7850.0 * 3.915e-5
    beta_l = np.array([1.8751040687, 4.6940911330, 7.8547574382])
    reference = beta_l**2 / (2 * np.pi) * math.sqrt(ei / rho_a)
    assert len(modes.frequencies_hz) == 6
    np.testing.assert_allclose(modes.frequencies_hz[:3], reference, rtol=2e-3)


def test_hanging_chain_equilibrium_is_the_catenary():
    sc = load_scenario("hanging_chain")
    columns = evaluate(sc.static_results(), sc.outputs)
    weight = 0.8 * 2.2 * 9.81
    # the pins carry half the weight each: force on the chain −λ, so λ_y = −W/2
    assert columns["left_fy"][0] == pytest.approx(-weight / 2, rel=1e-9)
    nodes = mesh.catenary_nodes((0.0, 0.0), (2.0, 0.0), 2.2, 16)
    sag = nodes[8, 1]  # node 8 is at s = 1.1, mid-span
    assert columns["mid_x"][0] == pytest.approx(1.0, abs=1e-12)
    assert columns["mid_y"][0] == pytest.approx(sag, rel=2e-3)
    # the horizontal tension of the catenary, H = w a (the pin pulls the chain with −λ_x = −H)
    assert columns["left_fx"][0] == pytest.approx(horizontal_tension(2.2, 2.0, 0.8 * 9.81), rel=5e-3)


def horizontal_tension(length, span, weight_per_length):
    """H = w a of the inextensible catenary, 2a sinh(span / 2a) = length."""
    from scipy.optimize import brentq
    a = brentq(lambda a: 2 * a * math.sinh(span / (2 * a)) - length, 0.05, 100.0)
    return weight_per_length * a


def test_cable_car_outputs_follow_the_bodies():
    """On the round trip's run of the cable car (the same few steps)."""
    _, results, columns = round_trip("cable_car")
    pose = results.body("cabin1")
    np.testing.assert_allclose(columns["hook1_x"], pose[:, 0] - np.sin(pose[:, 2]) * 0.6, atol=1e-14)
    np.testing.assert_allclose(columns["s1"], results.sliding("slider1"))
    q0 = results.q[0]
    for k in (0, 2):  # each cabin starts hanging 0.6 m below its trolley
        np.testing.assert_allclose(q0[3 * k + 3: 3 * k + 5], q0[3 * k: 3 * k + 2] + [0.0, -0.6], atol=1e-9)
