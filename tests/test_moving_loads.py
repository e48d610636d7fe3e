"""Moving loads and unilateral moving contact (issue 20) against closed forms.

* A constant force entering a pre-tensioned string at t = 0 and crossing it at
  v = 0.2c and 0.5c: the deflection under the load against the string's modal series,
  and the slope jump P / (T (1 − v²/c²)) at the load; with a bending stiffness EI
  against the beam series (ωₙ² = ((nπ/ℓ)² T + (nπ/ℓ)⁴ EI) / μ). Mesh convergence sets
  the tolerances: first order for the string (the kinks of its wave fronts, which a C¹
  element smears), second order with EI.
* A moving mass tends to the moving force of its weight as its mass vanishes (first
  order in the mass).
* A mass bouncing on a stiff penalty contact: contact time and restitution against the
  closed form of a mass on a linear spring-damper that cannot pull; located contact
  events restore second order.
* Gradients of a contact-force statistic with respect to the speed of a moving
  contact and the contact stiffness against finite differences.
* A lumped-mass chain's natural frequencies against its 2 × 2 eigenproblem.

Compiled programs are shared: one for the string runs (speed, EI and the padded mesh
are data), one for the bounce runs (damping and step are data), one gradient program.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax import mesh
from ancf_jax.functions import ConstantSpeed
from ancf_jax.integrate import RunOptions
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha
from ancf_jax.model import Model, body_point, node
from ancf_jax.results import Results
from ancf_jax.section import Section

from .beam_theory import moving_load_series
from .dynamics import observed_orders, run_fixed

# ---------------------------------------------------------------------------- string
L, EPS0, EA, RHOA, P = 1.0, 1e-3, 1e5, 1.0, 0.01
ELL = L * (1 + EPS0)                          # current length [m]
T_STRING = EA * (EPS0 + EPS0**2 / 2) * (1 + EPS0)  # |N r'| of the Green-strain law [N]
MU = RHOA / (1 + EPS0)                        # mass per current length [kg/m]
C = np.sqrt(T_STRING / MU)


def taut_string(n, bending_stiffness, gravity=0.0):
    """A model holding a string of reference length L, n elements, stretched by EPS0
    between two pins; gravity (0, −gravity) [m/s²] acts on what is added, not on the
    string."""
    m = Model(gravity=(0.0, -gravity))
    track = mesh.straight((0.0, 0.0), (1.0, 0.0), L, n)
    nodes = np.asarray(track.reference_nodes).copy()
    nodes[:, 0] *= 1 + EPS0
    nodes[:, 2] = 1 + EPS0
    m.add_beam("string", track, Section(1e9, EA / 1e9, bending_stiffness / 1e9, RHOA), initial_nodes=nodes,
               gravity=False)
    m.pin("a", node("string", 0))
    m.pin("b", node("string", -1))
    return m


def string_model(n, speed, bending_stiffness):
    """The taut string, gravity off, a force (0, −P) entering at x = 0 at t = 0 and
    moving at x = speed·t."""
    m = taut_string(n, bending_stiffness)
    m.moving_force("P", "string", (0.0, -P), path=ConstantSpeed(0.0, speed))
    return m.build(pad_to=32, assemble=False)  # consistent as built (no eager projection)


def modal_series(t, x, v, bending_stiffness=0.0, modes=4000):
    """Deflection w(x, t) (along the load) of the pinned string/beam under a force P
    entering at t = 0 at speed v, by its modal series."""
    return moving_load_series(t, x, v, T_STRING, MU, bending_stiffness, ELL, P, modes)


#: (v / c, EI [N·m²], step [s]); the beam's step is finer so that its time error
#: (~1e-4 relative at 2e-4 s) stays below its mesh error at 32 elements
CASES = {"string 0.2c": (0.2, 1e-6, 4e-4), "string 0.5c": (0.5, 1e-6, 4e-4), "beam 0.5c": (0.5, 0.5, 1e-4)}


@pytest.fixture(scope="module")
def string_runs():
    """Every case at 16 and 32 elements (one program: the meshes are padded to 32
    elements, speed and EI are data)."""
    out = {}
    for n in (16, 32):
        system, state = string_model(n, 1.0, 1e-6)
        for name, (frac, ei, h) in CASES.items():
            sys = eqx.tree_at(lambda s: (s.forces[0].location.path.speed, s.beams[0].section.second_moment),
                              system, (jnp.asarray(frac * C, float), jnp.asarray(ei / 1e9, float)))
            t_end = round(ELL / (frac * C) / h / 50) * 50 * h
            run = run_fixed(sys, state, GeneralizedAlpha().forward_only(), h, t_end)
            out[name, n] = Results(sys, run.t, run.q, run.v, run.acc, run.lam, run.work, np.zeros(len(run.t)))
    return out


_SERIES: dict = {}


def series_under_the_load(t, frac, ei):
    """modal_series under the load at times t (the same for both meshes of a case:
    computed once)."""
    key = (frac, ei, np.asarray(t).tobytes())
    if key not in _SERIES:
        _SERIES[key] = modal_series(t, frac * C * t, frac * C, ei)
    return _SERIES[key]


def deflection_error(res, frac, ei):
    """max |w − w_series| under the load over the crossing, relative to max |w_series|."""
    load = res.moving_load("P")
    t = np.asarray(res.t)
    w_ref = series_under_the_load(t, frac, ei)
    assert np.allclose(load[:, 0][load[:, 3] > 0], np.interp(frac * C * t, [0, ELL], [0, L])[load[:, 3] > 0],
                       atol=1e-6)  # on a straight string, s = x / (1 + ε₀)
    return np.max(np.abs(-load[:, 2] - w_ref)) / np.max(np.abs(w_ref))


@pytest.mark.parametrize("case", ["string 0.2c", "string 0.5c"])
def test_string_deflection_under_a_moving_force(string_runs, case):
    """Against the modal series. Measured relative errors 2.5 % (16 elements), 1.2 %
    (32); first order: the largest error is where the wave front reflected from the
    far pin meets the load (its kink is smeared by the C¹ elements)."""
    frac, ei, _ = CASES[case]
    errors = [deflection_error(string_runs[case, n], frac, ei) for n in (16, 32)]
    assert errors[1] < 0.015
    assert 0.8 < observed_orders(errors)[0] < 1.3


def test_moving_force_energy_balance(string_runs):
    """The moving force's power enters the energy balance as external work: kinetic +
    strain energy = work of the load, up to the time discretization of the work
    integral (undamped, the whole crossing at 0.5c: 6.2e-10, 1.9e-10, 5.7e-11 J of
    2.2e-7 J at h = 0.4, 0.2, 0.1 ms, order 1.7; the same with ρ∞ = 1)."""
    energy = string_runs["string 0.5c", 32].energy()
    assert energy["external"][-1] > 2e-7
    assert np.max(np.abs(energy["balance_error"])) < 3.5e-3 * energy["external"][-1]


def test_beam_deflection_under_a_moving_force(string_runs):
    """With EI = 0.5 N·m² (bending and tension comparable in the first modes) against
    the beam series: second order in the mesh (measured 0.072 %, 0.020 %)."""
    errors = [deflection_error(string_runs["beam 0.5c", n], 0.5, 0.5) for n in (16, 32)]
    assert errors[1] < 3e-3
    assert observed_orders(errors)[0] > 1.6


@pytest.mark.parametrize("case,x_load", [("string 0.2c", 0.25), ("string 0.5c", 0.4)])
def test_slope_jump_at_the_moving_force(string_runs, case, x_load):
    """The slope jump P / (T (1 − v²/c²)) at the load (momentum balance across the moving
    point), from straight-line fits of the nodes on either side, at least 1.5 elements
    from the load and from the nearest wave front (measured 0.07 % and 0.04 %)."""
    frac = CASES[case][0]
    v = frac * C
    res = string_runs[case, 32]
    j = int(np.argmin(np.abs(np.asarray(res.t) - x_load * ELL / v)))
    t = res.t[j]
    x_l, x_f = v * t, (C * t if C * t < ELL else 2 * ELL - C * t)
    nodes = np.stack([res.node("string", k)[j] for k in range(33)])
    h = ELL / 32
    left = (nodes[:, 0] > 0.0) & (nodes[:, 0] < x_l - 1.5 * h)
    right = (nodes[:, 0] > x_l + 1.5 * h) & (nodes[:, 0] < x_f - 1.5 * h)
    assert left.sum() >= 4 and right.sum() >= 4
    jump = np.polyfit(nodes[right, 0], nodes[right, 1], 1)[0] - np.polyfit(nodes[left, 0], nodes[left, 1], 1)[0]
    assert jump == pytest.approx(P / (T_STRING * (1 - frac**2)), rel=3e-3)


def test_moving_mass_tends_to_the_moving_force_of_its_weight(string_runs):
    """A point mass m entering the string at x = 0 at t = 0 and moving at x = 0.2c t
    (gravity g on the mass only) against the moving force of its weight m g
    (string_runs' run at 16 elements scaled by m g / P, the force being linear): the
    mass's inertia, m times the acceleration of the point it rides (the convective
    terms of the sliding joint included), changes the deflection under the load by a
    part proportional to m. Measured relative differences over 0.9 of the crossing:
    1.88 % at m = 0.02 kg, 0.99 % at 0.01 kg (ratio 1.90; 0.51 % at 0.005 kg, ratio
    1.95): first order in m. The mass follows x = v t, and the work of the drive and
    of gravity matches the kinetic and strain energy (measured 6e-8 relative)."""
    g, h, v = 9.81, 4e-4, 0.2 * C
    m = taut_string(16, 1e-6, gravity=g)
    m.moving_mass("M", "string", mass=1.0, path=ConstantSpeed(0.0, v))
    system, state = m.build()
    force = string_runs["string 0.2c", 16]
    t_end = round(0.9 * ELL / v / h / 50) * 50 * h
    n = int(round(t_end / h)) + 1
    np.testing.assert_allclose(force.t[:n], np.arange(n) * h, rtol=1e-12)
    differences = []
    for mass in (0.02, 0.01):
        sys = eqx.tree_at(lambda s: s.bodies.mass, system, jnp.asarray([mass]))
        run = run_fixed(sys, state, GeneralizedAlpha().forward_only(), h, t_end)
        assert run.status == 0
        res = Results(sys, run.t, run.q, run.v, run.acc, run.lam, run.work, np.zeros(len(run.t)))
        np.testing.assert_allclose(res.body("M")[:, 0], v * res.t, atol=1e-10)
        assert res.energy_balance_error() < 1e-6
        weight = force.moving_load("P")[:n, 2] * mass * g / P
        differences.append(np.max(np.abs(res.body("M")[:, 1] - weight)) / np.max(np.abs(weight)))
    assert 0.005 < differences[1] < 0.012
    assert 1.7 < differences[0] / differences[1] < 2.3


def test_loads_placed_by_arc_length_on_an_inclined_cantilever():
    """A cantilever of length 1 m at β = 30° (clamped at the origin, 4 elements, EI =
    2000 N·m², beam gravity off) holding, standing still by arc length, a force P = 1 N
    at s = 0.25 m and a moving mass of 0.2 kg at s = 0.75 m (nodes), both normal to the
    beam (gravity along −n̂), in static equilibrium: the loaded points are the material
    points s (the loaded points' x are s cos β, not s), and their deflections along n̂
    are Maxwell's w(a) = Σ F_b min(a, b)² (3 max(a, b) − min(a, b)) / (6 EI), which the
    cubic elements give exactly at the nodes (measured 3e-8 relative: the static
    solver's step tolerance and the geometric nonlinearity, (w/ℓ)² ~ 1e-8). Loads
    placed at arc length s = x would give deflections 1.3 to 1.5 times larger."""
    from ancf_jax.statics import solve_static

    beta, force, mass, g, ei = np.pi / 6, 1.0, 0.2, 9.81, 2e3
    along, normal = np.array([np.cos(beta), np.sin(beta)]), np.array([-np.sin(beta), np.cos(beta)])
    m = Model(gravity=tuple(-g * normal))
    m.add_beam("arm", mesh.straight((0.0, 0.0), along, 1.0, 4), Section(2e11, 1e-4, ei / 2e11, 1.0),
               gravity=False)
    m.clamp("root", "arm", 0)
    m.moving_force("P", "arm", tuple(-force * normal), path=ConstantSpeed(0.25, 0.0), along="arc_length")
    m.moving_mass("M", "arm", mass=mass, path=ConstantSpeed(0.75, 0.0), along="arc_length")
    system, state = m.build(assemble=False)  # built on the beam, at rest
    sol = solve_static(system, state, load_steps=1, tolerance=1e-12)
    q = np.asarray(sol.state.q)[None]
    res = Results(system, np.zeros(1), q, 0 * q, 0 * q, np.asarray(sol.multipliers)[None], np.zeros((1, 3)),
                  np.zeros(1))

    def maxwell(a, loads):
        """Deflection [m] along n̂ at arc length a under normal loads {b: F_b [N]}."""
        return sum(f * min(a, b)**2 * (3 * max(a, b) - min(a, b)) / (6 * ei) for b, f in loads.items())

    loads = {0.25: -force, 0.75: -mass * g}
    points = {0.25: res.moving_load("P")[0, 1:3], 0.75: res.body("M")[0, :2]}
    assert res.moving_load("P")[0, 0] == 0.25
    for s, p in points.items():
        assert p @ along == pytest.approx(s, abs=1e-7)  # the shortening ∫ w′² / 2 ds ~ 2e-8 m
        assert p @ normal == pytest.approx(maxwell(s, loads), rel=1e-6)
    # negative control: the model's deflection is far from that of the same loads placed
    # at x = s (arc length s / cos β, the mass's then off the 1 m arm), which the
    # tolerance above would tell apart
    wrong = {b / np.cos(beta): f for b, f in loads.items() if b / np.cos(beta) <= 1.0}
    assert abs(points[0.25] @ normal / maxwell(0.25 / np.cos(beta), wrong) - 1) > 0.15


# ---------------------------------------------------------------------------- bounce
M_BALL, K_C, ZETA, V0, GAP0 = 1.0, 1e4, 0.1, 1.0, 0.01
T_BOUNCE = 0.06


def bounce_model():
    """A point mass falling (no gravity, speed V0) onto a rigid track (every node
    clamped, x from −0.5 to 1, a node at x = 0.25) from a gap GAP0, through a penalty
    contact k = K_C (damping set per run). A moving force on the track, standing at
    arc length 0.1 m (x = −0.4; speed 0: set per run), which the clamps take up."""
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("track", mesh.straight((-0.5, 0.0), (1.0, 0.0), 1.0, 2), Section(2e11, 1e-4, 1e-8, 0.8))
    for i in range(3):
        m.clamp(f"c{i}", "track", i)
    m.add_point_mass("ball", mass=M_BALL, position=(0.1, GAP0), velocity=(0.0, -V0))
    m.contact("contact", body_point("ball"), "track", stiffness=K_C, damping=1.0)
    m.moving_force("rider", "track", (0.0, -1.0), path=ConstantSpeed(0.1, 0.0), along="arc_length")
    return m.build(assemble=False)  # consistent as built: the ball is free (no eager projection)


def bounce_system(zeta):
    """The bounce model with contact damping c = 2 ζ √(k m)."""
    system, state = bounce_model()
    return eqx.tree_at(lambda s: s.forces[0].damping, system,
                       jnp.asarray(2 * zeta * np.sqrt(K_C * M_BALL), float)), state


def force_zero_time(zeta):
    """t* [s] after closing at which the force k δ + c δ̇ of bounce_closed_form
    vanishes: ω_d t* = π − atan(2ζ√(1−ζ²) / (1 − 2ζ²))."""
    wd = np.sqrt(K_C / M_BALL) * np.sqrt(1 - zeta**2)
    return (np.pi - np.arctan(2 * zeta * np.sqrt(1 - zeta**2) / (1 - 2 * zeta**2))) / wd


def bounce_closed_form(zeta):
    """(contact time [s], restitution) of a mass m hitting a spring-damper k, c at V0
    whose force k δ + c δ̇ cannot pull: δ = (V0/ω_d) e^{−ζωt} sin ω_d t until the force
    vanishes at ω_d t* = π − atan(2ζ√(1−ζ²) / (1 − 2ζ²)); then free flight at the
    speed there, out of the penetration δ(t*)."""
    w = np.sqrt(K_C / M_BALL)
    wd = w * np.sqrt(1 - zeta**2)
    ts = force_zero_time(zeta)
    decay = np.exp(-zeta * w * ts)
    delta = V0 / wd * decay * np.sin(wd * ts)
    rate = V0 * decay * (np.cos(wd * ts) - zeta * w / wd * np.sin(wd * ts))
    return ts + delta / -rate, -rate / V0


STEPS = (1e-3, 5e-4, 2.5e-4)


@pytest.fixture(scope="module")
def bounce_runs():
    """Undamped and damped (ζ = ZETA) bounces with located events at STEPS (one
    program: damping and the step are data; the same runs without located events are
    ``python -m benchmarks.contact_events``). Step retries on, as in ``simulate``: a
    damped contact's force jumps by c V0 when it closes, and an implicit step ending
    just inside it has no solution."""
    out = {}
    for zeta in (0.0, ZETA):
        sys, state = bounce_system(zeta)
        for h in STEPS:
            run = run_fixed(sys, state, GeneralizedAlpha().forward_only(), h, T_BOUNCE, chunk=60,
                            options=BOUNCE_OPTIONS)
            assert run.status == 0
            out[zeta, h] = run
    return out


#: options of the bounce runs: contact events and node crossings of the contact point
#: and the moving force located (the bounce itself crosses no node)
BOUNCE_OPTIONS = RunOptions(locate_crossings=True, locate_load_nodes=True)


def bounce_errors(run, zeta):
    """(contact time, restitution) errors: the time out of contact from the final free
    flight, y(t) = y_end + v_end (t − t_end) = 0."""
    t_c, e = bounce_closed_form(zeta)
    y, vy = run.q[-1, 1], run.v[-1, 1]
    t_out = run.t[-1] - y / vy
    return abs(t_out - GAP0 / V0 - t_c), abs(vy / V0 - e)


def test_undamped_bounce_located_contact_is_second_order(bounce_runs):
    """ζ = 0: contact time π/ω and restitution 1. Located events: restitution errors
    2.0e-5, 1.8e-6, 4.6e-7 at h = 1, 0.5, 0.25 ms; without (benchmarks.contact_events):
    1.2e-3, 1.6e-4, 6.9e-5 (erratic, about first order), 60 to 150 times larger.
    Contact time second order either way (measured 2.6e-5 to 1.7e-6 s)."""
    located = np.array([bounce_errors(bounce_runs[0.0, h], 0.0) for h in STEPS])
    assert np.all(observed_orders(located[:, 0]) > 1.9)
    assert np.all(observed_orders(located[:, 1]) > 1.8)
    assert located[-1, 1] < 1e-6 and located[-1, 0] < 2e-6


def test_damped_bounce_against_the_closed_form(bounce_runs):
    """ζ = 0.1 (restitution 0.73): the contact's force jumps by c V0 when it closes, and
    generalized-α's acceleration variable carries that jump's error on: restitution
    first order with or without located events (measured 7.8e-3, 3.8e-3, 1.9e-3
    located), as for the damped rope (docs/cable-machinery.md); contact time second
    order (2.9e-5 to 1.8e-6 s)."""
    located = np.array([bounce_errors(bounce_runs[ZETA, h], ZETA) for h in STEPS])
    assert np.all(observed_orders(located[:, 0]) > 1.9)
    assert np.all((observed_orders(located[:, 1]) > 0.9) & (observed_orders(located[:, 1]) < 1.2))
    assert located[-1, 1] < 2.5e-3 and located[-1, 0] < 2.5e-6


def test_contact_outputs_gap_force_and_loss_of_contact(bounce_runs):
    """Results.contact of the bounces at h = 0.5 ms: on the flat track the gap is the
    ball's height y, the contact is engaged exactly while y < 0, and the normal force
    is k δ + max(c δ̇, −k δ) (δ = −y) there, 0 elsewhere, never negative. Closing,
    loss of the force and opening fall in the steps holding the closed-form times
    GAP0/V0, GAP0/V0 + t* and GAP0/V0 + contact time (bounce_closed_form); damped, the
    force vanishes (t* = 29.56 ms after closing) 2 ms before the ball is back at the
    surface (4 steps), undamped the two coincide."""
    h = 5e-4
    for zeta in (0.0, ZETA):
        system, _ = bounce_system(zeta)
        run = bounce_runs[zeta, h]
        res = Results(system, run.t, run.q, run.v, run.acc, run.lam, run.work, np.zeros(len(run.t)))
        force, gap, engaged = res.contact("contact")[:, :3].T
        y, vy = res.body("ball")[:, 1], run.v[:, system.body_offset(0) + 1]
        np.testing.assert_allclose(gap, y, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(engaged, (y < 0).astype(float))
        c = 2 * zeta * np.sqrt(K_C * M_BALL)
        np.testing.assert_allclose(force, np.where(y < 0, -K_C * y + np.maximum(-c * vy, K_C * y), 0.0),
                                   rtol=1e-12, atol=1e-12)
        assert np.all(force >= 0.0)
        t_c, t_zero = bounce_closed_form(zeta)[0], force_zero_time(zeta)
        closed, pushing = np.nonzero(engaged)[0], np.nonzero(force > 0)[0]
        for first, last, t_end in ((closed[0], closed[-1], t_c), (pushing[0], pushing[-1], t_zero)):
            assert run.t[first - 1] < GAP0 / V0 <= run.t[first] + 1e-12
            assert run.t[last] < GAP0 / V0 + t_end <= run.t[last + 1]
        assert np.all(np.diff(closed) == 1) and np.all(np.diff(pushing) == 1)
        assert (closed[-1] > pushing[-1]) == (zeta > 0)


def test_a_batch_locates_each_members_events_as_its_single_run(bounce_runs):
    """The two bounces (undamped, damped) at h = 1 ms as one vmapped batch with located
    events and step retries (``simulate_batch``): under ``vmap`` the located step's
    loop runs until every member is done, each member's search, substeps and retries
    masked to its own, so a member's run equals its single run of the fixture up to
    rounding (the batch's products are summed in another order); a located event missed
    or misplaced moves the ball by far more (without location the restitution differs
    by 1e-3, test_undamped_bounce_located_contact_is_second_order). Measured: 1.1e-16 m
    in q, 1.1e-12 m/s in v. (Until 2026-12-07 the members done with their step took a
    step of size 0 in the loop's passes the others still needed: non-finite states,
    and the contact's closest-point search raised.)"""
    from ancf_jax.simulation import simulate_batch
    h = STEPS[0]
    systems, states = zip(*(bounce_system(z) for z in (0.0, ZETA)))
    batch = simulate_batch(systems, states, t_end=T_BOUNCE, dt=h, output_dt=h, solver=GeneralizedAlpha(),
                           options=BOUNCE_OPTIONS, progress=False)
    for res, zeta in zip(batch, (0.0, ZETA)):
        single = bounce_runs[zeta, h]
        assert res.status == "ok"
        np.testing.assert_allclose(res.t, single.t, rtol=0, atol=1e-12)
        np.testing.assert_allclose(res.q, single.q, rtol=0, atol=1e-13)
        np.testing.assert_allclose(res.v, single.v, rtol=0, atol=1e-10)
        assert int(np.sum(single.crossings)) > 0  # the single run located events


def test_default_contact_stiffness_from_the_beam():
    """Without a stiffness, a contact gets CONTACT_STIFFNESS_FACTOR (100) times the
    static stiffness of the beam where its point touches it: on a cantilever (EI =
    2000 N·m², 2 elements, clamped at x = 0) under a ball at a = 0.5 m, 100 · 3 EI / a³
    (the cubic elements give the nodal deflection exactly: measured 1e-14). On a beam
    clamped at every node (rigid: k_b infinite) there is no such default: one-line
    ModelError naming the contact's stiffness (likewise on a beam not held at all,
    k_b = 0: one more compile, left out for time). (On the taut string of
    pantograph_model the derived k_b converges to T ℓ / (x (ℓ − x)) at first order, the
    load's kink being smeared by the C¹ elements: 5.9 %, 2.7 %, 1.4 % at 8, 16, 32
    elements.)"""
    from ancf_jax.errors import ModelError
    from ancf_jax.model import CONTACT_STIFFNESS_FACTOR

    ei = 2e3

    def cantilever(clamped):
        m = Model(gravity=(0.0, -9.81))
        m.add_beam("arm", mesh.straight((0.0, 0.0), (1.0, 0.0), 1.0, 2), Section(2e11, 1e-4, ei / 2e11, 1.0))
        for i in clamped:
            m.clamp(f"c{i}", "arm", i)
        m.add_point_mass("ball", mass=1.0, position=(0.5, 0.0))
        m.contact("touch", body_point("ball"), "arm")
        return m

    system, _ = cantilever([0]).build(assemble=False)  # built consistent, at rest
    assert CONTACT_STIFFNESS_FACTOR == 100.0
    assert float(system.forces[0].stiffness) == pytest.approx(100.0 * 3 * ei / 0.5**3, rel=1e-12)
    with pytest.raises(ModelError, match=r"^stiffness of contact 'touch' has no default: .* static stiffness "
                       r"there is inf N/m: the model holds it rigidly\); give stiffness \[N/m\] > 0") as err:
        cantilever([0, 1, 2]).build()
    assert "\n" not in str(err.value)
    # the derivation is a dense solve: above CONTACT_STIFFNESS_MAX_COORDINATES it is refused
    # (lowered here below the 15 coordinates of the cantilever and ball), before anything is solved
    import ancf_jax.model as model_module
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(model_module, "CONTACT_STIFFNESS_MAX_COORDINATES", 11)
        with pytest.raises(ModelError, match=r"^stiffness of contact 'touch' has no default in a model of 15 "
                           r"coordinates \(the default's dense solve is limited to 11\): give stiffness"):
            cantilever([0]).build(assemble=False)


# ---------------------------------------------------------------------------- gradients
def pantograph_model():
    """A one-mass current collector (0.1 kg, uplift 1 N, gravity off) under the string
    of :func:`string_model` (8 elements), starting at x = 0.2 m in static contact (1 mm
    penetration) and moving at x = 0.2 + v t, pressed up against the string through a
    contact k = 1e3 N/m, c = 1 N·s/m."""
    m = taut_string(8, 1e-6)
    head = m.lumped_chain("collector", base=(0.2, -0.5), heights=[0.501], masses=[0.1], stiffness=[0.0],
                          forces=[1.0], path=ConstantSpeed(0.2, 1.0))[0]
    m.contact("contact", body_point(head), "string", stiffness=1e3, damping=1.0, side=-1)
    return m.build()


@pytest.mark.study
def test_gradients_of_contact_force_statistics():
    """d mean(F_n²)/d(v, k) over 0.025 s (the head pushed into the wire, contact kept),
    forward mode through the implicit steps (the search for the contact point
    differentiated implicitly), against central differences (steps 1e-4 relative;
    Newton tolerance 1e-12 as in the friction gradients)."""
    from ancf_jax.newton import ModifiedNewton
    from ancf_jax.simulation import trajectory

    system, state = pantograph_model()
    contact = next(f for f in system.forces if f.name == "contact")
    k_contact = system.forces.index(contact)
    k_path = next(i for i, c in enumerate(system.constraints) if c.name == "collector.1.x")

    def statistic(p):
        sys = eqx.tree_at(lambda s: (s.constraints[k_path].path.speed, s.forces[k_contact].stiffness),
                          system, (p[0], p[1]))
        seg, _ = trajectory(sys, state, GeneralizedAlpha(root_finder=ModifiedNewton(tolerance=1e-12)),
                            t_end=0.025, dt=5e-4)
        f = jax.vmap(lambda q, v: sys.forces[k_contact].normal_force(sys, q, v))(seg.q, seg.v)
        return jnp.mean(f**2), jnp.min(f)

    @jax.jit
    def value_and_derivative(p, direction):
        # one program (the direction is data) for both partial derivatives and the
        # differences: its primal is the statistic at p
        values, tangents = jax.jvp(statistic, (p,), (direction,))
        return values[0], values[1], tangents[0]

    p0 = jnp.array([1.0, 1e3])
    steps = 1e-4 * p0
    grad, fd = [], []
    for e, d in zip(jnp.eye(2), jnp.diag(steps)):
        _, smallest, derivative = value_and_derivative(p0, e)
        assert smallest > 0.0  # contact kept: no event in the differentiated run
        grad.append(derivative)
        fd.append((value_and_derivative(p0 + d, e)[0] - value_and_derivative(p0 - d, e)[0]) / (2 * d @ e))
    grad, fd = np.asarray(grad), np.asarray(fd)
    assert np.all(np.abs(np.asarray(grad)) > 0)
    np.testing.assert_allclose(grad, fd, rtol=1e-6)


def test_lumped_chain_frequencies():
    """A two-stage chain (base spring k₁ to mass m₁, k₂ between m₁ and m₂; gravity off)
    against the eigenvalues of K = [[k₁ + k₂, −k₂], [−k₂, k₂]], M = diag(m₁, m₂); the
    masses' x held, so these are its only two degrees of freedom."""
    from scipy.linalg import eigh

    from ancf_jax.modal import modal_analysis

    m = Model(gravity=(0.0, 0.0))
    names = m.lumped_chain("pantograph", base=(0.0, 0.0), heights=[0.3, 0.5], masses=[15.0, 7.0],
                           stiffness=[160.0, 8000.0], damping=[100.0, 10.0], forces=[70.0, 0.0])
    assert names == ("pantograph.1", "pantograph.2")
    system, state = m.build()
    modes = modal_analysis(system, state.q)
    k = np.array([[160.0 + 8000.0, -8000.0], [-8000.0, 8000.0]])
    w = np.sqrt(eigh(k, np.diag([15.0, 7.0]), eigvals_only=True))
    assert modes.angular_frequencies.shape == (2,)
    np.testing.assert_allclose(modes.angular_frequencies, w, rtol=1e-10)


def test_moving_mass_on_an_incline():
    """A moving mass at x = x₀ + v t on a rigid incline (every node clamped, slope
    angle β, gravity): it starts on the track with velocity v (1, −tan β) (the joints
    set it), follows the track, and the track's and the drive's forces balance its
    weight at constant velocity."""
    beta, v, mass, g = 0.3, 2.0, 3.0, 9.81
    m = Model(gravity=(0.0, -g))
    m.add_beam("track", mesh.straight((0.0, 0.0), (np.cos(beta), -np.sin(beta)), 2.0, 2),
               Section(2e11, 1e-4, 1e-8, 0.8))
    for i in range(3):
        m.clamp(f"c{i}", "track", i)
    m.moving_mass("cart", "track", mass=mass, path=ConstantSpeed(0.3, v))
    system, state = m.build()
    pose = np.asarray(state.q[:2])
    np.testing.assert_allclose(pose, [0.3, -0.3 * np.tan(beta)], atol=1e-12)
    np.testing.assert_allclose(np.asarray(state.v[:2]), [v, -v * np.tan(beta)], atol=1e-10)
    run = run_fixed(system, state, GeneralizedAlpha().forward_only(), 0.01, 0.2, chunk=20)
    res = Results(system, run.t, run.q, run.v, run.acc, run.lam, run.work, np.zeros(len(run.t)))
    np.testing.assert_allclose(res.body("cart")[:, 0], 0.3 + v * res.t, atol=1e-10)
    np.testing.assert_allclose(res.body("cart")[:, 1], -(0.3 + v * res.t) * np.tan(beta), atol=1e-9)
    # forces on the cart at constant velocity: the track's N n̂ (normal to it: no
    # friction) and the drive's H x̂ balance the weight: N = m g / cos β, H = −m g tan β
    track_force = res.joint_force("cart.slider")
    drive = res.drive_force("cart.drive")
    np.testing.assert_array_equal(drive, -res.multipliers("cart.drive")[:, 0])
    normal = np.array([np.sin(beta), np.cos(beta)])
    np.testing.assert_allclose(track_force, np.outer(np.full(len(res.t), mass * g / np.cos(beta)), normal),
                               rtol=1e-8)
    np.testing.assert_allclose(drive, -mass * g * np.tan(beta), rtol=1e-8)


def test_speed_is_a_parameter_by_name_and_scenario_key():
    """``speed.NAME`` (scenario keys loads.NAME.speed, moving_masses.NAME.speed,
    chains.NAME.speed) reads and sets the data of the path(s) that move an item, for
    fits and local sensitivities (derivatives through the paths:
    test_gradients_of_contact_force_statistics)."""
    from ancf_jax.errors import ModelError
    from ancf_jax.identification.parameters import from_scenario_key, resolve

    assert from_scenario_key("chains.collector.speed") == "speed.collector"
    assert from_scenario_key("loads.P.speed") == "speed.P"
    system, _ = pantograph_model()
    (p,) = resolve(system, ["chains.collector.speed"])
    assert p.unit == "m/s" and float(p.get(system)) == 1.0
    moved = p.set(system, 2.5)
    assert float(next(c for c in moved.constraints if c.name == "collector.1.x").path.speed) == 2.5
    string, _ = string_model(4, 3.0, 1e-6)
    (q,) = resolve(string, ["speed.P"])
    assert float(q.set(string, 4.0).forces[0].location.path.speed) == 4.0
    with pytest.raises(ModelError, match="no moving force, moving mass or chain named 'nothing'"):
        resolve(string, ["speed.nothing"])


# ---------------------------------------------------------------------------- node crossings
def test_node_crossing_value_changes_sign_at_interior_nodes_only():
    """(−1)ᵏ f (1 − f) of the global element coordinate on an uneven mesh (elements of
    lengths alternating 1:2, padded): exactly zero at the interior nodes, one sign
    within each element, alternating, continuous, constant near and beyond the ends
    (a point's entry and exit are no crossings)."""
    from ancf_jax.contact import node_crossing_value
    from .dynamics import uneven_arc

    track = uneven_arc(5, 1.0, 1.2)
    padded = mesh.through_points(np.asarray(track.reference_nodes)[:, :2], np.asarray(track.reference_nodes)[:, 2:],
                                 n_max=8)
    edges = np.asarray(padded.node_arc_lengths)[:6]
    value = jax.jit(jax.vmap(lambda s: node_crossing_value(padded, s)))
    assert np.all(np.asarray(value(jnp.asarray(edges[1:5]))) == 0.0)
    s = np.linspace(-0.3, edges[-1] + 0.3, 4001)
    g = np.asarray(value(jnp.asarray(s)))
    changes = s[1:][np.sign(g[1:]) * np.sign(g[:-1]) < 0]
    np.testing.assert_allclose(changes, edges[1:5], atol=2 * (s[1] - s[0]))
    assert np.max(np.abs(np.diff(g))) < 2 * (s[1] - s[0]) / np.min(np.diff(edges))  # |dg/ds| <= 1 / l
    mids = 0.5 * (edges[1:] + edges[:-1])
    np.testing.assert_allclose(np.asarray(value(jnp.asarray(mids))), [0.25, -0.25, 0.25, -0.25, 0.25])
    ends = np.asarray(value(jnp.asarray([-1.0, 0.0, edges[-1], edges[-1] + 1.0])))
    np.testing.assert_allclose(ends, [0.25, 0.25, 0.25, 0.25])


def test_node_crossings_of_a_contact_point_and_a_moving_force_are_located(bounce_runs):
    """The undamped bounce with the ball also moving along the track at −5.9 m/s
    (frictionless: its x is 0.1 − 5.9 t), and the moving force running at 13.7 m/s
    along the arc length from x = −0.4: the track's node at x = 0 is crossed by the contact point at
    t = 0.1/5.9 = 16.95 ms, in contact (closed from 10 to 41.42 ms), and by the force
    at 0.4/13.7 = 29.20 ms. With h = 0.5 ms the located crossings are those of the
    bounce standing still (bounce_runs: the contact's opening in step 83, and its
    closing where round-off puts it) plus exactly the steps holding those two times,
    34 and 59. The bounce programs are reused (speeds and state are data)."""
    h = 5e-4
    system, state = bounce_model()
    k_rider = next(i for i, f in enumerate(system.forces) if f.name == "rider")
    sys = eqx.tree_at(lambda s: (s.forces[0].damping, s.forces[k_rider].location.path.speed), system,
                      (jnp.asarray(0.0, float), jnp.asarray(13.7, float)))
    ball = system.body_offset(0)
    moving = eqx.tree_at(lambda s: s.v, state, state.v.at[ball].set(-5.9))
    run = run_fixed(sys, moving, GeneralizedAlpha().forward_only(), h, T_BOUNCE, chunk=60, options=BOUNCE_OPTIONS)
    assert run.status == 0
    np.testing.assert_allclose(run.q[:, ball], 0.1 - 5.9 * run.t, atol=1e-12)
    crossed = [int(np.ceil(t / h)) for t in (0.1 / 5.9, 0.4 / 13.7)]
    assert crossed == [34, 59]
    standing = np.nonzero(bounce_runs[0.0, h].crossings)[0]
    t_open = GAP0 / V0 + np.pi * np.sqrt(M_BALL / K_C)
    assert int(np.ceil(t_open / h)) in standing and len(standing) <= 2
    np.testing.assert_array_equal(np.nonzero(run.crossings)[0], np.sort(np.concatenate([standing, crossed])))


def test_moving_loads_along_x_and_contacts_need_a_beam_monotonic_in_x():
    """On a vertical mast (its nodes all at x = 2) a moving force or mass along x and a
    contact are refused with one line naming the item, the beam and what is accepted,
    when the item is added (moving mass) or at the start of build (before anything is
    compiled); along the arc length they are accepted."""
    from ancf_jax.errors import ModelError

    def mast():
        m = Model(gravity=(0.0, 0.0))
        m.add_beam("mast", mesh.straight((2.0, 0.0), (0.0, 1.0), 1.0, 2), Section(1e9, 1e-4, 1e-9, 1.0))
        m.add_point_mass("ball", mass=1.0, position=(2.5, 0.5))
        return m

    needs = r"needs beam 'mast' to run left to right or right to left, but the x of its nodes is not strictly " \
            r"monotonic \(x = 2, 2, 2 m\); accepted: "
    m = mast()
    m.moving_force("P", "mast", (1.0, 0.0), path=ConstantSpeed(0.0, 1.0))
    with pytest.raises(ModelError, match=r"^moving force 'P' along=\"x\" " + needs + '"arc_length", or a beam') as err:
        m.build()
    assert "\n" not in str(err.value)
    with pytest.raises(ModelError, match=r"^moving mass 'M' along=\"x\" " + needs):
        mast().moving_mass("M", "mast", mass=1.0, path=ConstantSpeed(2.0, 1.0))
    m = mast()
    m.contact("touch", body_point("ball"), "mast", stiffness=1e3)
    with pytest.raises(ModelError, match=r"^contact 'touch' \(its search starts under the point's x\) " + needs
                       + "a beam whose node x"):
        m.build()
    m = mast()
    m.moving_force("P", "mast", (1.0, 0.0), path=ConstantSpeed(0.0, 1.0), along="arc_length")
    m.moving_mass("M", "mast", mass=1.0, path=ConstantSpeed(0.2, 1.0), along="arc_length")
    m._check_references()


# ---------------------------------------------------------------------------- contact friction
def test_contact_friction_against_coulomb_and_momentum():
    """A 1 kg block resting on a straight beam (its penalty penetration m g / k, so
    F_n = m g) slides at 2 m/s with μ = 0.3; the beam (1.6 kg) is held in y and
    slope_y only, free along x, so the friction's reaction accelerates it. Closed form
    of rigid-body Coulomb friction: the block decelerates at μ g until the relative
    motion stops at t_s = v₀ / (μ g (1 + m/M)), then both move at m v₀ / (m + M); the
    dissipated work is ½ m v₀² M / (m + M). The x-momentum of block and beam is
    conserved (the reaction acts on the beam's material point). Measured at h = 1 ms:
    block speed while sliding and momentum to round-off (3e-14), common speed 2.7e-6
    m/s, dissipation and energy balance 1.6e-6 J (second order: 3.5e-7 J at 0.5 ms;
    the regularization's creep, v_ε = 1 mm/s, adds about v_ε² π² / (12 μ g) = 3e-7 m
    to the sliding distance). With a viscous part the force adds −c u in contact, and
    it vanishes, viscous part included, once the block is lifted off."""
    g, mu, k, mass, v0 = 9.81, 0.3, 1e5, 1.0, 2.0
    m = Model(gravity=(0.0, -g))
    m.add_beam("track", mesh.straight((0.0, 0.0), (1.0, 0.0), 2.0, 2), Section(2e11, 1e-4, 1e-8, 0.8))
    for i in range(3):
        m.coordinate(f"y{i}", node("track", i), "y", value=0.0)
        m.coordinate(f"t{i}", node("track", i), "slope_y", value=0.0)
    m.add_point_mass("block", mass=mass, position=(0.2, -mass * g / k), velocity=(v0, 0.0))
    m.contact("contact", body_point("block"), "track", stiffness=k, mu=mu)
    system, state = m.build(assemble=False)  # consistent as built: the block is free (no eager projection)
    run = run_fixed(system, state, GeneralizedAlpha().forward_only(), 1e-3, 0.6)
    assert run.status == 0
    res = Results(system, run.t, run.q, run.v, run.acc, run.lam, run.work, np.zeros(len(run.t)))
    translation = np.zeros(system.n_coordinates)
    translation[system.body_offset(0)] = 1.0
    translation[np.asarray(system.chain_indices())[0::4]] = 1.0      # every node's x
    mass_matrix = np.asarray(eqx.filter_jit(lambda s: s.mass_matrix())(system))  # one program, not op by op
    beam_mass = translation @ mass_matrix @ translation - mass
    assert beam_mass == pytest.approx(1.6, rel=1e-12)
    momentum = run.v @ (mass_matrix @ translation)
    np.testing.assert_allclose(momentum, mass * v0, rtol=1e-12)
    t, block = res.t, run.v[:, system.body_offset(0)]
    t_stop = v0 / (mu * g * (1 + mass / beam_mass))
    sliding, together = t < t_stop - 0.01, t > t_stop + 0.05
    np.testing.assert_allclose(block[sliding], v0 - mu * g * t[sliding], atol=1e-12)
    contact = res.contact("contact")
    np.testing.assert_allclose(contact[sliding, 0], mass * g, rtol=1e-12)
    np.testing.assert_allclose(contact[sliding, 4], -mu * mass * g, rtol=1e-12)
    np.testing.assert_allclose(block[together], mass * v0 / (mass + beam_mass), atol=5e-6)
    energy = res.energy()
    dissipated = 0.5 * mass * v0**2 * beam_mass / (mass + beam_mass)
    assert energy["dissipated"][-1] == pytest.approx(dissipated, abs=3e-6)
    assert np.max(np.abs(energy["balance_error"])) < 3e-6
    # with a viscous part c = 1 N·s/m: −μ m g − c v₀ in contact, nothing once lifted
    k_contact = next(i for i, f in enumerate(system.forces) if f.name == "contact")
    viscous = eqx.tree_at(lambda s: s.forces[k_contact].friction.viscous, system, jnp.asarray(1.0))
    force = jax.jit(lambda q: viscous.forces[k_contact].tangential_force(viscous, q, state.v))
    assert float(force(state.q)) == pytest.approx(-mu * mass * g - v0, rel=1e-12)
    assert float(force(state.q.at[system.body_offset(0) + 1].set(0.01))) == 0.0
