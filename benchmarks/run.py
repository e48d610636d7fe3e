"""Run the ancf_jax ↔ Exudyn benchmarks and regenerate benchmarks/RESULTS.md.

    python -m benchmarks.run [--quick] [--only NAME[,NAME]] [--no-exudyn] [--report-only]

Sections (in this order; each writes benchmarks/results/NAME.json): agreement,
single_run, batch, gradient, scaling, work_precision, compile_time. ``--quick``: few
repetitions, batches up to 64, element counts up to 48, short spans (the files are
marked quick). ``--no-exudyn`` (or ANCF_BENCH_NO_EXUDYN=1) runs as if Exudyn were not
installed. The report (:mod:`benchmarks.report`) is rendered from the JSON files only.
Compile times are a first run's: ancf_jax's persistent compilation cache is off
(``ANCF_JAX_CACHE=0``) unless the environment sets ``ANCF_JAX_CACHE``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import time
import traceback

SECTIONS = ("agreement", "single_run", "batch", "gradient", "scaling", "work_precision", "compile_time")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="a few minutes: small counts, short spans")
    ap.add_argument("--only", default="", help=f"comma-separated subset of {','.join(SECTIONS)}")
    ap.add_argument("--no-exudyn", action="store_true", help="pretend Exudyn is not installed")
    ap.add_argument("--report-only", action="store_true", help="only re-render RESULTS.md")
    args = ap.parse_args(argv)
    from . import cases as C
    if args.no_exudyn:
        os.environ[C.NO_EXUDYN_ENV] = "1"
    only = [s.strip() for s in args.only.split(",") if s.strip()]
    unknown = set(only) - set(SECTIONS)
    if unknown:
        ap.error(f"unknown section(s) {sorted(unknown)}; known: {', '.join(SECTIONS)}")
    selected = [] if args.report_only else [s for s in SECTIONS if not only or s in only]
    exudyn = C.exudyn_available()
    if not exudyn:
        print(f"note: {C.exudyn_missing_reason()}: Exudyn rows are marked as missing", flush=True)
    failed = []
    for name in selected:
        t0 = time.perf_counter()
        print(f"== {name}{' (quick)' if args.quick else ''}", flush=True)
        try:
            mod = importlib.import_module(f"benchmarks.{name}")
            mod.main(quick=args.quick, exudyn=exudyn)
        except Exception as err:  # keep going; the report says which section failed
            traceback.print_exc()
            failed.append(name)
            from .common import write
            write(name, dict(section=name, quick=args.quick, exudyn=exudyn, error=f"{type(err).__name__}: {err}",
                             command="python -m benchmarks.run" + (" --quick" if args.quick else "")
                             + f" --only {name}"))
        print(f"== {name}: {time.perf_counter() - t0:.0f} s", flush=True)
    from . import report
    path = report.render()
    print(f"written {path}")
    if failed:
        print(f"failed sections: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    # compile times are reported as a first run's: without ancf_jax's persistent cache
    # (a run after another would read the programs from it), unless you set it
    os.environ.setdefault("ANCF_JAX_CACHE", "0")
    sys.exit(main())
