"""XLA:CPU flags chosen by measurement, set when ancf_jax is imported.

XLA reads ``XLA_FLAGS`` once, when JAX first starts a backend; importing ancf_jax
before any JAX computation adds the flags of :data:`DEFAULT_FLAGS` that the user did
not set (a flag already named in ``XLA_FLAGS``, with any value, is left as it is):

* ``--xla_cpu_use_fusion_emitters=false``: XLA:CPU's newer fusion emitters made the
  compilation of a simulation ~1.5× slower and its run no faster. Measured on 2 cores
  (jaxlib 0.10.2, no compilation cache, each flag setting in a fresh process;
  ``python -m benchmarks.compile_time`` with and without ``ANCF_JAX_XLA_FLAGS=0``
  repeats the compile part): XLA compile of the M1 chunk program 3.5 s → 2.1 s,
  first ``simulate`` call 6.6 s → 4.5 s, 2 s M1 run 0.28 s → 0.24 s; a vmapped batch
  of 64 M1 variants, first call 14.1 s → 10.5 s, run 3.1 s → 3.0 s; M2 (24 elements)
  first call 7.7 s → 5.7 s, run unchanged. Results are the same to rounding (other
  instruction orders: the 2 s M1 run differs by at most 9.5e-14 m in q).
  On the largest program of the test suite (the located-contact chunk of
  ``tests/test_moving_loads.py``, XLA compile alone, fresh processes, 2026-12-06) it
  took the compile from 11.9 to 8.3–9.5 CPU s. Flags tried with it that changed
  nothing beyond the ±10 % spread of such timings: ``xla_llvm_disable_expensive_passes``,
  ``xla_cpu_parallel_codegen_split_count=1``, ``xla_cpu_use_thunk_runtime=false``,
  ``xla_cpu_enable_concurrency_optimized_scheduler=false``,
  ``xla_cpu_emitter_verification_level=0``, ``xla_cpu_copy_insertion_use_region_analysis=false``,
  and JAX's ``jax_exec_time_optimization_effort=-1``; most of the remaining time is
  XLA's HLO passes (LLVM at level 0 instead of 3 saves ~20 %).
* ``--xla_cpu_experimental_ynn_fusion_type=`` (no fusion types): XLA:CPU hands batched
  ``dot`` fusions to the YNNPACK library, which ran the element matrices of mid-size
  beams (products over elements × quadrature points, :mod:`ancf_jax._products`) several
  times slower than XLA's own kernels. Measured on 2 cores (jaxlib 0.10.2, 2026-12-07),
  both settings compiled in one process as per-program options and run interleaved,
  median of 5: M2 (24 elements, 0–1 s) 0.358 → 0.172 s, the three-mesh M2 batch (12, 18
  and 24 elements, 0–0.5 s) 1.60 → 0.68 s, M1 (6 elements, 0–2 s: no dot) 0.157 →
  0.159 s, a vmapped batch of 64 M1 variants (0–0.5 s) 3.01 → 3.07 s (the same within
  the spread); in fresh processes (one each, two alternations) M1 with 24 elements 268–435
  → 190–197 µs per step, 96 elements 1,101–1,258 → 840–945 µs, the shipped
  pantograph–catenary (2,400 elements) 3.44 → 2.61 s for 0.2 s. Results agree to
  rounding (at most 9e-14 m in q over 1 s of M1 and M2, 1.3e-12 m for the catenary;
  ``python -m benchmarks.kernel_census`` found the YNNPACK kernels at 24 elements).

* ``--xla_cpu_multi_thread_eigen=false``: XLA:CPU runs a ``dot`` it does not fuse as
  a call into Eigen, which by XLA's default splits the product over the process's
  thread pool. ancf_jax's products are small (per element and quadrature point, per
  batch member) and the hand-off to the pool cost more than the second thread gave.
  Measured on 2 cores (jaxlib 0.10.2, 2026-12-08; ``python -m benchmarks.eigen_threads``:
  both settings compiled in one process as per-program options, run interleaved,
  medians of 9, RESULTS.md "Eigen's threads in XLA's dot calls"), on → off in two runs:
  M1 with 96 elements 1.11 → 0.71 and 0.94 → 0.63 ms per step, with 384 elements 5.0 → 3.7
  and 4.0 → 2.9 ms, a vmapped batch of 64 M1 variants 42.9 → 20.8 and 34.2 → 17.1 ms per
  simulation; M1 (6 elements, 0–2 s) 98 → 96 and 118 → 125 ms (the run-to-run spread);
  M2 (24 elements, 0–3 s) 359 → 379 and 533 → 541 ms (1.5–6 % slower in four runs).
  Results agree to rounding (at most 2.1e-13 m in q over M1 and M2). M1 is a control:
  its 6 elements' products are traced as sums (:mod:`ancf_jax._products`), no ``dot``.
  Measured on 2 cores only: on a machine with many cores large products may gain from
  the pool (``XLA_FLAGS=--xla_cpu_multi_thread_eigen=true`` restores XLA's default).

Programs that run once per simulation (the initial state: consistent accelerations and
projections, a few linear solves) are compiled with :func:`run_once_options`, LLVM's
optimization off (``xla_backend_optimization_level=0``): their XLA compilation takes
about half the time and their single run a millisecond more at most. Measured on 2 cores
(jaxlib 0.10.2, no cache), XLA compile of the initial-state program and its run: M1 (6
elements) 0.69 s → 0.38 s, run 0.38 → 0.45 ms; M2 (24 elements) 0.92 s → 0.52 s, run
0.42 → 0.92 ms; 384 elements 0.75 s → 0.44 s, run 1.7 → 3.2 ms. (The chunk program, which
runs every step, stays optimized: at level 0 M1's steps ran 4.8× slower.)

Loop kernels (opt-in: ``ANCF_JAX_LOOP_KERNELS=1``). XLA:CPU runs a program as a
sequence of small compiled kernels ("thunks"), one per fusion, each dispatched on its
own; the step of a small model is hundreds of them, a few tens of nanoseconds each, and
that dispatch is most of its cost (M1, 6 elements: the Newton matrix and its
factorization, 21 of 40 µs per step, ``python -m benchmarks.step_profile``, are a few
dozen tiny operations each; the loop kernels below halve the step). XLA can instead compile a while loop whose
instructions touch at most ``xla_cpu_small_while_loop_byte_threshold`` bytes into one
kernel (its small-while-loop hoisting pass; XLA's default threshold is 1,024 bytes). With the
switch on, ancf_jax raises it to :data:`LOOP_KERNEL_BYTES`, so that a small model's
whole Newton loop (residual, Newton matrix, factorization, solves) becomes one kernel,
and factors the small dense matrices of its solves without LAPACK
(:func:`ancf_jax.linalg.lu_factor`: a LAPACK call inside a loop keeps the loop out of
the pass). Measured on 2 cores (jaxlib 0.10.2, no cache, fresh processes;
``python -m benchmarks.loop_kernels``, ``benchmarks/results/loop_kernels.json``): the
M1 run (0–2 s, 6 elements) 0.055 → 0.029 s, 1.9× faster (0.44 → 0.23 of Exudyn's run),
with 12 elements 1.5× faster, its first call (compilation) 2.9 → 8.0 s; larger models
gain nothing (M1 with 24 elements the same, M2 with 24 elements 9 % slower, compile +1 s)
and vmapped batches are not affected (their loops exceed the threshold). Results agree with the default to
rounding (other instruction orders). Off by default for the compile time; worth it for
long runs or many runs of one small model (the persistent compilation cache keeps the
compiled program between processes). Like the flags above it must be set before JAX
starts a backend; a user's own ``xla_backend_extra_options`` in ``XLA_FLAGS`` is left
as it is (:func:`loop_kernels` reads the threshold from there).

Compiler options for a block of code: :func:`compiler_options` sets XLA compiler options
(``jax.stages.Lowered.compile``'s ``compiler_options``) for the programs that ancf_jax
compiles in a ``with`` block: simulations (:func:`ancf_jax.simulation.simulate`,
``simulate_batch``) and identification's evaluation programs. ``XLA_FLAGS`` is read once per
process; these apply per program, so one process can compile short test runs fast and
long fits optimized. ``ANCF_JAX_COMPILER_OPTIONS=name=value[,name=value...]`` in the
environment sets them for the whole process (read at import; a child process, e.g. a
notebook kernel, inherits them). Measured on 2 cores (jaxlib 0.10.2, no cache, fresh processes): M1
(6 elements) first call 7.7–8.0 s at XLA's default LLVM level (3) and 5.9 s at level 0;
its 2 s run (2,000 steps) 0.17–0.22 s at level 3 and 0.93 s at level 0. The test suite
compiles at level 0 (``tests/conftest.py``) and its identification modules at level 3:
``tests/test_identification.py`` 114 → 71 s of pytest (one process, 54 tests), whose fits
run the same Jacobian program dozens of times.

An unknown flag in ``XLA_FLAGS`` aborts the process, and XLA renames and removes
flags between releases, so the flags are added only for the jaxlib releases they were
measured with (:data:`TESTED_JAXLIB`); other releases run with XLA's defaults.
``ANCF_JAX_XLA_FLAGS=0`` (or ``off``, ``false``, ``no``) turns them off. Nothing is
changed once a JAX backend is running (the flags could no longer take effect).
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import re

#: environment variable that turns the defaults off (0/off/false/no)
ENV = "ANCF_JAX_XLA_FLAGS"
_OFF = ("0", "off", "false", "no")

#: flags added to ``XLA_FLAGS`` (see the module docstring for the measurements)
DEFAULT_FLAGS = ("--xla_cpu_use_fusion_emitters=false", "--xla_cpu_experimental_ynn_fusion_type=",
                 "--xla_cpu_multi_thread_eigen=false")

#: compiler options of the programs that run once per simulation (see the module docstring)
RUN_ONCE_OPTIONS = {"xla_backend_optimization_level": 0}

#: environment variable that turns loop kernels on (1/on/true/yes; module docstring)
LOOP_KERNELS_ENV = "ANCF_JAX_LOOP_KERNELS"
_ON = ("1", "on", "true", "yes")

#: threshold [bytes] of XLA:CPU's small-while-loop hoisting with loop kernels on: M1's
#: Newton loop (~0.5 MB accessed) becomes one kernel, a vmapped batch's does not
#: (``python -m benchmarks.loop_kernels``: 0.26 MB hoists only the chain scans, no gain)
LOOP_KERNEL_BYTES = 1_000_000

_THRESHOLD = "xla_cpu_small_while_loop_byte_threshold"

#: jaxlib releases (major, minor) the flags were measured with
TESTED_JAXLIB = ((0, 10),)


def _jaxlib_release() -> tuple[int, int] | None:
    try:
        from jaxlib import version
        major, minor = version.__version__.split(".")[:2]
        return int(major), int(minor)
    except Exception:  # pragma: no cover - an unreadable version gets XLA's defaults
        return None


def _backend_running() -> bool:
    try:
        from jax._src import xla_bridge
        return bool(xla_bridge._backends)
    except Exception:  # pragma: no cover - private API moved: assume it is running
        return True


def with_default_flags(flags: str) -> str:
    """``flags`` (an ``XLA_FLAGS`` value) with each of :data:`DEFAULT_FLAGS` appended
    whose name it does not contain."""
    extra = [f for f in DEFAULT_FLAGS if f.split("=")[0] not in flags]
    return " ".join([flags.strip(), *extra]).strip()


def with_loop_kernels(flags: str) -> str:
    """``flags`` with XLA's small-while-loop threshold raised to :data:`LOOP_KERNEL_BYTES`,
    unless they name ``xla_backend_extra_options`` already (the user's own, kept)."""
    if "xla_backend_extra_options" in flags:
        return flags.strip()
    return f"{flags.strip()} --xla_backend_extra_options={_THRESHOLD}={LOOP_KERNEL_BYTES}".strip()


def loop_kernels() -> bool:
    """Whether XLA may compile loops into single kernels in this process: ``XLA_FLAGS``
    sets ``xla_cpu_small_while_loop_byte_threshold`` (by ``ANCF_JAX_LOOP_KERNELS`` or
    by the user) above XLA's default (1,024 bytes). Read when a program is traced:
    :func:`ancf_jax.linalg.lu_factor` then keeps LAPACK out of small solves."""
    match = re.search(_THRESHOLD + r"=(\d+)", os.environ.get("XLA_FLAGS", ""))
    return match is not None and int(match.group(1)) > 1024


def configure_xla_flags() -> str | None:
    """Add :data:`DEFAULT_FLAGS` to ``XLA_FLAGS`` as the module docstring says, and the
    loop-kernel threshold where ``ANCF_JAX_LOOP_KERNELS`` asks for it.

    Returns:
        the resulting ``XLA_FLAGS``, or None when nothing was changed.
    """
    if _jaxlib_release() not in TESTED_JAXLIB or _backend_running():
        return None
    current = os.environ.get("XLA_FLAGS", "")
    new = current.strip() if os.environ.get(ENV, "").strip().lower() in _OFF else with_default_flags(current)
    if os.environ.get(LOOP_KERNELS_ENV, "").strip().lower() in _ON:
        new = with_loop_kernels(new)
    if new == current.strip():
        return None
    os.environ["XLA_FLAGS"] = new
    return new


def run_once_options() -> dict | None:
    """Compiler options for a program that runs once per simulation:
    :data:`RUN_ONCE_OPTIONS` on the tested jaxlib releases, None (XLA's defaults) on
    others or when ``ANCF_JAX_XLA_FLAGS`` turns the defaults off."""
    if os.environ.get(ENV, "").strip().lower() in _OFF or _jaxlib_release() not in TESTED_JAXLIB:
        return None
    return dict(RUN_ONCE_OPTIONS)


#: environment variable with compiler options for the whole process, read when ancf_jax
#: is imported: ``name=value[,name=value...]`` (the outermost :func:`compiler_options`)
OPTIONS_ENV = "ANCF_JAX_COMPILER_OPTIONS"


def parse_options(text: str) -> dict:
    """Compiler options from ``name=value[,name=value...]`` (:data:`OPTIONS_ENV`):
    ``true``/``false`` are booleans, integers and decimals numbers, anything else a
    string; empty text: none.

    Raises:
        ValueError: an entry is not ``name=value``.
    """
    out: dict = {}
    for entry in filter(None, (e.strip() for e in text.split(","))):
        name, sep, value = (s.strip() for s in entry.partition("="))
        if not sep or not name or not value:
            raise ValueError(f"{OPTIONS_ENV}: {entry!r} is not name=value (accepted: XLA compiler options "
                             f"as name=value[,name=value...], e.g. xla_backend_optimization_level=0)")
        if value.lower() in ("true", "false"):
            out[name] = value.lower() == "true"
            continue
        for kind in (int, float):
            try:
                out[name] = kind(value)
                break
            except ValueError:
                pass
        else:
            out[name] = value
    return out


#: XLA compiler options set by :func:`compiler_options` for the current context (sorted
#: items); outside any block those of :data:`OPTIONS_ENV`
_OPTIONS: contextvars.ContextVar = contextvars.ContextVar(
    "ancf_jax_compiler_options", default=tuple(sorted(parse_options(os.environ.get(OPTIONS_ENV, "")).items())))


@contextlib.contextmanager
def compiler_options(**options: bool | int | float | str):
    """XLA compiler options for the programs ancf_jax compiles inside the ``with`` block
    (see the module docstring), e.g. ``compiler_options(xla_backend_optimization_level=0)``
    to compile a short run faster (it runs slower). Nested blocks add to the outer
    block's options, and the outermost to those of ``ANCF_JAX_COMPILER_OPTIONS``. A
    program's own choice of an option takes precedence (the initial-state program, which
    runs once, keeps the LLVM level of :func:`run_once_options` where those apply; the
    block's other options reach it). A program compiled with other options is a
    different program: it is compiled again, and cached separately.

    Raises:
        ValueError: an option's value is not a bool, int, float or str.
    """
    for name, value in options.items():
        if not isinstance(value, (bool, int, float, str)):
            raise ValueError(f"compiler_options: {name} must be a bool, int, float or str (an XLA "
                             f"compiler option), got {type(value).__name__}")
    token = _OPTIONS.set(tuple(sorted({**dict(_OPTIONS.get()), **options}.items())))
    try:
        yield
    finally:
        _OPTIONS.reset(token)


def program_options(options: dict | None = None) -> dict | None:
    """The options of the enclosing :func:`compiler_options` blocks updated with
    ``options`` (a program's own compiler options, or None); None when both are empty
    (XLA's defaults)."""
    merged = {**dict(_OPTIONS.get()), **(options or {})}
    return merged or None

