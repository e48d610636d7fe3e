"""Simulation: run a system in time with any integrator, with diagnostics.

:func:`simulate` is the user-facing entry point: it checks its input before anything is
compiled, compiles once (timing the compilation separately), runs the time loop in
chunks with a progress bar for long runs, stops at the first failure with a
:class:`~ancf_jax.errors.SimulationError` that says when and why and carries the
results up to then, and returns a :class:`~ancf_jax.results.Results`.

:func:`trajectory` is the pure functional core for ``jax.jit``, ``jax.vmap`` and
``jax.grad`` (batches over systems of identical structure, gradients of trajectory
functionals).

Solvers (``solver=``):

=====================  ==========================================================
``"generalized-alpha"``  implicit, index 3, second order (default; see below)
``"rk4"``                the paper's classical RK4 (explicit, fixed step, projection)
``"tsit5"``, ``"dopri5"``  diffrax adaptive explicit, index-1 with Baumgarte
``"kvaerno5"``           diffrax adaptive implicit (ESDIRK), index-1 with Baumgarte
=====================  ==========================================================

Default: generalized-α. Steel wires have axial frequencies of tens of kHz, so explicit
methods need microsecond steps (RK4 on model M1: h ≈ 5.8 µs, 3.4e5 steps; Tsit5 about
2.8 million adaptive steps), while generalized-α runs M1 at h = 1 ms with 2–4 Newton
iterations per step (measurements: ``benchmarks/``).
"""

from __future__ import annotations

import math
import time
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .errors import ModelError, SimulationError
from .integrate import LoopState, RunOptions, initial_loop, integrate_fixed, segment_of
from .integrators.base import OK, REASONS, AbstractIntegrator, Carry
from .integrators.diffrax_solvers import KINDS as DIFFRAX_KINDS
from .integrators.diffrax_solvers import DiffraxSolver, succeeded
from .integrators.generalized_alpha import GeneralizedAlpha
from .integrators.rk4 import RK4
from .results import Results
from .system import State, System
from .validation import check_positive

SOLVERS = ("generalized-alpha", "rk4") + DIFFRAX_KINDS
DEFAULT_SOLVER = "generalized-alpha"


def make_solver(name: str, **options):
    """A solver instance from its name (see module docstring) and options."""
    if name not in SOLVERS:
        raise ModelError(f"solver must be one of {', '.join(SOLVERS)}, got {name!r}")
    if name == "generalized-alpha":
        return GeneralizedAlpha(**options)
    if name == "rk4":
        return RK4(**options)
    return DiffraxSolver(kind=name, **options)


def solver_name(solver) -> str:
    if isinstance(solver, GeneralizedAlpha):
        return "generalized-alpha"
    if isinstance(solver, RK4):
        return "rk4"
    if isinstance(solver, DiffraxSolver):
        return solver.kind
    return type(solver).__name__


def time_grid(t_end: float, dt: float, output_dt: float | None):
    """(n_intervals, substeps, h, output_dt): outputs every output_dt, each interval
    split into equal substeps h <= dt."""
    t_end = check_positive("t_end", t_end, "s")
    dt = check_positive("dt", dt, "s")
    output_dt = dt if output_dt is None else check_positive("output_dt", output_dt, "s")
    if output_dt < dt * (1 - 1e-9):
        output_dt = dt
    n_intervals = max(1, int(round(t_end / output_dt)))
    output_dt = t_end / n_intervals
    substeps = max(1, int(math.ceil(output_dt / dt * (1 - 1e-9))))
    return n_intervals, substeps, output_dt / substeps, output_dt


