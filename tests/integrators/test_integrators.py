"""The integrators (RK4, explicit Euler, generalized-α, and diffrax's Tsit5, Dopri5,
Kvaerno5) on common problems: the very flexible pendulum H1 (docs/models.md, 4 elements)
over t ∈ [0, 0.5] s and a rigid pendulum swinging ±143°.

Shown: each method's convergence order in the step size (RK4 4, explicit Euler 1,
generalized-α 2, the diffrax methods 5 at a fixed step), conservation of energy at the method's order, no
energy gain with Rayleigh damping, agreement of all five to their tolerances, and a
bounded constraint violation over a long run.
"""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha
from ancf_jax.integrators.explicit import RK4, ExplicitEuler
from ancf_jax.simulation import make_solver, simulate

from ..dynamics import h1_model, observed_orders, pendulum_model, run_fixed

T_H1 = 0.5
RK4_STEPS = (2e-3, 1e-3, 5e-4, 2.5e-4)
GA_STEPS = (1e-3, 5e-4, 2.5e-4)
ALPHA, BETA = 1.0, 2e-3  # Rayleigh damping of the damped runs [1/s, s]
DIFFRAX = ("tsit5", "dopri5", "kvaerno5")


@pytest.fixture(scope="module")
def h1():
    return h1_model(4).build()


@eqx.filter_jit
def mechanical_energy(system, q, v):
    """T + V_gravity + U at every row [J]."""
    return jax.vmap(lambda qq, vv: system.kinetic_energy(vv) + system.gravity_potential(qq)
                    + system.strain_energy(qq))(q, v)


def h1_run(system, state, solver, h):
    run = run_fixed(system, state, solver, h, T_H1, chunk=50)
    assert run.status == 0
    stride = int(round(0.01 / h))
    return dict(h=h, tip=run.q[::stride, -4:-2], energy=np.asarray(mechanical_energy(system, run.q, run.v)),
                dissipated=run.work[:, 0])


@pytest.fixture(scope="module")
def rk4_study(h1):
    return [h1_run(*h1, RK4(), h) for h in RK4_STEPS]


@pytest.fixture(scope="module")
def ga_study(h1):
    return [h1_run(*h1, GeneralizedAlpha(), h) for h in GA_STEPS]


@pytest.fixture(scope="module")
def reference(rk4_study):
    """Tip every 10 ms: Richardson extrapolation of the two finest RK4 runs (their
    difference is 3.1e-8 m, so the extrapolated error is ~2e-9 m)."""
    a, b = rk4_study[-2]["tip"], rk4_study[-1]["tip"]
    return b + (b - a) / 15.0


def fitted_order(steps, errors):
    """Least-squares slope of log(error) against log(h)."""
    return np.polyfit(np.log(steps), np.log(errors), 1)[0]


# ---------------------------------------------------------------------------- orders
def test_rk4_converges_at_fourth_order(rk4_study, reference):
    """H1 tip trajectory: measured errors 7.7e-6, 5.3e-7, 3.3e-8 m at h = 2, 1, 0.5 ms
    (orders 3.85, 4.0)."""
    errors = [np.max(np.abs(r["tip"] - reference)) for r in rk4_study[:-1]]
    orders = observed_orders(errors)
    assert np.all((orders > 3.7) & (orders < 4.3)), (errors, orders)


def test_generalized_alpha_converges_at_second_order(ga_study, reference):
    """H1 tip trajectory (ρ∞ = 0.9): measured errors 1.2e-4, 3.1e-5, 7.8e-6 m (orders
    1.95, 1.99)."""
    errors = [np.max(np.abs(r["tip"] - reference)) for r in ga_study]
    orders = observed_orders(errors)
    assert np.all((orders > 1.8) & (orders < 2.2)), (errors, orders)


def test_explicit_euler_converges_at_first_order(h1, reference):
    """H1 tip trajectory over the first 0.1 s (the forward Euler step amplifies every
    undamped mode by √(1 + ω²h²): over the whole 0.5 s the runs at h ≥ 0.5 ms diverge,
    measured): errors 4.9e-4, 2.5e-4, 1.2e-4, 6.2e-5 m at h = 1, 0.5, 0.25, 0.125 ms
    (orders 0.999, 0.999, 1.000)."""
    steps = (1e-3, 5e-4, 2.5e-4, 1.25e-4)
    errors = []
    for h in steps:
        run = run_fixed(*h1, ExplicitEuler(), h, 0.1, chunk=50)
        assert run.status == 0
        tip = run.q[::int(round(0.01 / h)), -4:-2]
        errors.append(np.max(np.abs(tip - reference[:len(tip)])))
    orders = observed_orders(errors)
    assert np.all((orders > 0.95) & (orders < 1.05)), (errors, orders)


