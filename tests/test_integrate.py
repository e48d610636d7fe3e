"""The fixed-step time loop: node crossings of sliding joints (the kinks of one-sided
members: tests/test_cable_machinery.py).

r'' of the cubic interpolation jumps at the nodes, so the accelerations jump when a
sliding joint crosses one and a fixed step that straddles the crossing loses the
method's order; ``locate_crossings`` splits such steps at the crossing. Shown here for
RK4 on a clamped circular track whose curvature jumps at every node, against the
motion on the same curve computed by SciPy with the crossings as events.
(``benchmarks/locate_crossings.py`` runs the same study through ``simulate``.)
"""

import jax
import numpy as np
import pytest

from ancf_jax.integrate import RunLimits, RunOptions
from ancf_jax.integrators.explicit import RK4
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha
from ancf_jax.newton import ModifiedNewton

from .dynamics import LazyRuns, curve_motion, observed_orders, run_fixed, track_model, uneven_arc

S0, T_END = 0.35, 1.2  # released 0.85 rad from the bottom: 7 crossings
STEPS = (0.02, 0.01, 0.005)  # 0.0025 adds nothing but two compilations (errors below)


@pytest.fixture(scope="module")
def crossing_runs():
    """{(located, h [s]): the arc run with RK4 at step h, node crossings located or not}
    as rows: error in s against the closed form, crossings located and passed, status
    and max |Φ|; each run made when a test first asks for it (every located/step pair
    is a compilation of its own)."""
    track = uneven_arc(8, 1.0, 1.2)
    n = int(track.n_elements)
    nodes, lengths = np.asarray(track.reference_nodes)[: n + 1], np.asarray(track.element_lengths)[:n]
    system, state = track_model(track, S0).build()
    phi = jax.jit(jax.vmap(lambda sy, q: sy.constraint(q), in_axes=(None, 0)))

    def row(key):
        locate, h = key
        run = run_fixed(system, state, RK4(), h, T_END, chunk=10,
                        options=RunOptions(locate_crossings=locate, max_halvings=0))
        ref, crossings = curve_motion(nodes, lengths, S0, 0.0, run.t)
        s = run.q[:, system.sliding_offset]
        return dict(error=np.max(np.abs(s - ref[:, 0])), located=int(run.crossings.sum()), crossings=len(crossings),
                    status=run.status, drift=float(np.max(np.abs(phi(system, run.q)))))
    return LazyRuns(row)


@pytest.fixture(scope="module")
def crossing_study(crossing_runs):
    """{located: rows at STEPS} (a validation study: six compilations)."""
    return {locate: [crossing_runs[locate, h] for h in STEPS] for locate in (False, True)}


def test_located_crossings_meet_the_closed_form(crossing_runs):
    """At h = 10 ms (the order study below measures the rest): the seven crossings
    located, the error 1.1e-8 (measured; bound 3e-8), 90 times smaller than without
    locating them (9.9e-7), and the constraint kept at round-off in both runs."""
    located, plain = crossing_runs[True, 0.01], crossing_runs[False, 0.01]
    assert located["status"] == 0 == plain["status"]
    assert located["located"] == located["crossings"] == 7 and plain["located"] == 0
    assert located["error"] < 3e-8 and plain["error"] > 30.0 * located["error"], (located, plain)
    assert max(located["drift"], plain["drift"]) < 1e-12


@pytest.mark.study
def test_located_crossings_keep_rk4_fourth_order(crossing_study):
    """Measured errors 1.7e-7, 1.1e-8, 7.1e-10 (orders 3.98, 3.95; at 2.5 ms 4.4e-11,
    order 4.01: ``python -m benchmarks.locate_crossings``)."""
    rows = crossing_study[True]
    assert all(r["status"] == 0 for r in rows)
    assert all(r["located"] == r["crossings"] == 7 for r in rows)
    orders = observed_orders([r["error"] for r in rows])
    assert np.all((orders > 3.7) & (orders < 4.4)), orders


