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


# XLA flags added at import (ancf_jax/_xla.py): only where the user did not name them,
# not when switched off, not once a backend runs; the process must then compute (an
# unknown flag would abort it).
FLAGS_CODE = ("{pre}import os, ancf_jax, jax, jax.numpy as jnp; float(jnp.ones(3).sum()); "
              "print(repr(os.environ.get('XLA_FLAGS')), jax.device_count())")


def flags_in_fresh_process(pre="", **env):
    e = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", "ANCF_JAX_XLA_FLAGS", "ANCF_JAX_LOOP_KERNELS")}
    e.update(JAX_PLATFORMS="cpu", **env)
    out = subprocess.run([sys.executable, "-c", FLAGS_CODE.format(pre=pre)], env=e,
                         capture_output=True, text=True, check=True)
    return out.stdout.strip().splitlines()[-1]


def test_xla_flags_setting():
    """In fresh interpreters (each ~3 s), that XLA accepts what is set and the process
    computes: the defaults, a user's flag kept and in effect, loop kernels, and nothing
    changed once a backend runs."""
    from ancf_jax import _xla
    default = " ".join(_xla.DEFAULT_FLAGS) if _xla._jaxlib_release() in _xla.TESTED_JAXLIB else None
    two = "--xla_force_host_platform_device_count=2"
    assert flags_in_fresh_process() == f"{default!r} 1"
    assert flags_in_fresh_process(XLA_FLAGS=two) == f"{(two + ' ' + default) if default else two!r} 2"
    if default:  # loop kernels asked for: the threshold added
        loops = f"--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold={_xla.LOOP_KERNEL_BYTES}"
        assert flags_in_fresh_process(ANCF_JAX_LOOP_KERNELS="1") == f"{default + ' ' + loops!r} 1"
    # a backend started before ancf_jax is imported: nothing changed (too late to act)
    assert flags_in_fresh_process(pre="import jax; jax.devices(); ") == "None 1"


@pytest.mark.parametrize("env, expected", [
    ({}, "{default}"),
    ({"XLA_FLAGS": "{mine}"}, "{mine}"),                                    # the user's own value kept
    ({"ANCF_JAX_XLA_FLAGS": "off"}, None),                                  # switched off
    ({"ANCF_JAX_LOOP_KERNELS": "1", "ANCF_JAX_XLA_FLAGS": "off"}, "{loops}"),
    ({"ANCF_JAX_LOOP_KERNELS": "1", "XLA_FLAGS": "{own}"}, "{own} {default}"),  # a user's extra options kept
])
def test_xla_flags_composed(monkeypatch, env, expected):
    """configure_xla_flags as at import, in this process (no backend as far as it can
    tell): what XLA_FLAGS becomes for the user's settings."""
    from ancf_jax import _xla
    if _xla._jaxlib_release() not in _xla.TESTED_JAXLIB:
        pytest.skip("the flags are added only on the measured jaxlib releases")
    words = dict(default=" ".join(_xla.DEFAULT_FLAGS), mine=" ".join(_xla.DEFAULT_FLAGS).replace("=false", "=true"),
                 loops=f"--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold={_xla.LOOP_KERNEL_BYTES}",
                 own="--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=5000")
    for name in ("XLA_FLAGS", _xla.ENV, _xla.LOOP_KERNELS_ENV):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value.format(**words))
    monkeypatch.setattr(_xla, "_backend_running", lambda: False)
    given = os.environ.get("XLA_FLAGS")
    changed = _xla.configure_xla_flags()
    if expected is None:
        assert changed is None and "XLA_FLAGS" not in os.environ
    else:
        assert os.environ["XLA_FLAGS"] == expected.format(**words)
        # None exactly when nothing had to change
        assert changed == (None if given == os.environ["XLA_FLAGS"] else os.environ["XLA_FLAGS"])


YNN_CODE = ("import ancf_jax, jax, jax.numpy as jnp; "
            "f = jax.jit(lambda a, b: jnp.tanh(jnp.matmul(a, b)) * 2.0); a = jnp.ones((72, 8, 8)); "
            "print('ynn' in f.lower(a, a).compile().as_text().lower())")


def test_ynnpack_fusions_off_by_default():
    """The batched small products of the element code (here 72 = elements × quadrature
    points of 8×8 matrices) are compiled by XLA itself, not handed to YNNPACK
    (``--xla_cpu_experimental_ynn_fusion_type=``, ancf_jax/_xla.py); with the defaults
    switched off, XLA's own default fuses them into YNNPACK calls."""
    from ancf_jax import _xla
    if _xla._jaxlib_release() not in _xla.TESTED_JAXLIB:
        pytest.skip("flags are added for the tested jaxlib releases only")

    def ynn(**env):
        e = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", "ANCF_JAX_XLA_FLAGS")}
        e.update(JAX_PLATFORMS="cpu", **env)
        out = subprocess.run([sys.executable, "-c", YNN_CODE], env=e, capture_output=True, text=True, check=True)
        return out.stdout.strip().splitlines()[-1]

    assert ynn() == "False"
    assert ynn(ANCF_JAX_XLA_FLAGS="off") == "True"
