"""Cable machinery (issue 19): one-sided spring-dampers (ropes, droppers, stops),
point masses on beams, driven and frictional sliding joints.

Closed forms and independent numbers: a body bouncing on a tension-only rope (free
flight while slack, harmonic while taut; scipy's solve_ivp as the independent answer),
the energy balance through slack and taut phases with its tolerance from a step-halving
study; a clamp mass's kinetic energy, weight and the frequency of a taut string with a
central mass (z tan z = ρL/M, with a convergence study); a body on a frictional incline
that creeps at v_ε artanh(F/μN) or slides at g (sin β − μ cos β); trolleys hauled at
constant speed by a prescribed arc length, a servo and a pull against the closed-form
resistance; the same slide on a taut inclined cable within its kink bound; the Newton
matrix with ∂Q/∂λ against a dense jacfwd; gradients through friction (Coulomb and
viscous) and every drive kind against finite differences and closed forms.

Compiled programs are shared: the rope runs (h is data), the incline runs and the
Coulomb oscillator's runs without location (tan β, the spring and h are data), one
three-trolley run, one taut-cable run, one eyelet model, one gradient program (not
vmapped).
"""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from ancf_jax import dae, mesh
from ancf_jax.beam import Beam
from ancf_jax.forces import CompressionOnlySpringDamper, TensionOnlySpringDamper
from ancf_jax.integrate import NO_RETRIES, RunOptions
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha
from ancf_jax.modal import modal_analysis
from ancf_jax.model import Model, body_point, ground, node
from ancf_jax.newton import ModifiedNewton
from ancf_jax.outputs import Output, evaluate
from ancf_jax.points import BodyPoint, GroundPoint
from ancf_jax.results import Results
from ancf_jax.section import Section

from .dynamics import G, run_fixed, track_model

# ---------------------------------------------------------------------------- ropes
K_ROPE, M_ROPE, L_ROPE, V_UP, T_ROPE = 400.0, 1.0, 1.0, 2.0, 1.6


def rope_model(damping):
    """A body hanging on a tension-only rope of rest length L from the origin, thrown
    up at V_UP from where the rope is just taut (slack flight, then taut bounce)."""
    m = Model(gravity=(0.0, -G))
    m.add_body("b", mass=M_ROPE, inertia=0.1, position=(0.0, -L_ROPE), velocity=(0.0, V_UP),
               angular_velocity=0.0)
    m.spring_damper("rope", ground(0.0, 0.0), body_point("b"), stiffness=K_ROPE, damping=damping,
                    rest_length=L_ROPE, acts="tension")
    return m.build()


@pytest.fixture(scope="module")
def rope_runs():
    """Undamped and damped rope at h = 2, 1, 0.5 ms (one compiled loop: h is data)."""
    out = {}
    for c in (0.0, 2.0):
        system, state = rope_model(c)
        for h in (0.002, 0.001, 0.0005):
            out[c, h] = system, run_fixed(system, state, GeneralizedAlpha().forward_only(), h, T_ROPE, chunk=200)
    return out


def balance(run):
    """max |T + V + U + D − W_e − W_c − (same at t = 0)| [J] (Results.energy's balance)."""
    y = run.q[:, 1]
    e = np.maximum(-y - L_ROPE, 0.0)
    total = (0.5 * M_ROPE * np.sum(run.v[:, :2] ** 2, 1) + M_ROPE * G * y + 0.5 * K_ROPE * e**2
             + run.work[:, 0] - run.work[:, 1] - run.work[:, 2])
    return np.max(np.abs(total - total[0]))


def rope_reference(damping, t):
    """The vertical motion y(t) by solve_ivp (rtol 1e-11) with the same law: free flight
    while y > −L, k e + max(c ė, −k e) while taut (e = −y − L)."""
    def rhs(_, z):
        y, vy = z
        e = -y - L_ROPE
        f = np.where(e > 0, K_ROPE * e + max(damping * -vy, -K_ROPE * e), 0.0) if e > 0 else 0.0
        return [vy, -G + f / M_ROPE]
    sol = solve_ivp(rhs, (0.0, t[-1]), [-L_ROPE, V_UP], t_eval=t, rtol=1e-11, atol=1e-12,
                    method="DOP853", max_step=1e-3)
    return sol.y[0]


def test_one_sided_laws_zero_on_the_other_side():
    """Tension only: no force while shorter than ℓ₀, k e while longer; a fast retraction
    of a taut rope is limited to zero force (the damper never pushes). Compression only:
    the mirror image. Exact zeros."""
    k, c, l0 = 100.0, 50.0, 1.0
    system, _ = rope_model(0.0)

    @eqx.filter_jit
    def evaluate(f, q, v):
        return f.tension(system, q, v), f.generalized_force(system, q, v, 0.0)[1]
    for law, sign in ((TensionOnlySpringDamper, 1.0), (CompressionOnlySpringDamper, -1.0)):
        f = law("m", GroundPoint(jnp.zeros(2)), BodyPoint(0, jnp.zeros(2)), jnp.asarray(k),
                jnp.asarray(c), jnp.asarray(l0))
        for ell, ell_dot, expected in ((1.0 - sign * 0.1, 0.0, 0.0), (1.0 - sign * 0.1, sign * 3.0, 0.0),
                                       (1.0 + sign * 0.1, 0.0, sign * k * 0.1),
                                       (1.0 + sign * 0.1, sign * 0.05, sign * (k * 0.1 + c * 0.05)),
                                       (1.0 + sign * 0.1, -sign * 3.0, 0.0)):
            q = jnp.array([0.0, -ell, 0.0])
            v = jnp.array([0.0, -ell_dot, 0.0])
            tension, q_y = evaluate(f, q, v)
            assert float(tension) == pytest.approx(expected, abs=1e-12)
            # the generalized force on y of the body below the anchor is the member force
            assert float(q_y) == pytest.approx(expected, abs=1e-12)