@pytest.mark.study
def test_unlocated_crossings_lose_the_order(crossing_study):
    """Without locating, each straddled crossing leaves an error of lower order
    (measured 4.7e-6, 9.9e-7, 1.5e-7: 2.5 on average, erratic because it depends on
    where the nodes fall in the steps; 1.3e-7 at 2.5 ms); at the finest step here it is
    200 times the located error."""
    plain, located = crossing_study[False], crossing_study[True]
    assert all(r["status"] == 0 and r["located"] == 0 and r["crossings"] == 7 for r in plain)
    errors = np.array([r["error"] for r in plain])
    mean_order = np.log2(errors[0] / errors[-1]) / (len(errors) - 1)
    assert mean_order < 3.0, errors
    assert errors[-1] > 100.0 * located[-1]["error"]


@pytest.mark.study
def test_projection_keeps_the_sliding_constraint(crossing_study):
    """RK4 projects q and v onto the constraints after every step (two Newton steps):
    max |Φ| over every run, crossings included, stays at round-off."""
    for rows in crossing_study.values():
        assert max(r["drift"] for r in rows) < 1e-12


# ---------------------------------------------------------------------------- retries
def test_failed_newton_step_is_completed_in_substeps():
    """M1 with generalized-α limited to 6 Newton iterations: at h = 4 ms some steps need
    7–8 (measured), so without retries the run stops with reason "newton" at the first
    of them (t = 16 ms); with ``max_halvings = 3`` those steps are redone in substeps of
    2 ms or less (one halving is not always enough: measured), the run completes, and it
    stays within the O(h²) difference between 4 ms and 2 ms runs of the 2 ms run."""
    from ancf_jax.models.m1 import m1_model
    from ancf_jax.simulation import simulate

    system, state = m1_model(6).build()
    # generalized-α with 6 Newton iterations (that logs its steps: the plain and the 2 ms
    # runs are then the program of test_steps_past_the_end_or_a_failure_are_skipped_by_blocks,
    # outputs at every step, the step size traced)
    kw = dict(t_end=0.2, progress=False, on_failure="return", solver=LOGGED_SOLVER)
    plain = simulate(system, state, dt=4e-3, output_dt=4e-3, options=RunOptions(max_halvings=0), **kw)
    retried = simulate(system, state, dt=4e-3, output_dt=4e-3, options=RunOptions(max_halvings=3), **kw)
    fine = simulate(system, state, dt=2e-3, output_dt=2e-3, options=RunOptions(max_halvings=0), **kw)
    _STEP_LOG.clear()
    assert plain.status == "newton" and 0.0 < plain.failure_time < 0.2
    assert retried.status == "ok" and fine.status == "ok"
    # up to the failure the retried run is the plain one, step for step: to rounding (the
    # two are different compiled programs, whose operations XLA may order differently;
    # measured up to 1.2e-18 m), where a step taken otherwise would differ by ~h²
    n = len(plain.t)
    np.testing.assert_allclose(retried.q[:n], plain.q, rtol=0, atol=1e-15)
    tip = lambda r: r.node("beam", -1)[:, 1]  # noqa: E731
    np.testing.assert_allclose(fine.t[::2], retried.t, rtol=0, atol=1e-12)
    assert np.max(np.abs(tip(retried) - tip(fine)[::2])) < 1e-4
    # the failed steps cost more iterations than any plain step (two substeps, retry)
    assert np.max(retried.iterations) > 6
    # out of retries (one halving is not enough for the step from t = 64 ms, measured):
    # the run stops with "newton" at the first attempt's end t + h (not where a substep
    # ended), and its steps before are the retried run's
    once = simulate(system, state, dt=4e-3, output_dt=4e-3, options=RunOptions(max_halvings=1), **kw)
    _STEP_LOG.clear()
    assert once.status == "newton" and once.failure_time == pytest.approx(0.068, rel=0, abs=1e-12)
    assert once.failure_time == pytest.approx(once.t[-1] + 4e-3, rel=0, abs=1e-15)
    assert n < len(once.t) < len(retried.t)
    np.testing.assert_allclose(once.q, retried.q[:len(once.t)], rtol=0, atol=1e-15)


_STEP_LOG = []


def _log_step(alpha, h, iterations):
    _STEP_LOG.append(np.column_stack([np.ravel(alpha), np.ravel(h), np.ravel(iterations)]))


