"""Throughput of the M1 sweep: local backend vs Ray with 1 and 2 workers on this
machine, and Ray's per-member overhead at equal chunk size.

    python -m benchmarks.sweep_throughput --quick     # 3 elements, 0.05 s, 8 members
    python -m benchmarks.sweep_throughput             # 6 elements, 0.5 s, 64 members

Each configuration runs the same grid over Rayleigh alpha twice (the first run pays
the compilation, the second reuses the programs: local in-process cache, Ray workers
their processes and the persistent cache); the second run is reported.

Configurations: Ray with 1 worker and one chunk of all members (one task running the
same vmapped batch as the local backend's one batch), Ray with W workers and chunks of
members / (2 W), and the local backend with each of these chunk sizes. Ray's overhead
per member = (Ray wall − local wall with the same chunk size) / members, for 1 worker
(the same batches, one after another, in a Ray worker instead of this process: what
Ray adds, tasks, pickling and result transfer); with W > 1 workers the ratio of the
local wall to Ray's is the speed-up from running chunks in parallel. Writes
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
    workers = [int(x) for x in args.workers.split(",")]
    # (workers, chunk size) of the Ray runs: one chunk of all members on 1 worker (the
    # local batch as one task), then chunks of members / (2 W) on W workers
    ray_runs = [(1, members)] * (1 in workers) + [(w, max(1, members // (2 * w))) for w in workers]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        local = {}
        for chunk in sorted({c for _, c in ray_runs} | {members}, reverse=True):
            for rep in range(2):
                wall = _sweep("local", members, overrides, chunk, tmp, f"local{chunk}_{rep}")
            local[chunk] = wall
            rows.append(dict(backend="local", workers=1, chunk=chunk, wall_s=wall, members_per_s=members / wall))
        import ray
        for w in sorted({w for w, _ in ray_runs}):
            os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
            ray.init(address="local", num_cpus=w, include_dashboard=False, log_to_driver=False,
                     logging_level="ERROR")
            for chunk in [c for ww, c in ray_runs if ww == w]:
                for rep in range(2):
                    wall = _sweep("ray", members, overrides, chunk, tmp, f"ray{w}_{chunk}_{rep}")
                row = dict(backend="ray", workers=w, chunk=chunk, wall_s=wall, members_per_s=members / wall,
                           local_wall_s_same_chunk=local[chunk], speedup_over_local=local[chunk] / wall)
                if w == 1:
                    row["overhead_per_member_s"] = (wall - local[chunk]) / members
                rows.append(row)
            ray.shutdown()
    out = dict(model="m1", elements=n_el, t_end=t_end, members=members, quick=args.quick,
               cpus=os.cpu_count(), rows=rows)
    path = Path(__file__).parent / "results" / "sweep_throughput.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(out, indent=2))
    for r in rows:
        extra = (f"  overhead {r['overhead_per_member_s'] * 1e3:+7.2f} ms/member" if "overhead_per_member_s" in r
                 else f"  speed-up {r['speedup_over_local']:.2f}x" if "speedup_over_local" in r else "")
        print(f"{r['backend']:5s} {r['workers']} worker(s), chunks of {r['chunk']:3d}: {r['members_per_s']:8.2f} "
              f"members/s  wall {r['wall_s']:7.2f} s{extra}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