def test_rope_slack_and_taut_phases(rope_runs):
    """Slack phase: free flight (the rope does nothing: y = −L + V t − ½ g t² to
    round-off... the generalized-α error); taut: the maximum stretch of the undamped rope
    mg/k + √((mg/k)² + V²/ω²); the damped run against solve_ivp."""
    system, run = rope_runs[0.0, 0.0005]
    y = run.q[:, 1]
    slack = run.t < 2 * V_UP / G - 0.01
    np.testing.assert_allclose(y[slack], -L_ROPE + V_UP * run.t[slack] - 0.5 * G * run.t[slack] ** 2,
                               atol=1e-9)
    w = np.sqrt(K_ROPE / M_ROPE)
    e_max = M_ROPE * G / K_ROPE + np.sqrt((M_ROPE * G / K_ROPE) ** 2 + V_UP**2 / w**2)
    # measured error 2.1e-5, 1.1e-5, 5.8e-6, 1.9e-6 m at h = 4, 2, 1, 0.5 ms
    assert np.max(-y - L_ROPE) == pytest.approx(e_max, abs=5e-6)
    for c in (0.0, 2.0):
        _, run = rope_runs[c, 0.0005]
        ref = rope_reference(c, run.t)
        assert np.max(np.abs(run.q[:, 1] - ref)) < 2e-4
    # the member output (Results.member, output kind "member") of the damped rope: the
    # law k e + max(c ℓ̇, −k e) while taut evaluated here from ℓ = |r|, ℓ̇ = r·v/ℓ of
    # the body's state, exactly 0 and disengaged while slack
    system, run = rope_runs[2.0, 0.0005]
    results = Results(system, run.t, run.q, run.v, run.acc, run.lam, run.work, np.zeros(len(run.t)))
    member = results.member("rope")
    ell = np.linalg.norm(run.q[:, :2], axis=1)
    e, ell_dot = ell - L_ROPE, np.sum(run.q[:, :2] * run.v[:, :2], axis=1) / ell
    taut = e > 0
    assert 0 < taut.sum() < len(taut)  # both phases
    np.testing.assert_array_equal(member[:, 1], taut.astype(float))
    assert np.all(member[~taut, 0] == 0.0) and np.all(member[:, 0] >= 0.0)
    law = K_ROPE * e + np.maximum(2.0 * ell_dot, -K_ROPE * e)
    np.testing.assert_allclose(member[taut, 0], law[taut], rtol=1e-12, atol=1e-9)
    assert np.max(member[:, 0]) > 4.0 * M_ROPE * G  # the bounce pulls hard (measured 47 N)
    cols = evaluate(results, [Output("r", "member", "rope"), Output("on", "member", "rope", "engaged")])
    np.testing.assert_array_equal(cols["r"], member[:, 0])
    np.testing.assert_array_equal(cols["on"], member[:, 1])


def test_rope_energy_balance_step_halving(rope_runs):
    """The energy balance through two slack/taut transitions closes to the integrator's
    error: step-halving study (measured, undamped: 2.6e-3, 6.0e-4, 3.1e-4, 5.1e-5 J at
    h = 4, 2, 1, 0.5 ms; damped c = 2 N·s/m: 1.4e-3, 4.3e-4, 1.6e-4, 5.8e-5 J, with 1.55 J
    dissipated; initial energy 2 J). Tolerance: 2× the measured error at each step, and
    the error must fall with the step."""
    measured = {(0.0, 0.002): 6.0e-4, (0.0, 0.001): 3.1e-4, (0.0, 0.0005): 5.1e-5,
                (2.0, 0.002): 4.3e-4, (2.0, 0.001): 1.6e-4, (2.0, 0.0005): 5.8e-5}
    for c in (0.0, 2.0):
        errs = [balance(rope_runs[c, h][1]) for h in (0.002, 0.001, 0.0005)]
        for h, e in zip((0.002, 0.001, 0.0005), errs):
            assert e < 2.0 * measured[c, h], (c, h, e)
        assert errs[2] < errs[1] < errs[0]
    d = rope_runs[2.0, 0.0005][1].work[-1, 0]
    assert 1.4 < d < 1.7   # dissipated while taut only
    assert rope_runs[0.0, 0.0005][1].work[-1, 0] == 0.0


def test_located_slack_taut_transitions_restore_second_order(rope_runs):
    """locate_crossings splits the steps at the slack/taut kinks of the rope
    (ancf_jax.forces.kink_values): the undamped rope's height against the exact answer
    then converges at second order, measured errors 1.03e-4, 2.45e-5, 6.14e-6 m at
    h = 2, 1, 0.5 ms (orders 2.07, 2.00; without: 1.97e-4, 1.52e-5, 4.81e-6 m, orders
    3.7, 1.7, and 4.29e-6 m at 0.25 ms), and the energy balance closes 13-30x better
    (3.4e-5, 1.1e-5, 4.1e-6 J against 6.0e-4, 3.1e-4, 5.1e-5 J). The damped rope (its
    force jumps by c·ℓ̇ when it engages) runs through its nine located transitions; its
    height error stays erratic, ~first order (measured 5.4e-4, 4.8e-4, 3.0e-4 m with
    location, 6.7e-4, 5.4e-4, 1.3e-4 m without): the second substep straddles the force
    jump by KINK_MARGIN of the step (docs/cable-machinery.md)."""
    located = RunOptions(locate_crossings=True, max_halvings=0)
    steps = (0.002, 0.001, 0.0005)
    errors, balances = [], []
    for h in steps:
        system, state = rope_model(0.0)
        run = run_fixed(system, state, GeneralizedAlpha().forward_only(), h, T_ROPE, chunk=200, options=located)
        assert run.status == 0 and run.crossings.sum() == 5
        errors.append(np.max(np.abs(run.q[:, 1] - rope_reference(0.0, run.t))))
        balances.append(balance(run))
        assert balances[-1] < balance(rope_runs[0.0, h][1]) / 5.0, h
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all((orders > 1.8) & (orders < 2.2)), (errors, orders)
    system, state = rope_model(2.0)
    for h in steps:
        run = run_fixed(system, state, GeneralizedAlpha().forward_only(), h, T_ROPE, chunk=200, options=located)
        assert run.status == 0 and run.crossings.sum() >= 8
        assert np.max(np.abs(run.q[:, 1] - rope_reference(2.0, run.t))) < 1e-3


