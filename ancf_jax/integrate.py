"""The jittable time loop of the fixed-step integrators.

:func:`integrate_fixed` advances a system with a one-step method
(:mod:`ancf_jax.integrators`) over ``n_intervals`` output intervals of ``substeps``
steps each, checks every step for failure, and returns what it computed. It is a pure
function of arrays: ``jax.jit``, ``jax.vmap`` (batches of systems with identical
structure, e.g. padded meshes of different element counts) and ``jax.grad`` pass
through it.

Failures (:class:`ancf_jax.failures.Failure`, checked here and nowhere else): a
non-finite state (NAN), a
Newton solve that did not converge (NEWTON), a constraint violation max|Φ| above
``drift_tolerance`` (DRIFT), a sliding coordinate outside its beam (LEFT_BEAM), a
sliding coordinate that moved more than ``max_sliding_step`` of an element in one step,
i.e. a spurious Newton solution (SLIDING_JUMP; retried in substeps like a Newton
failure). After
the first failure the state is frozen at the last good step and the failure time is
recorded; :mod:`ancf_jax.simulation` turns that into an error. The outcome of an
adaptive (diffrax) solve maps to a failure here too (:func:`adaptive_failure`).

Node crossings of sliding joints and kinks of force laws. The curvature of the cubic
interpolation jumps at nodes, so the acceleration and the joint reaction jump when a
sliding joint crosses one; the stiffness of a one-sided spring-damper jumps from 0 to k
when it goes taut (:func:`ancf_jax.forces.kink_values`). A fixed step that straddles
such a point loses order; sliding friction's force swings from ∓μN to ±μN within a
few v_ε where the sliding speed reverses. With ``locate_crossings=True`` a step that changes the
element of a sliding coordinate, or the sign of a kink value, is split at the first of
them: the crossing fraction θ is found by regula falsi (Illinois) on
θ ↦ g(step(θ h)) − g*, g the sliding coordinate (g* just past the node) or the kink
value (g* just before 0, :data:`KINK_MARGIN`), and the step is completed from there.
(Crossing location and step retries are solver internals written as while
loops; gradients by reverse mode need both off, which is the default of
:func:`ancf_jax.simulation.trajectory`.) The crossing search is written here rather
than taken from optimistix: its only bracketing root finder is bisection, which gains
one bit per iteration, and every iteration is a full implicit step; Illinois reaches
the node to a fraction 1e-9 of an element in ~6.

Node crossings of moving forces and contact points (``locate_load_nodes``,
:func:`ancf_jax.forces.node_crossing_values`) are located like kinks when asked for,
not with ``locate_crossings``: those forces are C¹ in time there (docs/moving-loads.md
measures under 1 % of a run's error), and every located crossing costs
``crossing_iterations`` + 2 extra steps (the search's steps and the two substeps).
"""

from __future__ import annotations

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .errors import ModelError
from .failures import Failure
from .forces import has_kinks, has_node_crossings, kink_values, node_crossing_values
from .integrators.base import AbstractIntegrator, Carry, StepInfo, select_carry
from ._control import reached_by, traced_once
from .joints import SlidingJoint
from .system import State, System
from .validation import check_count, check_positive


#: default fixed step [s] of a run (simulate, the scenario format, the CLI): M1 and M2
#: at their validated settings (docs/theory.md, "Defaults from measurements")
DEFAULT_DT = 1e-3

#: default number of step halvings of a run (:class:`RunOptions`; the pure core
#: :func:`~ancf_jax.simulation.trajectory` runs without retries, :data:`NO_RETRIES`)
DEFAULT_HALVINGS = 6

#: most time steps a run takes unless asked for more (:class:`RunLimits`, ``--max-steps``)
MAX_STEPS = 50_000_000
#: most output a run keeps in memory unless asked for more (:class:`RunLimits`) [bytes]
MAX_OUTPUT_BYTES = 4 * 2**30

#: a located kink of a force law ends the first substep this fraction of the step's
#: change of the kink value before the kink. A damped one-sided member's force jumps by
#: c σℓ̇ when it engages, and implicit steps ending within ~(jump/m)·(θh)² of the jump
#: have no solution (Newton fails: measured on tests/test_cable_machinery.py's rope, a
#: band of 4e-7 m at h = 1 ms); the margin grows with h, the band with h², so a large
#: enough step will land in the band (measured without failure at h = 4 to 0.25 ms).
#: Measured effect on the undamped rope's error against the exact answer: orders 2.05,
#: 2.07, 2.00 at h = 4 to 0.5 ms (1e-3: 1.99, 2.02, 1.97)
KINK_MARGIN = 1e-2


