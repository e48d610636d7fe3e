"""Planning and running a sweep: validation (before anything is compiled), grouping of
members into chunks of one shape, the chunk task that a backend runs, and the loop
that stores each finished chunk.

A chunk is plain data (:class:`ChunkTask`): the scenario source, the ``--set`` items of
each member, the padding and the run settings; :func:`run_chunk` builds the members'
systems, runs them as one vmapped :func:`~ancf_jax.simulation.simulate_batch` and
returns the named outputs, statuses and timings as NumPy arrays. The same function runs
in this process (backend ``local``) or as a Ray task (backend ``ray``).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import socket
import time
from typing import Sequence

import numpy as np

from .._version import __version__
from ..errors import ModelError
from ..failures import Failure
from ..scenario import ScenarioError, load_scenario
from ..scenario.scenario import RunSettings
from ..outputs import output_units
from ..simulation import FIXED_STEP_SOLVERS, run_size, time_grid
from .design import Param, SweepError, make_design, override

#: default memory budget of one chunk's histories [bytes]
CHUNK_BYTES = 1 << 30
#: largest chunk (members per vmapped program)
MAX_CHUNK = 256


@dataclasses.dataclass(frozen=True)
class SweepDefinition:
    """What a sweep computes (stored in the store; ``--resume`` checks it)."""

    model: str
    params: tuple[Param, ...]
    design: str = "lhs"
    samples: int | None = None
    levels: int = 3
    seed: int = 0
    overrides: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        return dict(model=self.model, params=[p.to_dict() for p in self.params], design=self.design,
                    samples=self.samples, levels=self.levels, seed=self.seed, overrides=list(self.overrides))

    @classmethod
    def from_dict(cls, d: dict) -> "SweepDefinition":
        return cls(model=d["model"], params=tuple(Param.from_dict(p) for p in d["params"]),
                   design=d["design"], samples=d["samples"], levels=d["levels"], seed=d["seed"],
                   overrides=tuple(d["overrides"]))


@dataclasses.dataclass(frozen=True)
class ChunkTask:
    """One vmapped chunk: plain data, picklable (Ray ships it to a worker).

    Attributes:
        source: scenario (shipped name or path, readable where the chunk runs).
        overrides: the sweep's own ``--set`` items (every member).
        members: member indices.
        member_overrides: per member, its ``--set`` items.
        pad_to: element slots per beam (one shape for the whole sweep).
        run: keyword arguments of :func:`~ancf_jax.simulation.simulate_batch`.
        batch: members per program (the chunk is padded to it with copies, so
            that every chunk of a group reuses one compiled program).
        outputs: names of the outputs to return.
        devices: shard the batch across all local JAX devices.
    """

    source: str
    overrides: tuple[str, ...]
    members: tuple[int, ...]
    member_overrides: tuple[tuple[str, ...], ...]
    pad_to: tuple[tuple[str, int], ...]
    run: tuple[tuple[str, object], ...]
    batch: int
    outputs: tuple[str, ...]
    devices: bool = False


@dataclasses.dataclass
class Plan:
    """A validated sweep: member values, groups of equal run settings, chunks."""

    definition: SweepDefinition
    values: dict[str, list]
    outputs: list[str]
    times: np.ndarray
    chunks: list[ChunkTask]
    chunk_size: int
    units: dict = dataclasses.field(default_factory=dict)

    @property
    def n_members(self) -> int:
        return len(next(iter(self.values.values())))


def _signature(system, state):
    import jax
    # the beams' static β-rate switch differs between β = 0 and β != 0 members; the
    # batch sets it on for all (simulate_batch), so it is not part of the shape
    leaves, treedef = jax.tree.flatten((system.with_rate_stiffness(True), state))
    return treedef, tuple(np.shape(x) for x in leaves)


def _load(source, items, key=None):
    try:
        return load_scenario(source, list(items))
    except ScenarioError as e:
        if key is None:
            raise SweepError(str(e)) from None
        raise SweepError(f"--param {key}: {e}") from None


def _run_kwargs(sc) -> dict:
    """The scenario's run settings as plain data (a chunk task's ``run``; grouping key)."""
    kw = dataclasses.asdict(sc.solver)
    kw["solver_options"] = dict(sorted(kw["solver_options"].items()))
    return kw


def _freeze(d: dict) -> tuple:
    return tuple((k, tuple(sorted(v.items())) if isinstance(v, dict) else v) for k, v in sorted(d.items()))


def plan(definition: SweepDefinition, *, chunk_size: int | None = None, workers: int = 1,
         multiple: int = 1, devices: bool = False) -> Plan:
    """Validate a sweep and split it into chunks; nothing is compiled.

    Each parameter is tried at its extremes (range ends, every listed value): an unknown
    key or a value outside what the scenario accepts, or a key that changes the model's
    array shapes (other than element counts, which are padded to the largest), raises
    :class:`~ancf_jax.sweep.design.SweepError` with one line. Members with different
    run settings (``solver.dt``, ``solver.t_end``, ``outputs.dt``, ...) go into
    separate chunks. ``chunk_size`` (default: as many members as keep at most
    :data:`CHUNK_BYTES` of histories (:func:`member_bytes` each), at most
    :data:`MAX_CHUNK`, and split so that ``workers`` have work) is rounded up to a
    multiple of ``multiple`` (the number of devices a chunk is sharded across).
    """
    d = definition
    base = _load(d.model, d.overrides)
    if base.solver.solver not in FIXED_STEP_SOLVERS:
        raise SweepError(f"solver.name: sweeps run fixed-step solvers in vmapped chunks, got "
                         f"{base.solver.solver!r} (accepted: {', '.join(FIXED_STEP_SOLVERS)})")
    outputs = [o.name for o in base.outputs]
    if not outputs:
        raise SweepError(f"{d.model}: the scenario names no outputs (accepted: a scenario with "
                         f"[outputs.columns])")
    values = make_design(d.params, d.design, samples=d.samples, levels=d.levels, seed=d.seed)
    # padding: every beam to the largest element count any member gives it
    pad = dict(base.beam_elements)
    for p in d.params:
        parts = p.key.split(".")
        if p.integer:
            if len(parts) != 3 or parts[0] != "beams" or parts[1] not in pad:
                raise SweepError(f"--param {p.key}: no such beam (accepted: beams.NAME.elements with NAME "
                                 f"one of {', '.join(pad)})")
            counts = values[p.key]
            if any(not isinstance(c, int) or isinstance(c, bool) for c in counts):
                raise SweepError(f"--param {p.key}: element counts must be integers, got {counts[0]!r}")
            pad[parts[1]] = max(pad[parts[1]], max(counts))
    pad_to = tuple(sorted(pad.items()))
    ref = base.build(pad_to=dict(pad_to))
    sig = _signature(*ref)
    for p in d.params:
        extremes = list(p.values) if p.values is not None else sorted(set(p.levels(2)))
        for v in extremes:
            sc = _load(d.model, list(d.overrides) + [override(p.key, v)], p.key)
            if p.integer:
                continue
            try:
                built = sc.build(pad_to=dict(pad_to))
            except ModelError as e:
                raise SweepError(f"--param {p.key}: at {v!r}: {e}") from None
            if _signature(*built) != sig:
                raise SweepError(f"--param {p.key}: changes the model's array shapes (at {v!r}); only element "
                                 f"counts (beams.NAME.elements) may change shapes, they are padded")
    n = len(next(iter(values.values())))
    items = [tuple(override(k, values[k][i]) for k in values) for i in range(n)]
    # group by run settings (step, span, outputs): each group has its own programs
    time_keys = [p.key for p in d.params if p.key.split(".")[0] in ("solver", "outputs")]
    groups: dict[tuple, list[int]] = {}
    kwargs: dict[tuple, dict] = {}
    for i in range(n):
        sc = base if not time_keys else _load(
            d.model, list(d.overrides) + [it for it in items[i] if it.split("=")[0] in time_keys])
        kw = _run_kwargs(sc)
        key = _freeze(kw)
        groups.setdefault(key, []).append(i)
        kwargs[key] = kw
    grids = {key: _times(kw) for key, kw in kwargs.items()}
    times = np.unique(np.concatenate(list(grids.values())))
    if len(times) > 1:  # merge times equal to rounding
        keep = np.concatenate([[True], np.diff(times) > 1e-12 * max(1.0, times[-1])])
        times = times[keep]
    dofs, n_mult = int(np.asarray(ref[1].q).size), int(ref[0].n_constraints)
    chunks = []
    size = chunk_size
    for key, members in groups.items():
        if chunk_size is None:
            per_member = member_bytes(kwargs[key], dofs, n_mult)
            size = max(1, min(MAX_CHUNK, CHUNK_BYTES // per_member, math.ceil(len(members) / max(1, workers))))
        size = int(math.ceil(size / multiple) * multiple)
        for s in range(0, len(members), size):
            part = members[s:s + size]
            chunks.append(ChunkTask(source=d.model, overrides=tuple(d.overrides), members=tuple(part),
                                    member_overrides=tuple(items[i] for i in part), pad_to=pad_to,
                                    run=tuple(sorted(kwargs[key].items())), batch=size,
                                    outputs=tuple(outputs), devices=devices))
    return Plan(definition=d, values=values, outputs=outputs, times=times, chunks=chunks,
                chunk_size=size or 1, units=output_units(base.outputs))


def member_bytes(run: dict, n_coordinates: int, n_multipliers: int) -> int:
    """Bytes of one member's history in a chunk's output (``run``: a chunk's run
    settings), as :func:`~ancf_jax.simulation.simulate_batch` counts them against
    ``max_output_bytes`` (:func:`~ancf_jax.simulation.run_size`)."""
    n_int, sub, _, _ = time_grid(run["t_end"], run["dt"], run["output_dt"])
    return run_size(n_int, sub, n_coordinates, n_multipliers)[1]


def _times(kw) -> np.ndarray:
    n_int, _, _, out_dt = time_grid(kw["t_end"], kw["dt"], kw["output_dt"])
    return out_dt * np.arange(n_int + 1)


def run_chunk(task: ChunkTask) -> dict:
    """Build and run the members of one chunk as one vmapped batch.

    Never raises for a member: a member whose scenario is rejected gets status
    ``"invalid"``, a failed run its failure's reason; an exception of the whole batch
    gives every member ``"error"`` (with its message). Ctrl-C raises
    ``KeyboardInterrupt`` (also when it stopped the batch's time loop, which would
    otherwise return members cut short): the chunk is not stored, ``--resume`` reruns it.
    Returns plain NumPy data: ``members``, ``times``, ``outputs`` {name: (members,
    times)}, ``status``, ``message``, ``failure_time``, and ``compile_s`` (seconds spent
    compiling now; 0.0 when this process had the program), ``wall_s``, ``pid``,
    ``host``, ``compilation_cache`` (the JAX persistent cache directory it used, or None).
    """
    from ..outputs import evaluate
    from ..simulation import simulate_batch
    import jax

    kw = dict(task.run)
    times = _times(kw)
    n, t = len(task.members), len(times)
    out = dict(members=list(task.members), times=times,
               outputs={k: np.full((n, t), np.nan) for k in task.outputs},
               status=[""] * n, message=[""] * n, failure_time=[math.nan] * n,
               compile_s=0.0, wall_s=0.0, pid=os.getpid(), host=socket.gethostname(),
               compilation_cache=jax.config.jax_compilation_cache_dir)
    built, ok = [], []
    outputs = None
    for i, items in enumerate(task.member_overrides):
        try:
            sc = load_scenario(task.source, list(task.overrides) + list(items))
            built.append(sc.build(pad_to=dict(task.pad_to)))
            outputs = sc.outputs if outputs is None else outputs
            ok.append(i)
        except (ScenarioError, ModelError) as e:
            out["status"][i], out["message"][i] = "invalid", str(e)
    if not ok:
        return out
    fill = task.batch - len(ok)
    systems = [b[0] for b in built] + [built[-1][0]] * fill
    states = [b[1] for b in built] + [built[-1][1]] * fill
    t0 = time.perf_counter()
    try:
        results = simulate_batch(systems, states, **RunSettings(**kw).simulate_kwargs(), on_failure="return",
                                 progress=False, devices=jax.devices() if task.devices else None)
    except Exception as e:  # noqa: BLE001 - a chunk never stops the sweep
        for i in ok:
            out["status"][i], out["message"][i] = "error", f"{type(e).__name__}: {e}".splitlines()[0]
        return out
    if any(r.status == Failure.INTERRUPTED.reason for r in results):
        raise KeyboardInterrupt  # Ctrl-C in the time loop: members cut short are not results
    out["wall_s"] = time.perf_counter() - t0
    out["compile_s"] = results[0].compile_time_s
    for i, r in zip(ok, results):
        cols = evaluate(r, outputs)
        rows = len(cols["t"])
        for k in task.outputs:
            out["outputs"][k][i, :rows] = cols[k]
        out["status"][i] = r.status
        out["message"][i] = r.message
        out["failure_time"][i] = math.nan if r.failure_time is None else float(r.failure_time)
    return out


def run_sweep(model: str, params: Sequence[Param | str], *, out, design: str = "lhs",
              samples: int | None = None, levels: int = 3, seed: int = 0, overrides: Sequence[str] = (),
              backend: str = "local", address: str | None = None, resume: bool = False,
              chunk_size: int | None = None, progress: bool | None = None, on_chunk=None):
    """Run a parameter sweep of a scenario and store it (see :mod:`ancf_jax.sweep`).

    Args:
        model: shipped scenario name or scenario file.
        params: :class:`~ancf_jax.sweep.design.Param` or ``"KEY=LOW:HIGH[:log]"`` /
            ``"KEY=[V1, V2]"`` strings.
        out: the Zarr store (a directory; must not exist unless ``resume``).
        design: the design (see :func:`~ancf_jax.sweep.design.make_design`).
        samples: members (random, lhs, sobol) or base samples (saltelli).
        levels: grid levels per range.
        seed: design seed.
        overrides: ``--set`` items applied to every member.
        backend: ``"local"`` (this process, the batch sharded across ``jax.devices()``)
            or ``"ray"`` (chunks as Ray tasks; ``address`` of a running cluster, None: the
            initialized one or a new local one).
        resume: complete an existing store of the same sweep (only missing members run).
        chunk_size: members per vmapped chunk (default: sized to memory).
        progress: progress bar (members/s, ETA); None: only on a terminal.
        on_chunk: called with each finished chunk's result dict (after it is stored).

    Returns:
        the store as an xarray Dataset (``xarray.open_zarr``).
    """
    from . import store
    from .backends import get_backend
    params = tuple(p if isinstance(p, Param) else _parse(p) for p in params)
    definition = SweepDefinition(model=str(model), params=params, design=design, samples=samples,
                                 levels=levels, seed=seed, overrides=tuple(overrides))
    runner = get_backend(backend, address=address)
    if resume:
        if not os.path.exists(out):
            raise SweepError(f"--resume: no store at {out} (accepted: the --out of an interrupted sweep)")
        old = store.definition(out)
        if old != json.loads(json.dumps(definition.to_dict())):
            raise SweepError(f"--resume: {out} holds a different sweep ({old['model']}, "
                             f"{', '.join(p['key'] for p in old['params'])}, design {old['design']}); "
                             f"give the same model, --param, --design, --samples, --levels, --seed and --set")
    else:
        store.check_new(out)
    p = plan(definition, chunk_size=chunk_size, workers=runner.workers, multiple=runner.multiple,
             devices=runner.multiple > 1)
    if not resume:
        store.create(out, definition.to_dict(), p.values, p.times, p.outputs, p.chunk_size, p.units)
    done = store.stored(out)
    run = store.next_run(out)
    tasks = []
    for c in p.chunks:
        todo = [k for k, m in enumerate(c.members) if not done[m]]
        if not todo:
            continue
        if len(todo) < len(c.members):
            c = dataclasses.replace(c, members=tuple(c.members[k] for k in todo),
                                    member_overrides=tuple(c.member_overrides[k] for k in todo))
        tasks.append(c)
    total = sum(len(c.members) for c in tasks)
    meta = dict(run=run, backend=runner.name, started=time.time(), members=total, chunks=len(tasks),
                chunk_size=p.chunk_size, ancf_jax=__version__, **runner.describe())
    from tqdm.auto import tqdm
    bar = tqdm(total=total, unit="member", desc=f"sweep {definition.model}", disable=progress is False,
               delay=0 if progress else 1.0, smoothing=0.1)
    t0 = time.perf_counter()
    written = set()
    compile_s = 0.0
    stored_now = 0
    try:
        for result in runner.run(tasks):
            # a member is stored once: a second result of it (a chunk Ray ran twice) is
            # dropped; one with status "error" (not stored) may be replaced by a later one
            fresh = sorted(m for m in result["members"] if m not in written and not done[m])
            if fresh:
                store.write(out, fresh, p.times, result, run)
                ok = {m for m, s in zip(result["members"], result["status"]) if s != "error"} & set(fresh)
                written.update(ok)
                stored_now += len(ok)
            compile_s += result["compile_s"]
            bar.update(len(fresh))
            if on_chunk is not None:
                on_chunk(result)
    finally:
        bar.close()
        meta.update(wall_s=time.perf_counter() - t0, stored=stored_now, compile_s_sum=compile_s,
                    completed=stored_now == total)
        store.add_run(out, meta)
    return store.open_store(out)


def _parse(text: str) -> Param:
    from .design import parse_param
    return parse_param(text)
