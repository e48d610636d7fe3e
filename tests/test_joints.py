"""The sliding joint (paper §4, Eqs. 19–21) in motion: a body sliding without friction
on a straight incline (s = ½ g sin θ t²) and on a circular arc (the pendulum), across
several nodes; the reaction is the centripetal force and jumps at nodes exactly as the
jump of r'' in γ (Eq. 12) dictates; a flexible but stiff track converges to the rigid
answers as 1/E.

Every track has 8 elements, so the fully clamped tracks share one compiled RK4 loop
and the end-clamped ones one generalized-α loop (only array values differ).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ancf_jax import dae, mesh
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha
from ancf_jax.integrators.explicit import RK4

from .dynamics import G, curve_motion, hermite_point, run_fixed, track_model, uneven_arc

N = 8
THETA = np.radians(30.0)
DOWN = np.array([np.cos(THETA), -np.sin(THETA)])  # incline direction
S0_LINE, T_LINE = 0.1, 0.8  # slides to s = 1.67 m: crosses the nodes at 0.25 … 1.5 m
R, HALF, S0_ARC, T_ARC = 1.0, 1.2, 0.35, 1.2  # released 0.85 rad from the bottom
H_ARC = 0.005


def incline(n=N):
    return mesh.straight((0.0, 0.0), DOWN, 2.0, n)


def arc(n=N):
    return mesh.arc((0.0, R), R, -np.pi / 2 - HALF, -np.pi / 2 + HALF, n)


def geometry(track):
    n = int(track.n_elements)
    return np.asarray(track.reference_nodes)[: n + 1], np.asarray(track.element_lengths)[:n]


def sliding_run(track, s0, h, t_end):
    system, state = track_model(track, s0).build()
    return system, run_fixed(system, state, RK4(), h, t_end, chunk=10)


def reaction_components(system, run, nodes, lengths):
    """(normal, tangential) reaction on the body from λ (force on the body is +λ),
    with the unit tangent of the Hermite curve at each step's s, shape (N, 2)."""
    lam = run.lam[:, [i for i, lbl in enumerate(system.constraint_labels()) if lbl.startswith("slider[")]]
    s = run.q[:, system.sliding_offset]
    tangent = np.array([hermite_point(nodes, lengths, x, 1) for x in s])
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    return np.column_stack([np.sum(lam * normal, 1), np.sum(lam * tangent, 1)]), tangent, normal


def node_arc_lengths(lengths):
    return np.concatenate([[0.0], np.cumsum(lengths)])


# ---------------------------------------------------------------------------- incline
def test_incline_closed_form():
    """Clamped straight incline, θ = 30°: s = s₀ + ½ g sin θ t², ṡ = g sin θ t, normal
    reaction m g cos θ, no tangential reaction, no rotation, across 6 nodes. RK4 is exact
    for this polynomial motion: tolerances are round-off (measured 1e-13)."""
    track = incline()
    system, run = sliding_run(track, S0_LINE, 0.01, T_LINE)
    nodes, lengths = geometry(track)
    s, sd = run.q[:, system.sliding_offset], run.v[:, system.sliding_offset]
    np.testing.assert_allclose(s, S0_LINE + 0.5 * G * np.sin(THETA) * run.t**2, atol=1e-10)
    np.testing.assert_allclose(sd, G * np.sin(THETA) * run.t, atol=1e-10)
    crossed = np.sum((node_arc_lengths(lengths) > s[0]) & (node_arc_lengths(lengths) < s[-1]))
    assert crossed == 6
    force, _, _ = reaction_components(system, run, nodes, lengths)
    np.testing.assert_allclose(force[:, 0], 1.0 * G * np.cos(THETA), rtol=1e-10)
    np.testing.assert_allclose(force[:, 1], 0.0, atol=1e-9)
    np.testing.assert_allclose(run.q[:, 2], 0.0, atol=1e-12)


# ---------------------------------------------------------------------------- arc
@pytest.fixture(scope="module")
def arc_run():
    track = arc()
    system, run = sliding_run(track, S0_ARC, H_ARC, T_ARC)
    return system, run, *geometry(track)