@eqx.filter_jit
def _fixed_step(system, solver, y0, h, ts):
    """The solver's own vector field (index-1 form with Baumgarte terms) and diffrax
    method at a constant step h, saved at ts."""
    term = diffrax.ODETerm(solver.vector_field(system, None))
    return diffrax.diffeqsolve(term, solver.diffrax_solver(), t0=0.0, t1=ts[-1], dt0=h, y0=y0,
                               saveat=diffrax.SaveAt(ts=ts), max_steps=4096,
                               stepsize_controller=diffrax.ConstantStepSize()).ys[0]


@pytest.mark.parametrize("kind", DIFFRAX)
def test_diffrax_solvers_converge_at_fifth_order(kind):
    """At a fixed step (diffrax ConstantStepSize; the shipped solvers are adaptive, and
    their global error is not a power of the tolerance), on the rigid pendulum over 2 s,
    positions every 0.1 s: successive differences for h = 5, 2.5, 1.25, 0.625 ms give
    measured orders 5.8, 5.7 (Tsit5), 5.8, 5.7 (Dopri5), 4.86, 4.93 (Kvaerno5)."""
    system, state = pendulum_model(2.5).build()
    solver = make_solver(kind)
    ts = jnp.linspace(0.1, 2.0, 20)
    y0 = (state.q, state.v, jnp.zeros(3))
    q = np.array([np.asarray(_fixed_step(system, solver, y0, jnp.asarray(h), ts))
                  for h in (5e-3, 2.5e-3, 1.25e-3, 6.25e-4)])
    diffs = np.max(np.abs(np.diff(q, axis=0)), axis=(1, 2))
    orders = observed_orders(diffs)
    assert np.all((orders > 4.7) & (orders < 6.3)), (diffs, orders)


# ---------------------------------------------------------------------------- energy
def test_rk4_energy_error_falls_at_fourth_order(rk4_study):
    """Undamped H1: max |E(t) − E(0)| over 0.5 s, measured 7.4e-5, 3.1e-6, 3.6e-7,
    2.8e-8 J at h = 2 … 0.25 ms (E varies by ~20 J between its parts). The error at a
    given time changes sign with h (it is a sum of oscillating contributions), so the
    order is the least-squares slope over the four steps: measured 3.8."""
    errors = [np.max(np.abs(r["energy"] - r["energy"][0])) for r in rk4_study]
    assert 3.5 < fitted_order(RK4_STEPS, errors) < 4.5, errors
    assert errors[1] < 1e-5  # h = 1 ms


def test_generalized_alpha_energy_error_falls_at_second_order(ga_study):
    """Undamped H1: measured 4.1e-3, 1.0e-3, 2.5e-4 J (orders 2.01, 2.00)."""
    errors = [np.max(np.abs(r["energy"] - r["energy"][0])) for r in ga_study]
    orders = observed_orders(errors)
    assert np.all((orders > 1.9) & (orders < 2.1)), errors


@pytest.mark.parametrize("name,h", [("rk4", 1e-3), ("generalized-alpha", 5e-4)])
def test_damped_energy_never_increases(h1, rk4_study, ga_study, name, h):
    """H1 with Rayleigh α = 1 1/s, β = 2 ms: no step raises T + V + U by more than the
    largest change of a step of the undamped run at the same h (the method's own energy
    error per step: 4.9e-7 J for RK4, 1.7e-5 J for generalized-α); measured, the energy
    falls at every step. The dissipated work (the integral of vᵀCv ≥ 0) never
    decreases, and the damping removes over 20 J."""
    system, state = h1
    damped = eqx.tree_at(lambda s: (s.beams[0].alpha, s.beams[0].beta), system,
                         (jnp.asarray(ALPHA, float), jnp.asarray(BETA, float)))
    solver = RK4() if name == "rk4" else GeneralizedAlpha()
    undamped = next(r for r in (rk4_study if name == "rk4" else ga_study) if r["h"] == h)
    per_step_error = np.max(np.abs(np.diff(undamped["energy"])))
    run = h1_run(damped, state, solver, h)
    assert np.max(np.diff(run["energy"])) <= per_step_error
    assert np.min(np.diff(run["dissipated"])) >= 0.0
    assert run["energy"][0] - run["energy"][-1] > 20.0


# ---------------------------------------------------------------------------- agreement
@pytest.fixture(scope="module")
def adaptive_runs(h1):
    system, state = h1
    return {kind: simulate(system, state, t_end=T_H1, dt=1e-3, solver=kind, output_dt=0.01,
                           progress=False) for kind in DIFFRAX}


