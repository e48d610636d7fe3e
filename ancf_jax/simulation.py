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
``"explicit-euler"``     forward Euler (explicit, fixed step, first order; Exudyn parity)
``"tsit5"``, ``"dopri5"``  diffrax adaptive explicit, index-1 with Baumgarte
``"kvaerno5"``           diffrax adaptive implicit (ESDIRK), index-1 with Baumgarte
=====================  ==========================================================

Default: generalized-α. Steel wires have axial frequencies of tens of kHz, so explicit
methods need microsecond steps (RK4 on model M1: h ≈ 5.8 µs, 3.4e5 steps; Tsit5 about
2.8 million adaptive steps), while generalized-α runs M1 at h = 1 ms with 2–4 Newton
iterations per step (measurements: ``benchmarks/``).
"""

from __future__ import annotations

import concurrent.futures
import contextvars
import math
import time
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _memory, _products, _xla
from .errors import ModelError, SimulationError, SimulationInterrupted
from .integrate import (DEFAULT_DT, MAX_OUTPUT_BYTES, MAX_STEPS, NO_RETRIES, Checkpoint,  # noqa: F401
                        LoopState, RunLimits, RunOptions, adaptive_failure, initial_loop, integrate_fixed,
                        segment_of, sliding_beams)
from .failures import Failure
from .integrators.base import AbstractAdaptiveSolver, AbstractIntegrator, AbstractSolver, Carry
from .integrators.diffrax_solvers import KINDS as DIFFRAX_KINDS
from .integrators.diffrax_solvers import DiffraxSolver
from .integrators.generalized_alpha import CONSTRAINT_LEVELS, AcrossSteps, GeneralizedAlpha
from .integrators.explicit import RK4, ExplicitEuler
from .linalg import LINEAR_SOLVERS
from .newton import ModifiedNewton
from .results import Results
from .system import State, System
from .validation import check_positive

#: the fixed-step solvers (run by the one time loop, batched and differentiable)
FIXED_STEP_SOLVERS = ("generalized-alpha", "rk4", "explicit-euler")
SOLVERS = FIXED_STEP_SOLVERS + DIFFRAX_KINDS
DEFAULT_SOLVER = "generalized-alpha"


#: flat option names (scenario format, ``solver_options``) of the generalized-α root
#: finder, and the :class:`~ancf_jax.newton.ModifiedNewton` fields they set
ROOT_FINDER_OPTIONS = {"newton_tol": "tolerance", "max_iterations": "max_iterations",
                       "refresh_every": "refresh_every", "contraction": "contraction",
                       "refresh_first": "refresh_first"}


def make_solver(name: str, **options):
    """A solver instance from its name (see module docstring) and flat options, as the
    scenario format's ``[solver.<name>]`` tables and ``solver_options`` give them.

    The one translation from flat options to the composed solver: generalized-α's
    ``newton_tol``, ``max_iterations``, ``refresh_every``, ``contraction`` and
    ``refresh_first`` configure its root finder (:data:`ROOT_FINDER_OPTIONS`);
    ``linear_solver`` (``"auto"``, ``"bordered"``, ``"dense"``,
    :data:`ancf_jax.linalg.LINEAR_SOLVERS`) its linear solver; the rest are fields of
    the integrator, except ``index`` (2 or 3), which chooses generalized-α's constraint
    level (:data:`~ancf_jax.integrators.generalized_alpha.CONSTRAINT_LEVELS`), and
    ``reuse_factors`` (an integer N >= 1), which carries its Newton-matrix factors across
    steps, N at most (:class:`~ancf_jax.integrators.generalized_alpha.AcrossSteps`).
    Defaults are those of the classes."""
    if name not in SOLVERS:
        raise ModelError(f"solver must be one of {', '.join(SOLVERS)}, got {name!r}")
    options = dict(options)
    ls = options.pop("linear_solver", None)
    if ls is not None:
        if ls not in LINEAR_SOLVERS:
            raise ModelError(f"linear_solver must be one of {', '.join(LINEAR_SOLVERS)}, got {ls!r}")
        ls = LINEAR_SOLVERS[ls]()
    if name == "generalized-alpha":
        rf = {ROOT_FINDER_OPTIONS[k]: options.pop(k) for k in list(options) if k in ROOT_FINDER_OPTIONS}
        if ls is not None:
            rf["linear_solver"] = ls
        index = options.pop("index", None)
        if index is not None:
            if index not in CONSTRAINT_LEVELS:
                raise ModelError(f"index (constraint level) of generalized-alpha must be one of "
                                 f"{sorted(CONSTRAINT_LEVELS)}, got {index!r}")
            options["constraints"] = CONSTRAINT_LEVELS[index]()
        reuse = options.pop("reuse_factors", None)
        if reuse is not None:
            options["factor_reuse"] = AcrossSteps(max_age=reuse)
        return GeneralizedAlpha(root_finder=ModifiedNewton(**rf), **options)
    if ls is not None:
        options["linear_solver"] = ls
    if name == "rk4":
        return RK4(**options)
    if name == "explicit-euler":
        return ExplicitEuler(**options)
    return DiffraxSolver(kind=name, **options)


def solver_name(solver: AbstractSolver) -> str:
    """The name of a solver instance (inverse of :func:`make_solver`)."""
    return solver.name


#: steps of one compiled call of the host loop unless :class:`RunLimits` ``chunks`` says
STEPS_PER_CHUNK = 500


def run_size(n_intervals: int, substeps: int, n_coordinates: int, n_multipliers: int = 0,
             batch: int = 1) -> tuple[int, int]:
    """(time steps of one run, bytes of the output kept in memory) of a run of
    ``n_intervals`` output intervals of ``substeps`` steps each: every output row holds
    t, q, v, acc (``n_coordinates`` each), the multipliers, the work (3) and the
    iteration count, 8 bytes per value, for each of ``batch`` members."""
    rows = n_intervals + 1
    return int(n_intervals) * int(substeps), rows * (3 * n_coordinates + n_multipliers + 5) * 8 * batch


def check_run_size(t_end: float, dt: float, output_dt: float | None, n_coordinates: int,
                   n_multipliers: int = 0, *, batch: int = 1, fixed_step: bool = True,
                   limits: RunLimits = RunLimits(), names: dict | None = None) -> tuple[int, int]:
    """Refuse a runaway run before anything is compiled.

    Args:
        t_end: the run's end time [s] (as :func:`time_grid` takes it).
        dt: the step [s].
        output_dt: the output interval [s] (None: every step).
        n_coordinates: size of q.
        n_multipliers: number of multipliers of the system.
        batch: number of batch members (output of each is kept).
        fixed_step: count steps (adaptive solvers choose theirs: only the output is
            checked).
        limits: the most steps and output accepted (:class:`~ancf_jax.integrate.RunLimits`,
            default :data:`~ancf_jax.integrate.MAX_STEPS` and
            :data:`~ancf_jax.integrate.MAX_OUTPUT_BYTES`).
        names: how the message names ``t_end``, ``dt``, ``output_dt``, ``max_steps`` and
            ``max_output_bytes`` (the command line names its options; an empty name: no
            such knob to mention).

    Returns:
        (steps, output bytes), see :func:`run_size`.

    Raises:
        ModelError: one line with the estimate and the knob that allows the run.
    """
    nm = {**dict(t_end="t_end", dt="dt", output_dt="output_dt", max_steps="RunLimits.max_steps",
                 max_output_bytes="RunLimits.max_output_bytes"), **(names or {})}
    if not isinstance(limits, RunLimits):
        raise ModelError(f"limits must be a RunLimits, got {type(limits).__name__}")
    max_steps, max_output_bytes = limits.max_steps, limits.max_output_bytes
    n_int, sub, _, out_dt = time_grid(t_end, dt, output_dt)
    steps, size = run_size(n_int, sub, n_coordinates, n_multipliers, batch)
    if fixed_step and steps > max_steps:
        raise ModelError(f"{nm['t_end']} = {t_end:g} s with {nm['dt']} = {dt:g} s needs about {steps:.3g} "
                         f"time steps, more than {nm['max_steps']} = {max_steps:.3g}: raise {nm['dt']}, "
                         f"shorten {nm['t_end']}, or give {nm['max_steps']} to run it anyway")
    if size > max_output_bytes:
        raise ModelError(f"{nm['t_end']} = {t_end:g} s with {nm['output_dt']} = {out_dt:g} s keeps about "
                         f"{size / 2**30:.3g} GiB of output ({n_int + 1:.3g} rows of "
                         f"{3 * n_coordinates + n_multipliers + 5} values{f' x {batch} runs' if batch > 1 else ''}), "
                         f"more than {max_output_bytes / 2**30:.3g} GiB: raise {nm['output_dt']} or shorten "
                         f"{nm['t_end']}" + (f", or give {nm['max_output_bytes']}" if nm["max_output_bytes"] else ""))
    return steps, size


def _chunking(n_intervals: int, substeps: int, chunks: int | None,
              batched: bool = False) -> tuple[int, int]:
    """(intervals per chunk, number of chunks). By default a chunk is about
    STEPS_PER_CHUNK steps, so runs of different lengths share one compiled chunk.

    Batched runs (``batched``) split the run into equal chunks instead: under vmap the
    skipped steps after the end of a partly used last chunk still cost a full step
    (a conditional becomes a select), so there the chunks are sized to the run."""
    if chunks is None and batched:
        n_chunks = max(1, int(math.ceil(n_intervals * substeps / STEPS_PER_CHUNK)))
        per = int(math.ceil(n_intervals / n_chunks))
    elif chunks is None:
        per = max(1, int(math.ceil(STEPS_PER_CHUNK / substeps)))
    else:
        per = int(math.ceil(n_intervals / max(1, min(int(chunks), n_intervals))))
    return per, int(math.ceil(n_intervals / per))


def _check_on_failure(on_failure):
    if on_failure not in ("raise", "return"):
        raise ModelError(f"on_failure must be 'raise' or 'return', got {on_failure!r}")


def _raise_failed_members(out):
    """:class:`SimulationError` naming every member of ``out`` (a list of Results) that
    did not end ok, with all of them as its ``results``; nothing if all did."""
    if any(r.status != "ok" for r in out):
        bad = [f"member {i}: {r.message}" for i, r in enumerate(out) if r.status != "ok"]
        first = next(r for r in out if r.status != "ok")
        raise SimulationError("; ".join(bad), time=first.failure_time, reason=first.status, results=out)


def _prepare(t_end, dt, solver, output_dt, options, limits, on_failure, batched=False):
    """Check the run arguments (before anything is compiled) and derive the solver
    instance, time grid and chunking."""
    _check_on_failure(on_failure)
    if not isinstance(options, RunOptions):
        raise ModelError(f"options must be a RunOptions, got {type(options).__name__}")
    if not isinstance(limits, RunLimits):
        raise ModelError(f"limits must be a RunLimits, got {type(limits).__name__}")
    grid = time_grid(t_end, dt, output_dt)
    if isinstance(solver, str):
        solver = make_solver(solver)
    elif not isinstance(solver, AbstractSolver):
        raise ModelError(f"solver must be one of {', '.join(SOLVERS)} or an AbstractSolver "
                         f"instance (make_solver(name, **options) for options), got {type(solver).__name__}")
    return solver, grid, _chunking(grid[0], grid[1], limits.chunks, batched)


def time_grid(t_end: float, dt: float, output_dt: float | None):
    """(n_intervals, substeps, h, output_dt): outputs every output_dt (shortened to
    t_end / n_intervals, so that they end at t_end), each interval split into equal
    substeps h <= dt.

    The interval is shortened, never lengthened: a longer one would need one more
    substep each, so a run whose t_end is not a multiple of dt (the pantograph–catenary
    at 250 km/h: 6.0408 s at 2 ms) took steps of half the size asked for, and twice as
    many (until 2026-12-06, when n_intervals was t_end / output_dt rounded)."""
    t_end = check_positive("t_end", t_end, "s")
    dt = check_positive("dt", dt, "s")
    output_dt = dt if output_dt is None else check_positive("output_dt", output_dt, "s")
    if output_dt < dt * (1 - 1e-9):
        raise ModelError(f"output_dt must be >= dt = {dt:g} s (outputs are taken at steps), "
                         f"got {output_dt:g} s")
    n_intervals = max(1, int(math.ceil(t_end / output_dt * (1 - 1e-9))))
    output_dt = t_end / n_intervals
    substeps = max(1, int(math.ceil(output_dt / dt * (1 - 1e-9))))
    return n_intervals, substeps, output_dt / substeps, output_dt


# ---------------------------------------------------------------------------- pure core
def trajectory(system: System, state: State, solver, *, t_end: float, dt: float,
               output_dt: float | None = None, options: RunOptions = NO_RETRIES):
    """Pure, jittable/vmappable/differentiable run: returns a
    :class:`~ancf_jax.integrate.Segment` with the initial state and one row per
    output time, plus the final :class:`~ancf_jax.integrate.LoopState` (status).

    ``t_end``, ``dt`` and ``output_dt`` are Python floats (they fix array shapes).
    Fixed-step solvers only.

    By default there are no retries in substeps (:data:`~ancf_jax.integrate.NO_RETRIES`:
    they are a while loop, which reverse-mode autodiff cannot pass): when a step fails (Newton not converged, NaN, drift), the
    state is frozen from then on and ``loop.status`` holds the failure code
    (:class:`~ancf_jax.failures.Failure`). Check ``loop.status == 0`` before
    using a value or gradient; a frozen run's gradient is meaningless. Reduce ``dt``
    if it fails.
    """
    if not isinstance(solver, AbstractIntegrator):
        raise ModelError("trajectory() runs fixed-step solvers; use simulate() for adaptive solvers")
    n_int, sub, h, _ = time_grid(t_end, dt, output_dt)
    context = solver.prepare(system)
    loop = initial_loop(system, solver, state, context)
    first = segment_of(loop)
    loop, seg = integrate_fixed(system, solver, loop, context, h, n_intervals=n_int,
                                substeps=sub, options=options)
    return jax.tree.map(lambda a, b: jnp.concatenate([a, b]), first, seg), loop


# ---------------------------------------------------------------------------- simulate
def _joints_that_left(system: System, q, v, t_last: float, t_fail: float) -> tuple[str, ...]:
    """Names of the sliding joints whose coordinate, continued from the last good state
    (q, v at t_last) to t_fail, lies outside [0, length] of its beam (all of them if
    none does, e.g. when the last state is unknown)."""
    if q is None or not system.sliding_names:
        return tuple(system.sliding_names)
    dt = max(t_fail - t_last, 0.0)
    out = []
    for j, b in sliding_beams(system).items():
        s = float(system.sliding(q, j)) + dt * float(system.sliding(v, j))
        if not 0.0 <= s <= float(system.beams[b].mesh.length):
            out.append(system.sliding_names[j])
    return tuple(out) or tuple(system.sliding_names)


def _failure_message(status: int, t_fail: float, system: System, options: RunOptions,
                     last=None, max_steps=None, solver: str = "time") -> str:
    """The one-line message of a :class:`~ancf_jax.failures.Failure`, with the run's
    numbers (tolerances, the joint that left its beam) and the solver's name."""
    failure = Failure(status)
    context = dict(drift_tolerance=options.drift_tolerance, max_sliding_step=options.max_sliding_step,
                   max_steps=max_steps, solver=solver)
    if failure is Failure.LEFT_BEAM:
        names = _joints_that_left(system, *(last or (None, None, 0.0)), t_fail)
        context["joint"] = (f"the sliding joint {names[0]!r}" if len(names) == 1 else
                            "a sliding joint (" + ", ".join(names) + ")")
    return failure.message(t_fail, **context)


