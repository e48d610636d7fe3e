"""Velocity and acceleration outputs (``Output.derivative``, scenario key
``derivative``): a free rigid body against its closed form, a beam point against finite
differences of its own position history (convergence in h), the scenario key, and a fit
of Rayleigh α to an accelerometer record."""

import numpy as np
import pytest

from ancf_jax.errors import ModelError
from ancf_jax.identification import Problem, fit, fit_joint, synthesize
from ancf_jax.identification.problem import output_unit
from ancf_jax.model import Model
from ancf_jax.models.m1 import m1_model
from ancf_jax.outputs import Output, evaluate
from ancf_jax.scenario import load_scenario
from ancf_jax.simulation import simulate

from .dynamics import G

V0, W0, L0 = (1.5, 2.0), 3.0, (0.2, 0.1)


def test_free_body_velocities_and_accelerations_closed_form():
    """A body thrown with velocity V0 spinning at W0 under gravity: centre velocity
    V0 − g t ĵ, acceleration −g ĵ, ω = W0, ω̇ = 0, and the body point L0 accelerates by
    −g ĵ − ω² R(θ) L0 (centripetal), θ = W0 t. Generalized-α is exact for constant
    accelerations: agreement to round-off."""
    m = Model(gravity=(0.0, -G))
    m.add_body("b", mass=2.0, inertia=0.1, position=(0.0, 0.0), velocity=V0, angular_velocity=W0)
    system, state = m.build()
    r = simulate(system, state, t_end=0.1, dt=1e-3, output_dt=1e-2, progress=False)
    cols = evaluate(r, [Output(f"{c}{d}", "body", "b", c, derivative=d) for c in ("x", "y", "theta")
                        for d in (1, 2)]
                    + [Output(f"p{c}", "body", "b", c, local=L0, derivative=2) for c in ("x", "y")])
    t = cols["t"]
    theta = W0 * t
    expected = {"x1": V0[0], "x2": 0.0, "y1": V0[1] - G * t, "y2": -G, "theta1": W0, "theta2": 0.0,
                "px": -W0**2 * (L0[0] * np.cos(theta) - L0[1] * np.sin(theta)),
                "py": -G - W0**2 * (L0[0] * np.sin(theta) + L0[1] * np.cos(theta))}
    for name, value in expected.items():
        np.testing.assert_allclose(cols[name], np.broadcast_to(value, t.shape), rtol=0, atol=1e-10, err_msg=name)


def test_beam_point_derivatives_converge_to_differences_of_its_position():
    """M1's material point at s = 0.3 m over 0.2 s: the velocity output against central
    differences of the position output, and the acceleration output against second
    differences, at h = 0.2, 0.1, 0.05 ms. Measured max differences: velocity 1.4e-4,
    3.8e-5, 1.0e-5 m/s (order 1.9), acceleration 0.52, 0.19, 0.055 m/s² of 18 m/s²
    (orders 1.4, 1.8: two second-order approximations of ÿ, the solver's q̈ and the
    differences of its positions)."""
    system, state = m1_model(6).build()
    dv, da = [], []
    for h in (2e-4, 1e-4, 5e-5):
        r = simulate(system, state, t_end=0.2, dt=h, progress=False)
        c = evaluate(r, [Output(f"y{d}", "point", "beam", "y", s=0.3, derivative=d) for d in (0, 1, 2)])
        y = c["y0"]
        dv.append(np.max(np.abs(c["y1"][1:-1] - (y[2:] - y[:-2]) / (2 * h))))
        da.append(np.max(np.abs(c["y2"][1:-1] - (y[2:] - 2 * y[1:-1] + y[:-2]) / h**2)))
    assert dv[0] / dv[1] > 3.5 and dv[1] / dv[2] > 3.5, dv
    assert da[0] / da[1] > 2.5 and da[1] / da[2] > 3.0, da
    assert da[-1] < 0.1


def test_scenario_derivative_key_and_refusals():
    sc = load_scenario("m1", ['outputs.columns.tip_ay={ type = "node", beam = "beam", component = "y", '
                              'derivative = "acceleration" }'])
    assert sc.outputs[-1] == Output("tip_ay", "node", "beam", "y", node=-1, derivative=2)
    with pytest.raises(ModelError, match="derivative must be 0, 1 or 2"):
        Output("a", "node", "beam", "y", derivative=3)
    with pytest.raises(ModelError, match="stress output has no derivative"):
        Output("a", "stress", "beam", "sigma", derivative=1)


