"""Loop kernels (``ANCF_JAX_LOOP_KERNELS=1``, :mod:`ancf_jax._xla`) against XLA's
default of one dispatched kernel per fusion: run time and compile time per model size,
and the M1 single run against Exudyn.

Every ancf_jax measurement is a fresh child process (the setting acts when JAX starts
its backend) without any compilation cache (``ANCF_JAX_CACHE=0``, no
``JAX_COMPILATION_CACHE_DIR``) and with ancf_jax's own XLA flags only (``XLA_FLAGS``
removed from its environment). Each child runs its model at the settings
``results/single_run.json`` chose for ancf_jax (M1's for every M1 mesh), output at every
step as in ``single_run``: the first call (compile + run), then the median of ``REPS``
runs. Exudyn runs M1 at its own chosen settings in this process, ``REPS`` times before
the children and ``REPS`` times after them (median of all). The two settings' outputs
are compared point by point (they differ by rounding only: other instruction orders).

    python -m benchmarks.loop_kernels [--quick]

Writes results/loop_kernels.json (RESULTS.md renders it).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from . import cases as C
from .common import write

#: (model, elements, end time [s]); M1 meshes at M1's chosen settings
CASES = (("M1", 6, 2.0), ("M1", 12, 2.0), ("M1", 24, 2.0), ("M2", 24, 3.0))
QUICK_CASES = (("M1", 6, 0.5),)
REPS = 5
ROOT = Path(__file__).resolve().parents[1]


def child(name: str, n: int, t_end: float, out: str) -> dict:
    """In the child: first call and median run of one model; its output saved to ``out``."""
    from ancf_jax import _xla
    h, opts = C.chosen_settings(name)
    system, state = C.m1(n) if name == "M1" else C.m2(n)
    t0 = time.perf_counter()
    first = C.run_ancf(name, system, state, t_end=t_end, dt=h, options=opts)
    first_call = time.perf_counter() - t0
    runs = [C.run_ancf(name, system, state, t_end=t_end, dt=h, options=opts) for _ in range(REPS)]
    np.save(out, np.asarray(runs[-1].y))
    return dict(compile_s=first.setup_s, first_call_s=first_call, run_s=C.median([r.run_s for r in runs]),
                status=runs[-1].status, steps=runs[-1].steps, iterations=runs[-1].iterations, dt=h,
                options=opts, loop_kernels=_xla.loop_kernels(), xla_flags=os.environ.get("XLA_FLAGS"))


def measure(name: str, n: int, t_end: float, loop_kernels: bool, out: str) -> dict:
    env = {k: v for k, v in os.environ.items()
           if not k.startswith("JAX_COMPILATION_CACHE") and k not in ("XLA_FLAGS", "ANCF_JAX_XLA_FLAGS")}
    env.update(ANCF_JAX_CACHE="0", ANCF_JAX_LOOP_KERNELS="1" if loop_kernels else "0",
               PYTHONPATH=os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]))
    p = subprocess.run([sys.executable, "-m", "benchmarks.loop_kernels", "--child", name, str(n), str(t_end), out],
                       capture_output=True, text=True, env=env, cwd=ROOT)
    if p.returncode != 0:
        raise RuntimeError(f"loop-kernel child {name} {n} failed:\n{p.stderr[-3000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def exudyn_m1(t_end: float, reps: int) -> list[float]:
    dt, opts = C.chosen_settings("M1", "exudyn")
    system, state = C.m1(6)
    return [C.run_exudyn("M1", system, state, t_end=t_end, dt=dt, options=opts).run_s for _ in range(reps)]


def main(argv=None, *, quick=None, exudyn=True) -> dict:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv or [])
    quick = args.quick if quick is None else quick
    cases = QUICK_CASES if quick else CASES
    m1_end = cases[0][2]
    ex = exudyn_m1(m1_end, REPS) if exudyn else []
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, n, t_end in cases:
            row = dict(model=name, elements=n, t_end=t_end)
            for mode in (False, True):
                key = "loop_kernels" if mode else "default"
                row[key] = measure(name, n, t_end, mode, str(Path(tmp) / f"{key}.npy"))
            a, b = np.load(Path(tmp) / "default.npy"), np.load(Path(tmp) / "loop_kernels.npy")
            row["max_difference_m"] = float(np.max(np.abs(a - b))) if a.shape == b.shape else float("inf")
            row["run_ratio"] = row["loop_kernels"]["run_s"] / row["default"]["run_s"]
            row["compile_ratio"] = row["loop_kernels"]["compile_s"] / row["default"]["compile_s"]
            rows.append(row)
            print(json.dumps(row, default=float), flush=True)
    if exudyn:
        ex += exudyn_m1(m1_end, REPS)
    out = dict(quick=quick, reps=REPS, rows=rows)
    if ex:
        m1 = rows[0]
        e = C.median(ex)
        out["exudyn_m1"] = dict(run_s=e, runs_s=ex, dt=C.chosen_settings("M1", "exudyn")[0],
                                options=C.chosen_settings("M1", "exudyn")[1], t_end=m1_end)
        out["m1_ratio_default"] = m1["default"]["run_s"] / e
        out["m1_ratio_loop_kernels"] = m1["loop_kernels"]["run_s"] / e
    print(json.dumps({k: v for k, v in out.items() if k != "rows"}, default=float))
    write("loop_kernels", out)
    return out


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        name, n, t_end, out = sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
        print(json.dumps(child(name, n, t_end, out), default=float))
    else:
        main(sys.argv[1:])