# ---------------------------------------------------------------------------- point masses
L_WIRE, STRETCH, RHOA_WIRE, EA_WIRE, M_CLAMP = 2.0, 1.001, 0.5, 1e6, 0.4


def wire_model(n, *, s_clamp=L_WIRE / 2, gravity=(0.0, 0.0)):
    """A taut wire, stress-free length L, stretched by STRETCH between two pins, with a
    clamp of mass M at reference arc length s_clamp; EI negligible (1e-9 N·m²). All
    meshes padded to 32 elements: one compiled program."""
    m = Model(gravity=gravity)
    track = mesh.straight((0.0, 0.0), (1.0, 0.0), L_WIRE, n)
    nodes = np.asarray(track.reference_nodes)[: n + 1].copy()
    nodes[:, [0, 2]] *= STRETCH
    m.add_beam("w", track, Section(EA_WIRE, 1.0, 1e-9, RHOA_WIRE), initial_nodes=nodes)
    m.pin("a", node("w", 0))
    m.pin("b", node("w", -1))
    m.attached_mass("clamp", "w", s_clamp, M_CLAMP)
    return m.build(pad_to=32, assemble=False)  # consistent as built: pins where the nodes are


def test_attached_mass_inertia_and_weight():
    """The beam's mass matrix gains exactly ½ m |ṙ(s)|² of kinetic energy (random
    velocities; the clamp inside an element), the total mass ρA L + m appears in the
    rigid translation, the gravity load sums to (ρA L + m) g, at its centre of mass."""
    system, state = wire_model(5, s_clamp=0.77, gravity=(0.0, -G))
    beam = system.beams[0]
    rng = np.random.default_rng(0)
    v = jnp.asarray(rng.normal(size=system.n_coordinates))
    bare = eqx.tree_at(lambda s: s.beams, system, (Beam(beam.mesh, beam.section),))
    ux = jnp.zeros(system.n_coordinates).at[system.beam_offset(0) + 4 * jnp.arange(6)].set(1.0)

    @eqx.filter_jit
    def quantities(system, bare, v):
        r_dot = system.beams[0].position(system.beam_nodes(v, 0), 0.77)  # ṙ(s) = S(x) ė
        return (system.kinetic_energy(v) - bare.kinetic_energy(v), jnp.dot(r_dot, r_dot),
                ux @ system.mass_times(ux), system.gravity_load(), system.beams[0].total_mass)

    extra, r_dot2, m_x, load, total_mass = quantities(system, bare, v)
    assert float(extra) == pytest.approx(0.5 * M_CLAMP * float(r_dot2), rel=1e-12)
    total = RHOA_WIRE * L_WIRE + M_CLAMP
    assert float(total_mass) == pytest.approx(total, rel=1e-14)
    assert float(m_x) == pytest.approx(total, rel=1e-12)
    f = np.asarray(load)[system.beam_offset(0):][: 4 * 6].reshape(6, 4)
    assert f[:, 1].sum() == pytest.approx(-G * total, rel=1e-12)
    # moment of the load about the origin: the centre of mass (ρA L·L/2 + m s)/total
    x_ref = np.asarray(beam.mesh.reference_nodes)[:6]
    moment = np.sum(x_ref[:, 0] * f[:, 1] + x_ref[:, 2] * f[:, 3])
    assert moment == pytest.approx(-G * (RHOA_WIRE * L_WIRE**2 / 2 + M_CLAMP * 0.77), rel=1e-12)


def test_taut_string_with_central_mass_frequency():
    """The lowest mode of a taut string (tension T, line density ρ, length L) with a
    central mass M: ω = 2 z c / L with z tan z = ρ L / M, c = √(T/ρ). The cubic Hermite
    elements are C¹ and cannot represent the string's kink under the mass, so the error
    is first order in the element size (measured 1.12e-2, 5.44e-3, 2.71e-3, 1.36e-3 at
    4, 8, 16, 32 elements, mass at a node; ratio 2.0); its Richardson extrapolation
    2 ω(32) − ω(16) agrees with the closed form to 6e-6 (asserted 2e-5). A clamp inside
    an element (odd meshes) converges alike."""
    errors = {}
    for n in (8, 16, 32, 9):
        system, state = wire_model(n)
        res = modal_analysis(system, state.q, n_modes=1)
        errors[n] = res.angular_frequencies[0]
    length = L_WIRE * STRETCH
    tension = EA_WIRE * 0.5 * (STRETCH**2 - 1.0) * STRETCH  # Green-Lagrange: EA ε |r'|
    rho = RHOA_WIRE / STRETCH
    z = brentq(lambda z: z * np.tan(z) - rho * length / M_CLAMP, 1e-9, np.pi / 2 - 1e-12)
    omega = 2.0 * z / length * np.sqrt(tension / rho)
    rel = {n: w / omega - 1.0 for n, w in errors.items()}
    assert 0.0 < rel[32] < rel[16] < rel[8] < 6e-3
    assert rel[16] / rel[32] == pytest.approx(2.0, abs=0.05)
    assert abs((2.0 * errors[32] - errors[16]) / omega - 1.0) < 2e-5
    assert 0.0 < rel[9] < 5e-3


# ---------------------------------------------------------------------------- friction, drives
MU = 0.3
V_EPS = 1e-3  # the default regularization speed
S_START = 0.5


def friction_track(track, s0, *, stiffness=0.0):
    """A body (1 kg) on a rigid track (4 elements, every node clamped) with friction μ
    on its sliding joint "slider" (default v_ε), tied to the ground point (−2, 0) by a
    spring of rest length 2 m and ``stiffness``: none (no force, no energy) on the
    inclines, 100 N/m in the Coulomb oscillator. One structure: the incline runs and the
    oscillator's runs without location share one compiled program."""
    m = track_model(track, s0)
    m.slider_friction("friction", "slider", mu=MU)
    m.spring_damper("spring", ground(-2.0, 0.0), body_point("slider_body"), stiffness=stiffness, rest_length=2.0)
    return m


