"""simulate() and trajectory(): the rigid pendulum against its closed-form period,
failures reported as SimulationError with the results up to then, and gradients of
trajectory functionals against central finite differences."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.special import ellipk

from ancf_jax import SimulationError, mesh
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha
from ancf_jax.integrators.explicit import RK4
from ancf_jax.models.m1 import m1_model
from ancf_jax.simulation import simulate, trajectory

from .dynamics import G, h1_model, pendulum_model, track_model

# ---------------------------------------------------------------------------- rigid pendulum
MASS, INERTIA, ARM = 1.0, 0.01, 0.5
I_HINGE = INERTIA + MASS * ARM**2
T_SMALL = 2.0 * np.pi * np.sqrt(I_HINGE / (MASS * G * ARM))


def exact_period(theta0):
    """T = 4 √(I_O / m g d) K(sin²(θ₀/2)) (K: complete elliptic integral of the first
    kind, scipy's parameter m = k²)."""
    return 4.0 * np.sqrt(I_HINGE / (MASS * G * ARM)) * ellipk(np.sin(theta0 / 2.0) ** 2)


def zero_crossings(t, theta, omega):
    """Times where θ changes sign, from the cubic Hermite interpolant of (θ, θ̇) on each
    step (interpolation error O(h⁴), like the integrator's)."""
    out = []
    for k in np.nonzero(np.sign(theta[:-1]) != np.sign(theta[1:]))[0]:
        h = t[k + 1] - t[k]
        p0, p1, m0, m1 = theta[k], theta[k + 1], omega[k] * h, omega[k + 1] * h
        coeffs = [2 * p0 + m0 - 2 * p1 + m1, -3 * p0 - 2 * m0 + 3 * p1 - m1, m0, p0]
        roots = [r.real for r in np.roots(coeffs) if abs(r.imag) < 1e-9 and -1e-9 <= r.real <= 1 + 1e-9]
        out.append(t[k] + h * roots[0])
    return np.array(out)


def measured_period(theta0):
    """Period of the pendulum released at θ₀, from RK4 at h = 2 ms over 5 s (one
    compilation for all amplitudes: only the initial state differs)."""
    system, state = pendulum_model(theta0, mass=MASS, inertia=INERTIA, arm=ARM).build()
    res = simulate(system, state, t_end=5.0, dt=2e-3, solver="rk4", progress=False)
    c = zero_crossings(res.t, res.body("bob")[:, 2], res.v[:, 2])
    assert len(c) >= 3
    return c[2] - c[0]


def test_small_amplitude_period():
    """θ₀ = 0.01: T = 2π √(I_O / m g d) (1 + θ₀²/16 + O(θ₀⁴)). The O(θ₀⁴) term is
    3.6e-11 and RK4 at 2 ms measures the period to 3e-12 (4e-3 s: 8e-10), so the
    deviation from T₀ must be the θ₀²/16 = 6.25e-6 correction to within 1e-9."""
    theta0 = 0.01
    deviation = measured_period(theta0) / T_SMALL - 1.0
    assert abs(deviation - theta0**2 / 16.0) < 1e-9


@pytest.mark.parametrize("theta0", [1.0, 2.5])
def test_large_amplitude_period(theta0):
    """Against the elliptic-integral period (6 % and 39 % longer than T₀); measured
    agreement 5e-12 at h = 2 ms (7e-11 at 4 ms)."""
    exact = exact_period(theta0)
    assert exact / T_SMALL - 1.0 > 0.06
    assert abs(measured_period(theta0) / exact - 1.0) < 1e-9


# ---------------------------------------------------------------------------- failures
def test_divergence_raises_with_time_and_partial_results():
    """RK4 far above the stability limit of a stiff beam (H1 made of steel: axial
    frequencies ~1e5 rad/s, h = 1 ms) becomes NaN within a few steps."""
    system, state = h1_model(4, youngs_modulus=2e11).build()
    with pytest.raises(SimulationError) as err:
        simulate(system, state, t_end=0.05, dt=1e-3, solver="rk4", progress=False)
    e = err.value
    assert e.reason == "nan" and 0.0 < e.time < 0.05
    assert f"t = {e.time:.6g} s" in str(e) and "NaN" in str(e)
    # the cause named is the rk4 step, not a Newton iteration (issue 25: rk4 failures
    # were reported as "Newton iteration did not converge")
    assert "rk4" in str(e) and "Newton" not in str(e), str(e)
    res = e.results
    assert res.status == "nan" and res.failure_time == e.time
    # every step up to the failing one, all finite, starting from the initial state
    assert len(res.t) >= 1 and res.t[0] == 0.0
    np.testing.assert_allclose(res.t, 1e-3 * np.arange(len(res.t)), atol=1e-12)
    assert res.t[-1] + 1e-3 == pytest.approx(e.time)
    assert np.all(np.isfinite(res.q)) and np.all(np.isfinite(res.v))
    np.testing.assert_array_equal(res.q[0], state.q)
    # on_failure="return" gives the same results instead of raising
    ret = simulate(system, state, t_end=0.05, dt=1e-3, solver="rk4", progress=False,
                   on_failure="return")
    assert ret.status == "nan" and ret.failure_time == e.time and ret.message == str(e)
    np.testing.assert_array_equal(ret.q, res.q)


@pytest.fixture(scope="module")
def left_beam_error():
    """Two bodies slide down a clamped straight incline (θ = 30°, L = 2 m); "lower"
    starts at s = 1.5 m and runs off the end at t = √(2·0.5 / (g sin θ)) = 0.4515 s,
    "upper" (s = 0.2 m) is still on the beam then."""
    theta = np.radians(30.0)
    track = mesh.straight((0.0, 0.0), (np.cos(theta), -np.sin(theta)), 2.0, 2)
    m = track_model(track, 1.5)  # body "slider_body" on sliding joint "slider"
    nodes = np.asarray(track.reference_nodes)
    m.add_body("upper_body", mass=1.0, inertia=0.1, position=nodes[0, :2] + 0.2 * nodes[0, 2:])
    m.slider("upper", "upper_body", "track", 0.2)
    system, state = m.build()
    with pytest.raises(SimulationError) as err:
        simulate(system, state, t_end=1.0, dt=0.01, solver="rk4", progress=False)
    return err.value, np.sqrt(2 * 0.5 / (G * np.sin(theta)))


def test_leaving_the_beam_is_reported_with_time_and_results(left_beam_error):
    e, t_exit = left_beam_error
    assert e.reason == "left_beam"
    assert t_exit <= e.time < t_exit + 0.01 + 1e-9  # the first step past the end
    assert f"t = {e.time:.6g} s" in str(e) and "left its beam" in str(e)
    assert "slider" in str(e)  # the joint that left
    s = e.results.sliding("slider")
    assert e.results.t[-1] < t_exit and np.all(s <= 2.0)
    np.testing.assert_allclose(s, 1.5 + 0.5 * G * np.sin(np.radians(30.0)) * e.results.t**2, atol=1e-9)


def test_leaving_the_beam_names_only_the_joint_that_left(left_beam_error):
    e, _ = left_beam_error
    assert "'slider'" in str(e) and "upper" not in str(e)


# ---------------------------------------------------------------------------- gradients
def rayleigh_functional(system, state, solver, t_end, dt):
    """(α, β) ↦ mean tip Y of beam 0 over the output times of a trajectory, with its
    gradient (jax.value_and_grad under one jit: the finite differences reuse it)."""
    n = int(system.beams[0].mesh.n_elements)
    tip_y = system.beam_offset(0) + 4 * n + 1

    def functional(p):
        s = eqx.tree_at(lambda s: (s.beams[0].alpha, s.beams[0].beta), system, (p[0], p[1]))
        seg, loop = trajectory(s, state, solver, t_end=t_end, dt=dt)
        return jnp.mean(seg.q[:, tip_y])

    return eqx.filter_jit(jax.value_and_grad(functional))


def central_differences(f, p0, rel_steps):
    out = []
    for i, rel in enumerate(rel_steps):
        d = rel * float(p0[i])
        e = jnp.zeros_like(p0).at[i].set(d)
        out.append(float((f(p0 + e)[0] - f(p0 - e)[0]) / (2.0 * d)))
    return np.array(out)


def test_gradient_generalized_alpha_m1_rayleigh():
    """M1 (tip Y averaged over 50 steps of 1 ms) w.r.t. α and β by the implicit
    function theorem through the Newton solves (ModifiedNewton.root's custom JVP; β
    set after the build, so the iteration's Newton matrix leaves its rate term out and
    the tangent solves factor the matrix with it, GeneralizedAlpha.tangent_system).

    FD steps: the functional is almost linear in α, so a large step (1 % of α) has no
    truncation error; smaller steps see the Newton tolerance (1e-10 m per step):
    measured FD − grad relative 4e-9 at 1 %, 8e-6 at 1e-5 %. For β (1e-5 s) truncation
    dominates above 1 % (1.5e-6 at 10 %), noise below 0.1 %: at 0.3 % the measured
    agreement is 2e-8. Tolerance 1e-6: 40× the measured FD error, while a derivative
    that missed the dependence through the Newton solve or the tangent-solve refinement
    would be off by far more (3e-4 relative in β for the matrix without its rate term,
    unrefined: ``benchmarks/gradient.py``)."""
    system, state = m1_model().build()
    p0 = jnp.array([0.02, 1e-5])
    f = rayleigh_functional(system, state, GeneralizedAlpha(), 0.05, 1e-3)
    _, grad = f(p0)
    fd = central_differences(f, p0, (1e-2, 3e-3))
    assert np.all(np.abs(np.asarray(grad)) > 0)
    np.testing.assert_allclose(np.asarray(grad), fd, rtol=1e-6)


@pytest.mark.study
def test_gradient_with_the_exact_newton_matrix_needs_no_refinement():
    """With the β-rate term in the Newton matrix (:meth:`System.with_rate_stiffness`, as
    the identification sets β) the matrix is the exact Jacobian of the step residual:
    the tangent solves take no refinement steps by default, and the gradient still
    agrees with central differences as closely as the refined one above (a matrix
    without the term, unrefined, was off by 1e-4 relative in the β component on M1's
    damping loss, ``benchmarks/gradient.py``)."""
    system, state = m1_model().build()
    p0 = jnp.array([0.02, 1e-5])
    plain = system
    system = system.with_rate_stiffness(True)
    solver = GeneralizedAlpha()
    assert solver.tangent_refinement(eqx.tree_at(lambda s: s.beams[0].beta, system, p0[1])) == 0
    assert solver.tangent_system(eqx.tree_at(lambda s: s.beams[0].beta, system, p0[1])) is None
    # a β set after the build without the term: the tangent solves factor the matrix
    # with it (the test above), unrefined
    late = eqx.tree_at(lambda s: s.beams[0].beta, plain, p0[1])
    assert solver.tangent_refinement(late) == 0 and solver.tangent_system(late).beams[0].rate_stiffness
    f = rayleigh_functional(system, state, solver, 0.05, 1e-3)
    _, grad = f(p0)
    fd = central_differences(f, p0, (1e-2, 3e-3))
    assert np.all(np.abs(np.asarray(grad)) > 0)
    np.testing.assert_allclose(np.asarray(grad), fd, rtol=1e-6)
    # the same gradient three ways, beyond what differences resolve: the forward
    # matrix without the term and the exact tangent matrix (the default), and that
    # matrix refined 8 times instead (measured agreement 2e-11 on the 2 s loss)
    _, late_grad = rayleigh_functional(plain, state, solver, 0.05, 1e-3)(p0)
    _, refined = rayleigh_functional(plain, state, GeneralizedAlpha(refinement=8), 0.05, 1e-3)(p0)
    np.testing.assert_allclose(np.asarray(late_grad), np.asarray(grad), rtol=1e-9)
    np.testing.assert_allclose(np.asarray(late_grad), np.asarray(refined), rtol=1e-9)


def test_gradient_rk4_h1_rayleigh():
    """Damped H1 (α = 0.5 1/s, β = 2 ms; tip Y averaged over 150 RK4 steps of 2 ms)
    w.r.t. α and β by reverse-mode through the steps and their projections. FD with
    relative step 1e-4: truncation O(δ²) measured 6e-8 (β) at 1e-3 and 5e-9 at 1e-4,
    round-off below 1e-10; tolerance 1e-6."""
    system, state = h1_model(4, alpha=0.5, beta=2e-3).build()
    p0 = jnp.array([0.5, 2e-3])
    f = rayleigh_functional(system, state, RK4(), 0.3, 2e-3)
    _, grad = f(p0)
    fd = central_differences(f, p0, (1e-4, 1e-4))
    assert np.all(np.abs(np.asarray(grad)) > 0)
    np.testing.assert_allclose(np.asarray(grad), fd, rtol=1e-6)


def test_time_grid_never_shortens_the_step_asked_for():
    """Outputs end at t_end and every step is at most dt, with the fewest steps that
    allow it: the output interval is shortened to t_end / n (never lengthened, which
    would take one more substep per interval: a 6.0408 s run at dt = 2 ms, output at
    every step, ran at 1 ms before 2026-12-06)."""
    import math
    from ancf_jax.simulation import time_grid
    rng = np.random.default_rng(6)
    cases = [(6.0408, 2e-3, None), (1.0002, 2e-3, 1e-2), (2.0, 1.25e-3, 0.01), (0.3, 1e-3, None),
             (1e-3, 2e-3, None)] + [(float(rng.uniform(0.01, 5)), float(rng.uniform(1e-4, 5e-3)), None)
                                     for _ in range(50)]
    for t_end, dt, out in cases:
        out_asked = dt if out is None else out
        n, sub, h, out_dt = time_grid(t_end, dt, out)
        assert h <= dt * (1 + 1e-12) and out_dt <= max(out_asked, t_end) * (1 + 1e-12)
        assert n * out_dt == pytest.approx(t_end, rel=1e-12) and sub * h == pytest.approx(out_dt, rel=1e-12)
        # the fewest substeps that keep h <= dt, and the fewest intervals that keep out_dt <= the asked one
        assert sub == max(1, math.ceil(out_dt / dt * (1 - 1e-9)))
        assert n == max(1, math.ceil(t_end / out_asked * (1 - 1e-9)))
        if out is None:
            assert sub == 1 and n == max(1, math.ceil(t_end / dt * (1 - 1e-9)))


# ---------------------------------------------------------------------------- simulate_each
def test_simulate_each_equals_single_runs_and_reports_failures():
    """Members in two threads give exactly their single runs (two structures: H1 and
    the rigid pendulum, and H1 with two damping values; RK4 stepping every 1 ms, so
    both are the programs of the period and divergence tests above, compiled once); a
    member made to fail (α = NaN: a NaN state) is named in the SimulationError after
    every member ran, or returned with its status."""
    from ancf_jax import ModelError
    from ancf_jax.simulation import simulate_each

    a, b = h1_model(4).build(), pendulum_model(1.0, mass=MASS, inertia=INERTIA, arm=ARM).build()
    damped = (eqx.tree_at(lambda s: s.beams[0].alpha, a[0], jnp.asarray(0.5)), a[1])
    members = [a, b, damped]
    kw = dict(t_end=0.03, dt=1e-3, solver="rk4", progress=False)
    runs = simulate_each([m[0] for m in members], [m[1] for m in members], workers=2, **kw)
    for (system, state), r in zip(members, runs):
        single = simulate(system, state, **kw)
        np.testing.assert_array_equal(r.q, single.q)
        np.testing.assert_array_equal(r.lam, single.lam)
    assert not np.array_equal(runs[0].q, runs[2].q)  # the damping reached its member

    bad = (eqx.tree_at(lambda s: s.beams[0].alpha, a[0], jnp.asarray(np.nan)), a[1])
    with pytest.raises(SimulationError, match="member 1: ") as err:
        simulate_each([a[0], bad[0], a[0]], [a[1], bad[1], a[1]], workers=2, **kw)
    assert [r.status for r in err.value.results][::2] == ["ok", "ok"] and err.value.results[1].status != "ok"
    returned = simulate_each([a[0], bad[0]], [a[1], bad[1]], on_failure="return", **kw)
    assert returned[0].status == "ok" and returned[1].status == err.value.results[1].status

    for workers in (0, 1.5, True):
        with pytest.raises(ModelError, match=r"workers must be an integer >= 1"):
            simulate_each([a[0]], [a[1]], workers=workers, **kw)
    with pytest.raises(ModelError, match="equally many"):
        simulate_each([a[0]], [], **kw)