@pytest.mark.study
def test_alpha_fitted_to_an_accelerometer_record():
    """Rayleigh α of M1 (3 elements, 0.5 s, h = 2 ms) from the tip's vertical
    acceleration, noise-free record of the same discretization: recovered to 1e-6
    relative from 4× the truth (the record's unit is m/s²); and from that record and
    the tip displacement's together (a joint fit of two sensors)."""
    system, state = m1_model(3).build()
    out = Output("tip_ay", "node", "beam", "y", node=-1, derivative=2)
    problem = Problem(system, state, ("alpha",), output=out, dt=2e-3, t_end=0.5)
    data, _ = synthesize(problem, {"alpha": 0.02}, noise=0.0, rate=500.0, program="jacobian")
    assert np.ptp(data.y) > 1.0  # m/s²: an acceleration, not a position
    res = fit(problem, data, {"alpha": 0.08})
    assert res.converged and abs(res.estimates[0] - 0.02) <= 1e-6 * 0.02
    assert output_unit(out) == "m/s^2"
    # two sensors of one experiment: the tip displacement and the accelerometer, jointly
    tip = Problem(system, state, ("alpha",), output=Output("tip_y", "node", "beam", "y", node=-1),
                  dt=2e-3, t_end=0.5)
    record, _ = synthesize(tip, {"alpha": 0.02}, noise=0.0, rate=500.0, program="jacobian")
    both = fit_joint([tip, problem], [record, data], {"alpha": 0.08})
    assert both.converged and abs(both.estimates[0] - 0.02) <= 1e-6 * 0.02


def test_every_output_kind_has_a_unit():
    """One units convention (issue 25): each kind and component has its SI unit, the
    derivatives per s and per s², and output_units maps the columns of a file."""
    from ancf_jax.outputs import COMPONENTS, DIFFERENTIABLE_KINDS, output_units
    for kind, comps in COMPONENTS.items():
        for comp in comps:
            o = Output("c", kind, "x", comp)
            assert o.unit, (kind, comp)
            if kind in DIFFERENTIABLE_KINDS:
                a = Output("c", kind, "x", comp, derivative=2).unit
                assert a.endswith("/s^2") and a.startswith("1" if o.unit == "-" else o.unit)
    assert Output("s", "stress", "b", "sigma").unit == "Pa" and Output("e", "energy", "", "total").unit == "J"
    assert Output("w", "body", "b", "theta", derivative=1).unit == "rad/s"
    assert output_units([Output("tip_y", "node", "beam", "y")]) == {"t": "s", "tip_y": "m"}


def test_axial_force_and_strain_outputs():
    """The "axial" output: along the hanging chain's static catenary against
    N(s) = √(H² + (w (L/2 − s))²) of the inextensible catenary (measured within 1.5e-3:
    the cable stretches, 16 elements), at the pins against the pin's reaction
    (measured 5e-6 relative), strain · EA = N (the linear law); and a uniformly
    stretching strain-rate damped bar: N = EA ε + d ε̇ (Green–Lagrange ε = (λ² − 1)/2,
    ε̇ = λλ̇) to round-off."""
    import math

    import jax.numpy as jnp
    from scipy.optimize import brentq

    from ancf_jax import mesh
    from ancf_jax.element import laws
    from ancf_jax.section import Section

    sc = load_scenario("hanging_chain")
    at = (0.0, 0.275, 0.55, 1.1)
    cols = evaluate(sc.static_results(), list(sc.outputs) + [Output(f"n{s}", "axial", "chain", "force", s=s)
                                                             for s in at]
                    + [Output("eps", "axial", "chain", "strain", s=1.1)])
    w = 0.8 * G
    a = brentq(lambda a: 2 * a * math.sinh(2.0 / (2 * a)) - 2.2, 0.05, 100.0)
    for s in at:
        assert cols[f"n{s}"][0] == pytest.approx(math.hypot(w * a, w * (1.1 - s)), rel=2e-3)
    assert cols["n0.0"][0] == pytest.approx(math.hypot(cols["left_fx"][0], cols["left_fy"][0]), rel=1e-4)
    assert cols["eps"][0] * 1e11 * 2.8e-5 == pytest.approx(cols["n1.1"][0], rel=1e-12)
    assert Output("n", "axial", "chain", "force", s=0.5).unit == "N"

    ea, d, lam, lam_dot, length = 1e4, 30.0, 1.01, 0.2, 1.0
    m = Model()
    m.add_beam("bar", mesh.straight((0.0, 0.0), (1.0, 0.0), length, 2), Section.from_stiffness(ea, 1.0, 0.5),
               axial_law=laws.StrainRateDamped(d))
    system, _ = m.build(assemble=False)
    beam, x = system.beams[0], np.linspace(0.0, length, 3)
    nodes = jnp.asarray(np.column_stack([lam * x, 0 * x, lam + 0 * x, 0 * x]))
    vel = jnp.asarray(np.column_stack([lam_dot * x, 0 * x, lam_dot + 0 * x, 0 * x]))
    n = beam.axial_force_with_rate(nodes, vel, 0.3)
    assert float(n) == pytest.approx(ea * (lam**2 - 1) / 2 + d * lam * lam_dot, rel=1e-12)