def _progress(total: int, enabled: bool | None, desc: str):
    from tqdm.auto import tqdm
    return tqdm(total=total, disable=(enabled is False), delay=1.0, desc=desc, unit="s",
                leave=False, bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")


def simulate(system: System, state: State, *, t_end: float, dt: float | None = None,
             solver: Any = DEFAULT_SOLVER, output_dt: float | None = None,
             options: RunOptions = RunOptions(), limits: RunLimits = RunLimits(),
             on_failure: str = "raise", progress: bool | None = None) -> Results:
    """Simulate ``system`` from ``state`` until ``t_end``.

    Args:
        t_end: end time [s] (> 0; the run starts at ``state.t``).
        dt: step [s] of fixed-step solvers, initial step of adaptive ones
            (default :data:`~ancf_jax.integrate.DEFAULT_DT`, 1 ms).
        solver: a name (see module docstring; its default settings) or a solver
            instance (:func:`make_solver` builds one from a name and flat options, as
            the scenario format gives them).
        output_dt: output interval [s] (default: every step).
        options: options of the time loop (:class:`~ancf_jax.integrate.RunOptions`):
            drift tolerance, location of node crossings and kinks, step retries.
        limits: most steps and output accepted before anything is compiled, and the
            size of the compiled calls (:class:`~ancf_jax.integrate.RunLimits`).
        on_failure: ``"raise"`` (a :class:`SimulationError` carrying the results up to
            the failure) or ``"return"`` (results with ``status`` set).
        progress: show a progress bar (None: only when the run takes over a second).

    A ``KeyboardInterrupt`` (Ctrl-C) during the run stops it at the next chunk
    boundary: the results up to then get ``status = "interrupted"`` and are returned
    (``on_failure="return"``) or raised in a
    :class:`~ancf_jax.errors.SimulationInterrupted` (a ``KeyboardInterrupt``).

    Raises:
        ModelError: bad arguments, or a run above ``limits`` (before anything is
            compiled).
        SimulationError: the run failed (NaN, Newton failure, constraint drift, a
            sliding joint leaving its beam); ``err.results`` holds the results so far.
        SimulationInterrupted: Ctrl-C with ``on_failure="raise"``; ``err.results``
            holds the results so far.
    """
    dt = DEFAULT_DT if dt is None else dt
    solver, (n_int, sub, h, out_dt), (per_chunk, n_chunks) = _prepare(
        t_end, dt, solver, output_dt, options, limits, on_failure)
    check_run_size(t_end, dt, output_dt, int(np.size(state.q)), int(system.n_constraints),
                   fixed_step=not isinstance(solver, AbstractAdaptiveSolver), limits=limits)
    t0 = float(state.t)
    if isinstance(state, Checkpoint) and (isinstance(solver, AbstractAdaptiveSolver)
                                          or solver_name(solver) != state.solver):
        raise ModelError(f"state: a checkpoint of a {state.solver} run continues with solver "
                         f"{state.solver!r}, got {solver_name(solver)!r}")
    if isinstance(solver, AbstractAdaptiveSolver):
        return _simulate_adaptive(system, state, solver, t0, n_int, out_dt, dt, per_chunk, n_chunks,
                                  options, on_failure, progress)
    return _simulate_fixed(system, state, solver, t0, n_int, sub, h, per_chunk, n_chunks, options,
                           on_failure, progress)


def _init_fixed(system, state, solver):
    context = solver.prepare(system)
    return initial_loop(system, solver, state, context), context


def _chunk_fixed(system, loop, context, solver, h, t_stop, n_intervals, substeps, options):
    return integrate_fixed(system, solver, loop, context, h, n_intervals=n_intervals,
                           substeps=substeps, options=options, t_stop=t_stop)


_init_single = eqx.filter_jit(_init_fixed)
_chunk_single = eqx.filter_jit(_chunk_fixed)
_init_batch = eqx.filter_jit(eqx.filter_vmap(_init_fixed, in_axes=(eqx.if_array(0), eqx.if_array(0), None)))
_chunk_batch = eqx.filter_jit(eqx.filter_vmap(
    _chunk_fixed, in_axes=(eqx.if_array(0), eqx.if_array(0), eqx.if_array(0), None, None, None, None,
                           None, None)))


_COMPILED: dict = {}
_memory.register_cache(_COMPILED.clear)


def _signature(args):
    """Hashable description of arguments: tree structure (with static fields), shapes
    and dtypes of arrays, values of everything else."""
    leaves, treedef = jax.tree.flatten(args)
    sig = tuple((tuple(np.shape(x)), str(x.dtype), getattr(x, "sharding", None)) if eqx.is_array(x)
                else ("static", x) for x in leaves)
    return treedef, sig


def _options_key(options):
    """Compiler options as part of a cache key (types too: 3 and 3.0, True and 1 are
    different options to XLA)."""
    return tuple((k, type(v).__name__, v) for k, v in sorted(options.items())) if options else ()


def _key(fn, args, options):
    """(cache key of ``fn`` for ``args``, the compiler options it compiles with: its own
    ``options`` with those of the enclosing :func:`ancf_jax.compiler_options` blocks)."""
    options = _xla.program_options(options)
    return (fn, _signature(args), _options_key(options)), options


def compiled(fn, *args, options=None):
    """AOT-compiled ``fn`` for these arguments, cached in-process by their structure
    and the compiler options (``options``: the program's own XLA compiler options, with
    those of enclosing :func:`ancf_jax.compiler_options` blocks).

    Returns (executable, seconds spent compiling now; 0.0 when cached)."""
    key, options = _key(fn, args, options)
    hit = _COMPILED.get(key)
    if hit is not None:
        return hit, 0.0
    # free programs before the process nears the kernel's memory-map limit (a crash in XLA)
    _memory.relieve()
    t0 = time.perf_counter()
    exe = fn.lower(*args).compile(options)
    _COMPILED[key] = exe
    return exe, time.perf_counter() - t0


def is_compiled(fn, *args, options=None) -> bool:
    """Whether :func:`compiled` holds ``fn`` for these arguments and options now."""
    return _key(fn, args, options)[0] in _COMPILED


#: one background thread for XLA compilations (:func:`compiled_pair`); XLA releases the
#: GIL while it compiles, so a compilation there overlaps tracing in the caller's thread
_COMPILER = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="ancf_jax-compile")


