"""Generalized-α with the Newton matrix's factors carried across steps (``AcrossSteps``,
issues 17 and 21) against factoring at every step (``PerStep``).

The model is H1 (tests/dynamics.py: a very flexible pendulum, 4 elements, pinned), the
soft system on which a factorization stays good for many steps, run with the traced-step
runner of tests/dynamics.py (one compiled program per solver).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax.errors import ModelError
from ancf_jax.integrate import NO_RETRIES, RunOptions
from ancf_jax.integrators.base import StepInfo
from ancf_jax.integrators.generalized_alpha import AcrossSteps, GeneralizedAlpha
from ancf_jax.newton import ModifiedNewton

from ..dynamics import _advance, _init, h1_model, run_fixed

H, T_END = 1e-3, 0.3
TOL = ModifiedNewton().tolerance


@pytest.fixture(scope="module")
def h1():
    return h1_model(4).build()


def _run(system, state, solver, h, t_end, chunk=50):
    """(q at every step, status, factorizations of the Newton matrix) of a run of
    ``solver`` (the compiled programs of :func:`tests.dynamics.run_fixed`)."""
    loop, context = _init(system, state, solver)
    qs = [np.asarray(loop.carry.q)[None]]
    for _ in range(int(round(t_end / h)) // chunk):
        loop, seg = _advance(system, solver, loop, context, jnp.asarray(h, float), chunk, NO_RETRIES)
        qs.append(np.asarray(seg.q))
    memory = loop.carry.memory
    return np.concatenate(qs), int(loop.status), None if memory is None else int(memory.factorizations)


def test_reused_factors_reach_the_per_step_solution(h1):
    """Modified Newton converges to the same root with a stale matrix; the runs differ by
    the Newton error. Each solve stops when its correction is below the tolerance
    (1e-10 m) while contracting by at most ``contraction`` = 1/4 per iteration (else the
    matrix is refreshed), so its error is at most tol·ρ/(1 − ρ) = tol/3 m per step; over
    N = 300 steps of a stable system the difference stays below N·tol = 3e-8 m (measured
    on H1: 7.5e-11 m, with 0.063 factorizations per step)."""
    system, state = h1
    per_step, status, _ = _run(system, state, GeneralizedAlpha(), H, T_END)
    reused, status_reused, n_fact = _run(system, state, GeneralizedAlpha(factor_reuse=AcrossSteps(16)), H, T_END)
    steps = round(T_END / H)
    assert status == 0 and status_reused == 0
    diff = np.max(np.abs(reused - per_step))
    assert diff <= steps * TOL, diff
    # the factors were reused: about one factorization per max_age steps
    assert n_fact < 0.25 * steps, n_fact


_LOG = []


def _log(h, h_memory, before, after, converged):
    _LOG.append(np.array([h, h_memory, before, after, converged], float))


class _FailOnce(GeneralizedAlpha):
    """Generalized-α whose steps of the full size H between t = 0.05 and 0.06 s report
    Newton failure (a forced retry in substeps), logging every step it takes."""

    def step(self, system, carry, h, context):
        new, info = super().step(system, carry, h, context)
        forced = (jnp.abs(h - H) < 1e-12) & (carry.t > 0.05 - 1e-9) & (carry.t < 0.06 - 1e-9)
        jax.debug.callback(_log, h, carry.memory.h, carry.memory.factorizations,
                           new.memory.factorizations, info.converged & ~forced)
        return new, StepInfo(info.iterations, info.converged & ~forced)


def test_factors_are_refreshed_when_the_step_size_changes(h1):
    """Forced retries: the failed full steps are redone as two half steps, and the step
    grows back to H. Every step whose size differs from that of the factors it is given
    (a retry, the return to H, the first step) factors anew and leaves factors of its own
    size; steps of the same size mostly reuse them."""
    system, state = h1
    _LOG.clear()
    run = run_fixed(system, state, _FailOnce(factor_reuse=AcrossSteps(16)), H, 0.1,
                    options=RunOptions(max_halvings=2))
    jax.effects_barrier()
    log = np.array(_LOG)
    assert run.status == 0
    h, h_mem, before, after = log[:, 0], log[:, 1], log[:, 2], log[:, 3]
    changed = ~(h == h_mem)  # NaN: the first step
    assert np.sum(np.isclose(h, H / 2)) >= 20  # ten forced retries, two half steps each
    assert np.all(after[changed] > before[changed])
    assert np.sum(after[~changed] > before[~changed]) < 0.2 * np.sum(~changed)  # mostly reused
    # the retried steps were completed: the run reached 0.1 s at the output steps
    np.testing.assert_allclose(run.t, H * np.arange(len(run.t)), rtol=0, atol=1e-12)


def test_gradient_with_reused_factors_equals_central_differences(h1):
    """d(tip y at 0.05 s)/d(I) by reverse mode through ``trajectory`` with reused
    factors: the tangent systems are those of the converged steps (implicit function
    theorem, each factored at its initial iterate as without reuse), so the gradient
    equals central differences of the run itself (same compiled program; Newton
    tolerance 1e-12 so that the differences over δ = 1e-4 relative see no Newton noise;
    truncation O(δ²)). Measured: 5e-10 relative."""
    from ancf_jax.simulation import trajectory
    system, state = h1

    def tip_y(scale, reuse):
        sys = eqx.tree_at(lambda s: s.beams[0].section.second_moment, system,
                          system.beams[0].section.second_moment * scale)
        solver = GeneralizedAlpha(root_finder=ModifiedNewton(tolerance=1e-12), factor_reuse=reuse)
        seg, loop = trajectory(sys, state, solver, t_end=0.05, dt=H)
        return seg.q[-1, -3], loop.status

    reused = jax.jit(jax.value_and_grad(lambda s: tip_y(s, AcrossSteps(16))[0]))
    _, grad = reused(1.0)
    d = 1e-4
    fd = (reused(1.0 + d)[0] - reused(1.0 - d)[0]) / (2 * d)
    assert abs(grad) > 0
    assert abs(grad - fd) <= 1e-6 * abs(grad), (grad, fd)


def test_memory_is_kept_by_checkpoints_and_set_by_flat_options(h1):
    """A checkpoint file holds the factor memory as its leaves (``checkpoint_memory_i``):
    ``resume`` rebuilds it for the same solver, starts fresh where it does not fit, and
    drops it for a solver that keeps none; the flat option ``reuse_factors`` (scenario
    key, ``make_solver``) is ``AcrossSteps(max_age)``."""
    from ancf_jax.simulation import make_solver
    system, state = h1
    solver = GeneralizedAlpha(factor_reuse=AcrossSteps(4))
    context = solver.prepare(system)
    carry = eqx.filter_jit(solver.init)(system, state, context)  # op by op: ~180 one-operation programs
    marked = jax.tree.map(lambda a: a + 1, carry.memory)
    leaves = tuple(np.asarray(a) for a in jax.tree.leaves(marked))
    kept = solver.resume(system, eqx.tree_at(lambda c: c.memory, carry, leaves), context)
    assert jax.tree.structure(kept.memory) == jax.tree.structure(carry.memory)
    assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(jax.tree.leaves(kept.memory), leaves))
    fresh = solver.resume(system, eqx.tree_at(lambda c: c.memory, carry, leaves[:-1]), context)
    assert np.isnan(fresh.memory.h) and int(fresh.memory.factorizations) == 0
    assert GeneralizedAlpha().resume(system, carry, context).memory is None
    assert make_solver("generalized-alpha", reuse_factors=8).factor_reuse == AcrossSteps(8)
    assert isinstance(make_solver("generalized-alpha").factor_reuse, type(GeneralizedAlpha().factor_reuse))


def test_max_age_must_be_a_positive_integer():
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ModelError, match="max_age must be an integer >= 1"):
            AcrossSteps(bad)


def test_a_discarded_step_keeps_its_factors_marked_invalid(h1):
    """``select_carry`` (the run loop's choice between a step's result and the state
    before it) takes every field of the kept carry, except that the factor memory is
    the newest one whichever is kept (never copied by a select), marked invalid (h NaN,
    so the next step factors anew) when the step is discarded; its age and count are
    those of the kept carry."""
    from ancf_jax.integrators.base import select_carry
    system, state = h1
    solver = GeneralizedAlpha(factor_reuse=AcrossSteps(4))
    context = solver.prepare(system)
    old = solver.init(system, state, context)
    new, _ = solver.step(system, old, H, context)
    assert int(new.memory.factorizations) == 1 and float(new.memory.h) == H
    for keep, kept in ((True, new), (False, old)):
        c = select_carry(jnp.asarray(keep), new, old)
        for a, b in zip(jax.tree.leaves(eqx.tree_at(lambda x: x.memory, c, None)),
                        jax.tree.leaves(eqx.tree_at(lambda x: x.memory, kept, None))):
            np.testing.assert_array_equal(a, b)
        assert all(np.array_equal(a, b) for a, b in zip(jax.tree.leaves(c.memory.factors),
                                                         jax.tree.leaves(new.memory.factors)))
        assert int(c.memory.age) == int(kept.memory.age)
        assert int(c.memory.factorizations) == int(kept.memory.factorizations)
        assert (float(c.memory.h) == H) if keep else np.isnan(c.memory.h)
    # a carry without memory: every field selected
    plain = GeneralizedAlpha()
    p_old = plain.init(system, state, context)
    p_new, _ = plain.step(system, p_old, H, context)
    c = select_carry(jnp.asarray(False), p_new, p_old)
    assert c.memory is None and np.array_equal(c.q, p_old.q)


def test_a_continued_run_with_reused_factors_is_within_the_newton_tolerance(h1):
    """A run that ends inside a block of steps takes its last, frozen steps without
    keeping their factors (marked invalid, never copied: ``select_carry``), so a run
    continued from its checkpoint factors anew at its first step: it equals the
    uninterrupted run to the Newton error (≤ tol·ρ/(1 − ρ) per step, N·tol over N
    steps; measured 2.3e-13 m), where with ``PerStep`` it is bit for bit
    (tests/test_cli_models.py; measured 0 here too)."""
    from ancf_jax.simulation import simulate
    system, state = h1
    solver = GeneralizedAlpha(factor_reuse=AcrossSteps(16))
    kw = dict(dt=H, solver=solver, progress=False)
    one = simulate(system, state, t_end=53 * H, **kw)
    first = simulate(system, state, t_end=27 * H, **kw)
    assert np.isnan(float(first.checkpoint.carry.memory.h))  # 27 steps end inside a block
    second = simulate(system, first.checkpoint, t_end=26 * H, **kw)
    assert one.status == first.status == second.status == "ok"
    np.testing.assert_allclose(second.t[-1], one.t[-1], rtol=0, atol=1e-12)
    assert np.max(np.abs(second.q[-1] - one.q[-1])) <= 53 * TOL
