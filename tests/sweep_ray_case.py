"""The Ray and device-sharding cases of ``tests/test_sweep.py``, run in one spawned
interpreter started with two XLA host devices (``XLA_FLAGS``): Ray's native
libraries (its core worker, gRPC, Abseil) never load into the pytest workers that
compile the rest of the suite's JAX programs (a worker that had started Ray in-process
later segfaulted inside XLA, as workers with Exudyn loaded had before; see
tests/exudyn_cases.py)."""

import os

import psutil


def _chunk_workers():
    """This process's Ray worker processes that are running a chunk now."""
    out = []
    for p in psutil.Process(os.getpid()).children(recursive=True):
        try:
            if "run_chunk" in " ".join(p.cmdline()) or "run_chunk" in p.name():
                out.append(p)
        except psutil.Error:
            pass
    return out


def sweep_on_ray_killing_a_worker(params, out, kw, root):
    """A local Ray cluster on 127.0.0.1 with 2 CPUs, no dashboard, no usage statistics;
    the sweep runs on it while one worker is killed (SIGKILL) mid-chunk. Returns
    (members seen in chunk order, pids killed)."""
    import warnings
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    os.environ["PYTHONPATH"] = os.pathsep.join([root] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep)
                                                         if p])
    warnings.filterwarnings("ignore", message="os.fork", category=RuntimeWarning)
    import ray

    from ancf_jax.sweep import run_sweep
    ray.init(address="local", num_cpus=2, include_dashboard=False, _node_ip_address="127.0.0.1",
             log_to_driver=False, logging_level="ERROR",
             runtime_env={"env_vars": {k: os.environ[k] for k in ("JAX_COMPILATION_CACHE_DIR",
                                                                  "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS")
                                       if k in os.environ}})
    seen, killed = [], []

    def kill_one(result):
        seen.extend(result["members"])
        if not killed:
            for p in _chunk_workers():
                p.kill()  # SIGKILL the worker mid-chunk: Ray retries its task elsewhere
                killed.append(p.pid)
                break

    try:
        run_sweep("m1", params, out=out, backend="ray", on_chunk=kill_one, **kw)
    finally:
        ray.shutdown()
    return seen, killed


def sweep_sharded_across_two_host_devices(params, out, kw):
    """The local backend in this interpreter, which has two host devices: each chunk is
    one program sharded across both. Returns the devices the run recorded."""
    import jax

    from ancf_jax.sweep import run_sweep
    assert len(jax.devices()) == 2, jax.devices()
    run_sweep("m1", params, out=out, **kw)
    return [str(d) for d in jax.devices()]