@pytest.mark.study
def test_all_integrators_agree_on_h1(rk4_study, ga_study, adaptive_runs, reference):
    """Tip of H1 every 10 ms against the reference, each to its own tolerance.

    RK4 and generalized-α at h = 1 ms (the default step of simulate): the errors their
    convergence studies measure, 5.3e-7 m and 1.2e-4 m, with a factor 2 of margin. The
    diffrax solvers at their default rtol = 1e-6, atol = 1e-8: within rtol × the tip
    coordinate scale (1.2 m) — measured 4e-9 (Tsit5), 8e-9 (Dopri5), 7e-8 (Kvaerno5)."""
    rk4 = next(r for r in rk4_study if r["h"] == 1e-3)
    ga = next(r for r in ga_study if r["h"] == 1e-3)
    assert np.max(np.abs(rk4["tip"] - reference)) < 1.1e-6
    assert np.max(np.abs(ga["tip"] - reference)) < 2.4e-4
    for kind, res in adaptive_runs.items():
        solver = make_solver(kind)
        assert res.status == "ok"
        np.testing.assert_allclose(res.t, 0.01 * np.arange(len(res.t)), atol=1e-12)
        tip = res.node("beam", -1)[:, :2]
        assert np.max(np.abs(tip - reference)) < solver.rtol * 1.2, kind


# ---------------------------------------------------------------------------- drift
@pytest.mark.parametrize("kind", ("rk4", "explicit-euler", "generalized-alpha") + DIFFRAX)
def test_constraint_drift_stays_bounded(kind):
    """Rigid pendulum (a pin at a body point: Φ nonlinear in θ) swinging ±143° for 20 s
    (9 periods), h = 1 ms (initial step for the adaptive ones). RK4 and explicit Euler
    project q and v after every step and generalized-α solves Φ = 0 to its Newton tolerance (1e-10):
    bound 1e-10, measured 2e-16. The diffrax solvers keep Φ by Baumgarte terms only
    (ω = 50 rad/s): bound 1e-6 m (simulate's default drift tolerance), measured 3e-8
    (Tsit5), 5e-8 (Dopri5), 3e-7 (Kvaerno5); and it does not grow: the second half of
    the run stays below the first half's maximum (with a 10 % margin)."""
    system, state = pendulum_model(2.5).build()
    res = simulate(system, state, t_end=20.0, dt=1e-3, solver=kind, output_dt=0.01, progress=False)
    assert res.status == "ok" and res.t[-1] == pytest.approx(20.0)
    drift, _ = res.constraint_violation()
    bound = 1e-10 if kind in ("rk4", "explicit-euler", "generalized-alpha") else 1e-6
    assert np.max(drift) < bound
    if kind in DIFFRAX:
        half = len(drift) // 2
        assert np.max(drift[half:]) <= 1.1 * np.max(drift[:half])


# ---------------------------------------------------------------------------- index 2
PENDULUM_STEPS = (4e-3, 2e-3, 1e-3, 5e-4)


def test_velocity_level_constraints_converge_at_second_order():
    """Generalized-α with velocity-level constraints (index 2, ``index=2``) at ρ∞ = 1, the
    trapezoidal rule, on the rigid pendulum (Φ nonlinear in θ) swinging ±143° for 1 s,
    against its equation of motion (J + m a²) θ̈ = −m g a sin θ integrated by scipy
    (rtol 1e-13). Measured θ errors 3.66e-4, 9.16e-5, 2.29e-5, 5.72e-6 rad (orders
    2.000); the positions drift off Φ = 0 at the same order (4.75e-5, 1.19e-5, 2.97e-6,
    7.43e-7 m) while the velocity constraints hold to the Newton tolerance (≤ 6e-12 m/s
    measured). (Index 3 at the same setting: θ errors 6.75e-4 ... 1.06e-5 rad, order 2,
    Φ at round-off.)"""
    from scipy.integrate import solve_ivp
    from ancf_jax.integrate import RunOptions
    from ..dynamics import G
    mass, inertia, arm, t_end = 1.0, 0.01, 0.5, 1.0
    system, state = pendulum_model(2.5, mass=mass, inertia=inertia, arm=arm).build()
    ref = solve_ivp(lambda t, y: [y[1], -mass * G * arm * np.sin(y[0]) / (inertia + mass * arm**2)], (0.0, t_end),
                    [2.5, 0.0], rtol=1e-13, atol=1e-13, dense_output=True)
    solver = make_solver("generalized-alpha", rho_inf=1.0, index=2, velocity_projection=False)
    errors, drifts, rates = [], [], []
    for h in PENDULUM_STEPS:
        run = run_fixed(system, state, solver, h, t_end, options=RunOptions(drift_tolerance=1.0))
        assert run.status == 0
        stride = int(round(0.02 / h))
        errors.append(np.max(np.abs(run.q[::stride, 2] - ref.sol(run.t[::stride])[0])))
        drifts.append(np.max(np.abs(jax.vmap(lambda q: system.constraint(q, 0.0))(jnp.asarray(run.q)))))
        rates.append(np.max(np.abs(jax.vmap(lambda q, v: system.constraint_velocity(q, v, 0.0))(
            jnp.asarray(run.q), jnp.asarray(run.v)))))
    assert np.ptp(run.q[:, 2]) > 4.0  # it swung
    for values in (errors, drifts):
        orders = observed_orders(values)
        assert np.all((orders > 1.95) & (orders < 2.05)), (values, orders)
    assert max(rates) < 1e-9, rates