# ---------------------------------------------------------------------------- pure core
def trajectory(system: System, state: State, solver, *, t_end: float, dt: float,
               output_dt: float | None = None, options: RunOptions = RunOptions()):
    """Pure, jittable/vmappable/differentiable run: returns a
    :class:`~ancf_jax.integrate.Segment` with the initial state and one row per
    output time, plus the final :class:`~ancf_jax.integrate.LoopState` (status).

    ``t_end``, ``dt`` and ``output_dt`` are Python floats (they fix array shapes).
    Fixed-step solvers only.
    """
    if isinstance(solver, DiffraxSolver):
        raise ModelError("trajectory() runs fixed-step solvers; use simulate() for diffrax solvers")
    n_int, sub, h, _ = time_grid(t_end, dt, output_dt)
    context = solver.prepare(system)
    loop = initial_loop(system, solver, state, context)
    first = segment_of(loop)
    loop, seg = integrate_fixed(system, solver, loop, context, h, n_intervals=n_int,
                                substeps=sub, options=options)
    return jax.tree.map(lambda a, b: jnp.concatenate([a, b]), first, seg), loop


# ---------------------------------------------------------------------------- simulate
def _failure_message(status: int, t_fail: float, system: System, options: RunOptions) -> str:
    reason = REASONS.get(status, "unknown")
    if reason == "nan":
        why = "the state became NaN or infinite (the step may be too large for the solver)"
    elif reason == "newton":
        why = "the Newton iteration did not converge (reduce dt)"
    elif reason == "constraint_drift":
        why = (f"the constraint violation exceeded drift_tolerance = {options.drift_tolerance:g} "
               "(reduce dt or tighten the solver tolerances)")
    elif reason == "left_beam":
        names = ", ".join(system.sliding_names)
        why = f"a sliding joint ({names}) left its beam at an end"
    else:
        why = "the solver failed"
    return f"simulation stopped at t = {t_fail:.6g} s: {why}"


