"""Compilation of a run (ancf_jax.simulation.compiled_pair, ancf_jax._xla): the
initial-state program compiles in a background thread while the chunk program is traced
with placeholders of its outputs, and is compiled with the run-once options."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax import _xla, simulation


def test_pair_compiled_once_with_the_signature_of_the_real_outputs():
    from ancf_jax.models.m1 import m1_model
    system, state = m1_model(3).build()
    simulation._COMPILED.clear()
    first = simulation.simulate(system, state, t_end=0.004, dt=1e-3, progress=False)
    assert first.compile_time_s > 0.0 and len(simulation._COMPILED) == 2
    again = simulation.simulate(system, state, t_end=0.004, dt=1e-3, progress=False)
    assert again.compile_time_s == 0.0 and len(simulation._COMPILED) == 2
    np.testing.assert_array_equal(again.q, first.q)
    # the chunk program traced with placeholders is the one the real outputs select
    solver = simulation.make_solver("generalized-alpha").forward_only()
    options = simulation.RunOptions()

    def chunk_args(loop, ctx):
        return (system, loop, ctx, solver, jnp.asarray(1e-3), jnp.asarray(0.004), 4, 1, options)

    simulation._COMPILED.clear()
    init, _, seconds = simulation.compiled_pair(simulation._init_single, (system, state, solver),
                                                simulation._chunk_single, chunk_args,
                                                first_options=_xla.run_once_options())
    assert seconds > 0.0 and len(simulation._COMPILED) == 2
    loop, ctx = init(system, state, solver)
    _, seconds = simulation.compiled(simulation._chunk_single, *chunk_args(loop, ctx))
    assert seconds == 0.0 and len(simulation._COMPILED) == 2
    # the initial state compiled with the run-once options equals XLA's defaults' to rounding
    reference = eqx.filter_jit(simulation._init_fixed)(system, state, solver)[0]
    for a, b in zip(jax.tree.leaves(loop), jax.tree.leaves(reference)):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-12, atol=1e-14)


def test_pair_with_weakly_typed_outputs_and_cached_first():
    first = eqx.filter_jit(lambda a: (a + 1.0, jax.lax.add(2.0, 0.0)))  # the second output is weak
    second = eqx.filter_jit(lambda a, b, c: a * b + c)
    x = jnp.arange(3.0)
    f, s, seconds = simulation.compiled_pair(first, (x,), second, lambda a, b: (a, b, 1.0))
    assert seconds > 0.0
    a, b = f(x)
    assert b.weak_type
    np.testing.assert_array_equal(np.asarray(s(a, b, 1.0)), 2.0 * (np.arange(3.0) + 1.0) + 1.0)
    # cached first, new second (another static argument): traced with the real outputs
    f2, s2, seconds = simulation.compiled_pair(first, (x,), second, lambda a, b: (a, b, 2.0))
    assert f2 is f and s2 is not s and seconds > 0.0
    np.testing.assert_array_equal(np.asarray(s2(a, b, 2.0)), 2.0 * (np.arange(3.0) + 1.0) + 2.0)


def test_run_once_options(monkeypatch):
    monkeypatch.setenv(_xla.ENV, "off")
    assert _xla.run_once_options() is None
    monkeypatch.delenv(_xla.ENV)
    tested = _xla._jaxlib_release() in _xla.TESTED_JAXLIB
    assert _xla.run_once_options() == (_xla.RUN_ONCE_OPTIONS if tested else None)


# Loop kernels (ANCF_JAX_LOOP_KERNELS=1, ancf_jax._xla): a fresh process (the flag acts when
# the backend starts); the chunk program without LAPACK calls, the run equal to the
# default's to rounding (other instruction orders).
LOOP_KERNEL_CODE = """
import json, sys, numpy as np
sys.path.insert(0, {root!r})
from tests.test_compile import m1_chunk_text
from ancf_jax import _xla, simulation
from ancf_jax.models.m1 import m1_model
system, state = m1_model(3).build()
r = simulation.simulate(system, state, t_end=0.02, dt=1e-3, progress=False)
print(json.dumps(dict(on=_xla.loop_kernels(), lapack="lapack" in m1_chunk_text(system, state),
                      q=np.asarray(r.q).tolist(), status=r.status)))