def incline_model(tan_beta, *, s0=S_START):
    """A body (1 kg) on a straight rigid incline (:func:`friction_track`, spring
    without stiffness) of slope angle β."""
    beta = np.arctan(tan_beta)
    track = mesh.straight((0.0, 0.0), (np.cos(beta), -np.sin(beta)), 2.0, 4)  # +s: downhill
    return friction_track(track, s0), beta


def total_energy(system, run):
    """T + V + U + D − W_e − W_c per row [J] (Results.energy's total)."""
    @eqx.filter_jit
    def mech(system, q, v):
        return jax.vmap(lambda qq, vv: system.kinetic_energy(vv) + system.potential_energy(qq))(q, v)
    return np.asarray(mech(system, run.q, run.v)) + run.work[:, 0] - run.work[:, 1] - run.work[:, 2]


@pytest.fixture(scope="module")
def incline_runs():
    """tan β = 0.5 μ (sticks) and 2 μ (slides) at h = 1 ms over 0.4 s (one program)."""
    out = {}
    for ratio in (0.5, 2.0):
        m, beta = incline_model(ratio * MU)
        system, state = m.build()
        out[ratio] = system, beta, run_fixed(system, state, GeneralizedAlpha().forward_only(), 0.001, 0.4, chunk=100)
    return out


def test_friction_sticks_below_the_limit(incline_runs):
    """tan β = μ/2: the regularized friction holds the body, which creeps at the
    stated speed v_ε artanh(tan β / μ) = 0.549 v_ε (steady state of F = μN tanh(u/v_ε);
    measured to 3e-9 relative after 0.1 s), far below any visible motion; the friction force is the
    slope component m g sin β, the normal reaction m g cos β."""
    system, beta, run = incline_runs[0.5]
    assert run.status == 0
    u = run.v[:, system.sliding_offset]
    creep = V_EPS * np.arctanh(np.tan(beta) / MU)
    late = run.t > 0.1
    np.testing.assert_allclose(u[late], creep, rtol=1e-8)
    # the first steps overshoot (h = 1 ms is 3 relaxation times v_ε/(μ g cos β) of the
    # regularized law; generalized-α, ρ∞ = 0.9, rings it down): measured 1.16× at 1 ms
    assert np.max(u) < 1.2 * creep
    lam = run.lam[:, system.constraint_offset(len(system.constraints) - 1):][:, :2]
    t_hat = np.array([np.cos(beta), -np.sin(beta)])
    n_hat = np.array([np.sin(beta), np.cos(beta)])
    np.testing.assert_allclose((lam @ t_hat)[late], -G * np.sin(beta), rtol=1e-8)  # friction up the slope
    np.testing.assert_allclose((lam @ n_hat)[late], G * np.cos(beta), rtol=1e-8)


def test_friction_slides_above_the_limit(incline_runs):
    """tan β = 2μ: the body accelerates at g (sin β − μ cos β) (from ṡ between 0.2 and
    0.4 s; measured 2e-12 relative); the energy balance with the friction dissipation
    closes to 3e-6 J (0.51 J dissipated; measured 2.4e-6 J at h = 1 ms, 9.7e-6 J at
    2 ms: second order)."""
    system, beta, run = incline_runs[2.0]
    u = run.v[:, system.sliding_offset]
    i, j = np.searchsorted(run.t, 0.2), len(run.t) - 1
    a = (u[j] - u[i]) / (run.t[j] - run.t[i])
    assert a == pytest.approx(G * (np.sin(beta) - MU * np.cos(beta)), rel=1e-9)
    total = total_energy(system, run)
    assert np.max(np.abs(total - total[0])) < 3e-6
    assert run.work[-1, 0] == pytest.approx(0.5108, abs=2e-3)


def test_friction_slides_on_a_taut_inclined_cable():
    """tan β = 2μ on a straight taut cable instead of a rigid track: 2 m, 8 elements,
    EA = 2.1e7 N, EI 1e-9 N·m², ρA = 0.1 kg/m, pinned at both ends and stretched by
    0.4 % (tension T = 84.5 kN), stiffness-proportional damping 1e-4 s (its vibration,
    excited by the body dropped on the straight cable, otherwise swings the
    step-to-step acceleration by ±100 %). The body (1 kg, from rest) deflects the cable
    by a kink of angle δ = N/T = 1.0e-4 (N = m g cos β) and the cable's weight by
    δ_c = ρA g L cos β/(2T) = 1.0e-5 at most, so the slope under the body differs from
    the chord's by at most δ + δ_c, which moves the closed form a = g (sin β − μ cos β)
    by at most (δ + δ_c) (cos β + μ sin β)/(sin β − μ cos β) = 4.3e-4 relative.
    Measured: the physical acceleration |r'| s̈ (least-squares slope of the speed over
    0.1-0.3 s) is 2.6e-4 above it (the same over 0.2-0.3 s); s̈ alone, without the
    stretch |r'| = 1.004, is 3.7e-3 off."""
    n, stretch, rhoa = 8, 1.004, 0.1
    beta = np.arctan(2 * MU)
    track = mesh.straight((0.0, 0.0), (np.cos(beta), -np.sin(beta)), 2.0, n)  # +s: downhill
    nodes = np.asarray(track.reference_nodes)[: n + 1] * stretch  # positions and slopes: uniform stretch
    m = Model(gravity=(0.0, -G))
    m.add_beam("track", track, Section(2.1e11, 1e-4, 1e-9, rhoa), initial_nodes=nodes, beta=1e-4)
    m.pin("a", node("track", 0))
    m.pin("b", node("track", -1))
    m.add_body("slider_body", mass=1.0, inertia=0.1, position=stretch * S_START * np.array([np.cos(beta), -np.sin(beta)]))
    m.slider("slider", "slider_body", "track", S_START)
    m.slider_friction("friction", "slider", mu=MU)
    system, state = m.build()
    run = run_fixed(system, state, GeneralizedAlpha().forward_only(), 0.001, 0.3, chunk=100)
    assert run.status == 0
    tension = 2.1e7 * 0.5 * (stretch**2 - 1.0) * stretch  # Green-Lagrange: EA ε |r'|
    kink = G * np.cos(beta) / tension + rhoa * G * 2.0 * np.cos(beta) / (2 * tension)
    a0 = G * (np.sin(beta) - MU * np.cos(beta))
    bound = kink * (np.cos(beta) + MU * np.sin(beta)) / (np.sin(beta) - MU * np.cos(beta))
    assert 4e-4 < bound < 5e-4
    u = stretch * run.v[:, system.sliding_offset]  # |r'| ṡ: the cable's strain from the load is ~1e-7
    for t0 in (0.1, 0.2):
        late = run.t >= t0
        a = np.polyfit(run.t[late], u[late], 1)[0]
        assert abs(a / a0 - 1.0) < bound, (t0, a / a0 - 1.0)
        assert abs(a / stretch / a0 - 1.0) > 5 * bound  # s̈ is not the acceleration


