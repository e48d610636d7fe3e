"""JAX's persistent compilation cache, on by default for ancf_jax runs.

Compiling a simulation (seconds: the generalized-α step of M1 is several thousand XLA
instructions) costs more than running it; JAX can keep compiled programs on disk and
reuse them in later processes (``jax.config.jax_compilation_cache_dir``). Importing
ancf_jax turns that cache on, unless the user or JAX configured one already:

* ``JAX_COMPILATION_CACHE_DIR`` set (or ``jax_compilation_cache_dir`` configured
  before ancf_jax is imported): left as it is;
* ``ANCF_JAX_CACHE=0`` (or ``off``, ``false``, ``no``): no cache;
* ``ANCF_JAX_CACHE=DIR``: that directory;
* otherwise: ``$XDG_CACHE_HOME/ancf_jax/xla`` (default ``~/.cache/ancf_jax/xla``).

Programs compiled in under ``jax_persistent_cache_min_compile_time_secs`` (JAX's
default, 1 s) are not stored. The cache is safe to delete at any time.
"""

from __future__ import annotations

import os
from pathlib import Path

#: environment variable that disables (0/off) or relocates (a path) the cache
ENV = "ANCF_JAX_CACHE"
_OFF = ("0", "off", "false", "no")


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/ancf_jax/xla``, or ``~/.cache/ancf_jax/xla``."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "ancf_jax" / "xla"


def configure_compilation_cache() -> str | None:
    """Turn on JAX's persistent compilation cache as the module docstring says.

    Returns:
        the cache directory in use (the user's own, or the one set here), or None when
        there is none.
    """
    import jax
    current = jax.config.jax_compilation_cache_dir
    if current:
        return current
    setting = os.environ.get(ENV, "").strip()
    if setting.lower() in _OFF:
        return None
    path = str(Path(setting).expanduser() if setting else default_cache_dir())
    jax.config.update("jax_compilation_cache_dir", path)
    return path