def _devices(args) -> set:
    """The devices the JAX arrays of ``args`` are on (empty: no JAX arrays)."""
    return {d for x in jax.tree.leaves(args) if isinstance(x, jax.Array) for d in x.sharding.device_set}


def _placeholders(lowered, device):
    """Arrays of zeros on ``device`` (None: the default one) shaped as the outputs of an ``eqx.filter_jit``
    function that ``lowered`` is the lowering of (its static outputs as they are): what
    a second program can be traced with before the first one is compiled and run.
    (``device_put`` of NumPy zeros: ``jnp.zeros`` would compile a program per shape. A
    weakly typed output is passed later to a program traced with a strong zero:
    accepted.)"""
    _, dynamic, static = lowered.lowered.out_info
    zeros = jax.tree.map(lambda s: jax.device_put(np.zeros(s.shape, s.dtype), device), dynamic)
    return eqx.combine(zeros, static.value)


def compiled_pair(first, first_args, second, second_args, first_options=None):
    """AOT-compiled ``first`` and ``second``, where ``second``'s arguments are made
    from ``first``'s outputs (``second_args(*outputs)`` returns them), both cached as
    :func:`compiled` caches.

    When ``first`` is not cached, it is traced and lowered, its XLA compilation runs in
    a background thread while ``second`` is traced and lowered (with zeros shaped as
    ``first``'s outputs), and then ``second`` is compiled: the compile time of the pair
    is about the sum of the two tracings and ``second``'s XLA compilation.

    ``first_options``: XLA compiler options of ``first``; both also get those of enclosing
    :func:`ancf_jax.compiler_options` blocks (``first_options`` take precedence).

    Returns (first's executable, second's executable, wall-clock seconds spent
    compiling now; 0.0 when both were cached)."""
    key, first_options = _key(first, first_args, first_options)
    devices = _devices(first_args)
    if key in _COMPILED or len(devices) > 1:
        # only the second may be new, or the arguments are sharded (the outputs'
        # placement is XLA's to choose): one after the other, the second traced with
        # the first's real outputs
        exe1, c1 = compiled(first, *first_args, options=first_options)
        exe2, c2 = compiled(second, *second_args(*exe1(*first_args)))
        return exe1, exe2, c1 + c2
    device = devices.pop() if devices else None  # None: JAX's default device
    _memory.relieve()
    t0 = time.perf_counter()
    low1 = first.lower(*first_args)
    job = _COMPILER.submit(low1.compile, first_options)
    try:
        exe2, _ = compiled(second, *second_args(*_placeholders(low1, device)))
    finally:
        exe1 = job.result()  # waits, and re-raises the compiler's error, if any
    _COMPILED[key] = exe1
    return exe1, exe2, time.perf_counter() - t0


