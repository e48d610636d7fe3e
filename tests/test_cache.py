"""The persistent compilation cache ancf_jax turns on at import (ancf_jax/_cache.py):
default directory, the user's own setting left alone, and the switch that turns it off.
Each case is a fresh interpreter (the setting is made at import)."""

import os
import subprocess
import sys

import pytest

CODE = "import ancf_jax, jax; print(jax.config.jax_compilation_cache_dir)"


def cache_dir_in_fresh_process(tmp_path, **env):
    e = {k: v for k, v in os.environ.items() if k not in ("JAX_COMPILATION_CACHE_DIR", "ANCF_JAX_CACHE")}
    e.update(XDG_CACHE_HOME=str(tmp_path / "xdg"), JAX_PLATFORMS="cpu", **env)
    out = subprocess.run([sys.executable, "-c", CODE], env=e, capture_output=True, text=True, check=True)
    return out.stdout.strip().splitlines()[-1]


@pytest.mark.parametrize("env, expected", [
    ({}, "{tmp}/xdg/ancf_jax/xla"),                          # default: the user cache dir
    ({"ANCF_JAX_CACHE": "{tmp}/mine"}, "{tmp}/mine"),          # relocated
    ({"ANCF_JAX_CACHE": "0"}, "None"),                         # off
    ({"JAX_COMPILATION_CACHE_DIR": "{tmp}/jax"}, "{tmp}/jax"),  # the user's JAX setting wins
])
def test_compilation_cache_setting(tmp_path, env, expected):
    env = {k: v.format(tmp=tmp_path) for k, v in env.items()}
    assert cache_dir_in_fresh_process(tmp_path, **env) == expected.format(tmp=tmp_path)