U_DRIVE, F_PULL, T_DRIVE = 0.5, 10.0, 0.3
SERVO_GAIN, SERVO_MAX = 2000.0, 50.0


@pytest.fixture(scope="module")
def driven_run():
    """Three trolleys (1 kg) with friction μ on one rigid incline, tan β = 0.15, hauled
    uphill: "a" by a prescribed arc length s = 1.5 − U t, "b" by a velocity servo to
    −U (gain 2000 N·s/m, limit 50 N) from ṡ = −U, "c" by a constant pull of 10 N from
    rest. One run, h = 1 ms, 0.3 s."""
    beta = np.arctan(0.15)
    track = mesh.straight((0.0, 0.0), (np.cos(beta), -np.sin(beta)), 2.0, 2)
    m = Model(gravity=(0.0, -G))
    m.add_beam("track", track, Section(2.1e11, 1e-4, 1e-9, 0.785))
    for i in range(3):
        m.clamp(f"clamp{i}", "track", i)
    t_hat = np.array([np.cos(beta), -np.sin(beta)])
    for name, s0, rate in (("a", 1.5, -U_DRIVE), ("b", 1.0, -U_DRIVE), ("c", 0.5, 0.0)):
        m.add_body(name, mass=1.0, inertia=0.1, position=s0 * t_hat, velocity=rate * t_hat)
        m.slider(f"s{name}", name, "track", s0, rate=rate)
        m.slider_friction(f"friction_{name}", f"s{name}", mu=MU)
    m.slider_drive("drive_a", "sa", position=lambda t: 1.5 - U_DRIVE * t)
    m.slider_drive("drive_b", "sb", speed=-U_DRIVE, gain=SERVO_GAIN, max_force=SERVO_MAX)
    m.slider_drive("drive_c", "sc", force=-F_PULL)
    system, state = m.build()
    # projected velocities: the closed forms hold to the Newton tolerance. With the default
    # (no projection) the index-3 multipliers alternate about them from step to step by
    # up to 9.4e-8 relative (drive a), 1.7e-9 (servo b) and 5.3e-9 (normal force):
    # measured when the default changed (benchmarks/velocity_projection.py)
    run = run_fixed(system, state, GeneralizedAlpha(velocity_projection=True).forward_only(), 0.001, T_DRIVE,
                    chunk=100)
    results = Results(system, run.t, run.q, run.v, run.acc, run.lam, run.work, np.zeros(len(run.t)))
    return system, beta, run, results


def test_driven_trolleys_closed_form_resistance(driven_run):
    """At constant speed uphill the drive force equals the closed-form resistance
    −m g (sin β + μ cos β) (tanh(U/v_ε) = 1 to 1e-200): prescribed s(t) (its reaction)
    to 1e-9 relative; the servo's to 1e-9 relative at the speed error
    (F_max/k) artanh(F/F_max) it needs; the pulled trolley accelerates at
    −F/m + g (sin β + μ cos β). The friction output is μ m g cos β, the energy balance
    (drive work as constraint and external work, friction dissipation) closes to
    4e-6 of the work done (the pulled trolley's start from rest is the transient)."""
    system, beta, run, results = driven_run
    resistance = G * (np.sin(beta) + MU * np.cos(beta))
    late = run.t > 0.1
    cols = evaluate(results, [Output("fa", "drive", "drive_a"), Output("fb", "drive", "drive_b"),
                              Output("fc", "drive", "drive_c"), Output("na", "friction", "friction_a", "normal"),
                              Output("ra", "friction", "friction_a", "force")])
    np.testing.assert_allclose(cols["fa"][late], -resistance, rtol=1e-8)  # measured 2.6e-9 (Newton tolerance)
    np.testing.assert_allclose(cols["fb"][late], -resistance, rtol=1e-9)  # measured 2.8e-10
    np.testing.assert_allclose(cols["fc"], -F_PULL, rtol=1e-14)
    np.testing.assert_allclose(cols["na"], G * np.cos(beta), rtol=1e-9)
    np.testing.assert_allclose(cols["ra"][late], MU * G * np.cos(beta), rtol=1e-9)
    o = system.sliding_offset
    np.testing.assert_allclose(run.q[:, o], 1.5 - U_DRIVE * run.t, atol=1e-12)
    error = SERVO_MAX / SERVO_GAIN * np.arctanh(resistance / SERVO_MAX)
    np.testing.assert_allclose(run.v[late, o + 1], -U_DRIVE + error, rtol=1e-9)
    u_c = run.v[:, o + 2]
    i, j = np.searchsorted(run.t, 0.1), len(run.t) - 1
    assert (u_c[j] - u_c[i]) / (run.t[j] - run.t[i]) == pytest.approx(-F_PULL + resistance, rel=1e-9)
    total = total_energy(system, run)
    assert np.max(np.abs(total - total[0])) < 3e-5  # measured 1.3e-5 J of 3.2 J + 0.65 J work
    assert run.work[-1, 1] > 0.0 and run.work[-1, 2] > 0.0  # servo, pull; hauling a