def _rows_until_failure(t_rows: np.ndarray, n_rows: int) -> int:
    """After a failure the state is frozen: rows stop advancing in time."""
    stalled = np.nonzero(np.diff(t_rows) <= 0.0)[0]
    return min(n_rows, int(stalled[0]) + 1 if stalled.size else len(t_rows))


def _run_fixed(system, state, solver, t0, n_int, sub, h, per_chunk, n_chunks, options, progress,
               batch: int | None):
    """Compile and run the chunked fixed-step loop; ``batch`` members share one vmapped
    program. Returns (segments, final loop, compile time, wall time, whether Ctrl-C
    stopped it). A ``KeyboardInterrupt`` while the chunks run stops the loop: the
    chunks finished until then are kept."""
    init_fn, chunk_fn = (_init_single, _chunk_single) if batch is None else (_init_batch, _chunk_batch)
    solver = solver.forward_only()  # the chunked loop is never differentiated
    t_end = t0 + n_int * sub * h
    h = jnp.asarray(h)  # traced: runs with other steps reuse the compiled program
    t_stop = jnp.asarray(t_end)
    with _products.batch(batch or 1):  # products as dot or sums by the batch (_products)
        init_c, chunk_c, compile_s = compiled_pair(
            init_fn, (system, state, solver), chunk_fn,
            lambda loop, ctx: (system, loop, ctx, solver, h, t_stop, per_chunk, sub, options),
            first_options=_xla.run_once_options())  # the initial state runs once
    tw = time.perf_counter()
    loop, ctx = init_c(system, state, solver)
    first = segment_of(loop) if batch is None else eqx.filter_vmap(segment_of)(loop)
    segs = [first]
    bar = _progress(t_end - t0, progress, solver_name(solver) + ("" if batch is None else f" ×{batch}"))
    interrupted = False
    try:
        for c in range(n_chunks):
            new, seg = chunk_c(system, loop, ctx, solver, h, t_stop, per_chunk, sub, options)
            jax.block_until_ready(seg.q)
            segs.append(seg)
            loop = new
            bar.update(min(per_chunk, n_int - c * per_chunk) * (t_end - t0) / n_int)
            if np.all(np.asarray(loop.status) != Failure.OK):
                break
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
    return segs, loop, compile_s, time.perf_counter() - tw, interrupted


