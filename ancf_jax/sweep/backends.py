"""Where the chunks of a sweep run.

* :class:`LocalBackend`: in this process, one chunk after another, each batch sharded
  across all local JAX devices (``jax.devices()``: CPU host devices with
  ``XLA_FLAGS=--xla_force_host_platform_device_count=N``, or GPUs).
* :class:`RayBackend`: each chunk is a Ray task on a running cluster. Ray schedules the
  tasks, retries those whose worker died (``max_retries``) and reuses worker processes,
  so a worker compiles a program once and reuses it for every later chunk of the same
  shape (the in-process cache of :func:`ancf_jax.simulation.compiled`); the JAX
  persistent compilation cache (``JAX_COMPILATION_CACHE_DIR``, passed to the workers)
  shares compiled programs between workers on one node, or across nodes on a shared
  file system. Results come back to the driver, which alone writes the store.
"""

from __future__ import annotations

import os
from typing import Iterable, Iterator

from ._deps import need
from .design import SweepError
from .runner import ChunkTask, run_chunk

BACKENDS = ("local", "ray")


class LocalBackend:
    """Chunks in this process, sharded across the local devices."""

    name = "local"

    def __init__(self):
        import jax
        self.devices = jax.devices()

    @property
    def workers(self) -> int:
        return 1

    @property
    def multiple(self) -> int:
        return len(self.devices)

    def describe(self) -> dict:
        return dict(devices=[str(d) for d in self.devices])

    def run(self, tasks: Iterable[ChunkTask]) -> Iterator[dict]:
        for task in tasks:
            yield run_chunk(task)


class RayBackend:
    """Chunks as Ray tasks (see module docstring).

    Args:
        address: the cluster (``"auto"``, ``"HOST:PORT"``, ``"ray://HOST:10001"``); None:
            the cluster ``ray.init`` already connected to, else a new local one.
        max_retries: retries of a task whose worker process died.
        num_cpus: CPUs a chunk task reserves (one task per that many CPUs).
    """

    name = "ray"

    def __init__(self, address: str | None = None, max_retries: int = 3, num_cpus: float = 1):
        ray = need("ray")
        self.ray = ray
        if not ray.is_initialized():
            env = {k: v for k, v in os.environ.items()
                   if k in ("JAX_COMPILATION_CACHE_DIR", "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS")}
            import jax
            cache = jax.config.jax_compilation_cache_dir
            if cache and "JAX_COMPILATION_CACHE_DIR" not in env:
                env["JAX_COMPILATION_CACHE_DIR"] = str(cache)
            try:
                ray.init(address=address, runtime_env={"env_vars": env} if env else None,
                         log_to_driver=False, logging_level="ERROR")
            except (ConnectionError, RuntimeError, ValueError) as e:
                raise SweepError(f"--address {address}: cannot connect to a Ray cluster ({e})".splitlines()[0]) from None
        self.remote = ray.remote(num_cpus=num_cpus, max_retries=max_retries, retry_exceptions=False)(run_chunk)
        self._cpus = float(ray.cluster_resources().get("CPU", 1))
        self.num_cpus = num_cpus

    @property
    def workers(self) -> int:
        return max(1, int(self._cpus // self.num_cpus))

    @property
    def multiple(self) -> int:
        return 1

    def describe(self) -> dict:
        nodes = [n for n in self.ray.nodes() if n.get("Alive")]
        return dict(ray=self.ray.__version__, nodes=len(nodes), cpus=self._cpus)

    def run(self, tasks: Iterable[ChunkTask]) -> Iterator[dict]:
        ray = self.ray
        tasks = list(tasks)
        refs = {self.remote.remote(t): t for t in tasks}
        pending = list(refs)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            for ref in ready:
                try:
                    yield ray.get(ref)
                except ray.exceptions.RayError as e:  # retries exhausted: the members stay missing
                    yield failed_chunk(refs[ref], f"{type(e).__name__}: {e}".splitlines()[0])


def failed_chunk(task: ChunkTask, message: str) -> dict:
    """The result of a chunk that never ran to the end (a Ray task whose retries are
    exhausted): every member ``"error"`` with ``message``, so that the store leaves
    them unstored and ``--resume`` runs them again."""
    n = len(task.members)
    return dict(members=list(task.members), times=[], outputs={k: [[]] * n for k in task.outputs},
                status=["error"] * n, message=[message] * n, failure_time=[float("nan")] * n,
                compile_s=0.0, wall_s=0.0, pid=None, host=None, compilation_cache=None)


def get_backend(name: str, *, address: str | None = None):
    """A backend by name (``local`` or ``ray``)."""
    if name == "local":
        if address is not None:
            raise SweepError("--address: only with --backend ray")
        return LocalBackend()
    if name == "ray":
        return RayBackend(address)
    raise SweepError(f"--backend: must be one of {', '.join(BACKENDS)}, got {name!r}")