def test_arc_motion_on_the_interpolated_circle(arc_run):
    """Clamped arc (mesh.arc, R = 1 m, 8 elements of 0.3 rad): the sliding coordinate
    and its rate against the motion of a particle on the same Hermite curve (SciPy,
    node crossings as events). RK4 at h = 5 ms: measured max |Δs| 1.2e-8 (1.5e-7 at
    10 ms); tolerance 5e-8. Velocity continuous across the 5 crossings: ṡ matches the
    reference at every step, the first ones after each crossing included."""
    system, run, nodes, lengths = arc_run
    ref, crossings = curve_motion(nodes, lengths, S0_ARC, 0.0, run.t)
    assert len(crossings) >= 5
    s, sd = run.q[:, system.sliding_offset], run.v[:, system.sliding_offset]
    assert np.max(np.abs(s - ref[:, 0])) < 5e-8
    assert np.max(np.abs(sd - ref[:, 1])) < 2e-7
    # body on the curve, velocity along it
    pos = np.array([hermite_point(nodes, lengths, x) for x in s])
    np.testing.assert_allclose(run.q[:, :2], pos, atol=1e-12)
    tangent = np.array([hermite_point(nodes, lengths, x, 1) for x in s])
    np.testing.assert_allclose(run.v[:, :2], tangent * sd[:, None], atol=1e-12)


def circle_pendulum(phi0, t):
    """Angle from the bottom of a point mass on a circle of radius R (exact ODE)."""
    sol = solve_ivp(lambda _, y: [y[1], -G / R * np.sin(y[0])], (0.0, t[-1]), [phi0, 0.0],
                    method="DOP853", rtol=1e-13, atol=1e-14, dense_output=True)
    phi = sol.sol(t)[0]
    return np.column_stack([R * np.sin(phi), R - R * np.cos(phi)])


def test_arc_is_the_pendulum(arc_run):
    """The Hermite interpolation of the circle deviates from it radially by δ = O(Δφ⁴)
    (2.1e-5 m for 8 elements of 0.3 rad; measured order 4.0 from 8 to 32 elements).
    A radius off by δ changes the pendulum frequency by δ/2R relative, so the body may
    be off the pendulum by δ (1 + φ₀ ω t): 8.6e-5 m over 1.2 s. Measured 4.9e-5 m; the
    integrator adds 5e-8 (previous test)."""
    system, run, nodes, lengths = arc_run
    deviation = []
    for n in (8, 16, 32):
        nn, ll = geometry(arc(n))
        s = np.linspace(0.0, node_arc_lengths(ll)[-1], 40 * n + 1)
        radius = np.linalg.norm(np.array([hermite_point(nn, ll, x) for x in s]) - [0.0, R], axis=1)
        deviation.append(np.max(np.abs(radius - R)))
    orders = np.log2(np.array(deviation[:-1]) / np.array(deviation[1:]))
    assert np.all((orders > 3.8) & (orders < 4.2)), orders
    p0 = run.q[0, :2]
    phi0 = np.arctan2(p0[0], R - p0[1])
    t = run.t[::10]
    exact = circle_pendulum(phi0, t)
    bound = deviation[0] * (1.0 + abs(phi0) * np.sqrt(G / R) * t[-1]) + 5e-8
    error = np.max(np.linalg.norm(run.q[::10, :2] - exact, axis=1))
    assert error < bound < 1e-4  # the body swings ±0.75 m


# ---------------------------------------------------------------------------- reaction jumps
@pytest.fixture(scope="module")
def uneven_run():
    track = uneven_arc(N, R, HALF)
    system, run = sliding_run(track, S0_ARC, H_ARC, T_ARC)
    return system, run, *geometry(track)


