"""Time of the test suite (README's test command) and where it goes, per test module.

Target (issue 17): ``python -m pytest -n 2 -q`` takes at most 8 minutes of pytest on a
2-core CI machine. The suite's own hook (``tests/conftest.py``) appends
``cpu_s wall_s nodeid`` per test phase to the file named by ``ANCF_JAX_TIMING_LOG``; this
section runs the suite with it (or reads a log a run wrote: ``--log``, with that run's
pytest seconds ``--pytest-seconds``) and writes, per module, the tests, worker wall and
CPU seconds (a module runs whole in one xdist worker; modules whose tests run in child
processes, the notebooks, the sweep suite and the Exudyn cross-check, show wall seconds
with little worker CPU), the sum over all modules and the pytest time.

    python -m benchmarks.suite_time                       # runs the suite (~20 min on 2 cores)
    python -m benchmarks.suite_time --log FILE --pytest-seconds S
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .common import write

ROOT = Path(__file__).resolve().parents[1]
TARGET_S = 480.0
#: modules listed in the report (the rest are summed)
TOP = 15
#: modules that a test runs in a child pytest process (tests/test_sweep.py runs
#: tests/sweep_suite.py), which inherits the timing log: their seconds are inside that
#: test's, so they are listed apart and left out of the sums
CHILD_SUITES = {"tests/sweep_suite.py": "tests/test_sweep.py"}


def parse_log(text: str) -> list[dict]:
    """Per-module totals from ``cpu_s wall_s nodeid`` lines (setup, call and teardown of
    a test are separate lines with the same id), longest worker wall first."""
    mods: dict[str, dict] = {}
    for line in text.splitlines():
        parts = line.split(None, 2)
        if len(parts) < 3:
            continue
        try:
            cpu, wall = float(parts[0]), float(parts[1])
        except ValueError:
            continue
        module = parts[2].split("::")[0]
        m = mods.setdefault(module, dict(module=module, tests=set(), wall_s=0.0, cpu_s=0.0))
        m["tests"].add(parts[2].strip())
        m["wall_s"] += wall
        m["cpu_s"] += cpu
    rows = [dict(m, tests=len(m["tests"])) for m in mods.values()]
    return sorted(rows, key=lambda m: -m["wall_s"])


def _pytest_seconds(output: str) -> float | None:
    """The "in 1234.56s" of pytest's summary line."""
    found = re.findall(r" in ([0-9.]+)s", output)
    return float(found[-1]) if found else None


def run_suite(log: Path) -> tuple[float | None, float, str]:
    """README's test command in this checkout with a fresh compilation cache. Returns
    (pytest's seconds, wall seconds, the summary line)."""
    env = dict(os.environ, ANCF_JAX_TIMING_LOG=str(log))
    with tempfile.TemporaryDirectory() as cache:
        env["JAX_COMPILATION_CACHE_DIR"] = cache
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "pytest", "-n", "2", "-q"], cwd=ROOT, env=env,
                              capture_output=True, text=True)
        wall = time.perf_counter() - t0
    summary = (proc.stdout.strip().splitlines() or [""])[-1]
    if proc.returncode != 0:
        raise SystemExit(f"suite_time: the suite failed ({summary})")
    return _pytest_seconds(proc.stdout), wall, summary


def summarize(modules: list[dict], pytest_s: float | None, **extra) -> dict:
    children = [dict(m, inside=CHILD_SUITES[m["module"]]) for m in modules if m["module"] in CHILD_SUITES]
    modules = [m for m in modules if m["module"] not in CHILD_SUITES]
    return dict(section="suite_time", target_s=TARGET_S, pytest_s=pytest_s, modules=modules,
                child_suites=children, worker_wall_s=sum(m["wall_s"] for m in modules),
                worker_cpu_s=sum(m["cpu_s"] for m in modules), tests=sum(m["tests"] for m in modules), **extra)


def markdown(d: dict) -> str:
    from .common import table
    if not d["modules"]:
        return "No test in the log.\n"
    rows = [[m["module"], m["tests"], f"{m['wall_s']:.0f}", f"{m['cpu_s']:.0f}",
             f"{100 * m['wall_s'] / d['worker_wall_s']:.0f} %"] for m in d["modules"][:TOP]]
    rest = d["modules"][TOP:]
    if rest:
        w = sum(m["wall_s"] for m in rest)
        rows.append([f"the other {len(rest)} modules", sum(m["tests"] for m in rest), f"{w:.0f}",
                     f"{sum(m['cpu_s'] for m in rest):.0f}", f"{100 * w / d['worker_wall_s']:.0f} %"])
    rows.append(["all", d["tests"], f"{d['worker_wall_s']:.0f}", f"{d['worker_cpu_s']:.0f}", "100 %"])
    for m in d.get("child_suites", []):
        rows.append([f"{m['module']} (in {m['inside']}'s child process)", m["tests"], f"{m['wall_s']:.0f}",
                     f"{m['cpu_s']:.0f}", "–"])
    return table(["module", "tests", "worker wall [s]", "worker CPU [s]", "share"], rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--log", type=Path, help="read this ANCF_JAX_TIMING_LOG instead of running the suite")
    ap.add_argument("--pytest-seconds", type=float, help="with --log: the seconds pytest reported for that run")
    ap.add_argument("--note", default="", help="where the run was made (kept in the JSON)")
    args = ap.parse_args(argv)
    if args.log is not None:
        if not args.log.is_file():
            ap.error(f"--log: no such file {args.log}")
        out = summarize(parse_log(args.log.read_text()), args.pytest_seconds, source=str(args.log),
                        note=args.note, command="python -m benchmarks.suite_time --log FILE --pytest-seconds S")
    else:
        with tempfile.TemporaryDirectory() as tmp:
            log = Path(tmp) / "timing.log"
            pytest_s, wall, summary = run_suite(log)
            out = summarize(parse_log(log.read_text()), pytest_s, wall_s=wall, summary=summary, note=args.note,
                            command="python -m benchmarks.suite_time")
    write("suite_time", out)
    print(markdown(out))
    print(f"pytest: {out['pytest_s']} s (target {TARGET_S:g} s)")


if __name__ == "__main__":
    main()