# ------------------------------------------------------------ friction reversals (events)
K_OSC, X_OSC, T_OSC = 100.0, 0.2, 1.2


def coulomb_oscillator():
    """A 1 kg body on a horizontal rigid track (friction μ, default v_ε) held by a
    100 N/m spring and released 0.2 m from the spring's rest: three half-cycles of
    sliding (each reverses the friction force), then it sticks at 0.024 m."""
    track = mesh.straight((-1.0, 0.0), (1.0, 0.0), 2.0, 4)
    return friction_track(track, 1.0 + X_OSC, stiffness=K_OSC).build()


@functools.cache
def coulomb_reference():
    """x(t) of the same regularized law, m ẍ = −k x − μ m g tanh(ẋ/v_ε), by scipy's
    Radau (rtol 1e-12): a function of t over [0, T_OSC]."""
    sol = solve_ivp(lambda _, z: [z[1], -K_OSC * z[0] - MU * G * np.tanh(z[1] / V_EPS)], (0.0, T_OSC),
                    [X_OSC, 0.0], method="Radau", rtol=1e-12, atol=1e-14, dense_output=True, max_step=1e-3)
    return lambda t: sol.sol(t)[0]


@pytest.mark.study
def test_friction_reversals_are_located():
    """With locate_crossings, steps are split where the sliding speed reverses
    (SlidingFriction.kinks: the friction force swings from −μN to +μN within a few
    v_ε). Measured on the Coulomb oscillator against the same law by Radau, max |x|
    error over 1.6 s at h = 4, 2, 1 ms: 1.08e-3, 5.7e-4, 3.0e-4 m by default, 7.2e-4,
    4.6e-4, 2.1e-4 m located (here over 1.2 s, the sliding phase and the start of the
    sticking): 1.3-1.5 times smaller, first order either way (the
    force's near-jump still falls inside the step after the split, as for a damped
    rope engaging; docs/cable-machinery.md). Each located run finds the three
    reversals (and three node crossings), none in the sticking phase (the dead band).
    Both without retries (no step fails; the errors are those with the default
    retries to the last digit): the runs without location share the incline runs'
    program."""
    plain, located = NO_RETRIES, RunOptions(locate_crossings=True, max_halvings=0)
    errors = {}
    for label, options in (("plain", plain), ("located", located)):
        for h in (0.004, 0.001):
            system, state = coulomb_oscillator()
            run = run_fixed(system, state, GeneralizedAlpha().forward_only(), h, T_OSC, chunk=100, options=options)
            assert run.status == 0
            x = run.q[:, system.sliding_offset] - 1.0
            errors[label, h] = np.max(np.abs(x - coulomb_reference()(np.minimum(run.t, T_OSC))))
            if label == "located":
                assert run.crossings.sum() == 6  # 3 reversals + 3 node crossings (x = 0 at s = 1)
    for h in (0.004, 0.001):
        assert errors["located", h] < 0.8 * errors["plain", h], errors
    assert 2.5 < errors["located", 0.004] / errors["located", 0.001] < 5.0, errors  # first order
    assert errors["located", 0.001] < 2.5e-4, errors


# ---------------------------------------------------------------------- eyelets, capstan
def test_cable_through_frictional_eyelets():
    """A cable drawn through n = 2 frictional point eyelets turning it by π/2 in all
    (benchmarks/eyelets.py, which runs n = 1, 4 and 16): the steady hold/load ratio
    matches the elastic rod's point-eyelet closed form at the measured turn (measured
    1.1e-4 relative), not the string's bisector formula
    (3.0 % off), and lies 0.93 % below the capstan value e^(μθ), 3.8 times closer than
    one eyelet's rod closed form at the same turn (3.5 % below; the benchmark: 0.2 %
    and 0.01 % at n = 4 and 16): the capstan is approached as the eyelets multiply.
    Each eyelet's friction is μN, and the tension rises by their sum (steady sliding's
    energy balance; measured 5e-6 relative). One eyelet count only: each count is
    another model, with four programs of its own to compile (the statics held and
    released, the run's start and its chunk)."""
    from benchmarks.eyelets import MU as MU_EYELET, T_LOAD, eyelet_run, rod_eyelet_ratio

    # legs of 6 ℓ, 0.25 s averaged over the last 0.08 s (the benchmark: 8 ℓ, 0.3 s, 0.1 s)
    r = eyelet_run(2, legs=6.0, t_end=0.25, window=0.08)
    assert r["ratio"] == pytest.approx(r["rod"], rel=1e-3), r
    assert r["spread"] < 0.02, r  # the axial ringing around the steady state
    # each eyelet's s decreases (the cable runs towards the drawn end): F = +μN on it
    np.testing.assert_allclose(r["friction"], MU_EYELET * np.asarray(r["normal"]), rtol=1e-6)
    # steady sliding: the tension jumps by μN at each eyelet
    assert (r["ratio"] - 1.0) * T_LOAD == pytest.approx(sum(r["friction"]), rel=1e-4), r
    assert abs(r["ratio"] - r["string"]) > 0.02, r
    assert abs(r["ratio"] - r["string"]) > 20 * abs(r["ratio"] - r["rod"]), r
    # towards the capstan: closer than one eyelet turning the cable as much
    assert abs(r["ratio"] - r["capstan"]) < abs(rod_eyelet_ratio(r["turn"]) - r["capstan"]) / 3.0, r


