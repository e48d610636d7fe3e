"""Throughput of the M1 sweep: local backend vs Ray with 1 and 2 workers on this
machine, and Ray's per-member overhead against one vmapped batch.

    python -m benchmarks.sweep_throughput --quick     # 3 elements, 0.05 s, 8 members
    python -m benchmarks.sweep_throughput             # 6 elements, 0.5 s, 64 members

Each configuration runs the same grid over Rayleigh alpha twice (the first run pays
the compilation, the second reuses the programs: local in-process cache, Ray workers
their processes and the persistent cache); members/s of the second run is reported.
Overhead per member = (Ray wall − local batch wall) / members. Writes
benchmarks/results/sweep_throughput.json. Needs the sweep extra.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path


def _sweep(backend, members, overrides, chunk, tmp, tag):
    from ancf_jax.sweep import run_sweep
    t0 = time.perf_counter()
    ds = run_sweep("m1", [f"beams.beam.alpha=[{', '.join(str(0.01 + 0.001 * i) for i in range(members))}]"],
                   design="grid", overrides=overrides, backend=backend, chunk_size=chunk, progress=False,
                   out=Path(tmp) / f"{tag}.zarr")
    wall = time.perf_counter() - t0
    assert list(ds["status"].values).count("ok") == members
    return wall


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--workers", default="1,2", help="Ray worker counts (default 1,2)")
    args = ap.parse_args(argv)
    n_el, t_end, members = (3, 0.05, 8) if args.quick else (6, 0.5, 64)
    overrides = [f"beams.beam.elements={n_el}", f"solver.t_end={t_end}"]
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(2):
            wall = _sweep("local", members, overrides, members, tmp, f"local{rep}")
        rows["local (one vmapped batch)"] = dict(wall_s=wall, members_per_s=members / wall)
        import ray
        for w in (int(x) for x in args.workers.split(",")):
            os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
            ray.init(address="local", num_cpus=w, include_dashboard=False, log_to_driver=False,
                     logging_level="ERROR")
            chunk = max(1, members // (2 * w))
            for rep in range(2):
                wall = _sweep("ray", members, overrides, chunk, tmp, f"ray{w}_{rep}")
            ray.shutdown()
            rows[f"ray, {w} worker(s), chunks of {chunk}"] = dict(wall_s=wall, members_per_s=members / wall)
    base = rows["local (one vmapped batch)"]["wall_s"]
    for r in rows.values():
        r["overhead_per_member_s"] = (r["wall_s"] - base) / members
    out = dict(model="m1", elements=n_el, t_end=t_end, members=members, quick=args.quick,
               cpus=os.cpu_count(), rows=rows)
    path = Path(__file__).parent / "results" / "sweep_throughput.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(out, indent=2))
    for k, r in rows.items():
        print(f"{k:40s} {r['members_per_s']:8.2f} members/s  wall {r['wall_s']:7.2f} s  "
              f"overhead {r['overhead_per_member_s'] * 1e3:+8.1f} ms/member")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
