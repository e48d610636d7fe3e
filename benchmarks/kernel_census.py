"""How many XLA:CPU kernels one step runs (issue 17: what dominates the small models' step).

XLA:CPU runs a compiled program as a sequence of kernels ("thunks": one per fusion, copy,
library call or loop), dispatched one after the other; a while loop dispatches its
body's kernels at every iteration. For a small model every kernel does a few dozen
floating-point operations, so the step's time is mostly how many kernels it runs. With
``--xla_cpu_enable_xprof_traceme=true`` every kernel execution is an event of
``jax.profiler``'s trace; this census counts them exactly, per step and by kind (the
kernel's name without its number: ``multiply_reduce_fusion``, ``copy``, ``lu``, ...).
The events' own times are not reported: the tracing adds about a microsecond to each.
The step's time comes from a second child without the flag.

Each case runs in two fresh child processes (the flag acts when JAX starts its
backend) on the bare generalized-α step (``lax.scan`` of the integrator's step, as
``benchmarks.step_profile``) at the settings ``results/single_run.json`` chose for the
model, from the model's initial state:

    python -m benchmarks.kernel_census [--quick]

Writes results/kernel_census.json (RESULTS.md renders it).
"""

from __future__ import annotations

import argparse
import collections
import glob
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .common import write

#: (model, elements, steps) of the census: M1 meshes (M2's bare step from the model's
#: initial state took 30 Newton iterations per step over its first 200 steps, against 2.1
#: in a run of ``simulate``: not representative, left out)
CASES = (("M1", 6, 400), ("M1", 12, 400), ("M1", 24, 200))
QUICK_CASES = (("M1", 3, 20),)
REPS = 5
ROOT = Path(__file__).resolve().parents[1]
TRACE_FLAG = "--xla_cpu_enable_xprof_traceme=true"
#: events that are not kernels: the executors, loops (their body's kernels are counted)
#: and the host-side transposes of LAPACK calls' operands
NOT_KERNELS = ("ThunkExecutor", "while", "Transpose", "end:")


def kind(name: str) -> str:
    """A kernel's kind: its name without XLA's instruction number."""
    return re.sub(r"[._]\d+$", "", name)


def _bare(name, n, steps):
    """(bare-step program, its argument, model facts) for the census."""
    from ancf_jax.simulation import make_solver

    from . import cases as C
    from .step_profile import make_bare_step
    h, opts = C.chosen_settings(name)
    system, state = C.m1(n) if name == "M1" else C.m2(n)
    solver = make_solver("generalized-alpha", **opts).forward_only()
    bare, carry, _ = make_bare_step(solver, system, state, h, steps)
    return bare, carry, dict(h=h, options=opts, coordinates=system.n_coordinates,
                             multipliers=system.n_constraints)


def child(name: str, n: int, steps: int, traced: bool) -> dict:
    """In the child: the bare step's time per step (untraced) or its kernel census."""
    import jax
    import numpy as np
    bare, carry, info = _bare(name, n, steps)
    carry, its = jax.block_until_ready(bare(carry))  # compiles; the census starts a step later
    out = dict(info, iterations_per_step=float(np.mean(np.asarray(its))))
    if not traced:
        best = float("inf")
        for _ in range(REPS):
            t0 = time.perf_counter()
            jax.block_until_ready(bare(carry))
            best = min(best, time.perf_counter() - t0)
        return dict(out, step_s=best / steps)
    with tempfile.TemporaryDirectory() as d:
        with jax.profiler.trace(d):
            jax.block_until_ready(bare(carry))
        data = jax.profiler.ProfileData.from_file(glob.glob(d + "/**/*.xplane.pb", recursive=True)[0])
        counts = collections.Counter()
        for plane in data.planes:
            for line in plane.lines:
                if "XLAEigen" not in line.name:  # XLA:CPU's kernel threads
                    continue
                for ev in line.events:
                    if not ev.name.startswith(NOT_KERNELS):
                        counts[kind(ev.name)] += 1
    return dict(out, kernels_per_step=sum(counts.values()) / steps,
                kinds={k: c / steps for k, c in counts.most_common()})


def measure(name: str, n: int, steps: int) -> dict:
    """Both children of one case; the census and the time merged."""
    out = {}
    for traced in (False, True):
        env = {k: v for k, v in os.environ.items() if not k.startswith("JAX_COMPILATION_CACHE")}
        env.update(ANCF_JAX_CACHE="0", XLA_FLAGS=" ".join(filter(None, [os.environ.get("XLA_FLAGS", ""),
                                                                        TRACE_FLAG if traced else ""])),
                   PYTHONPATH=os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]))
        p = subprocess.run([sys.executable, "-m", "benchmarks.kernel_census", "--child", name, str(n), str(steps),
                            str(int(traced))], capture_output=True, text=True, env=env, cwd=ROOT)
        if p.returncode != 0:
            raise RuntimeError(f"kernel census child {name} {n} failed:\n{p.stderr[-3000:]}")
        out.update(json.loads(p.stdout.strip().splitlines()[-1]))
    out.update(model=name, elements=n, steps=steps,
               ns_per_kernel=out["step_s"] / out["kernels_per_step"] * 1e9,
               kernels_per_iteration=out["kernels_per_step"] / max(out["iterations_per_step"], 1e-12))
    return out


def main(argv=None, *, quick=None) -> dict:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv or [])
    quick = args.quick if quick is None else quick
    rows = []
    for name, n, steps in QUICK_CASES if quick else CASES:
        r = measure(name, n, steps)
        rows.append(r)
        print(f"kernel census {name} ({n} el.): {r['kernels_per_step']:.0f} kernels per step "
              f"({r['iterations_per_step']:.2f} Newton it.), {r['step_s'] * 1e6:.1f} µs per step, "
              f"{r['ns_per_kernel']:.0f} ns per kernel", flush=True)
    return write("kernel_census", dict(quick=quick, rows=rows, flag=TRACE_FLAG,
                                       command="python -m benchmarks.kernel_census" + (" --quick" if quick else "")))


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        name, n, steps, traced = sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), bool(int(sys.argv[5]))
        print(json.dumps(child(name, n, steps, traced)))
    else:
        print(main(sys.argv[1:]))
