"""The safe time-function language: values, JAX tracing, and everything it refuses."""

import math
import time

import jax
import numpy as np
import pytest

from ancf_jax.scenario.expressions import FUNCTIONS, ExpressionError, compile_expression

T = np.linspace(-0.5, 2.5, 31)

VALUES = [
    ("2*t + 1", lambda t: 2 * t + 1),
    ("-t**2 / 4 - 3", lambda t: -t**2 / 4 - 3),
    ("0.02 * sin(2*pi*t)", lambda t: 0.02 * np.sin(2 * np.pi * t)),
    ("cos(t) + tan(0.1*t) + exp(-t) + tanh(t)", lambda t: np.cos(t) + np.tan(0.1 * t) + np.exp(-t) + np.tanh(t)),
    ("sqrt(abs(t)) + log(1 + t*t)", lambda t: np.sqrt(np.abs(t)) + np.log(1 + t * t)),
    ("min(t, 1) + max(t, 0) + clip(t, 0.2, 0.8) + sign(t - 1)",
     lambda t: np.minimum(t, 1) + np.maximum(t, 0) + np.clip(t, 0.2, 0.8) + np.sign(t - 1)),
    ("(t > 1) * 5 + (t <= 0) * 2", lambda t: (t > 1) * 5.0 + (t <= 0) * 2.0),
    ("step(t, 1) + pulse(t, 0.5, 1.5)", lambda t: (t >= 1) * 1.0 + ((t >= 0.5) & (t < 1.5)) * 1.0),
    ("ramp(t, 0, 2)", lambda t: np.clip(t / 2, 0, 1)),
    ("smoothstep(t, 0, 2)", lambda t: (lambda x: x * x * (3 - 2 * x))(np.clip(t / 2, 0, 1))),
    ("smootherstep(t, 0, 2)", lambda t: (lambda x: 6 * x**5 - 15 * x**4 + 10 * x**3)(np.clip(t / 2, 0, 1))),
    ("3", lambda t: 3.0 + 0 * t),
    ("+t", lambda t: t),
]


@pytest.mark.parametrize("source,reference", VALUES, ids=[v[0] for v in VALUES])
def test_values(source, reference):
    f = compile_expression(source)
    got = np.array([float(f(t)) for t in T])
    np.testing.assert_allclose(got, reference(T), rtol=1e-13, atol=1e-15)


def test_every_function_is_exercised():
    used = {name for source, _ in VALUES for name in FUNCTIONS if f"{name}(" in source}
    assert used == set(FUNCTIONS)


def test_traceable_and_differentiable():
    f = compile_expression("0.5 * sin(2*pi*t) * smootherstep(t, 0, 1)")
    g = jax.jit(jax.vmap(jax.grad(f)))(np.array([0.0, 0.3, 1.5]))
    h = 1e-6
    fd = [(float(f(t + h)) - float(f(t - h))) / (2 * h) for t in (0.0, 0.3, 1.5)]
    np.testing.assert_allclose(np.asarray(g), fd, rtol=1e-6, atol=1e-9)


def test_equal_sources_are_equal_functions():
    a, b = compile_expression("sin(t)"), compile_expression(" sin(t) ")
    assert a == b and hash(a) == hash(b)
    assert a != compile_expression("cos(t)")


REJECTED = [
    ("__import__('os')", "unknown function '__import__'"),
    ("__import__('os').system('touch pwned')", "attribute access"),
    ("open('/etc/passwd')", "unknown function 'open'"),
    ("open('pwned', 'w')", "unknown function 'open'"),
    ("eval('1')", "unknown function 'eval'"),
    ("exec('import os')", "unknown function 'exec'"),
    ("globals()", "unknown function 'globals'"),
    ("t.real", "attribute access"),
    ("sin.__globals__", "attribute access"),
    ("().__class__.__bases__[0].__subclasses__()", "attribute access"),
    ("sin(t)[0]", "a subscript"),
    ("lambda: 1", "a lambda"),
    ("[x for x in (1, 2)]", "a comprehension"),
    ("(x for x in (1,))", "a comprehension"),
    ("'abc'", "a string"),
    ("f'{t}'", "a string"),
    ("b'x'", "a string"),
    ("t if t > 0 else 0", "'if ... else'"),
    ("t > 0 and t < 1", "'and'/'or'"),
    ("0 < t < 1", "single comparisons"),
    ("t == 1", "single comparisons"),
    ("t % 2", "operator Mod"),
    ("t // 2", "operator FloorDiv"),
    ("x + 1", "unknown name 'x'"),
    ("e", "unknown name 'e'"),
    ("sin", "must be called"),
    ("sin(x=t)", "keyword arguments"),
    ("sin(*t)", "a starred argument"),
    ("ramp(t, 1)", "takes 3 arguments"),
    ("(t := 1)", "an assignment"),
    ("[t, 1]", "a list"),
    ("{t: 1}", "a dict"),
    ("True", "True"),
    ("None", "None"),
    ("import os", "invalid syntax"),
    ("t; import os", "invalid syntax"),
    ("t\nimport os", "invalid syntax"),
    ("", "empty"),
    ("t +" * 200 + "t", "longer than"),
    ("-" * 300 + "t", "syntax nodes"),
    ("+".join(["t"] * 150), "syntax nodes"),
    ("1" * 400, "number too large"),
]


@pytest.mark.parametrize("source,reason", REJECTED, ids=[r[0][:40] for r in REJECTED])
def test_rejected(source, reason, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ExpressionError, match=None) as err:
        compile_expression(source)
    assert reason in str(err.value)
    assert not (tmp_path / "pwned").exists()


def test_deep_nesting_within_the_limits_is_fine():
    assert float(compile_expression("(" * 150 + "t" + ")" * 150)(2.0)) == 2.0
    assert float(compile_expression("sin(" * 60 + "t" + ")" * 60)(0.0)) == 0.0


def test_huge_powers_do_not_hang():
    start = time.perf_counter()
    f = compile_expression("9**9**9**9")
    assert math.isinf(float(f(0.0)))
    assert time.perf_counter() - start < 5.0