class RunOptions(eqx.Module):
    """Options of the time loop (static: they shape the compiled program). Their
    defaults are the defaults of :func:`~ancf_jax.simulation.simulate`, the scenario
    format and the CLI.

    Attributes:
        drift_tolerance: largest accepted constraint violation max|Φ| [m] (and rad), > 0.
        locate_crossings: split steps at node crossings of sliding joints, at
            slack/taut transitions of one-sided spring-dampers and contacts, and at
            reversals of sliding friction.
        locate_load_nodes: also split steps where a moving force's point or a closed
            contact's point crosses an interior node of its beam: their forces are C¹
            there, and locating them changes a run's error by under 1 %
            (docs/moving-loads.md), so it is off.
        crossing_iterations: regula-falsi iterations to locate a crossing (1..50).
        max_halvings: when a step fails (Newton not converged, non-finite state,
            sliding jump), redo it in substeps, halving down to h / 2^max_halvings and
            growing back after successes (0..30; 0: no retries; a ``while_loop``, so
            reverse-mode differentiation needs 0: :data:`NO_RETRIES`).
        max_sliding_step: largest move of a sliding coordinate in one step, as a
            fraction of the length of the element it starts in (> 0); a larger move is
            taken for a spurious Newton solution (SLIDING_JUMP), retried like a failed
            step.

    Raises:
        ModelError: a value out of its range (on construction).
    """

    drift_tolerance: float = eqx.field(static=True, default=1e-6)
    max_sliding_step: float = eqx.field(static=True, default=0.5)
    locate_crossings: bool = eqx.field(static=True, default=False)
    locate_load_nodes: bool = eqx.field(static=True, default=False)
    crossing_iterations: int = eqx.field(static=True, default=6)
    max_halvings: int = eqx.field(static=True, default=DEFAULT_HALVINGS)

    def __check_init__(self):
        check_positive("drift_tolerance", self.drift_tolerance, "m")
        check_positive("max_sliding_step", self.max_sliding_step, "element lengths")
        for name in ("locate_crossings", "locate_load_nodes"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ModelError(f"{name} must be true or false, got {getattr(self, name)!r}")
        check_count("crossing_iterations", self.crossing_iterations, 1, 50)
        check_count("max_halvings", self.max_halvings, 0, 30)


#: options of the pure, differentiable core (:func:`~ancf_jax.simulation.trajectory`,
#: :func:`integrate_fixed`): no retries in substeps (a ``while_loop``, which
#: reverse-mode autodiff cannot pass); the other options as :class:`RunOptions`
NO_RETRIES = RunOptions(max_halvings=0)


class RunLimits(eqx.Module):
    """Host-side limits of a run: checked before anything is compiled, and the size of
    the compiled calls the host loop makes.

    Attributes:
        max_steps: most time steps accepted (integer >= 1): a longer run is refused
            before anything is compiled (:func:`~ancf_jax.simulation.check_run_size`).
        max_output_bytes: most output kept in memory [bytes] (> 0).
        chunks: number of compiled calls the run is split into (integer >= 1; progress,
            Ctrl-C and early stop act between them). None: calls of about
            :data:`~ancf_jax.simulation.STEPS_PER_CHUNK` steps, so that runs of any
            length share one compiled program.

    Raises:
        ModelError: a value out of its range (on construction).
    """

    max_steps: int = MAX_STEPS
    max_output_bytes: float = MAX_OUTPUT_BYTES
    chunks: int | None = None

    def __check_init__(self):
        check_count("max_steps", self.max_steps, 1)
        check_positive("max_output_bytes", self.max_output_bytes, "bytes")
        if self.chunks is not None:
            check_count("chunks", self.chunks, 1)


class Segment(eqx.Module):
    """Outputs of :func:`integrate_fixed` (leading axis: output intervals).

    Attributes:
        t: times at the end of every interval [s].
        q: coordinates at the end of every interval (see :class:`Carry`).
        v: velocities.
        acc: accelerations.
        lam: Lagrange multipliers.
        work: work integrals [J].
        iterations: Newton iterations in the interval (sum over steps).
        max_iterations: largest Newton iteration count of a step in the interval.
        crossings: node crossings and kinks located in the interval.
    """

    t: jnp.ndarray
    q: jnp.ndarray
    v: jnp.ndarray
    acc: jnp.ndarray
    lam: jnp.ndarray
    work: jnp.ndarray
    iterations: jnp.ndarray
    max_iterations: jnp.ndarray
    crossings: jnp.ndarray


class LoopState(eqx.Module):
    """Carry of the time loop: integrator carry plus failure bookkeeping."""

    carry: Carry
    status: jnp.ndarray
    fail_time: jnp.ndarray


def sliding_beams(system: System) -> dict[int, int]:
    """Beam index of every sliding coordinate (from the sliding joints)."""
    out = {}
    for c in system.constraints:
        if isinstance(c, SlidingJoint):
            out.setdefault(c.sliding, c.beam)
    return out


def sliding_jumped(system: System, q_old, q_new, max_step: float):
    """True if a sliding coordinate moved more than ``max_step`` times the length of
    the element it started in during one step.

    A step that moves a joint that far is not a usable step (the node-crossing logic
    assumes at most one crossing per step); in practice it is a spurious Newton
    solution with the joint elsewhere on the cable (measured: M2, 12 elements of
    0.335 m, ρ∞ = 0.5, h = 1 ms, trolley at rest at s₀ = 0.493 m: s = 0.710 m after the
    first step, 0.65 of an element, and the run went on oscillating until the joint
    left the beam). Such a step counts as failed: redone in substeps like a Newton
    failure, or reported as SLIDING_JUMP."""
    out = jnp.array(False)
    for j, b in sliding_beams(system).items():
        s0, s1 = system.sliding(q_old, j), system.sliding(q_new, j)
        mesh = system.beams[b].mesh
        k, _ = mesh.locate(s0)
        out = out | (jnp.abs(s1 - s0) > max_step * mesh.element_lengths[k])
    return out


#: most steps in a block of output intervals that :func:`integrate_fixed` skips as a
#: whole past its ``t_stop`` (a conditional per block, not per step: steps past
#: ``t_stop`` inside the last block are computed as frozen steps and discarded)
BLOCK_STEPS = 16

#: step of a frozen batch member, relative to h (see integrate_fixed)
FROZEN_STEP = 1e-6


def step_rejected(system: System, old: Carry | None, new: Carry, converged, options: RunOptions):
    """:class:`~ancf_jax.failures.Failure` of a step the solver failed to take (OK if
    none): non-finite state (NAN), Newton not converged (NEWTON), spurious jump of a
    sliding joint (SLIDING_JUMP), i.e. the ``retryable`` failures.
    These are the failures a smaller step can cure (``_step_with_retries``). ``old``
    None checks ``new`` alone (no jump check: the adaptive diffrax solvers have no
    step to compare)."""
    finite = (jnp.all(jnp.isfinite(new.q)) & jnp.all(jnp.isfinite(new.v))
              & jnp.all(jnp.isfinite(new.lam)))
    code = jnp.where(finite, Failure.OK, Failure.NAN)
    code = jnp.where((code == Failure.OK) & ~converged, Failure.NEWTON, code)
    if sliding_beams(system) and old is not None:
        code = jnp.where((code == Failure.OK) & sliding_jumped(system, old.q, new.q, options.max_sliding_step),
                         Failure.SLIDING_JUMP, code)
    return code


def step_status(system: System, old: Carry | None, new: Carry, converged, options: RunOptions):
    """:class:`~ancf_jax.failures.Failure` of a step (OK if none): :func:`step_rejected`,
    then a constraint violation above ``drift_tolerance`` (DRIFT) and a sliding joint off
    its beam (LEFT_BEAM)."""
    code = step_rejected(system, old, new, converged, options)
    if system.n_constraints:
        viol = jnp.max(jnp.abs(system.constraint(new.q, new.t)))
        code = jnp.where((code == Failure.OK) & ~(viol <= options.drift_tolerance), Failure.DRIFT, code)
    for j, b in sliding_beams(system).items():
        s = system.sliding(new.q, j)
        length = system.beams[b].mesh.length
        out = (s < 0.0) | (s > length)
        code = jnp.where((code == Failure.OK) & out, Failure.LEFT_BEAM, code)
    return code


#: the :class:`~ancf_jax.failures.Failure` of each outcome of a diffrax solve (by the
#: name of its ``diffrax.RESULTS`` member); any other outcome (a failed linear or
#: nonlinear solve inside the solver) is ADAPTIVE
ADAPTIVE_FAILURES = {"successful": Failure.OK, "event_occurred": Failure.OK,
                     "max_steps_reached": Failure.MAX_STEPS, "max_steps_rejected": Failure.MAX_STEPS,
                     "dt_min_reached": Failure.STEP_SIZE, "nonfinite": Failure.NAN,
                     "nonfinite_input": Failure.NAN}


def adaptive_failure(result):
    """:class:`~ancf_jax.failures.Failure` code (traced int) of a diffrax solve's
    ``result`` (a ``diffrax.RESULTS`` item): :data:`ADAPTIVE_FAILURES`, else ADAPTIVE."""
    code = jnp.asarray(Failure.ADAPTIVE)
    for name, failure in ADAPTIVE_FAILURES.items():
        code = jnp.where(result == getattr(diffrax.RESULTS, name), failure, code)
    return code


def _retry_next(system, options, h, h_min, c, done, h_try, new, info, dt, active=True):
    """The rule of a step's retries after one attempt ``new`` of size dt from c
    (:func:`_step_with_retries`; ``active``: where the attempt counts as one): kept if
    not rejected (:func:`step_rejected`), the next attempt twice as long after a success
    (up to h) and half as long after a failure, down to h_min. Returns (the attempt's
    rejection code, kept?, c, done, next size, whether to go on)."""
    code = step_rejected(system, c, new, info.converged, options)
    good = code == Failure.OK
    taken = active & good
    h_next = jnp.where(good, jnp.minimum(2.0 * h_try, h), 0.5 * h_try)
    ok = good | (0.5 * h_try >= h_min * (1.0 - 1e-12))
    return code, taken, select_carry(taken, new, c), jnp.where(taken, done + dt, done), h_next, ok


def _retry_rule(system, options, h, h_min, c, first, done, h_try, attempt, new, info, dt, active=True):
    """:func:`_retry_next` keeping the first attempt ``first``: the located step
    (:func:`_located_step`) reads its watched values and, where the retries run out,
    returns it as the step (its status and failure time). Returns (first attempt?,
    kept?, first, c, done, next size, whether to go on)."""
    _, taken, c, done, h_next, ok = _retry_next(system, options, h, h_min, c, done, h_try, new, info, dt, active)
    first_try = active & (attempt == 0)
    return first_try, taken, select_carry(first_try, new, first), c, done, h_next, ok


def _located(system, options):
    """(sliding joints' beams, kinks located, node crossings of loads located) of the
    crossing search (module doc); all empty/False: nothing is located."""
    slides = sliding_beams(system) if options.locate_crossings else {}
    kinked = options.locate_crossings and has_kinks(system)
    nodes_of_loads = options.locate_load_nodes and has_node_crossings(system)
    return slides, kinked, nodes_of_loads


def _located_step(system, integrator, carry, h, context, options):
    """One step of size h (with retries in substeps where ``options.max_halvings`` > 0,
    as :func:`_step_with_retries`), split at the first node crossing of a sliding joint
    or kink of a force law (module doc) that it straddles.

    One while loop holds the only copy of the integrator's step in the compiled program
    (a loop for the retries and another for the crossing, each with its step, doubled
    the program): every pass takes one step. First the step and its retries, from the
    start of the step or the last good substep; then, where the step's outcome (the
    completed step, or its first attempt if the retries ran out) straddles a crossing,
    the regula-falsi search (steps θh from the start) and the two substeps, θh from the
    start and (1 − θ)h from the end of the first.

    Returns (carry, StepInfo, crossed) for the completed step of size h."""
    slides, kinked, nodes_of_loads = _located(system, options)
    js = list(slides)

    def values(c):
        """The watched values g: sliding coordinates, then kink values, then node
        crossings of moving loads (each group only where it is located)."""
        parts = [jnp.stack([system.sliding(c.q, j) for j in js])] if js else []
        parts += [kink_values(system, c.q, c.v)] if kinked else []
        parts += [node_crossing_values(system, c.q, c.v, c.t)] if nodes_of_loads else []
        return jnp.concatenate(parts)

    def crossing(g0, g1):
        """(target values, crossed, before a kink) of the watched values over a step."""
        targets, crossings, kinks = [], [], []
        if js:
            s0, s1 = g0[:len(js)], g1[:len(js)]
            k0 = jnp.stack([system.beams[slides[j]].mesh.locate(s0[i])[0] for i, j in enumerate(js)])
            k1 = jnp.stack([system.beams[slides[j]].mesh.locate(s1[i])[0] for i, j in enumerate(js)])
            nodes = jnp.stack([system.beams[slides[j]].mesh.node_arc_lengths[
                jnp.where(k1[i] > k0[i], k0[i] + 1, k0[i])] for i, j in enumerate(js)])
            lengths = jnp.stack([system.beams[slides[j]].mesh.element_lengths[k0[i]] for i, j in enumerate(js)])
            targets.append(nodes + jnp.sign(s1 - s0) * 1e-9 * lengths)
            crossings.append(k0 != k1)
            kinks.append(jnp.zeros(len(js), bool))
        if kinked or nodes_of_loads:
            # kinks and node crossings of moving loads alike
            e0, e1 = g0[len(js):], g1[len(js):]
            # just before the kink (KINK_MARGIN): the first substep ends on the side where
            # the law is smooth; the second straddles the kink by that margin. A value
            # exactly zero at the start (a rope just taut) is no crossing.
            targets.append(-jnp.sign(e1) * KINK_MARGIN * jnp.abs(e1 - e0))
            crossings.append(e0 * e1 < 0.0)
            kinks.append(jnp.ones(e0.shape, bool))
        return jnp.concatenate(targets), jnp.concatenate(crossings), jnp.concatenate(kinks)

    n_iter = options.crossing_iterations
    retries = options.max_halvings > 0
    h_min = h / 2.0**options.max_halvings
    g0 = values(carry)
    zero = jnp.zeros((), jnp.asarray(h).dtype)
    zg = jnp.zeros((), g0.dtype)  # the search's fractions and watched values
    zi = jnp.zeros((), jnp.int32)
    yes, no = jnp.array(True), jnp.array(False)
    # phase 0: the step and its retries; 1: the crossing's search and substeps; 2: done
    init = dict(phase=zi, c=carry, first=carry, g_c=g0, g_first=g0, done=zero, h_try=h + zero, attempt=zi,
                iters=zi, step=carry, step_iters=zi, step_conv=yes, crossed=no,
                idx=zi, tgt=zg, before=no, k=zi, a=zg, b=zg + 1.0, fa=zg, fb=zg, side=zi,
                theta=zg + 0.5, mid=carry, out=carry, sub_iters=zi, sub_conv=yes)

    def body(st):
        searching = st["phase"] == 1
        k = st["k"]
        bracketing = k < n_iter
        second = k > n_iter
        a, b, fa, fb, side = st["a"], st["b"], st["fa"], st["fb"], st["side"]
        # Illinois regula falsi on θ ∈ (0, 1) (f(0) and f(1) bracket the root), then the
        # best end of the bracket (for a kink: the end before it, a, see above) and the
        # two substeps θh and (1 − θ)h
        theta_rf = jnp.clip((a * fb - b * fa) / jnp.where(fb != fa, fb - fa, 1.0), 1e-6, 1 - 1e-6)
        theta_best = jnp.clip(jnp.where((jnp.abs(fa) < jnp.abs(fb)) | st["before"], a, b), 1e-6, 1.0 - 1e-6)
        theta = jnp.where(bracketing, theta_rf, jnp.where(k == n_iter, theta_best, st["theta"]))
        start = select_carry(searching, select_carry(second, st["mid"], carry), st["c"])
        dt = jnp.where(searching, jnp.where(second, 1.0 - theta, theta) * h,
                       jnp.where(st["phase"] == 0, jnp.minimum(st["h_try"], h - st["done"]), FROZEN_STEP * h))
        new, info = integrator.step(system, start, dt, context)
        g_new = values(new)
        out = dict(st)

        # phase 0: the step, redone in substeps after a failure (_step_with_retries)
        stepping = st["phase"] == 0
        keep0 = lambda x, old: jnp.where(stepping, x, old)  # noqa: E731
        first_try, taken, first, c, done, h_next, ok = _retry_rule(
            system, options, h, h_min, st["c"], st["first"], st["done"], st["h_try"], st["attempt"], new, info, dt,
            active=stepping)
        out.update(first=first, g_first=jnp.where(first_try, g_new, st["g_first"]),
                   c=c, g_c=jnp.where(taken, g_new, st["g_c"]), done=done, h_try=keep0(h_next, st["h_try"]),
                   iters=keep0(st["iters"] + info.iterations, st["iters"]), attempt=keep0(st["attempt"] + 1, st["attempt"]))
        completed = out["done"] >= h * (1.0 - 1e-12)
        ended = stepping & ~(ok & ~completed)
        # the step (completed, or its first attempt where the retries ran out: its status
        # and failure time) and where it straddles a crossing
        step = select_carry(completed, out["c"], out["first"])
        g1 = jnp.where(completed, out["g_c"], out["g_first"])
        target, crossed, before = crossing(g0, g1)
        idx = jnp.argmin(jnp.where(crossed, jnp.clip((target - g0) / jnp.where(g1 != g0, g1 - g0, 1.0), 0.0, 1.0),
                                   2.0)).astype(jnp.int32)
        tgt = target[idx]
        keep_e = lambda x, old: jnp.where(ended, x, old)  # noqa: E731
        out.update(step=select_carry(ended, step, st["step"]), step_iters=keep_e(out["iters"], st["step_iters"]),
                   step_conv=keep_e(completed if retries else info.converged, st["step_conv"]),
                   crossed=keep_e(jnp.any(crossed), st["crossed"]), idx=keep_e(idx, st["idx"]),
                   tgt=keep_e(tgt, st["tgt"]), before=keep_e(before[idx], st["before"]),
                   fa=keep_e(g0[idx] - tgt, fa), fb=keep_e(g1[idx] - tgt, fb))

        # phase 1: the crossing's search and substeps
        ft = g_new[st["idx"]] - st["tgt"]
        same_b = jnp.sign(ft) == jnp.sign(fb)
        a2, fa2 = jnp.where(same_b, a, theta), jnp.where(same_b, fa, ft)
        b2, fb2 = jnp.where(same_b, theta, b), jnp.where(same_b, ft, fb)
        fa2 = jnp.where(same_b & (side == 1), 0.5 * fa2, fa2)
        fb2 = jnp.where(~same_b & (side == -1), 0.5 * fb2, fb2)
        move = searching & bracketing
        keep1 = lambda x, old: jnp.where(searching, x, old)  # noqa: E731
        sub = searching & ~bracketing
        out.update(a=jnp.where(move, a2, a), b=jnp.where(move, b2, b), side=jnp.where(move, jnp.where(same_b, 1, -1), side),
                   theta=keep1(theta, st["theta"]), mid=select_carry(searching & (k == n_iter), new, st["mid"]),
                   out=select_carry(searching & second, new, st["out"]),
                   sub_iters=st["sub_iters"] + jnp.where(sub, info.iterations, 0).astype(jnp.int32),
                   sub_conv=st["sub_conv"] & (~sub | info.converged), k=keep1(k + 1, k))
        out["fa"] = jnp.where(move, fa2, out["fa"])
        out["fb"] = jnp.where(move, fb2, out["fb"])
        phase = jnp.where(ended, jnp.where(out["crossed"], 1, 2),
                          jnp.where(searching & (k + 1 >= n_iter + 2), 2, st["phase"]))
        out["phase"] = phase.astype(jnp.int32)
        return out

    st = jax.lax.while_loop(lambda st: st["phase"] < 2, body, init)
    crossed = st["crossed"]
    result = select_carry(crossed, st["out"], st["step"])
    return result, StepInfo(st["step_iters"] + st["sub_iters"], jnp.where(crossed, st["sub_conv"], st["step_conv"])), crossed


def _step_with_retries(system, integrator, carry, h, context, options):
    """One step of size h, redone as a sequence of smaller steps if it fails
    (:func:`step_rejected`: NaN, Newton not converged, sliding jump): the step is
    halved after a failure and doubled again (up to h) after a success, down to
    h / 2^max_halvings (see RunOptions).

    One while loop holds the only copy of the integrator's step in the compiled
    program (a separate first attempt would double the compile time); under vmap only
    the members that need more substeps keep working. If the step cannot be completed,
    the failure is reported for the first attempt (size h): NAN where that attempt was
    not finite, else NEWTON, at its end t + h. The loop carries that attempt's rejection
    code, not its state (a second carry in the loop: M1's step ran 505 XLA kernels with
    it, 488 without, the difference copies and selects of the carry).
    Not reverse-differentiable (a while loop): ``trajectory`` runs with
    ``max_halvings = 0``.

    Returns (carry, StepInfo, code): the completed step, or where it could not be
    completed the last substep kept (or ``carry``) with converged False; code: the
    first attempt's :func:`step_rejected` code.
    """
    h_min = h / 2.0**options.max_halvings

    def cond(st):
        _, _, done, _, _, ok, _ = st
        return ok & (done < h * (1.0 - 1e-12))

    def body(st):
        c, first_code, done, h_try, iters, _, attempt = st
        # under vmap the passes go on while any member needs one: a member done with its
        # step, or out of retries, takes a negligible one (discarded), not one of size
        # h − done = 0 (non-finite) or its failing one again (a full Newton loop)
        dt = jnp.where(cond(st), jnp.minimum(h_try, h - done), FROZEN_STEP * h)
        new, info = integrator.step(system, c, dt, context)
        code, _, c, done, h_next, ok = _retry_next(system, options, h, h_min, c, done, h_try, new, info, dt)
        first_code = jnp.where(attempt == 0, code, first_code)
        return c, first_code, done, h_next, iters + info.iterations, ok, attempt + 1

    zero = jnp.zeros((), jnp.asarray(h).dtype)
    c, first_code, done, _, iters, _, _ = jax.lax.while_loop(
        cond, body, (carry, jnp.asarray(Failure.OK), zero, h + zero, jnp.zeros((), jnp.int32),
                     jnp.ones((), bool), jnp.zeros((), jnp.int32)))
    completed = done >= h * (1.0 - 1e-12)
    return c, StepInfo(iters, completed), first_code


#: one step, traced once per program (:func:`~ancf_jax._control.traced_once`): the
#: loops' passes under ``jvp`` and ``vmap`` transform its cached jaxpr
_step = traced_once(lambda integrator, system, carry, h, context: integrator.step(system, carry, h, context))


def integrate_fixed(system: System, integrator: AbstractIntegrator, loop: LoopState, context,
                    h, *, n_intervals: int, substeps: int, options: RunOptions = NO_RETRIES,
                    t_stop=None):
    """Advance ``loop`` by ``n_intervals`` × ``substeps`` steps of size h.

    Steps that would start at or after ``t_stop`` [s] (None: no limit) are not taken, so
    a run split into equal chunks ends exactly at its end time, and neither are the
    steps after a failure (the state stays frozen). Unbatched, blocks of output
    intervals (up to :data:`BLOCK_STEPS` steps) past that point are skipped by one
    conditional; within a block every step is computed and kept only while the run is
    active. Returns (final LoopState, Segment with one entry per interval).
    Jittable and vmappable; n_intervals and substeps are static.

    Why steps are selected, not branched: a conditional around every step costs 3 µs
    of M1's 36 µs step unbatched, and reverse mode keeps, and copies out of it, every
    residual of the step through both branches (M1's value and gradient ran 1.8x
    slower, ``benchmarks.gradient``); under vmap it was a select anyway.
    """

    def one_step(c, _):
        loop, iters, maxit, ncross = c
        active = loop.status == Failure.OK
        if t_stop is not None:  # past it: the rest of the last block, and batch members
            active = active & (loop.carry.t < t_stop - 0.5 * h)
        # A member that has failed or finished still computes a step, whose result is discarded. It
        # takes a negligible step (h · FROZEN_STEP from its last good state, where Newton
        # converges at once), so it does not keep a batch's Newton and retry loops
        # running (a failed member repeating its failing step made every later step run
        # the full retry ladder).
        hs = jnp.where(active, h, FROZEN_STEP * h)
        first_code = None  # the retry loop's first attempt, where it ran out of retries
        if any(_located(system, options)):
            new2, info, crossed = _located_step(system, integrator, loop.carry, hs, context, options)
        elif options.max_halvings:
            new2, info, first_code = _step_with_retries(system, integrator, loop.carry, hs, context, options)
            crossed = False
        else:
            (new2, info), crossed = _step(integrator, system, loop.carry, hs, context), False
        it = info.iterations
        conv = info.converged
        code = step_status(system, loop.carry, new2, conv, options)
        t_end = new2.t
        if first_code is not None:
            # a step not completed fails as its first attempt (size h), at that attempt's
            # end: NAN where it was not finite, else NEWTON (the step could not be
            # completed), as the located step (_located_step) reports it
            code = jnp.where(conv, code, jnp.where(first_code == Failure.NAN, Failure.NAN, Failure.NEWTON))
            t_end = jnp.where(conv, t_end, loop.carry.t + hs)
        ok = active & (code == Failure.OK)
        carry = select_carry(ok, new2, loop.carry)
        nl = LoopState(carry, jnp.where(active, code, loop.status),
                       jnp.where(ok | ~active, loop.fail_time, t_end))
        it = jnp.where(active, it, 0)
        return (nl, iters + it, jnp.maximum(maxit, it), ncross + (active & crossed).astype(jnp.int32)), None

    def steps(loop):
        zero = jnp.zeros((), jnp.int32)
        (loop, iters, maxit, ncross), _ = jax.lax.scan(one_step, (loop, zero, zero, zero), None,
                                                       length=substeps)
        return loop, iters, maxit, ncross

    def interval(loop, _):
        loop, iters, maxit, ncross = steps(loop)
        c = loop.carry
        return loop, Segment(c.t, c.q, c.v, c.acc, c.lam, c.work, iters, maxit, ncross)

    if t_stop is None:
        return jax.lax.scan(interval, loop, None, length=n_intervals)

    # blocks of k intervals, each skipped whole once the run has ended or failed
    k = max(d for d in range(1, n_intervals + 1) if n_intervals % d == 0 and d * substeps <= BLOCK_STEPS) \
        if substeps <= BLOCK_STEPS else 1

    def skipped(loop):
        c, zero = loop.carry, jnp.zeros((k,), jnp.int32)
        rows = [jnp.broadcast_to(x, (k,) + jnp.shape(x)) for x in (c.t, c.q, c.v, c.acc, c.lam, c.work)]
        return loop, Segment(*rows, zero, zero, zero)

    def block(loop, _):
        run = (loop.status == Failure.OK) & (loop.carry.t < t_stop - 0.5 * h)
        return jax.lax.cond(run, lambda lp: jax.lax.scan(interval, lp, None, length=k), skipped, loop)

    loop, seg = jax.lax.scan(block, loop, None, length=n_intervals // k)
    return loop, jax.tree.map(lambda a: jnp.reshape(a, (n_intervals,) + a.shape[2:]), seg)


class Checkpoint(eqx.Module):
    """Where a fixed-step run stopped: the integrator's carry after its last step, its
    memory of earlier steps included (generalized-α's algorithmic acceleration) and the
    work integrals. A run started from it with the same solver and step continues the
    stopped one as if it had not stopped (:attr:`ancf_jax.results.Results.checkpoint`),
    bit for bit; with generalized-α's factors carried across steps
    (:class:`~ancf_jax.integrators.generalized_alpha.AcrossSteps`) to the Newton
    tolerance, where the stopped run ended inside a block of steps: its last, untaken
    steps leave the factors marked invalid (never copied by a select,
    :func:`~ancf_jax.integrators.base.select_carry`), so the continued run factors anew at
    its first step (H1: 2.3e-13 m, ``tests/integrators/test_factor_reuse.py``); keeping
    them exact cost a copy of the factors at every step (10 % of the 4-span catenary's
    step, measured 2026-12-06).

    Attributes:
        carry: the :class:`~ancf_jax.integrators.base.Carry`.
        solver: the name of the solver that made it.
    """

    carry: Carry
    solver: str = eqx.field(static=True)

    @property
    def q(self):
        return self.carry.q

    @property
    def v(self):
        return self.carry.v

    @property
    def t(self):
        return self.carry.t


#: the fields of a :class:`Carry` that a step makes depend on every input of the run
#: (marked so at the start, :func:`~ancf_jax._control.reached_by`: a loop over steps
#: traced once under ``jvp`` and ``vmap``; the identification's Jacobian program of M1
#: traced in 4.6 s instead of 8.6 s). Not time; the solver's memory (factors, held
#: constant in derivatives) gets a batch axis only.
_STATE_FIELDS = ("q", "v", "acc", "aux", "lam", "work", "power")


def initial_loop(system: System, integrator: AbstractIntegrator, state: State | Checkpoint,
                 context) -> LoopState:
    """Initial :class:`LoopState`: consistent accelerations and multipliers of a state,
    or the carry of a :class:`Checkpoint` as it is (its solver memory as the integrator
    keeps it, :meth:`~ancf_jax.integrators.base.AbstractIntegrator.resume`)."""
    if isinstance(state, Checkpoint):
        carry = integrator.resume(system, state.carry, context)
    else:
        carry = integrator.init(system, state, context)
    inputs = (system, state, context)
    carry = eqx.tree_at(lambda c: [getattr(c, f) for f in _STATE_FIELDS], carry,
                        reached_by([getattr(carry, f) for f in _STATE_FIELDS], inputs))
    if carry.memory is not None:
        carry = eqx.tree_at(lambda c: c.memory, carry, reached_by(carry.memory, inputs, tangents=False))
    # strongly typed scalars, as the loop returns them: a weakly typed ``jnp.asarray(nan)``
    # made a jitted chunk called with the initial loop and then with its own output
    # trace and compile twice (tests/test_integrate.py::test_second_chunk_reuses_the_program)
    return LoopState(carry, jnp.asarray(Failure.OK), jnp.full((), jnp.nan, jnp.result_type(carry.t)))


def segment_of(loop: LoopState) -> Segment:  # noqa: D401
    """The current state as a one-row :class:`Segment` (for the initial output)."""
    c = loop.carry
    zero = jnp.zeros((1,), jnp.int32)
    return Segment(c.t[None], c.q[None], c.v[None], c.acc[None], c.lam[None], c.work[None],
                   zero, zero, zero)