def test_newton_matrix_holds_the_friction_linearization(incline_runs):
    """The Newton matrix (:func:`ancf_jax.dae.iteration_matrix`) is the Jacobian of the
    generalized-α residual with friction, ∂Q_r/∂λ included (a dense ``jax.jacfwd`` of
    the residual in (Δq, λ) as the independent reference), at a creeping state of the
    sticking run (u ≈ 0.55 v_ε: tanh is far from its saturation) with a perturbed λ."""
    system, _, run = incline_runs[0.5]
    k = len(run.t) // 2
    q, v = jnp.asarray(run.q[k]), jnp.asarray(run.v[k])
    lam = jnp.asarray(run.lam[k]) * 1.1
    t, beta_p, gamma_p = float(run.t[k]), 3.7e5, 1.1e3
    n = system.n_coordinates

    @eqx.filter_jit
    def both(system, q, v, lam):
        def residual(x):
            dq, lm = x[:n], x[n:]
            q1, v1 = q + dq, v + gamma_p * dq
            phi, vjp = jax.vjp(lambda qq: system.constraint(qq, t), q1)
            r = (system.mass_times(beta_p * dq) - system.generalized_force(q1, v1, t)
                 - system.reaction_force(q1, v1, t, lm) + vjp(lm)[0])
            return dae.to_solver_order(system, r, phi)
        perm = np.concatenate([dae.solver_permutation(system), n + np.arange(lam.shape[0])])
        reference = jax.jacfwd(residual)(jnp.concatenate([jnp.zeros(n), lam]))[:, perm]
        jac = system.constraint_jacobian(q, t)
        return dae.iteration_matrix(system, q, v, lam, t, beta_p, gamma_p, jac).effective_dense(), reference

    structured, reference = both(system, q, v, lam)
    scale = jnp.max(jnp.abs(reference))
    np.testing.assert_allclose(structured / scale, reference / scale, rtol=0, atol=1e-13)
    # the friction's λ-columns are really there: the sliding row holds r'(s) (= t̂, the
    # frictionless Φ_qᵀ entry) plus −∂(|r'| F)/∂λ = μ tanh(u/v_ε) ∂N/∂λ (0.3 · 0.5 n̂)
    o = system.sliding_offset
    row = list(np.asarray(dae.solver_permutation(system))).index(o)
    cols = n + system.constraint_offset(system.reaction_forces[0].joint) + np.arange(2)
    r1 = np.asarray(system.beams[0].slope(system.beam_nodes(q, 0), q[o]))
    assert np.linalg.norm(np.asarray(reference)[row, cols] - r1) > 0.1


@pytest.mark.study
def test_gradients_through_friction_and_drives():
    """Derivatives through every drive kind and both parts of the friction law, forward
    mode through the implicit generalized-α steps (0.05 s, h = 1 ms), against central
    finite differences and closed forms. One rigid incline (tan β = 2μ, +s downhill)
    carries two trolleys (1 kg) with friction μ:

    * "a" pulled uphill by a drive force F from rest (through the regularization
      transient): d s_a(T)/d(μ, F), near ½ T² (−N, 1/m) of the saturated motion;
    * "c" hauled uphill at constant speed U = 0.3 m/s by a prescribed arc length
      s = s₀ − U t (a ``ConstantSpeed`` path: U is data; c's initial velocity is U),
      with a viscous part c = 4 N·s/m in its friction and a velocity servo to
      u* = −0.2 m/s (gain k = 200 N·s/m, limit F_max = 20 N) holding it back: its drive
      force is the closed form F_c = −(m g (sin β + μ cos β) + c U + F_s), with the
      servo's F_s = F_max tanh(x), x = k (u* + U)/F_max (tanh(U/v_ε) = 1 to 1e-170).
      d F_c/d(U, c, k, F_max) = −(c + k sech²x, U, sech²x (u* + U), tanh x − x sech²x).

    Newton's tolerance is 1e-12 here: at the default 1e-10 the computed map s(p) differs
    from the exact-root map whose derivative the JVP gives (implicit differentiation) by
    ~8e-7 relative in its slope, and differences over steps under 1e-5 see the Newton
    noise (measured, steps 1e-7 to 1e-3). At 1e-12, relative steps 1e-4: agreement
    9e-10 (μ) and 2e-9 (F) for "a" (the step-1e-3 differences are 3e-8 off: truncation,
    O(h²)). F_c is an index-3 multiplier, which alternates about its value from step to
    step (±3.6e-9 relative at T, decaying: generalized-α, ρ∞ = 0.9): F_c(T) is the mean
    over the last two steps (1.2e-10 off the closed form). Its differences take relative
    steps of 1e-2 (0.25 in c, in which F_c is linear), their truncation error (measured
    2e-4 in U) removed by Richardson extrapolation with doubled steps; what is left is
    the Newton noise over the step, measured 3.4e-7 (U), 1.5e-9 (c), 3.0e-8 (k),
    3.5e-8 (F_max) relative, checked to 3e-6. The closed forms check F_c to 1e-9 and its
    JVPs to 2e-8 (measured 3.4e-10).

    The 30 points (6 JVPs, 24 differences) run one by one through one compiled program:
    a vmapped batch of them compiled twice as long on the CPU (its while loops become
    selects) to save ~1 s of running, and its lock-step Newton iterations (every member
    iterates until the last converges) happened to leave the last step's F_c within
    6e-11 of the closed form, where a member run alone alternates by ±3.6e-9."""
    from ancf_jax.functions import ConstantSpeed
    from ancf_jax.simulation import trajectory

    beta = np.arctan(2 * MU)
    track = mesh.straight((0.0, 0.0), (np.cos(beta), -np.sin(beta)), 2.0, 2)
    m = Model(gravity=(0.0, -G))
    m.add_beam("track", track, Section(2.1e11, 1e-4, 1e-9, 0.785))
    for i in range(3):
        m.clamp(f"clamp{i}", "track", i)
    t_hat = np.array([np.cos(beta), -np.sin(beta)])
    speed, viscous, target, gain, limit = 0.3, 4.0, -0.2, 200.0, 20.0
    for name, s0, rate in (("a", 0.5, 0.0), ("c", 1.5, -speed)):
        m.add_body(name, mass=1.0, inertia=0.1, position=s0 * t_hat, velocity=rate * t_hat)
        m.slider(f"s{name}", name, "track", s0, rate=rate)
        m.slider_friction(f"friction_{name}", f"s{name}", mu=MU, viscous=viscous if name == "c" else 0.0)
    m.slider_drive("pull", "sa", force=-1.0)
    m.slider_drive("haul", "sc", position=ConstantSpeed(1.5, -speed))
    m.slider_drive("servo", "sc", speed=target, gain=gain, max_force=limit)
    system, state = m.build()
    o = system.sliding_offset
    haul = [c.name for c in system.constraints].index("haul")
    # c's initial velocity (its body's and ṡ) is linear in U
    moving_c = np.zeros(system.n_coordinates)
    moving_c[[system.body_offset(1), system.body_offset(1) + 1, o + 1]] = 1.0

    def final(p):
        """(s_a(T), F_c(T)) at p = (μ_a, F, U, c, k, F_max); F_c(T): mean of the last two steps."""
        sys = eqx.tree_at(lambda s: (s.reaction_forces[0].mu, s.forces[0].force, s.constraints[haul].path.speed,
                                     s.reaction_forces[1].viscous, s.forces[1].gain, s.forces[1].max_force),
                          system, (p[0], p[1], -p[2], p[3], p[4], p[5]))
        v0 = state.v * (1.0 + moving_c * (p[2] / speed - 1.0))
        seg, _ = trajectory(sys, eqx.tree_at(lambda st: st.v, state, v0),
                            GeneralizedAlpha(root_finder=ModifiedNewton(tolerance=1e-12)), t_end=0.05, dt=0.001)
        return jnp.stack([seg.q[-1, o], -jnp.mean(seg.lam[-2:, system.constraint_offset(haul)])])

    # one compiled program, called point by point (the differences are the primal of
    # zero-tangent JVPs; not vmapped: docstring)
    jvp = jax.jit(lambda x, e: jax.jvp(final, (x,), (e,)))

    def derivatives(p, steps):
        """The output at p, its Jacobian (JVPs) and central differences with ``steps``."""
        d = np.diag(steps)
        points = np.concatenate([np.tile(p, (6, 1)), p + d, p - d, p + 2 * d, p - 2 * d])
        directions = np.concatenate([np.eye(6), np.zeros((24, 6))])
        values, tangents = map(np.stack, zip(*(jvp(x, e) for x, e in zip(points, directions))))
        one, two = ((values[6 + 12 * k:12 + 12 * k] - values[12 + 12 * k:18 + 12 * k]) / (2 * (k + 1) * steps[:, None])
                    for k in (0, 1))
        return values[0], tangents[:6].T, ((4 * one - two) / 3).T  # Richardson: O(step⁴)

    p0 = np.array([MU, -1.0, speed, viscous, gain, limit])
    value, jac, fd = derivatives(p0, np.array([1e-4, 1e-4, 1e-2, 0.25, 1e-2, 1e-2]) * np.abs(p0))
    mask = np.array([[1, 1, 0, 0, 0, 0], [0, 0, 1, 1, 1, 1]], bool)
    np.testing.assert_allclose(jac[0, :2], fd[0, :2], rtol=1e-7)
    np.testing.assert_allclose(jac[1, 2:], fd[1, 2:], rtol=3e-6)  # F_c's noise: docstring
    # the trolleys are independent: what each output sees of the others' parameters is
    # the Newton iteration's residual (measured 2.5e-12 of the row's scale)
    scale = np.max(np.abs(np.where(mask, jac, 0.0)), axis=1, keepdims=True)
    assert np.all(np.abs(np.where(mask, 0.0, jac)) < 1e-6 * scale)
    # a: the closed form of the saturated motion, ½ T² (−N, 1/m), up to the transient
    assert jac[0, 0] == pytest.approx(-0.5 * 0.05**2 * G * np.cos(beta), rel=0.05)
    assert jac[0, 1] == pytest.approx(0.5 * 0.05**2, rel=0.05)
    # c: the resistance with the friction's viscous part and the servo, and its derivatives
    x = gain * (target + speed) / limit
    sech2 = 1.0 / np.cosh(x) ** 2
    servo = limit * np.tanh(x)
    assert value[1] == pytest.approx(-(G * (np.sin(beta) + MU * np.cos(beta)) + viscous * speed + servo), rel=1e-9)
    np.testing.assert_allclose(jac[1, 2:], [-(viscous + gain * sech2), -speed, -sech2 * (target + speed),
                                            -(np.tanh(x) - x * sech2)], rtol=2e-8)  # measured 3.4e-10