def _progress(total: int, enabled: bool | None, desc: str):
    from tqdm.auto import tqdm
    return tqdm(total=total, disable=(enabled is False), delay=1.0, desc=desc, unit="s",
                leave=False, bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")


def simulate(system: System, state: State, *, t_end: float, dt: float | None = None,
             solver: Any = DEFAULT_SOLVER, output_dt: float | None = None,
             drift_tolerance: float = 1e-6, locate_crossings: bool = False,
             on_failure: str = "raise", progress: bool | None = None,
             chunks: int | None = None, solver_options: dict | None = None) -> Results:
    """Simulate ``system`` from ``state`` until ``t_end``.

    Args:
        t_end: end time [s] (> 0; the run starts at ``state.t``).
        dt: step [s] of fixed-step solvers, initial step of adaptive ones
            (default 1e-3 s).
        solver: a name (see module docstring) or a solver instance.
        output_dt: output interval [s] (default: every step).
        drift_tolerance: stop when max|Φ| exceeds this [m].
        locate_crossings: split fixed steps at node crossings of sliding joints.
        on_failure: ``"raise"`` (a :class:`SimulationError` carrying the results up to
            the failure) or ``"return"`` (results with ``status`` set).
        progress: show a progress bar (None: only when the run takes over a second).
        chunks: number of compiled chunks the run is split into (progress and early
            stop granularity; default up to 50).
        solver_options: options for a solver given by name.

    Raises:
        ModelError: bad arguments (before anything is compiled).
        SimulationError: the run failed (NaN, Newton failure, constraint drift, a
            sliding joint leaving its beam); ``err.results`` holds the results so far.
    """
    dt = 1e-3 if dt is None else dt
    if on_failure not in ("raise", "return"):
        raise ModelError(f"on_failure must be 'raise' or 'return', got {on_failure!r}")
    check_positive("drift_tolerance", drift_tolerance, "m")
    n_int, sub, h, out_dt = time_grid(t_end, dt, output_dt)
    if isinstance(solver, str):
        solver = make_solver(solver, **(solver_options or {}))
    elif solver_options:
        raise ModelError("solver_options apply to solvers given by name")
    options = RunOptions(drift_tolerance=drift_tolerance, locate_crossings=locate_crossings)
    n_chunks = min(n_int, 50) if chunks is None else max(1, min(int(chunks), n_int))
    per_chunk = int(math.ceil(n_int / n_chunks))
    n_chunks = int(math.ceil(n_int / per_chunk))
    t0 = float(state.t)
    if isinstance(solver, DiffraxSolver):
        return _simulate_diffrax(system, state, solver, t0, n_int, out_dt, dt, per_chunk, n_chunks,
                                 options, on_failure, progress)
    return _simulate_fixed(system, state, solver, t0, n_int, sub, h, per_chunk, n_chunks, options,
                           on_failure, progress)


@eqx.filter_jit
def _init_fixed(system, state, solver):
    context = solver.prepare(system)
    return initial_loop(system, solver, state, context), context


@eqx.filter_jit
def _chunk_fixed(system, loop, context, solver, h, t_stop, n_intervals, substeps, options):
    # steps beyond t_stop (padding of the last chunk) are no-ops
    def run(loop):
        return integrate_fixed(system, solver, loop, context, h, n_intervals=n_intervals,
                               substeps=substeps, options=options)
    del t_stop
    return run(loop)


def _assemble(system, segs, solver_name_, h, status, t_fail, n_valid, wall, compile_s, message,
              info) -> Results:
    cat = {k: np.concatenate([np.asarray(getattr(s, k)) for s in segs])[:n_valid]
           for k in ("t", "q", "v", "acc", "lam", "work", "iterations")}
    return Results(system=system, solver=solver_name_, dt=float(h), wall_time_s=wall,
                   compile_time_s=compile_s, status=REASONS.get(status, "solver") if status else "ok",
                   failure_time=t_fail, message=message, info=info, **cat)


def _simulate_fixed(system, state, solver, t0, n_int, sub, h, per_chunk, n_chunks, options,
                    on_failure, progress):
    name = solver_name(solver)
    tc = time.perf_counter()
    init_c = _init_fixed.lower(system, state, solver).compile()
    chunk_c = None
    if n_chunks:
        loop0, ctx0 = init_c(system, state, solver)
        chunk_c = _chunk_fixed.lower(system, loop0, ctx0, solver, h, 0.0, per_chunk, sub,
                                     options).compile()
    compile_s = time.perf_counter() - tc

    tw = time.perf_counter()
    loop, ctx = init_c(system, state, solver)
    segs = [segment_of(loop)]
    t_end = t0 + n_int * sub * h
    status, t_fail = OK, None
    bar = _progress(n_int * sub * h, progress, f"{name}")
    done_intervals = 0
    for _ in range(n_chunks):
        loop, seg = chunk_c(system, loop, ctx, solver, h, t_end, per_chunk, sub, options)
        jax.block_until_ready(seg.q)
        segs.append(seg)
        done_intervals += per_chunk
        bar.update(min(per_chunk, n_int - done_intervals + per_chunk) * sub * h)
        status = int(loop.status)
        if status != OK:
            t_fail = float(loop.fail_time)
            break
    bar.close()
    wall = time.perf_counter() - tw
    # rows: the initial state plus n_int intervals; after a failure, rows up to the last good step
    n_rows = 1 + n_int
    if status != OK:
        # after a failure the state is frozen: rows stop advancing in time
        t_all = np.concatenate([np.asarray(s.t) for s in segs])
        stalled = np.nonzero(np.diff(t_all) <= 0.0)[0]
        n_rows = min(n_rows, int(stalled[0]) + 1 if stalled.size else len(t_all))
    message = "" if status == OK else _failure_message(status, t_fail, system, options)
    res = _assemble(system, segs, name, h, status, t_fail, n_rows, wall, compile_s, message,
                    dict(steps=int(min(done_intervals, n_int) * sub), substeps_per_output=sub))
    if status != OK and on_failure == "raise":
        raise SimulationError(message, time=t_fail, reason=REASONS[status], results=res)
    return res


@eqx.filter_jit
def _diffrax_chunk(system, solver, context, y0, t0, ts, dt0):
    sol = solver.solve(system, context, y0, t0, ts, dt0)
    q, v, w = sol.ys
    acc, lam = solver.multipliers(system, context, q, v, ts)
    return q, v, w, acc, lam, succeeded(sol), sol.stats["num_steps"]


def _simulate_diffrax(system, state, solver, t0, n_int, out_dt, dt, per_chunk, n_chunks, options,
                      on_failure, progress):
    from .integrate import step_status
    name = solver.kind
    context = jax.jit(solver.prepare)(system) if system.chain_size else None
    y0 = (state.q, state.v, jnp.zeros(3))
    ts_all = t0 + out_dt * np.arange(1, n_int + 1)
    pad = per_chunk * n_chunks - n_int
    ts_all = np.concatenate([ts_all, ts_all[-1] + out_dt * np.arange(1, pad + 1)])
    tc = time.perf_counter()
    chunk_c = _diffrax_chunk.lower(system, solver, context, y0, jnp.asarray(t0),
                                   jnp.asarray(ts_all[:per_chunk]), jnp.asarray(dt)).compile()
    status_fn = jax.jit(lambda sys, q, v, lam, t: jax.vmap(
        lambda qq, vv, ll, tt: step_status(sys, None, Carry(tt, qq, vv, qq, qq, ll, jnp.zeros(3), jnp.zeros(3)),
                                           jnp.array(True), options))(q, v, lam, t))
    compile_s = time.perf_counter() - tc

    acc0, lam0 = jax.jit(lambda s, q, v, t: solver.multipliers(s, context, q[None], v[None], t[None]))(
        system, state.q, state.v, jnp.asarray(t0, float))
    rows = dict(t=[np.array([t0])], q=[np.asarray(state.q)[None]], v=[np.asarray(state.v)[None]],
                acc=[np.asarray(acc0)], lam=[np.asarray(lam0)], work=[np.zeros((1, 3))],
                iterations=[np.zeros(1, int)])
    tw = time.perf_counter()
    bar = _progress(n_int * out_dt, progress, name)
    status, t_fail, steps = OK, None, 0
    y, t_start = y0, t0
    for c in range(n_chunks):
        ts = ts_all[c * per_chunk:(c + 1) * per_chunk]
        q, v, w, acc, lam, ok, nsteps = chunk_c(system, solver, context, y, jnp.asarray(t_start),
                                                jnp.asarray(ts), jnp.asarray(dt))
        steps += int(nsteps)
        codes = np.asarray(status_fn(system, q, v, lam, jnp.asarray(ts)))
        if not bool(ok):
            bad = ~np.all(np.isfinite(np.asarray(q)), axis=1)
            codes = np.where(bad & (codes == OK), 99, codes)
            if np.all(codes == OK):
                codes[-1] = 99
        keep = len(ts) if np.all(codes == OK) else int(np.argmax(codes != OK))
        for k, arr in zip(("t", "q", "v", "acc", "lam", "work"), (ts, q, v, acc, lam, w)):
            rows[k].append(np.asarray(arr)[:keep])
        rows["iterations"].append(np.zeros(keep, int))
        bar.update(len(ts) * out_dt)
        if keep < len(ts):
            status = int(codes[keep])
            t_fail = float(ts[keep])
            break
        y, t_start = (q[-1], v[-1], w[-1]), float(ts[-1])
    bar.close()
    wall = time.perf_counter() - tw
    cat = {k: np.concatenate(v)[: n_int + 1] for k, v in rows.items()}
    REASONS.setdefault(99, "solver")
    message = ""
    if status != OK:
        message = (_failure_message(status, t_fail, system, options) if status != 99 else
                   f"simulation stopped at t = {t_fail:.6g} s: the adaptive solver failed "
                   f"(step size underflow, max_steps = {solver.max_steps} reached, or NaN)")
    res = Results(system=system, solver=name, dt=float(dt), wall_time_s=wall, compile_time_s=compile_s,
                  status="ok" if status == OK else REASONS[status], failure_time=t_fail,
                  message=message, info=dict(steps=steps), **cat)
    if status != OK and on_failure == "raise":
        raise SimulationError(message, time=t_fail, reason=REASONS[status], results=res)
    return res