class LoggedSteps(GeneralizedAlpha):
    """Generalized-α that logs (α of beam 0, h, Newton iterations) of every step it
    computes into _STEP_LOG. One class for the module: runs with equal settings share
    their compiled program (a class made per call was a new program each time)."""

    def step(self, system, carry, h, context):
        new, info = super().step(system, carry, h, context)
        jax.debug.callback(_log_step, system.beams[0].alpha, h, info.iterations)
        return new, info


#: generalized-α limited to 6 Newton iterations, logging its steps (M1 at h = 4 ms needs
#: 7–8 in some steps: the retry and failure tests below)
LOGGED_SOLVER = LoggedSteps(root_finder=ModifiedNewton(max_iterations=6))


def _logged_pair(alpha_full, alpha_light, h, t_end, *, max_halvings):
    """Results of a batch of two M1 variants (α = ``alpha_full`` at full gravity,
    α = ``alpha_light`` at a tenth of it) run with LOGGED_SOLVER at step h [s] to t_end,
    outputs every step, one chunk; _STEP_LOG holds every step the batch computed."""
    import equinox as eqx

    from ancf_jax.models.m1 import m1_model
    from ancf_jax.simulation import simulate_batch

    system, state = m1_model(6).build()
    systems = [eqx.tree_at(lambda s: (s.beams[0].alpha, s.gravity), system,
                           (jax.numpy.asarray(a), g * system.gravity))
               for a, g in ((alpha_full, 1.0), (alpha_light, 0.1))]
    _STEP_LOG.clear()
    return simulate_batch(systems, [state] * 2, t_end=t_end, dt=h, output_dt=h,
                          options=RunOptions(max_halvings=max_halvings), solver=LOGGED_SOLVER,
                          on_failure="return", progress=False, limits=RunLimits(chunks=1))


def test_failed_batch_member_takes_negligible_steps():
    """Under vmap ``lax.cond`` is a select: a member that has failed still computes a
    step (discarded). It must take a negligible step from its last good state (Newton
    converges at once) instead of repeating its failing one, whose Newton loop would
    hold every other member of the batch. Two M1 variants, generalized-α with 6
    Newton iterations at h = 4 ms and no retries: the paper's α = 0.02 1/s fails at
    t = 16 ms (see the test above), the other member (measured) runs on. Every step
    the integrator computes is logged with its size and Newton iterations."""
    from ancf_jax.integrate import FROZEN_STEP

    # the survivor: another α (to tell the members apart in the log) and a tenth of
    # gravity, so its steps converge within 6 iterations (measured)
    failing, running = 0.02, 0.03
    h, t_end = 4e-3, 0.06
    res = _logged_pair(failing, running, h, t_end, max_halvings=0)
    assert res[0].status == "newton" and res[1].status == "ok"
    n_ok = int(round(res[0].failure_time / h)) - 1  # steps completed before the failing one
    log = np.concatenate(_STEP_LOG)
    mine = log[np.isclose(log[:, 0], failing)]
    assert len(mine) == round(t_end / h)  # the batch computed a step for it every time
    full, after = mine[: n_ok + 1], mine[n_ok + 1:]
    np.testing.assert_allclose(full[:, 1], h)
    assert full[-1, 2] == 6  # the failing step ran out of iterations
    assert len(after) > 0
    np.testing.assert_allclose(after[:, 1], FROZEN_STEP * h)
    assert np.all(after[:, 2] <= 2)  # negligible steps: Newton converges at once


def test_a_batch_member_done_with_its_step_waits_with_negligible_steps():
    """Under vmap the retry loop runs its passes until every member has completed its
    step: a member done with its step still computes one in the passes the others need
    for their substeps (discarded). It takes a negligible step (FROZEN_STEP · h from its
    completed state), not one of size h − done = 0 (until 2026-12-07: non-finite
    states, and a contact's closest-point search raised; test_moving_loads has the
    located batch). Two M1 variants at h = 4 ms with retries (``max_halvings = 3``):
    the paper's member needs substeps at some steps (as in
    test_failed_newton_step_is_completed_in_substeps), the other, at a tenth of
    gravity, never (measured); both complete. Fails on the old loop (steps of size 0
    logged, checked)."""
    from ancf_jax.integrate import FROZEN_STEP

    retrying, steady = 0.02, 0.03  # α of the two members, to tell them apart in the log
    h, t_end = 4e-3, 0.06
    res = _logged_pair(retrying, steady, h, t_end, max_halvings=3)
    log = np.concatenate(_STEP_LOG)
    _STEP_LOG.clear()
    assert res[0].status == "ok" and res[1].status == "ok"
    mine, theirs = log[np.isclose(log[:, 0], retrying)], log[np.isclose(log[:, 0], steady)]
    assert np.any(mine[:, 1] < 0.75 * h)  # the first member took substeps
    assert len(theirs) > round(t_end / h)  # so the second one waited in extra passes
    full = np.isclose(theirs[:, 1], h, rtol=1e-12, atol=0)
    np.testing.assert_allclose(theirs[~full, 1], FROZEN_STEP * h, rtol=1e-12)
    assert np.sum(full) == round(t_end / h) and np.all(theirs[~full, 2] <= 2)


