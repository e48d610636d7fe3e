"""Shared helpers of the benchmark scripts: machine/version stamp, JSON/Markdown output."""

from __future__ import annotations

import datetime
import json
import os
import platform
from pathlib import Path

#: where the sections write their JSON (ANCF_BENCH_RESULTS overrides, e.g. in tests)
RESULTS = Path(os.environ.get("ANCF_BENCH_RESULTS") or Path(__file__).resolve().parent / "results")


def stamp() -> dict:
    """Machine, versions and date of a measurement."""
    import diffrax
    import equinox
    import jax
    import numpy

    import ancf_jax
    # the installed version, read without importing Exudyn: its native libraries must not
    # load into a process that compiles JAX programs (tests/exudyn_cases.py says why)
    from importlib import metadata
    try:
        exu = metadata.version("exudyn")
    except metadata.PackageNotFoundError:
        exu = None
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return dict(date=datetime.datetime.now().isoformat(timespec="seconds"), machine=cpu,
                cores=os.cpu_count(), python=platform.python_version(), jax=jax.__version__,
                jax_backend=jax.default_backend(), diffrax=diffrax.__version__,
                equinox=equinox.__version__, numpy=numpy.__version__, ancf_jax=ancf_jax.__version__,
                exudyn=exu)


def write(name: str, data: dict, markdown: str | None = None) -> Path:
    """Write results/NAME.json (with the stamp) and optionally results/NAME.md."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.json"
    path.write_text(json.dumps({"stamp": stamp(), **data}, indent=2, default=float))
    if markdown is not None:
        (RESULTS / f"{name}.md").write_text(markdown)
    return path


def table(header: list[str], rows: list[list]) -> str:
    """A Markdown table."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join(" --- " for _ in header) + "|"]
    for r in rows:
        out.append("| " + " | ".join(str(c) for c in r) + " |")
    return "\n".join(out) + "\n"
