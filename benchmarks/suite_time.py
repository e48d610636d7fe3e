"""Time of the test suite (README's test command) and where it goes, per test module.

Target (issue 17): ``python -m pytest -n 2 -q`` takes at most 8 minutes of pytest on a
2-core CI machine. The suite's own hook (``tests/conftest.py``) appends
``cpu_s wall_s trace_s lower_s compile_s nodeid`` per test to the file named by
``ANCF_JAX_TIMING_LOG`` (logs of earlier versions hold ``cpu_s wall_s nodeid``); this
section runs the suite with it (or reads a log a run wrote: ``--log``, with that run's
pytest seconds ``--pytest-seconds``) and writes, per module, the tests, worker wall and
CPU seconds (a module runs whole in one xdist worker; modules whose tests run in child
processes, the notebooks, the sweep suite and the Exudyn cross-check, show wall seconds
with little worker CPU), the seconds JAX spent in the worker tracing, lowering and
compiling (XLA) its programs, the sum over all modules and the pytest time. The rest of
a module's wall time is running the programs, Python, and waiting for child processes.

    python -m benchmarks.suite_time                       # runs the suite
    python -m benchmarks.suite_time --log FILE --pytest-seconds S
    python -m benchmarks.suite_time --studies             # runs the validation studies

The validation studies (``-m study``: convergence orders, runs against finer runs of
themselves, finite-difference gradients through whole fits, the real-data identification
studies, three notebooks, the Ray cluster) are outside the default suite, which keeps CI
within its time; ``--studies`` runs them with the same command and options, fails when
one fails, and writes section ``studies`` (RESULTS.md: which commit passed them, when,
in how long).
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


#: JAX's seconds per test in the timing log, in its column order (tests/conftest.py)
PHASES = ("trace_s", "lower_s", "compile_s")


def parse_log(text: str) -> list[dict]:
    """Per-module totals from ``cpu_s wall_s [trace_s lower_s compile_s] nodeid`` lines
    (a test's setup, call and teardown are one line, or separate lines with the same id
    in logs of earlier versions), longest worker wall first. ``phases`` is False for a
    module whose lines have no JAX seconds."""
    mods: dict[str, dict] = {}
    for line in text.splitlines():
        parts = line.split()
        numbers = []
        for p in parts:
            try:
                numbers.append(float(p))
            except ValueError:
                break
        if len(numbers) not in (2, 2 + len(PHASES)) or len(parts) == len(numbers):
            continue
        nodeid = line.split(None, len(numbers))[-1].strip()
        module = nodeid.split("::")[0]
        m = mods.setdefault(module, dict(module=module, tests=set(), wall_s=0.0, cpu_s=0.0, phases=True,
                                         **dict.fromkeys(PHASES, 0.0)))
        m["tests"].add(nodeid)
        m["cpu_s"] += numbers[0]
        m["wall_s"] += numbers[1]
        if len(numbers) == 2:
            m["phases"] = False
        for k, v in zip(PHASES, numbers[2:]):
            m[k] += v
    rows = [dict(m, tests=len(m["tests"])) for m in mods.values()]
    return sorted(rows, key=lambda m: -m["wall_s"])


def _pytest_seconds(output: str) -> float | None:
    """The "in 1234.56s" of pytest's summary line."""
    found = re.findall(r" in ([0-9.]+)s", output)
    return float(found[-1]) if found else None


def run_suite(log: Path, marks: str | None = None) -> tuple[float | None, float, str]:
    """README's test command in this checkout with a fresh compilation cache (``marks``:
    its ``-m`` expression instead of the default one). Returns (pytest's seconds, wall
    seconds, the summary line)."""
    env = dict(os.environ, ANCF_JAX_TIMING_LOG=str(log))
    with tempfile.TemporaryDirectory() as cache:
        env["JAX_COMPILATION_CACHE_DIR"] = cache
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "pytest", "-n", "2", "-q", *(["-m", marks] if marks else [])],
                              cwd=ROOT, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    summary = (proc.stdout.strip().splitlines() or [""])[-1]
    if proc.returncode != 0:
        print(proc.stdout[-8000:])
        raise SystemExit(f"suite_time: the {'studies' if marks else 'suite'} failed ({summary})")
    return _pytest_seconds(proc.stdout), wall, summary


def _commit() -> str | None:
    """The checkout's commit and whether it has uncommitted changes to tracked files."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return head + (" with uncommitted changes" if dirty else "")


def summarize(modules: list[dict], pytest_s: float | None, **extra) -> dict:
    children = [dict(m, inside=CHILD_SUITES[m["module"]]) for m in modules if m["module"] in CHILD_SUITES]
    modules = [m for m in modules if m["module"] not in CHILD_SUITES]
    phases = {f"worker_{k}": sum(m[k] for m in modules) for k in PHASES} \
        if modules and all(m["phases"] for m in modules) else {}
    return dict(section="suite_time", target_s=TARGET_S, pytest_s=pytest_s, modules=modules,
                child_suites=children, worker_wall_s=sum(m["wall_s"] for m in modules),
                worker_cpu_s=sum(m["cpu_s"] for m in modules), tests=sum(m["tests"] for m in modules),
                **phases, **extra)


def markdown(d: dict) -> str:
    from .common import table
    if not d["modules"]:
        return "No test in the log.\n"
    phases = "worker_compile_s" in d  # a log with JAX's seconds (tests/conftest.py)

    def row(name, tests, ms):
        wall = sum(m["wall_s"] for m in ms)
        out = [name, tests, f"{wall:.0f}", f"{sum(m['cpu_s'] for m in ms):.0f}"]
        if phases:
            out += [f"{sum(m[k] for m in ms):.0f}" for k in reversed(PHASES)]
        return out + [f"{100 * wall / d['worker_wall_s']:.0f} %"]

    rows = [row(m["module"], m["tests"], [m]) for m in d["modules"][:TOP]]
    rest = d["modules"][TOP:]
    if rest:
        rows.append(row(f"the other {len(rest)} modules", sum(m["tests"] for m in rest), rest))
    rows.append(row("all", d["tests"], d["modules"]))
    for m in d.get("child_suites", []):
        rows.append(row(f"{m['module']} (in {m['inside']}'s child process)", m["tests"], [m])[:-1] + ["–"])
    head = ["module", "tests", "worker wall [s]", "worker CPU [s]"]
    if phases:
        head += ["XLA compile [s]", "lowering [s]", "tracing [s]"]
    return table(head + ["share"], rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--log", type=Path, help="read this ANCF_JAX_TIMING_LOG instead of running the suite")
    ap.add_argument("--pytest-seconds", type=float, help="with --log: the seconds pytest reported for that run")
    ap.add_argument("--note", default="", help="where the run was made (kept in the JSON)")
    ap.add_argument("--studies", action="store_true", help="run the validation studies (-m study) instead")
    args = ap.parse_args(argv)
    if args.studies:
        if args.log is not None:
            ap.error("--studies runs them; --log reads a run of the default suite")
        with tempfile.TemporaryDirectory() as tmp:
            log = Path(tmp) / "timing.log"
            pytest_s, wall, summary = run_suite(log, "study")
            out = summarize(parse_log(log.read_text()), pytest_s, wall_s=wall, summary=summary, note=args.note,
                            commit=_commit(), command="python -m benchmarks.suite_time --studies")
        write("studies", dict(out, section="studies"))
        print(markdown(out))
        print(f"studies: {summary}, {pytest_s} s of pytest")
        return
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