def _results_fixed(system, segs, loop, solver, n_int, sub, h, t0, compile_s, wall, options,
                   index=None, interrupted=False) -> Results:
    """Results of one (batch member of a) fixed-step run (``interrupted``: Ctrl-C
    stopped the chunk loop; rows missing at the end make the status INTERRUPTED)."""
    take = (lambda a: np.asarray(a)) if index is None else (lambda a: np.asarray(a)[index])
    axis = 0 if index is None else 1
    cat = {k: np.concatenate([np.asarray(getattr(s, k)) if index is None else
                              np.asarray(getattr(s, k))[index] for s in segs], axis=0)
           for k in ("t", "q", "v", "acc", "lam", "work", "iterations")}
    del axis
    status = int(take(loop.status))
    t_fail = float(take(loop.fail_time)) if status != Failure.OK else None
    n_rows = min(1 + n_int, len(cat["t"]))
    if status != Failure.OK:
        n_rows = _rows_until_failure(cat["t"], n_rows)
    cat = {k: v[:n_rows] for k, v in cat.items()}
    cat["t"] = t0 + h * sub * np.arange(n_rows)  # exact grid (the carry accumulates h)
    if status == Failure.OK and interrupted and n_rows < 1 + n_int:
        status, t_fail = Failure.INTERRUPTED, float(cat["t"][-1])
    message = "" if status == Failure.OK else _failure_message(
        status, t_fail, system, options, last=(cat["q"][-1], cat["v"][-1], float(cat["t"][-1])),
        solver=solver_name(solver))
    checkpoint = Checkpoint(jax.tree.map(take, loop.carry), solver_name(solver))
    return Results(system=system, solver=solver_name(solver), dt=float(h), wall_time_s=wall,
                   compile_time_s=compile_s, status=Failure(status).reason, failure_time=t_fail,
                   message=message, info=dict(steps=int((n_rows - 1) * sub), substeps_per_output=sub),
                   checkpoint=checkpoint, **cat)


