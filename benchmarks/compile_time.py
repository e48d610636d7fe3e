"""Compile time of ancf_jax in a fresh process (no in-process or persistent cache).

Measured in a child Python process (``JAX_COMPILATION_CACHE_DIR`` removed from its
environment, ``ANCF_JAX_CACHE=0``): M1 (6 elements, generalized-α defaults, h = 1 ms) through ``simulate``,
and the three-mesh M2 batch (12, 18, 24 elements padded to 24, M2's run settings)
through ``simulate_batch``. Reported: ``compile_time_s`` of the run (tracing, lowering
and XLA compilation of the initial-state and chunk programs) and the wall time of the
whole first call (compile + a short run). M2's static initial states are built (or read
from results/cache) before the clock starts. Then, each in another fresh process, the
same two programs of each case split into tracing + lowering and XLA compilation, one
after the other (in a run, the initial-state program's XLA compilation runs in a
background thread while the chunk program is traced: ``simulation.compiled_pair``).

    python -m benchmarks.compile_time [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

from .common import write

M2_COUNTS = (12, 18, 24)


def child(which: str) -> dict:
    from . import cases as C
    if which == "M1":
        from ancf_jax.simulation import simulate
        system, state = C.m1(6)
        t0 = time.perf_counter()
        r = simulate(system, state, t_end=0.05, dt=1e-3, progress=False)
        return dict(compile_s=r.compile_time_s, first_call_s=time.perf_counter() - t0, status=r.status)
    if which == "M1-parts":
        return _m1_parts()
    if which == "M2-parts":
        return _m2_parts()
    from ancf_jax.simulation import make_solver, simulate_batch
    built = [C.m2(n, pad_to=max(M2_COUNTS)) for n in M2_COUNTS]
    opts = C.ancf_settings("M2")
    t0 = time.perf_counter()
    rs = simulate_batch([b[0] for b in built], [b[1] for b in built], t_end=0.05, dt=1e-3,
                        solver=make_solver("generalized-alpha", **opts), on_failure="return", progress=False)
    return dict(compile_s=rs[0].compile_time_s, first_call_s=time.perf_counter() - t0,
                status=[r.status for r in rs], solver_options=opts)


def _program_parts(system, state, solver_options, *, batched) -> dict:
    """Where a first call's compile time goes: tracing + lowering vs XLA compilation,
    for the initial-state program and the chunk program, built exactly as
    ``simulate`` (``batched``: ``simulate_batch``) builds them for the child runs above
    (t_end = 0.05 s, dt = 1 ms)."""
    import jax.numpy as jnp

    from ancf_jax import _xla
    from ancf_jax import simulation as S
    options = S.RunOptions()
    solver, (n_int, sub, h, _), (per_chunk, _) = S._prepare(
        0.05, 1e-3, S.make_solver("generalized-alpha", **solver_options), None, options, S.RunLimits(),
        "return", batched=batched)
    solver = solver.forward_only()  # as S._run_fixed
    init_fn, chunk_fn = (S._init_batch, S._chunk_batch) if batched else (S._init_single, S._chunk_single)
    out = {}
    t0 = time.perf_counter()
    low = init_fn.lower(system, state, solver)
    t1 = time.perf_counter()
    init = low.compile(_xla.run_once_options())  # as S.compiled_pair compiles it
    t2 = time.perf_counter()
    out["init_lower_s"], out["init_xla_s"] = t1 - t0, t2 - t1
    loop, ctx = init(system, state, solver)
    args = (system, loop, ctx, solver, jnp.asarray(h), jnp.asarray(n_int * sub * h), per_chunk, sub, options)
    t0 = time.perf_counter()
    low = chunk_fn.lower(*args)
    t1 = time.perf_counter()
    low.compile()
    t2 = time.perf_counter()
    out["chunk_lower_s"], out["chunk_xla_s"] = t1 - t0, t2 - t1
    return out


def _m1_parts() -> dict:
    from . import cases as C
    return _program_parts(*C.m1(6), {}, batched=False)


def _m2_parts() -> dict:
    from ancf_jax.simulation import stack

    from . import cases as C
    built = [C.m2(n, pad_to=max(M2_COUNTS)) for n in M2_COUNTS]
    return _program_parts(stack([b[0] for b in built]), stack([b[1] for b in built]), C.ancf_settings("M2"),
                          batched=True)


def measure(which: str) -> dict:
    # no persistent cache in the child: neither JAX's setting nor the one ancf_jax turns
    # on at import (a warm ~/.cache/ancf_jax/xla made the second child of a case read
    # its programs from disk)
    env = {k: v for k, v in os.environ.items() if not k.startswith("JAX_COMPILATION_CACHE")}
    env["ANCF_JAX_CACHE"] = "0"
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "benchmarks.compile_time", "--child", which],
                       capture_output=True, text=True, env=env, cwd=os.path.dirname(os.path.dirname(__file__)))
    if p.returncode != 0:
        raise RuntimeError(f"compile-time child {which} failed:\n{p.stderr[-3000:]}")
    out = json.loads(p.stdout.strip().splitlines()[-1])
    out["process_s"] = time.perf_counter() - t0
    return out


def main(argv=None, *, quick=None, exudyn=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--child", default=None)
    args = ap.parse_args(argv or [])
    if args.child:
        print(json.dumps(child(args.child)))
        return None
    quick = args.quick if quick is None else quick
    m1 = measure("M1")
    print(f"compile M1: {m1['compile_s']:.1f} s (first call {m1['first_call_s']:.1f} s)", flush=True)
    m1["parts"] = measure("M1-parts")
    print(f"  M1 parts: {m1['parts']}", flush=True)
    m2 = measure("M2")
    print(f"compile M2 batch {M2_COUNTS}: {m2['compile_s']:.1f} s (first call {m2['first_call_s']:.1f} s)",
          flush=True)
    m2["parts"] = measure("M2-parts")
    print(f"  M2 parts: {m2['parts']}", flush=True)
    return write("compile_time", dict(section="compile_time", quick=quick, m1=m1, m2_batch=m2,
                                      m2_counts=M2_COUNTS,
                                      command="python -m benchmarks.run" + (" --quick" if quick else "")
                                      + " --only compile_time"))


if __name__ == "__main__":
    r = main(sys.argv[1:])
    if r is not None:
        print(r)