def test_steps_past_the_end_or_a_failure_are_skipped_by_blocks():
    """Unbatched, the steps of a chunk are selected, not branched, and blocks of output
    intervals past the run's end (or its failure) are skipped whole
    (``integrate.BLOCK_STEPS``): at most the rest of the last block is computed, as
    negligible frozen steps, and the results are those of the pure ``trajectory``
    (no end, no blocks). M1 at h = 4 ms with 6 Newton iterations and no retries: 15
    steps of a 500-step chunk (blocks of 10 steps); α = 0.02 1/s fails at the 4th
    step (the batch test above), α = 0.03 with a tenth of gravity runs through."""
    import equinox as eqx

    from ancf_jax.integrate import BLOCK_STEPS, FROZEN_STEP
    from ancf_jax.models.m1 import m1_model
    from ancf_jax.simulation import simulate, trajectory

    system, state = m1_model(6).build()
    solver = LOGGED_SOLVER
    h, t_end, steps = 4e-3, 0.06, 15
    for alpha, g, ok in ((0.02, 1.0, False), (0.03, 0.1, True)):
        s = eqx.tree_at(lambda s: (s.beams[0].alpha, s.gravity), system,
                        (jax.numpy.asarray(alpha), g * system.gravity))
        _STEP_LOG.clear()
        res = simulate(s, state, t_end=t_end, dt=h, output_dt=h, options=RunOptions(max_halvings=0),
                       solver=solver, on_failure="return", progress=False)
        log = np.concatenate(_STEP_LOG)
        taken = int(np.sum(np.isclose(log[:, 1], h)))
        frozen = log[taken:]
        np.testing.assert_allclose(log[:taken, 1], h)
        np.testing.assert_allclose(frozen[:, 1], FROZEN_STEP * h)
        assert len(log) % 10 == 0 and len(frozen) < 10 <= BLOCK_STEPS  # up to the end of one block
        if ok:
            assert res.status == "ok" and taken == steps and len(frozen) == 5
            seg, loop = jax.jit(lambda s: trajectory(s, state, solver.forward_only(), t_end=t_end, dt=h))(s)
            np.testing.assert_allclose(res.q, np.asarray(seg.q), rtol=0, atol=1e-12)
        else:
            assert res.status == "newton" and taken == 4 and len(frozen) == 6
            assert np.all(frozen[:, 2] <= 2)  # negligible steps: Newton converges at once
            assert len(res.t) == 4 and np.all(np.isfinite(res.q))


