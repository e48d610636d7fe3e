"""Batch throughput on an accelerator: the M1 rows of ``batch.py`` (the same seeded
variants of α and E, 1 to 1024 of them in one vmapped program) and the M2 s₀ variants,
run where JAX's default backend is a GPU. Writes ``results/batch_gpu.json``; the report
puts its rows beside the CPU batch (the Exudyn reference is the CPU machine's one run,
from ``results/batch.json``: a cross-machine ratio, stated as such).

Settings: the M1 equal-accuracy settings of ancf_jax from ``results/single_run.json``
whatever its mode (so the GPU rows run what the CPU batch rows run), else h = 1 ms;
``linear_solver`` is dropped as in ``batch.py`` unless ``--dense`` (batched dense LU: one
batched factorization instead of the block-tridiagonal scan's many small kernels;
written to ``results/batch_gpu_dense.json``). Not part of ``python -m benchmarks.run``
(it needs a GPU); on a machine with one::

    python -m benchmarks.batch_gpu [--quick] [--dense] [--sizes 1,8,64,256,1024] [--t-end 2.0]

The JSON is rewritten after every batch size, so an interrupted run keeps its rows.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from . import cases as C
from .batch import FULL, QUICK, m1_batch_row, s0_batch
from .common import RESULTS, write


def settings() -> dict:
    """ancf_jax's M1 equal-accuracy settings from single_run.json (either mode)."""
    path = RESULTS / "single_run.json"
    if path.exists():
        data = json.loads(path.read_text())
        for row in data.get("rows", []):
            c = row.get("ancf_jax", {}).get("chosen") if row["model"] == "M1" else None
            if c:
                return dict(dt=c["dt"], options=C.ancf_options(c["options"]),
                            source="single_run.json" + (" (quick)" if data.get("quick") else ""))
    return dict(dt=1e-3, options={}, source="default")


def main(argv=None) -> str:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="sizes 1, 8, 64; 0.5 s; one repetition")
    ap.add_argument("--sizes", default=None, help="comma-separated batch sizes (default: 1,8,64,256,1024)")
    ap.add_argument("--t-end", type=float, default=None, help="simulated span [s] (default 2, quick 0.5)")
    ap.add_argument("--no-s0", action="store_true", help="skip the M2 s0 variants")
    ap.add_argument("--dense", action="store_true", help="dense LU (batched) instead of the block-tridiagonal solver")
    args = ap.parse_args(argv)
    import jax
    plan = dict(QUICK if args.quick else FULL)
    if args.sizes:
        plan["sizes"] = tuple(int(s) for s in args.sizes.split(","))
    if args.t_end:
        plan["t_end"] = args.t_end
    device = jax.devices()[0]
    a = settings()
    options = {k: v for k, v in a["options"].items() if k not in ("dense", "linear_solver")}
    if args.dense:
        options["linear_solver"] = "dense"
    name = "batch_gpu_dense" if args.dense else "batch_gpu"
    system, state = C.m1(6)
    out = dict(section="batch_gpu", quick=args.quick, exudyn=False, backend=jax.default_backend(),
               device=getattr(device, "device_kind", str(device)), t_end=plan["t_end"],
               model="M1, 6 elements", parameters="alpha ~ U(0.01, 0.05) 1/s, E ~ U(180, 220) GPa, seed 0",
               settings=dict(ancf_jax={**a, "options": options}), rows=[],
               command="python -m benchmarks.batch_gpu" + (" --quick" if args.quick else "")
               + (" --dense" if args.dense else ""))
    for n in plan["sizes"]:
        row, final = m1_batch_row(system, state, n, plan, a["dt"], options, label="GPU batch")
        row["ancf_jax"]["final_tip_y_first"] = final[: min(n, 8)]
        out["rows"].append(row)
        path = write(name, out)
    if not args.no_s0:
        out["s0"] = s0_batch(plan["s0"], exudyn=False, dense=args.dense)
        path = write(name, out)
    return str(path)


if __name__ == "__main__":
    print(main())
