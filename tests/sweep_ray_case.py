"""The Ray and device-sharding cases of ``tests/test_sweep.py``, run in one spawned
interpreter started with two XLA host devices (``XLA_FLAGS``): Ray's native
libraries (its core worker, gRPC, Abseil) never load into the pytest workers that
compile the rest of the suite's JAX programs (a worker that had started Ray in-process
later segfaulted inside XLA, as workers with Exudyn loaded had before; see
tests/exudyn_cases.py)."""

import os

import psutil


def _chunk_workers():
    """Ray worker processes on this machine that are running a chunk now (a worker
    titles itself ``ray::run_chunk`` while it runs the task)."""
    out = []
    for p in psutil.process_iter(["name", "cmdline"]):
        try:
            if "run_chunk" in (p.info["name"] or "") or "run_chunk" in " ".join(p.info["cmdline"] or ()):
                out.append(p)
        except psutil.Error:
            pass
    return out


def _free_port() -> int:
    import socket
    with socket.socket() as s:
        s.bind(("", 0))
        return s.getsockname()[1]


def sweep_on_ray_killing_a_worker(params, out, kw, root):
    """A Ray cluster started as a user starts one, ``ray start --head`` (2 CPUs, no
    dashboard, no usage statistics) on this machine's own address (a driver given
    127.0.0.1 is sent there by Ray's address resolution; nothing leaves the machine),
    and the sweep connected to it by its address (the ``--address`` path of
    ``ancf-jax sweep``) while one worker is killed (SIGKILL) mid-chunk; ``ray stop``
    afterwards. Returns (members seen in chunk order, pids killed, the address, and per
    chunk in order (worker pid, seconds it spent compiling, the JAX persistent cache
    directory it used))."""
    import shutil
    import subprocess
    import sys
    import warnings
    from pathlib import Path
    # token authentication, as Ray 2.61+ requires of every cluster: the head, its workers
    # and this driver read the token of ~/.ray/auth_token (generated if missing)
    env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0", RAY_AUTH_MODE="token",
               PYTHONPATH=os.pathsep.join([root] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep)
                                                    if p]))
    os.environ.update(RAY_USAGE_STATS_ENABLED="0", RAY_AUTH_MODE="token", PYTHONPATH=env["PYTHONPATH"])
    warnings.filterwarnings("ignore", message="os.fork", category=RuntimeWarning)
    ray_cli = shutil.which("ray") or str(Path(sys.executable).with_name("ray"))
    from ray._private.services import get_node_ip_address
    host, port = get_node_ip_address(), _free_port()
    subprocess.run([ray_cli, "get-auth-token", "--generate"], env=env, check=True, capture_output=True, timeout=60)
    subprocess.run([ray_cli, "start", "--head", f"--port={port}", f"--node-ip-address={host}", "--num-cpus=2",
                    "--include-dashboard=false", "--disable-usage-stats"], env=env, check=True,
                   capture_output=True, timeout=180)
    import ray

    from ancf_jax.sweep import run_sweep
    seen, killed, chunks = [], [], []

    def kill_one(result):
        seen.extend(result["members"])
        chunks.append((result["pid"], result["compile_s"], result["compilation_cache"]))
        if not killed:
            for p in _chunk_workers():
                p.kill()  # SIGKILL the worker mid-chunk: Ray retries its task elsewhere
                killed.append(p.pid)
                break

    address = f"{host}:{port}"
    try:
        run_sweep("m1", params, out=out, backend="ray", address=address, on_chunk=kill_one, **kw)
    finally:
        ray.shutdown()
        subprocess.run([ray_cli, "stop", "--force"], env=env, capture_output=True, timeout=180)
    return seen, killed, address, chunks


def sweep_sharded_across_two_host_devices(params, out, kw):
    """The local backend in this interpreter, which has two host devices: each chunk is
    one program sharded across both. Returns the devices the run recorded."""
    import jax

    from ancf_jax.sweep import run_sweep
    assert len(jax.devices()) == 2, jax.devices()
    run_sweep("m1", params, out=out, **kw)
    return [str(d) for d in jax.devices()]
