"""Helpers of the scenario tests: writing scenario files and asserting that nothing
was compiled or built."""

import contextlib
import logging

import jax
import pytest

from ancf_jax.model import Model

#: a small valid scenario that the invalid-input cases mutate (never built)
BASE = '''
name = "base"
description = "a clamped arm with a tip body and a trolley on it"
gravity = [0.0, -9.81]

[beams.arm]
geometry = { type = "straight", start = [0.0, 0.0], direction = [1.0, 0.0], length = 1.0 }
elements = 4
alpha = 0.1

[beams.arm.section]
E = 2e11
A = 1e-4
I = 1e-9
density = 7800.0

[bodies.cart]
mass = 1.0
inertia = 0.1
position = [1.0, 0.0]

[bodies.trolley]
mass = 0.5
inertia = 0.01
at = { beam = "arm", s = 0.5 }

[joints.clamp]
type = "clamp"
beam = "arm"
node = 0

[joints.tip]
type = "fixed"
point = { beam = "arm", node = -1 }
body = "cart"

[joints.slide]
type = "sliding"
body = "trolley"
beam = "arm"
s = 0.5

[loads.push]
type = "point_force"
point = { beam = "arm", node = -1 }
force = [0.0, -1.0]
time_function = "0.5 * sin(2*pi*t)"

[solver]
name = "generalized-alpha"
dt = 1e-3
t_end = 0.01

[outputs]
dt = 1e-3

[outputs.columns]
tip_y = { type = "node", beam = "arm", node = -1, component = "y" }
'''


def write(tmp_path, text, name="case.toml"):
    """Write a scenario file and return its path."""
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@contextlib.contextmanager
def nothing_built(caplog, monkeypatch):
    """Fail if a model is built or anything is compiled inside the block (any JAX
    compilation counts: loading must not touch JAX at all)."""
    def forbidden(*a, **k):
        raise AssertionError("a model was built")
    monkeypatch.setattr(Model, "__init__", forbidden)
    caplog.clear()
    with jax.log_compiles(True), caplog.at_level(logging.DEBUG):
        yield
    compiled = [r.getMessage() for r in caplog.records if r.getMessage().startswith("Compiling")]
    assert not compiled, compiled


@pytest.fixture
def no_build(caplog, monkeypatch):
    return lambda: nothing_built(caplog, monkeypatch)
