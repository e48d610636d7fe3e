"""ancf_jax._memory: compiled programs are freed before the process reaches the
kernel's memory-map limit (XLA crashes there instead of raising)."""

import jax
import jax.numpy as jnp
import pytest

from ancf_jax import _memory, simulation


@pytest.mark.skipif(_memory.map_count() is None or _memory.map_limit() is None, reason="Linux /proc only")
def test_relieve_frees_compiled_programs_above_the_fraction():
    from ancf_jax.models.m1 import m1_model
    system, state = m1_model(2).build()
    simulation.simulate(system, state, t_end=0.002, dt=1e-3, progress=False)
    assert simulation._COMPILED
    before = _memory.map_count()
    assert not _memory.relieve(1.0)              # far from the limit: nothing freed
    assert simulation._COMPILED
    assert _memory.relieve(0.0)                  # above any fraction: freed
    assert not simulation._COMPILED
    assert _memory.map_count() < before - 500    # the programs' code maps are gone
    # and runs compile again afterwards
    r = simulation.simulate(system, state, t_end=0.002, dt=1e-3, progress=False)
    assert r.status == "ok"
    assert float(jax.jit(lambda x: jnp.sum(x))(jnp.ones(3))) == 3.0
