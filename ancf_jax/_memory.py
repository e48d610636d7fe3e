"""Keeping a long session under the kernel's limit on memory maps.

Every program XLA compiles for the CPU keeps its machine code in memory maps of its
own: ~1,500 for a 6-element M1 simulation chunk (measured with /proc/self/maps, jax
0.10), more for larger programs. Linux refuses new maps past ``vm.max_map_count``
(65,530 by default), and XLA then crashes inside a compilation or an executable
serialization (segfault or abort) instead of raising. A session that compiles some
forty such programs and keeps them (``jax.jit`` caches, the compiled-program cache of
:mod:`ancf_jax.simulation`) reaches it: a test worker, a notebook trying many model
sizes, a long identification session.

:func:`relieve` frees compiled programs when the process uses more than a fraction of
the limit: it clears the caches registered with :func:`register_cache` and JAX's own
(``jax.clear_caches``). Freed programs are compiled again when needed (from the
persistent compilation cache where it is on). Linux only; elsewhere it does nothing.
"""

from __future__ import annotations

import gc
from typing import Callable

_CLEARERS: list[Callable[[], None]] = []

#: free compiled programs above this fraction of vm.max_map_count
FRACTION = 0.5


def register_cache(clear: Callable[[], None]) -> None:
    """Register a function that empties a cache of compiled programs."""
    _CLEARERS.append(clear)


def map_count() -> int | None:
    """Memory maps of this process (None where /proc is not available)."""
    try:
        with open("/proc/self/maps", "rb") as f:
            return sum(1 for _ in f)
    except OSError:
        return None


def map_limit() -> int | None:
    """The kernel's limit on memory maps per process (None where unknown)."""
    try:
        with open("/proc/sys/vm/max_map_count") as f:
            return int(f.read().strip())
    except (OSError, ValueError):
        return None


def relieve(fraction: float = FRACTION) -> bool:
    """Free compiled programs if this process uses more than ``fraction`` of the
    memory-map limit; returns whether it did."""
    n, limit = map_count(), map_limit()
    if n is None or limit is None or n <= fraction * limit:
        return False
    import jax
    for clear in _CLEARERS:
        clear()
    jax.clear_caches()
    gc.collect()
    return True