def test_reaction_is_centripetal_and_jumps_at_nodes(uneven_run):
    """Arc with uneven elements (curvature jumps by ±1 % at every node): at every step
    the normal reaction is m (n·r'' ṡ² − n·g), the centripetal force of the current
    element (so it jumps by m ṡ² n·Δr'' = m v² Δκ across a node), and the tangential
    reaction is zero. These are identities of the index-1 solve: tolerance round-off."""
    system, run, nodes, lengths = uneven_run
    force, tangent, normal = reaction_components(system, run, nodes, lengths)
    s, sd = run.q[:, system.sliding_offset], run.v[:, system.sliding_offset]
    r2 = np.array([hermite_point(nodes, lengths, x, 2) for x in s])
    expected = 1.0 * (np.sum(normal * r2, 1) * sd**2 - normal @ np.array([0.0, -G]))
    np.testing.assert_allclose(force[:, 0], expected, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(force[:, 1], 0.0, atol=1e-9)
    # the run crossed nodes where the centripetal term jumps visibly
    s_nodes = node_arc_lengths(lengths)
    jumps = []
    for k in range(1, N):
        if s.min() < s_nodes[k] < s.max():
            i = np.argmin(np.abs(s - s_nodes[k]))
            d2 = (hermite_point(nodes, lengths, s_nodes[k], 2, element=k)
                  - hermite_point(nodes, lengths, s_nodes[k], 2, element=k - 1))
            jumps.append(abs(normal[i] @ d2) * sd[i] ** 2)
    # jumps of 7 to 66 mN: 6 to 7 orders above the tolerance of the identity
    assert len(jumps) >= 5 and max(jumps) > 1e6 * 1e-9 * np.max(np.abs(expected))
    ref, _ = curve_motion(nodes, lengths, S0_ARC, 0.0, run.t)
    assert np.max(np.abs(sd - ref[:, 1])) < 2e-6  # continuous velocity (RK4 5 ms, measured 6e-7)


@eqx.filter_jit
def _index1(system, q, v):
    """(q̈, λ) from dae.accelerations and the parts of the index-1 system: Φ_q, M, Q, γ."""
    t = jnp.zeros(())
    acc, lam = dae.accelerations(system, q, v, t)
    return (acc, lam, system.constraint_jacobian(q, t), system.mass_matrix(),
            system.generalized_force(q, v, t), system.constraint_rhs(q, v, t))


def jump_check(system, state, nodes_now, lengths, node_index):
    """Evaluate q̈, λ just before (s = previous float) and at the node (s = node: the
    next element), with identical q otherwise and identical v, and compare the jump with
    [[M, Φ_qᵀ], [Φ_q, 0]]⁻¹ [0; Δγ], Δγ = −Δr'' ṡ² in the sliding rows only."""
    js = system.sliding_offset
    q_after = np.asarray(state.q)
    q_before = q_after.copy()
    q_before[js] = np.nextafter(q_after[js], -np.inf)
    v = jnp.asarray(state.v)
    acc_a, lam_a, jac, mass, force, gamma_a = map(np.asarray, _index1(system, jnp.asarray(q_after), v))
    acc_b, lam_b, jac_b, _, force_b, gamma_b = map(np.asarray, _index1(system, jnp.asarray(q_before), v))
    # only the sliding rows of γ jump; Φ_q and Q do not
    np.testing.assert_allclose(jac_b, jac, atol=1e-12)
    np.testing.assert_allclose(force_b, force, rtol=1e-12, atol=1e-12 * np.abs(force).max())
    rows = [i for i, lbl in enumerate(system.constraint_labels()) if lbl.startswith("slider[")]
    s_node = q_after[js]
    d2 = (hermite_point(nodes_now, lengths, s_node, 2, element=node_index)
          - hermite_point(nodes_now, lengths, s_node, 2, element=node_index - 1))
    d_gamma = np.zeros(system.n_constraints)
    d_gamma[rows] = -d2 * float(v[js]) ** 2
    np.testing.assert_allclose(gamma_a - gamma_b, d_gamma, atol=1e-9 * np.abs(d_gamma).max())
    # the bordered solve is the dense solve of the index-1 system, to round-off: a
    # backward-stable solve errs by cond · eps relative to the solution; the bordered
    # block elimination is allowed 10 × that (measured 2.5 ×)
    n, m = system.n_coordinates, system.n_constraints
    a = np.block([[mass, jac.T], [jac, np.zeros((m, m))]])
    roundoff = 10.0 * np.linalg.cond(a) * np.finfo(float).eps * np.abs(np.concatenate([acc_a, lam_a])).max()
    np.testing.assert_allclose(np.concatenate([acc_a, lam_a]),
                               np.linalg.solve(a, np.concatenate([force, gamma_a])), atol=roundoff)
    # the jump is the response to Δγ and nothing more
    x = np.linalg.solve(a, np.concatenate([np.zeros(n), d_gamma]))
    jump = np.concatenate([acc_a - acc_b, lam_a - lam_b])
    scale = np.abs(x).max()
    assert scale > 1e-3
    np.testing.assert_allclose(jump, x, atol=1e-9 * scale + 2.0 * roundoff)
    return acc_a - acc_b, lam_a[rows] - lam_b[rows], d2


def test_jump_across_a_node_on_a_fixed_curve():
    """Clamped uneven arc, body at node 2 with ṡ = 1.5 m/s: the jump of (q̈, λ) is
    exactly the response to the γ jump, and on the fixed curve it is a normal reaction
    jump m ṡ² n·Δr'' = m v² Δκ (v = |r'| ṡ) with no tangential part; the body's
    acceleration jumps by ṡ² Δr'' minus its tangential part (Δs̈ = −r'·Δr'' ṡ²/|r'|²)."""
    track = uneven_arc(N, R, HALF)
    nodes, lengths = geometry(track)
    k = 2
    s_node = node_arc_lengths(lengths)[k]
    rate = 1.5
    system, state = track_model(track, s_node, rate=rate).build()
    d_acc, d_lam, d2 = jump_check(system, state, nodes, lengths, k)
    r1 = hermite_point(nodes, lengths, s_node, 1)
    t = r1 / np.linalg.norm(r1)
    n = np.array([-t[1], t[0]])
    kappa_jump = (r1[0] * d2[1] - r1[1] * d2[0]) / np.linalg.norm(r1) ** 3
    speed = np.linalg.norm(r1) * rate
    assert abs(kappa_jump) > 5e-3  # the uneven elements: Δκ ≈ 0.01 1/m
    np.testing.assert_allclose(d_lam @ n, 1.0 * speed**2 * kappa_jump, rtol=1e-8)
    np.testing.assert_allclose(d_lam @ t, 0.0, atol=1e-10)
    np.testing.assert_allclose(d_acc[:2], rate**2 * (d2 - (t @ d2) * t), rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(d_acc[system.sliding_offset], -(r1 @ d2) * rate**2 / (r1 @ r1), rtol=1e-8)


def test_jump_across_a_node_on_a_flexible_track(rng):
    """Track clamped at its ends only, deformed (nodes perturbed by up to 2 mm and 0.005
    in slope: elastic forces up to 4e5 N) and moving (random nodal velocities): the jump of (q̈, λ) across node 3 is
    still exactly the response to Δγ = −Δr'' ṡ² (the 2 ṡ r'_e·ė term of γ is continuous
    because the slope at a node is a nodal coordinate)."""
    track = uneven_arc(N, R, HALF)
    ref_nodes, lengths = geometry(track)
    nodes = ref_nodes + rng.uniform(-1, 1, ref_nodes.shape) * np.array([0.002, 0.002, 0.005, 0.005])
    k = 3
    s_node = node_arc_lengths(lengths)[k]
    system, state = track_model(track, s_node, nodes=nodes, clamp_nodes="ends", rate=1.2).build(
        assemble=False)
    v = np.asarray(state.v) + rng.uniform(-0.5, 0.5, system.n_coordinates)
    state = eqx.tree_at(lambda st: st.v, state, jnp.asarray(v))
    jump_check(system, state, nodes, lengths, k)


# ---------------------------------------------------------------------------- flexible track
@pytest.fixture(scope="module")
def flexible_line():
    """Straight incline clamped at its two ends only (steel bar, 1 cm², EI = 210 N m²
    at E = 210 GPa), starting straight: it sags and vibrates under its own weight and
    the body's. Generalized-α, h = 2 ms."""
    system, state = track_model(incline(), S0_LINE, clamp_nodes="ends").build()
    e0 = system.beams[0].section.youngs_modulus
    runs = {}
    for factor in (1.0, 10.0, 100.0):
        stiffer = eqx.tree_at(lambda s: s.beams[0].section.youngs_modulus, system, e0 * factor)
        runs[factor] = run_fixed(stiffer, state, GeneralizedAlpha(), 2e-3, T_LINE, chunk=50)
    return system, runs


def test_flexible_incline_converges_to_the_rigid_answer(flexible_line):
    """The deviation from s = s₀ + ½ g sin θ t² is the track's compliance: it falls as
    1/E (measured 5.3 mm, 0.55 mm, 55 µm for E × 1, 10, 100; the generalized-α error of
    this motion is below 1e-10), while the body crosses 6 nodes with a continuous
    velocity (no step changes ṡ by more than 1.1 h g sin θ)."""
    system, runs = flexible_line
    devs = []
    for factor, run in runs.items():
        assert run.status == 0
        s, sd = run.q[:, system.sliding_offset], run.v[:, system.sliding_offset]
        devs.append(np.max(np.abs(s - (S0_LINE + 0.5 * G * np.sin(THETA) * run.t**2))))
        assert np.max(np.abs(np.diff(sd))) < 1.1 * 2e-3 * G * np.sin(THETA)
        assert s[-1] > 1.5 + 0.1
    ratios = np.array(devs[:-1]) / np.array(devs[1:])
    assert np.all((ratios > 8.0) & (ratios < 12.0)), (devs, ratios)
    assert devs[-1] < 1e-4