def test_joint_forces_of_the_hanging_chain_pins():
    """Reaction outputs fx, fy (the force a pin applies to the point it holds, global
    frame): the two pins of the hanging chain each hold up half its weight (+W/2,
    exactly: statics) and pull its ends apart with the horizontal tension (left −H,
    right +H, equal and opposite to round-off); fx, fy are −λ of the pin's equations.
    The scenario key: component = "fx"."""
    sc = load_scenario("hanging_chain", ['outputs.columns.pin_fy={ type = "reaction", joint = "left", '
                                         'component = "fy" }'])
    cols = evaluate(sc.static_results(), list(sc.outputs)
                    + [Output(f"{j}_force_{c}", "reaction", j, c) for j in ("left", "right") for c in ("fx", "fy")])
    weight = 0.8 * 2.2 * G
    assert cols["left_force_fy"][0] == pytest.approx(weight / 2, rel=1e-9)
    assert cols["right_force_fy"][0] == pytest.approx(weight / 2, rel=1e-9)
    assert cols["left_force_fx"][0] < -10.0
    assert cols["right_force_fx"][0] == pytest.approx(-cols["left_force_fx"][0], rel=1e-12)
    assert cols["left_force_fx"][0] == -cols["left_fx"][0]  # the index-0 multiplier λ_x
    assert cols["pin_fy"][0] == cols["left_force_fy"][0]


def test_bending_moment_of_the_elastica():
    """The "bending" output on the cantilever under its tip load P = 5 N (static, large
    deflection, PL²/EI = 2): moment equilibrium of the part beyond s gives
    M(s) = −P (x_tip − x(s)) exactly; measured relative errors at s = 0, ¼, ½, ¾ L up to
    1.4e-3 with 10 elements and 4.7e-4 with 20 (the FE curvature converges at ~h²), and
    M = EI (κ − κ₀) (linear law) to round-off."""
    at = (0.0, 0.25, 0.5, 0.75)
    worst = []
    for n in (10, 20):
        sc = load_scenario("cantilever_tip_load", [f"beams.strip.elements={n}"])
        c = evaluate(sc.static_results(), [Output(f"m{s}", "bending", "strip", "moment", s=s) for s in at]
                     + [Output(f"x{s}", "point", "strip", "x", s=s) for s in at + (1.0,)]
                     + [Output("k0", "bending", "strip", "curvature", s=0.0)])
        worst.append(max(abs(c[f"m{s}"][0] / (-5.0 * (c["x1.0"][0] - c[f"x{s}"][0])) - 1.0) for s in at))
        assert c["m0.0"][0] == pytest.approx(2.5 * c["k0"][0], rel=1e-12)
    assert worst[0] < 2e-3 and worst[1] < worst[0] / 2.5, worst
    assert Output("m", "bending", "strip", "moment", s=0.1).unit == "N*m"


@pytest.mark.parametrize("mode", ["full", "direction", "exudyn"])
def test_clamp_moment_of_the_cantilever(mode):
    """Reaction component "moment" (Results.joint_moment): the clamp of the cantilever
    under its tip load P = 5 N (static, large deflection) holds it with the support
    moment M = P x_tip (moment equilibrium of the whole beam, exact for any mesh), for
    the clamp's three modes; and the support force (0, P)."""
    sc = load_scenario("cantilever_tip_load", [f'joints.root.mode="{mode}"', 'outputs.columns.moment={ '
                                               'type = "reaction", joint = "root", component = "moment" }'])
    c = evaluate(sc.static_results(), list(sc.outputs) + [Output("m", "reaction", "root", "moment"),
                                                          Output("fy", "reaction", "root", "fy"),
                                                          Output("x", "node", "strip", "x", node=-1)])
    assert c["moment"][0] == c["m"][0]  # the scenario key
    assert c["x"][0] < 0.9  # large deflection
    assert c["m"][0] == pytest.approx(5.0 * c["x"][0], rel=1e-9)
    assert c["fy"][0] == pytest.approx(5.0, rel=1e-9)
    assert Output("m", "reaction", "root", "moment").unit == "N*m"