def load_checkpoint(path) -> Checkpoint:
    """The :class:`~ancf_jax.integrate.Checkpoint` saved in an NPZ file of a fixed-step
    run (:meth:`~ancf_jax.results.Results.save_npz`), to continue it:
    ``simulate(system, load_checkpoint(path), t_end=more, dt=same)``."""
    with np.load(path) as f:
        if "checkpoint_solver" not in f:
            raise ModelError(f"{path}: no checkpoint in this file (written by a fixed-step run of "
                             "ancf_jax 0.1 or later)")
        fields = {k: jnp.asarray(f[f"checkpoint_{k}"]) for k in Carry.__dataclass_fields__ if k != "memory"}
        # the solver memory's leaves, rebuilt by the integrator that continues the run
        # (AbstractIntegrator.resume)
        n_memory = sum(k.startswith("checkpoint_memory_") for k in f.files)
        memory = tuple(jnp.asarray(f[f"checkpoint_memory_{i}"]) for i in range(n_memory)) or None
        return Checkpoint(Carry(**fields, memory=memory), str(f["checkpoint_solver"]))


def _simulate_fixed(system, state, solver, t0, n_int, sub, h, per_chunk, n_chunks, options,
                    on_failure, progress):
    segs, loop, compile_s, wall, interrupted = _run_fixed(system, state, solver, t0, n_int, sub, h,
                                                          per_chunk, n_chunks, options, progress, None)
    res = _results_fixed(system, segs, loop, solver, n_int, sub, h, t0, compile_s, wall, options,
                         interrupted=interrupted)
    if res.status == Failure.INTERRUPTED.reason and on_failure == "raise":
        raise SimulationInterrupted(res.message, time=res.failure_time, results=res)
    if res.status != "ok" and on_failure == "raise":
        raise SimulationError(res.message, time=res.failure_time, reason=res.status, results=res)
    return res


def harmonize_rate_stiffness(systems):
    """Systems built with β = 0 and β ≠ 0 differ in a static switch of their beams
    (:attr:`~ancf_jax.beam.Beam.rate_stiffness`, the Newton matrix's β-rate term): set
    it on for every member where it is on for one, so that they batch."""
    systems = list(systems)
    counts = {len(s.beams) for s in systems}
    if len(systems) < 2 or len(counts) != 1:
        return systems
    flags = [any(s.beams[i].rate_stiffness for s in systems) for i in range(counts.pop())]
    return [s.with_rate_stiffness(flags) for s in systems]


def stack(trees):
    """Stack pytrees of identical structure (systems, states) along a new leading axis."""
    return jax.tree.map(lambda *xs: jnp.stack(xs), *trees)


def unstack(tree, index):
    """Member ``index`` of a stacked pytree."""
    return jax.tree.map(lambda x: x[index], tree)


