"""The sweep tests (tests/sweep_suite.py) in a child pytest process: Zarr's codecs
(numcodecs: Blosc, Zstd, LZ4), xarray and the Ray client never load into the xdist
workers that compile the rest of the suite's JAX programs. Workers that had loaded
such native libraries (Exudyn before, then Zarr and Ray) segfaulted at random inside
XLA's executable serialization (jax compilation_cache.put_executable_and_time), in
later, unrelated tests; the child is short-lived and compiles only the sweep's few
programs. The child shares the run's persistent compilation cache."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
@pytest.mark.parametrize("marks", ["not study", pytest.param("study", marks=pytest.mark.study)])
def test_sweep_suite_in_a_child_process(marks):
    """The sweep suite's tests of the default run, or its validation studies (the local
    backend sharded across two host devices, the Ray cluster with a worker killed) with
    ``-m study``."""
    if __import__("importlib").util.find_spec("xarray") is None:  # found, not imported
        pytest.skip("xarray is not installed (it is in the test extra)")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider",
                           "-o", "addopts=", "-m", marks, "tests/sweep_suite.py"], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=1200)
    tail = (proc.stdout + proc.stderr)[-6000:]
    assert proc.returncode == 0, tail
    assert " passed" in tail and " failed" not in tail and " error" not in tail, tail