def test_a_sliding_joint_moving_more_than_half_an_element_is_a_failed_step():
    """``sliding_jumped``: a step that moves a sliding coordinate by more than
    ``max_sliding_step`` (0.5) of the element it starts in is taken for a spurious
    Newton solution (M2 at ρ∞ = 0.5, h = 1 ms from rest at s₀ = 0.493 m converged to
    s = 0.710 m in its first step, 0.65 of an element, and then went on oscillating
    until the trolley left the cable; with the check the step is redone in substeps
    and the run is the one at ρ∞ = 0.9). On an uneven track (elements alternate 1:2),
    the bound follows the element the joint starts in, in both directions."""
    from ancf_jax.integrate import RunOptions, sliding_jumped

    track = uneven_arc(8, 1.0, 1.2)
    lengths = np.asarray(track.element_lengths)[:8]
    system, state = track_model(track, 0.5 * lengths[0]).build()  # in element 0 (short)
    q0 = np.asarray(state.q)
    i = system.sliding_offset

    def moved(ds, start=0.5 * lengths[0]):
        old, new = q0.copy(), q0.copy()
        old[i], new[i] = start, start + ds
        return bool(sliding_jumped(system, old, new, RunOptions().max_sliding_step))

    assert RunOptions().max_sliding_step == 0.5
    for sign in (1.0, -1.0):
        assert not moved(sign * 0.49 * lengths[0]) and moved(sign * 0.51 * lengths[0])
    start_long = lengths[0] + 0.5 * lengths[1]  # in element 1, twice as long
    assert not moved(-0.9 * lengths[0], start_long) and moved(-1.1 * lengths[0], start_long)
    # the adaptive (diffrax) path checks single states (no previous step): no jump check
    from ancf_jax.integrate import step_status
    from ancf_jax.failures import Failure
    from ancf_jax.integrators.base import Carry
    z = np.zeros(3)
    lam = np.zeros(system.n_constraints)
    single = Carry(state.t, state.q, state.v, state.q, state.q, lam, z, z)
    assert int(step_status(system, None, single, np.array(True), RunOptions())) == Failure.OK
    # a step status sees the jump (and so do the retries, through step_rejected)
    from ancf_jax.integrate import step_rejected
    for ds, expected in ((0.4, Failure.OK), (0.6, Failure.SLIDING_JUMP)):
        q1 = q0.copy()
        q1[i] += ds * lengths[0]
        moved_state = Carry(state.t, q1, state.v, q1, q1, lam, z, z)
        assert int(step_rejected(system, single, moved_state, np.array(True), RunOptions())) == expected


# ---------------------------------------------------------------------------- chunks
@pytest.mark.parametrize("name", ["generalized-alpha", "rk4", "explicit-euler"])
def test_second_chunk_reuses_the_program(name):
    """The loop state a chunk returns has the types of the one it was given (dtype,
    shape and weak type of every leaf), so a jitted chunk called again with its own
    output reuses its compiled program. A weakly typed initial ``fail_time`` made every
    chunked test run (tests/dynamics.py) trace and compile its chunk twice (8 s for the
    contact bounce of tests/test_moving_loads.py). Traced only (``jax.eval_shape``)."""
    from ancf_jax.integrate import initial_loop, integrate_fixed
    from ancf_jax.simulation import make_solver

    from .dynamics import h1_model

    system, state = h1_model(2).build()
    solver = make_solver(name)
    context = solver.prepare(system)
    loop = jax.eval_shape(lambda: initial_loop(system, solver, state, context))
    out, _ = jax.eval_shape(lambda lp: integrate_fixed(system, solver, lp, context, 1e-3, n_intervals=1,
                                                       substeps=1), loop)

    def types(tree):
        return [(jax.typeof(x).shape, jax.typeof(x).dtype, jax.typeof(x).weak_type) for x in jax.tree.leaves(tree)]

    assert types(out) == types(loop)


@pytest.mark.parametrize("max_halvings", [0, 3])
def test_a_located_run_holds_one_copy_of_the_step(max_halvings, monkeypatch):
    """The step, its retries (max_halvings > 0), the crossing's search and its two
    substeps are passes of one loop (``integrate._located_step``): tracing a located
    run's program traces the integrator's step once (before 2026-12-07 twice: a loop
    for the retries or a plain step, and one for the crossing); a run locating nothing
    traces it once as well."""
    import equinox as eqx
    import jax.numpy as jnp

    from ancf_jax.integrate import initial_loop, integrate_fixed
    system, state = track_model(uneven_arc(4, 1.0, 1.2), S0).build()
    context = RK4().prepare(system)
    loop = jax.eval_shape(lambda: initial_loop(system, RK4(), state, context))  # traced, not run
    calls = []
    step = RK4.step
    monkeypatch.setattr(RK4, "step", lambda self, *a: calls.append(1) or step(self, *a))
    for locate in (True, False):
        calls.clear()
        eqx.filter_make_jaxpr(lambda lp, h: integrate_fixed(
            system, RK4(), lp, context, h, n_intervals=2, substeps=1,
            options=RunOptions(locate_crossings=locate, max_halvings=max_halvings)))(loop, jnp.asarray(0.01))
        assert len(calls) == 1, (locate, len(calls))
