"""Cable machinery (issue 19): one-sided spring-dampers (ropes, droppers, stops),
point masses on beams, driven and frictional sliding joints.

Closed forms and independent numbers: a body bouncing on a tension-only rope (free
flight while slack, harmonic while taut; scipy's solve_ivp with events as the
independent answer for the damped rope), the energy balance through slack and taut
phases with its tolerance from a step-halving study, ...
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ancf_jax.forces import CompressionOnlySpringDamper, TensionOnlySpringDamper
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha
from ancf_jax.model import Model, body_point, ground
from ancf_jax.points import BodyPoint, GroundPoint

from .dynamics import G, run_fixed

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
            out[c, h] = system, run_fixed(system, state, GeneralizedAlpha(), h, T_ROPE, chunk=200)
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