"""


def m1_chunk_text(system, state):
    """The lowered (unoptimized) chunk program of a 0.02 s M1 run at dt = 1 ms."""
    options = simulation.RunOptions()
    solver, (n_int, sub, h, _), (per_chunk, _) = simulation._prepare(
        0.02, 1e-3, simulation.make_solver("generalized-alpha"), None, options, simulation.RunLimits(),
        "return", batched=False)
    solver = solver.forward_only()
    loop, ctx = simulation._init_single(system, state, solver)
    args = (system, loop, ctx, solver, jnp.asarray(h), jnp.asarray(n_int * sub * h), per_chunk, sub, options)
    return simulation._chunk_single.lower(*args).as_text()


@pytest.mark.study
def test_loop_kernels_give_the_default_run_without_lapack_in_the_step():
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    from ancf_jax.models.m1 import m1_model
    root = str(Path(__file__).resolve().parents[1])
    env = dict(os.environ, ANCF_JAX_LOOP_KERNELS="1")
    # the suite's own flags, without any extra options of the caller's (ours must be added)
    env["XLA_FLAGS"] = " ".join(f for f in env.get("XLA_FLAGS", "").split()
                                if not f.startswith("--xla_backend_extra_options"))
    out = subprocess.run([sys.executable, "-c", LOOP_KERNEL_CODE.format(root=root)], env=env, cwd=root,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    child = json.loads(out.stdout.strip().splitlines()[-1])
    system, state = m1_model(3).build()
    assert "lapack" in m1_chunk_text(system, state) and not _xla.loop_kernels()  # this process: the default
    tested = _xla._jaxlib_release() in _xla.TESTED_JAXLIB
    assert child["on"] == tested and child["lapack"] == (not tested) and child["status"] == "ok"
    r = simulation.simulate(system, state, t_end=0.02, dt=1e-3, progress=False)
    np.testing.assert_allclose(child["q"], r.q, rtol=0, atol=1e-12)


def test_compiler_options_reach_xla_and_key_the_in_process_cache():
    """``ancf_jax.compiler_options``: a run compiled in the block is another program
    (compiled again, cached beside the first; the initial state keeps its run-once
    options and is reused), its numbers equal the first's to rounding (another LLVM
    level, the same floating-point operations); the options reach XLA (a name XLA does
    not know fails the compilation with that name); simulate_each's threads compile
    nothing new in the block; nested blocks add up; a value of the
    wrong type is refused before anything is compiled."""
    import pytest

    from ancf_jax import compiler_options
    from ancf_jax.models.m1 import m1_model
    system, state = m1_model(3).build()
    simulation._COMPILED.clear()
    with compiler_options(xla_backend_optimization_level=3):  # the suite compiles at 0 (conftest.py)
        other = simulation.simulate(system, state, t_end=0.004, dt=1e-3, progress=False)
        assert other.compile_time_s > 0.0 and len(simulation._COMPILED) == 2
        # simulate_each's member threads run in the block's context: its program, cached
        each = simulation.simulate_each([system] * 3, [state] * 3, workers=2, t_end=0.004, dt=1e-3)
        assert [r.compile_time_s for r in each] == [0.0] * 3 and len(simulation._COMPILED) == 2
        with compiler_options(xla_cpu_enable_fast_min_max=False):
            assert _xla.program_options() == {"xla_backend_optimization_level": 3,
                                              "xla_cpu_enable_fast_min_max": False}
            assert _xla.program_options({"xla_backend_optimization_level": 0})["xla_backend_optimization_level"] == 0
    assert _xla.program_options() is None
    first = simulation.simulate(system, state, t_end=0.004, dt=1e-3, progress=False)
    # the chunk again; the initial state again only where it has no level of its own
    compiled_now = 3 + (_xla.run_once_options() is None)
    assert first.compile_time_s > 0.0 and len(simulation._COMPILED) == compiled_now
    np.testing.assert_allclose(other.q, first.q, rtol=0, atol=1e-12)
    again = simulation.simulate(system, state, t_end=0.004, dt=1e-3, progress=False)
    assert again.compile_time_s == 0.0 and len(simulation._COMPILED) == compiled_now
    with compiler_options(xla_no_such_option_of_ancf_jax=1), \
            pytest.raises(Exception, match="xla_no_such_option_of_ancf_jax"):
        simulation.simulate(system, state, t_end=0.004, dt=1e-3, progress=False)
    # 3 and 3.0 (True and 1) are different options to XLA: different programs
    assert simulation._options_key({"a": 3}) != simulation._options_key({"a": 3.0})
    assert simulation._options_key({"a": True}) != simulation._options_key({"a": 1})
    with pytest.raises(ValueError, match="xla_backend_optimization_level must be a bool, int, float or str"):
        with compiler_options(xla_backend_optimization_level=[3]):
            pass


def test_compiler_options_from_the_environment():
    """``ANCF_JAX_COMPILER_OPTIONS`` (name=value[,...]): parsed into booleans, numbers and
    strings; the process's options outside any block (a child process reads them at
    import); an entry that is not name=value fails the import with one line naming the
    variable."""
    import os
    import subprocess
    import sys

    import pytest
    assert _xla.parse_options("") == {}
    assert _xla.parse_options(" xla_backend_optimization_level=3, a=true,b=False ,c=0.5,d=x") == \
        {"xla_backend_optimization_level": 3, "a": True, "b": False, "c": 0.5, "d": "x"}
    for bad in ("level", "=3", "a=", "a=1,,b"):
        if bad == "a=1,,b":  # empty entries are skipped, a bare name is not
            with pytest.raises(ValueError, match="'b' is not name=value"):
                _xla.parse_options(bad)
            continue
        with pytest.raises(ValueError, match="ANCF_JAX_COMPILER_OPTIONS: .* is not name=value"):
            _xla.parse_options(bad)
    code = "import ancf_jax, ancf_jax._xla as x; print(x.program_options(), x.program_options({'a': 0}))"
    for value, expected, rc in (("xla_backend_optimization_level=3",
                                 "{'xla_backend_optimization_level': 3} {'xla_backend_optimization_level': 3, 'a': 0}", 0),
                                ("level", "ANCF_JAX_COMPILER_OPTIONS: 'level' is not name=value", 1)):
        env = dict(os.environ, ANCF_JAX_COMPILER_OPTIONS=value, JAX_PLATFORMS="cpu")
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
        assert out.returncode == rc and expected in (out.stdout + out.stderr), out.stderr[-2000:]

