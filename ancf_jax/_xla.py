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

Programs that run once per simulation (the initial state: consistent accelerations and
projections, a few linear solves) are compiled with :func:`run_once_options`, LLVM's
optimization off (``xla_backend_optimization_level=0``): their XLA compilation takes
about half the time and their single run a millisecond more at most. Measured on 2 cores
(jaxlib 0.10.2, no cache), XLA compile of the initial-state program and its run: M1 (6
elements) 0.69 s → 0.38 s, run 0.38 → 0.45 ms; M2 (24 elements) 0.92 s → 0.52 s, run
0.42 → 0.92 ms; 384 elements 0.75 s → 0.44 s, run 1.7 → 3.2 ms. (The chunk program, which
runs every step, stays optimized: at level 0 M1's steps ran 4.8× slower.)

An unknown flag in ``XLA_FLAGS`` aborts the process, and XLA renames and removes
flags between releases, so the flags are added only for the jaxlib releases they were
measured with (:data:`TESTED_JAXLIB`); other releases run with XLA's defaults.
``ANCF_JAX_XLA_FLAGS=0`` (or ``off``, ``false``, ``no``) turns both off. Nothing is
changed once a JAX backend is running (the flags could no longer take effect).
"""

from __future__ import annotations

import os

#: environment variable that turns the defaults off (0/off/false/no)
ENV = "ANCF_JAX_XLA_FLAGS"
_OFF = ("0", "off", "false", "no")

#: flags added to ``XLA_FLAGS`` (see the module docstring for the measurements)
DEFAULT_FLAGS = ("--xla_cpu_use_fusion_emitters=false",)

#: compiler options of the programs that run once per simulation (see the module docstring)
RUN_ONCE_OPTIONS = {"xla_backend_optimization_level": 0}

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


def configure_xla_flags() -> str | None:
    """Add :data:`DEFAULT_FLAGS` to ``XLA_FLAGS`` as the module docstring says.

    Returns:
        the resulting ``XLA_FLAGS``, or None when nothing was changed.
    """
    if os.environ.get(ENV, "").strip().lower() in _OFF:
        return None
    if _jaxlib_release() not in TESTED_JAXLIB or _backend_running():
        return None
    current = os.environ.get("XLA_FLAGS", "")
    new = with_default_flags(current)
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