def test_bad_machinery_input_is_refused_before_compiling():
    """One-line errors naming the parameter, raised by the Model before any JAX work."""
    from ancf_jax.errors import ModelError

    def base():
        m = Model()
        m.add_beam("w", mesh.straight((0.0, 0.0), (1.0, 0.0), 1.0, 2), Section(1e9, 1e-4, 1e-9, 0.1))
        m.add_body("b", mass=1.0, inertia=0.1, position=(0.5, 0.0))
        m.slider("sl", "b", "w", 0.5)
        return m

    cases = [
        (lambda m: m.slider_drive("d", "sl"), "exactly one of position, force, speed, got none"),
        (lambda m: m.slider_drive("d", "sl", force=1.0, speed=1.0), "exactly one of position, force, speed"),
        (lambda m: m.slider_drive("d", "sl", speed=1.0, max_force=1.0), "gain of drive 'd'"),
        (lambda m: m.slider_drive("d", "sl", speed=1.0, gain=1.0, max_force=-1.0), "max_force of drive 'd'"),
        (lambda m: m.slider_friction("f", "sl", mu=-0.1), "mu of friction 'f'"),
        (lambda m: m.slider_friction("f", "sl", mu=0.1, regularization=0.0), "regularization of friction 'f'"),
        (lambda m: m.spring_damper("r", ground(0.0, 0.0), body_point("b"), stiffness=1.0, acts="pull"),
         "acts of spring-damper 'r'"),
        (lambda m: m.attached_mass("c", "w", 0.5, 0.0), "mass of attached mass 'c'"),
    ]
    for add, fragment in cases:
        with pytest.raises(ModelError, match=fragment):
            add(base())
    for add, fragment in [(lambda m: m.slider_friction("f", "nope", mu=0.1), "sliding joint 'nope'"),
                          (lambda m: m.attached_mass("c", "w", 1.5, 0.1), "outside beam 'w'")]:
        m = base()
        add(m)
        with pytest.raises(ModelError, match=fragment):
            m.build()
