"""Shared fixtures and helpers. JAX compile time dominates the suite: build systems
once per module and reuse compiled functions."""

import os

import ancf_jax  # noqa: F401  (turns on float64)
import numpy as np
import pytest


@pytest.fixture(scope="session")
def rng():
    return np.random.default_rng(20261122)


def pytest_configure(config):
    os.environ.setdefault("ANCF_JAX_QUICK", "1")
    # XLA compilation is most of the suite's time and the tests' runs are short: LLVM
    # without optimization passes compiles a simulation ~1.6x faster (M1 chunk program
    # 2.1 s -> 1.2 s) and runs it ~2x slower, with the same floating-point operations (no
    # fast-math at any level): results the same to rounding (the 2 s M1 run: 1.1e-13 m
    # in q, from other instruction orders; as across XLA releases). Set before any JAX backend
    # starts, and inherited by the subprocesses (CLI, notebooks, the sweep child suite).
    flags = os.environ.get("XLA_FLAGS", "")
    if "xla_backend_optimization_level" not in flags:
        os.environ["XLA_FLAGS"] = f"{flags} --xla_backend_optimization_level=0".strip()
    # One persistent compilation cache for the whole run: the xdist workers and the
    # subprocesses (CLI, notebooks) compile many identical programs (M1 and M2 appear
    # in the model, CLI, scenario, identification and notebook tests). A clean checkout
    # starts with an empty cache, so CI pays every distinct compilation once.
    cache = os.environ.setdefault("JAX_COMPILATION_CACHE_DIR",
                                  str(config.rootpath / ".jax_cache"))
    # programs compiling in under 2 s are not written (fewer executable serializations,
    # where the random native crashes of a worker happened; see tests/test_sweep.py)
    os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "2.0")
    import jax
    jax.config.update("jax_compilation_cache_dir", cache)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 2.0)
    if _TIMING_LOG:
        import jax.monitoring
        jax.monitoring.register_event_time_span_listener(_on_jax_span)


# A module whose tests run long (fits that run one program dozens of times) declares
# ``COMPILER_OPTIONS = {...}``: its programs compile with them (ancf_jax.compiler_options),
# e.g. at XLA's LLVM level 3 instead of the suite's 0 above. Measured per module, one
# process, fresh caches (2026-12-07, 2 cores): tests/test_identification.py 114 s of
# pytest at level 0, 71 s at 3; across the suite at level 3 instead of 0 (CI's command, per-module
# worker time): test_identification_real 353 -> 306 s, while the simulation modules
# got slower (cable machinery 160 -> 202 s, shipped scenarios 113 -> 151 s, Newton matrix
# 107 -> 141 s: short runs, compile-bound). Measured again module by module on 2026-12-07
# (level 0 and 3 side by side in two processes, fresh caches): no other module gains
# (factor reuse 59/61 s, integrators 105/109, M2 95/98, simulation 80/86, integrate
# 83/89, local sensitivity 58/59, fatigue 50/52 s of pytest at 0/3).
@pytest.fixture(autouse=True, scope="module")
def _module_compiler_options(request):
    options = getattr(request.module, "COMPILER_OPTIONS", None)
    if not options:
        yield
        return
    from ancf_jax import compiler_options
    with compiler_options(**options):
        yield


# ANCF_JAX_TIMING_LOG=FILE appends "cpu_s wall_s trace_s lower_s compile_s nodeid" per
# test (setup, call and teardown) to FILE as the tests run: CPU seconds of the worker
# process do not depend on how loaded the machine is, so the suite's cost on CI can be
# estimated on a busy one; trace, lower and compile are the seconds JAX spent in the
# worker tracing to jaxprs, lowering to StableHLO and compiling with XLA (the time spans
# of its jax.monitoring events, overlaps counted once: a jit traced inside another's
# trace is in both spans; a persistent-cache hit compiles nothing), what the suite's time
# is made of (python -m benchmarks.suite_time).
_TIMING_LOG = os.environ.get("ANCF_JAX_TIMING_LOG")
#: JAX's events timed in the timing log, in the log's column order
_JAX_PHASES = ("/jax/core/compile/jaxpr_trace_duration", "/jax/core/compile/jaxpr_to_mlir_module_duration",
               "/jax/core/compile/backend_compile_duration")
_spans: dict = {e: [] for e in _JAX_PHASES}


def _on_jax_span(event, start, end, **kwargs):
    if event in _spans:
        _spans[event].append((start, end))


def _covered(spans) -> float:
    """Seconds covered by the union of (start, end) spans."""
    total, reach = 0.0, float("-inf")
    for a, b in sorted(spans):
        if b > reach:
            total += b - max(a, reach)
            reach = b
    return total


if _TIMING_LOG:
    import time

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(item, nextitem):
        c0, w0 = time.process_time(), time.perf_counter()
        for spans in _spans.values():
            spans.clear()
        yield
        phases = " ".join(f"{_covered(_spans[e]):.2f}" for e in _JAX_PHASES)
        with open(_TIMING_LOG, "a") as f:
            f.write(f"{time.process_time() - c0:.2f} {time.perf_counter() - w0:.2f} {phases} {item.nodeid}\n")


# Each compiled XLA:CPU program keeps its code in memory maps of its own (~1,500 for an
# M1 chunk); a worker that keeps every program it compiled crashes inside XLA once it
# reaches vm.max_map_count (65,530 by default): the random segfaults and aborts of
# earlier CI runs, in compilation or executable serialization, late in a worker's life.
# Programs are freed after a module when the worker holds over 30 % of the limit, and
# during a module over 60 % (ancf_jax._memory; the library itself frees at 50 % before
# compiling a simulation).
@pytest.fixture(autouse=True, scope="module")
def _free_programs_after_the_module():
    yield
    from ancf_jax import _memory
    _memory.relieve(0.3)


@pytest.fixture(autouse=True)
def _free_programs_near_the_limit():
    from ancf_jax import _memory
    _memory.relieve(0.6)
    yield


# The longest modules start first. With ``--dist loadscope --no-loadscope-reorder``
# each module runs whole in one xdist worker, handed out in collection order; a long
# module collected late leaves the other worker idle at the end of the run. Longest
# first is the classic greedy schedule for two workers, except that the identification
# and the M1/M2/CLI modules go before the notebooks, which then find the programs those
# modules compiled in the persistent cache (measured: after tests/models and
# test_cli_models, notebook 02 ran in 19.0 instead of 22.4 s, 03 in 29.5 instead of
# 37.7 s; notebooks 04 and 06 compile with the identification modules' options,
# tests/test_notebooks.py, and ran in 34 and 38 s after them instead of 49 and 52 s).
# The list holds the modules over about a minute of worker
# time (ANCF_JAX_TIMING_LOG, summed per module) and those; the rest keep their order.
_LONG_MODULES = ("tests/test_identification.py", "tests/test_identification_real.py", "tests/models/test_m1.py",
                 "tests/models/test_m2.py", "tests/test_cli_models.py", "tests/test_notebooks.py",
                 "tests/test_catenary.py", "tests/test_cable_machinery.py", "tests/test_sweep.py",
                 "tests/test_moving_loads.py", "tests/scenario/test_shipped.py", "tests/test_newton_matrix.py",
                 "tests/test_exudyn_crosscheck.py", "tests/test_output_derivatives.py")


def pytest_collection_modifyitems(config, items):
    rank = {path: k for k, path in enumerate(_LONG_MODULES)}

    def key(item):
        path = item.nodeid.split("::")[0]
        return rank.get(path, len(rank))

    items.sort(key=key)  # stable: the order within a module and among the rest is kept