def simulate_batch(systems, states, *, t_end: float, dt: float | None = None,
                   solver: Any = DEFAULT_SOLVER, output_dt: float | None = None,
                   options: RunOptions = RunOptions(), limits: RunLimits = RunLimits(),
                   on_failure: str = "raise", progress: bool | None = None,
                   devices=None) -> list[Results]:
    """Simulate several systems of identical structure in ONE jitted, vmapped program.

    Systems differ only in array data: parameter values (α, masses, s₀, …) or meshes of
    different element counts padded to a common size (``Model.build(pad_to=...)``).
    Compilation is shared (reported in every result); the wall time of the batch is
    reported per result as the batch total divided by the batch size, and in
    ``info["batch_wall_time_s"]``. Arguments as for :func:`simulate` (fixed-step solvers;
    ``max_output_bytes`` counts the output of all members).

    ``devices`` (a list of JAX devices, e.g. ``jax.devices()``) shards the batch across
    them (the batch size must be a multiple of their number): one program, each device
    runs its share of the members.

    Raises:
        SimulationError: a member failed and ``on_failure="raise"``; ``err.results`` is
            the list of all members' results.
        SimulationInterrupted: Ctrl-C with ``on_failure="raise"``; ``err.results`` is the
            list of all members' results up to then.
    """
    systems, states = list(systems), list(states)
    if not systems or len(systems) != len(states):
        raise ModelError("simulate_batch needs equally many systems and states (at least one)")
    systems = harmonize_rate_stiffness(systems)
    treedefs = {jax.tree.structure(s) for s in systems}
    if len(treedefs) != 1 or len({tuple(np.shape(x) for x in jax.tree.leaves(s)) for s in systems}) != 1:
        raise ModelError("simulate_batch needs systems of identical structure and shapes: build them "
                         "from the same model with the same pad_to")
    dt = DEFAULT_DT if dt is None else dt
    solver, (n_int, sub, h, _), (per_chunk, n_chunks) = _prepare(
        t_end, dt, solver, output_dt, options, limits, on_failure, batched=True)
    if not isinstance(solver, AbstractIntegrator):
        raise ModelError(f"simulate_batch runs fixed-step solvers ({', '.join(FIXED_STEP_SOLVERS)})")
    t0s = {float(s.t) for s in states}
    if len(t0s) != 1:
        raise ModelError("simulate_batch needs a common start time")
    t0 = t0s.pop()
    check_run_size(t_end, dt, output_dt, int(np.size(states[0].q)), int(systems[0].n_constraints),
                   batch=len(systems), limits=limits)
    bs, bst = stack(systems), stack(states)
    if devices is not None and len(devices) > 1:
        bs, bst = _shard((bs, bst), list(devices), len(systems))
    segs, loop, compile_s, wall, interrupted = _run_fixed(bs, bst, solver, t0, n_int, sub, h, per_chunk,
                                                          n_chunks, options, progress, len(systems))
    out = []
    for i, sys_i in enumerate(systems):
        r = _results_fixed(sys_i, segs, loop, solver, n_int, sub, h, t0, compile_s,
                           wall / len(systems), options, index=i, interrupted=interrupted)
        r.info["batch_wall_time_s"] = wall
        r.info["batch_size"] = len(systems)
        out.append(r)
    stopped = [r for r in out if r.status == Failure.INTERRUPTED.reason]
    if on_failure == "raise" and stopped:
        raise SimulationInterrupted(stopped[0].message, time=stopped[0].failure_time, results=out)
    if on_failure == "raise":
        _raise_failed_members(out)
    return out


def simulate_each(systems, states, *, workers: int | None = None, on_failure: str = "raise",
                  **run) -> list[Results]:
    """Simulate several systems, each by :func:`simulate` (each member's results are
    exactly those of its single run), spread over ``workers`` threads (default: the
    number of CPU cores): XLA runs a compiled program with Python's lock released, so
    the threads' runs proceed in parallel. Members of one structure share one compiled
    program (the first member runs alone first and compiles it); members need not share
    a structure, a step or a start time.

    On the CPU this is the faster way to run many small models: a vmapped batch
    (:func:`simulate_batch`) adds no arithmetic units there and its batched small
    factorizations cost more than unbatched ones. Measured on 2 cores, 256 M1 variants
    (6 elements, 0–2 s, h = 1.25 ms; ``python -m benchmarks.batch_threads``,
    2026-12-06): 94.5 ms per simulation vmapped, 71.0 ms one after the other, 40.2 ms
    in two threads by this function; one Exudyn run 142 ms. On a GPU, use
    :func:`simulate_batch`.

    Args:
        systems: the :class:`~ancf_jax.system.System` of each member (at least one).
        states: the initial :class:`~ancf_jax.system.State` of each, as many.
        workers: threads (an integer >= 1; default ``os.cpu_count()``).
        on_failure: ``"raise"`` (after every member has run: :class:`SimulationError`
            naming the failed members, ``err.results`` all results) or ``"return"``.
        run: the keyword arguments of :func:`simulate` (``t_end``, ``dt``, ``solver``,
            …), the same for every member; ``progress`` is off in the members.

    Ctrl-C lets the running members finish, starts no other and raises
    :class:`~ancf_jax.errors.SimulationInterrupted` (a ``KeyboardInterrupt``) whose
    ``results`` hold the members' results (None for those not run).
    """
    import os
    from concurrent.futures import ThreadPoolExecutor

    systems, states = list(systems), list(states)
    if not systems or len(systems) != len(states):
        raise ModelError("simulate_each needs equally many systems and states (at least one)")
    if workers is None:
        workers = os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ModelError(f"workers must be an integer >= 1 (threads), got {workers!r}")
    _check_on_failure(on_failure)
    run = dict(run, on_failure="return", progress=False)
    out: list = [None] * len(systems)
    out[0] = simulate(systems[0], states[0], **run)  # compiles the common program once
    stop = out[0].status == Failure.INTERRUPTED.reason  # Ctrl-C in it: start no other member

    def member(i):
        if not stop:
            out[i] = simulate(systems[i], states[i], **run)

    pool = ThreadPoolExecutor(max_workers=min(int(workers), max(len(systems) - 1, 1)))
    try:
        # the members' threads run in the caller's context (its compiler_options, if any:
        # the program compiled by the first member is theirs)
        for f in [pool.submit(contextvars.copy_context().run, member, i) for i in range(1, len(systems))]:
            f.result()
        if stop:
            raise KeyboardInterrupt
    except KeyboardInterrupt:
        stop = True
        pool.shutdown(wait=True, cancel_futures=True)
        done = [r for r in out if r is not None]
        raise SimulationInterrupted(f"interrupted: {len(done)} of {len(out)} members finished",
                                    time=max(float(r.t[-1]) for r in done), results=out) from None
    finally:
        pool.shutdown(wait=True)
    if on_failure == "raise":
        _raise_failed_members(out)
    return out


def _shard(tree, devices, batch: int):
    """Place the batched arrays of ``tree`` (leading axis ``batch``) split across ``devices``."""
    if batch % len(devices):
        raise ModelError(f"simulate_batch: the batch size {batch} must be a multiple of the "
                         f"{len(devices)} devices it is sharded across")
    from jax.sharding import Mesh, NamedSharding, PartitionSpec
    sharding = NamedSharding(Mesh(np.asarray(devices), ("batch",)), PartitionSpec("batch"))
    return jax.tree.map(lambda x: jax.device_put(x, sharding)
                        if eqx.is_array(x) and np.ndim(x) >= 1 and np.shape(x)[0] == batch else x, tree)


@eqx.filter_jit
def _adaptive_chunk(system, solver, context, y0, t0, ts, dt0):
    (q, v, w), result, steps = solver.solve(system, context, y0, t0, ts, dt0)
    acc, lam = solver.multipliers(system, context, q, v, ts)
    return q, v, w, acc, lam, adaptive_failure(result), steps


def _simulate_adaptive(system, state, solver, t0, n_int, out_dt, dt, per_chunk, n_chunks, options,
                      on_failure, progress):
    from .integrate import step_status
    name = solver.name
    context = jax.jit(solver.prepare)(system) if system.chain_size else None
    y0 = (state.q, state.v, jnp.zeros(3))
    ts_all = t0 + out_dt * np.arange(1, n_int + 1)
    pad = per_chunk * n_chunks - n_int
    ts_all = np.concatenate([ts_all, ts_all[-1] + out_dt * np.arange(1, pad + 1)])
    tc = time.perf_counter()
    chunk_c, _ = compiled(_adaptive_chunk, system, solver, context, y0, jnp.asarray(t0),
                          jnp.asarray(ts_all[:per_chunk]), jnp.asarray(dt))
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
    status, t_fail, steps = Failure.OK, None, 0
    y, t_start = y0, t0
    try:
        for c in range(n_chunks):
            ts = ts_all[c * per_chunk:(c + 1) * per_chunk]
            q, v, w, acc, lam, failure, nsteps = chunk_c(system, solver, context, y, jnp.asarray(t_start),
                                                         jnp.asarray(ts), jnp.asarray(dt))
            codes = np.asarray(status_fn(system, q, v, lam, jnp.asarray(ts)))
            if int(failure) != Failure.OK:
                # the rows diffrax did not reach are not finite: the solver's failure
                bad = ~np.all(np.isfinite(np.asarray(q)), axis=1)
                codes = np.where(bad, int(failure), codes)
                if np.all(codes == Failure.OK):
                    codes[-1] = int(failure)
            keep = len(ts) if np.all(codes == Failure.OK) else int(np.argmax(codes != Failure.OK))
            chunk = [np.asarray(arr)[:keep] for arr in (ts, q, v, acc, lam, w)] + [np.zeros(keep, int)]
            for k, arr in zip(("t", "q", "v", "acc", "lam", "work", "iterations"), chunk):
                rows[k].append(arr)
            steps += int(nsteps)
            if keep < len(ts):
                status = int(codes[keep])
                t_fail = float(ts[keep])
                break
            y, t_start = (q[-1], v[-1], w[-1]), float(ts[-1])
            bar.update(len(ts) * out_dt)
    except KeyboardInterrupt:
        n = min(len(v) for v in rows.values())  # a chunk's rows are appended together
        rows = {k: v[:n] for k, v in rows.items()}
        if sum(len(x) for x in rows["t"]) < n_int + 1:
            status, t_fail = Failure.INTERRUPTED, float(np.concatenate(rows["t"])[-1])
    finally:
        bar.close()
    wall = time.perf_counter() - tw
    cat = {k: np.concatenate(v)[: n_int + 1] for k, v in rows.items()}
    message = ""
    if status != Failure.OK:
        message = _failure_message(status, t_fail, system, options,
                                   last=(cat["q"][-1], cat["v"][-1], float(cat["t"][-1])),
                                   max_steps=solver.max_steps, solver=name)
    res = Results(system=system, solver=name, dt=float(dt), wall_time_s=wall, compile_time_s=compile_s,
                  status=Failure(status).reason, failure_time=t_fail,
                  message=message, info=dict(steps=steps), **cat)
    if status == Failure.INTERRUPTED and on_failure == "raise":
        raise SimulationInterrupted(message, time=t_fail, results=res)
    if status != Failure.OK and on_failure == "raise":
        raise SimulationError(message, time=t_fail, reason=Failure(status).reason, results=res)
    return res
