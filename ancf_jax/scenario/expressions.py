"""Safe time functions: a small arithmetic language in ``t``, compiled without eval.

A scenario gives loads and prescribed motions as functions of time t [s], written as
text such as ``"0.02 * sin(2*pi*t) * ramp(t, 0, 0.5)"``. The text is parsed with
:mod:`ast` and every node is checked against a whitelist; the accepted tree is turned
into nested Python closures over :mod:`jax.numpy` functions, so the result is a
JAX-traceable ``f(t)``. Nothing is passed to ``eval``/``exec``/``compile``, no name
other than those below can be looked up, and no attribute, subscript, string,
lambda, comprehension or keyword argument is accepted.

Accepted:

* numbers (all arithmetic in floating point), the time ``t`` [s] and the constant ``pi``;
* ``+ - * / **``, unary ``+``/``-``, comparisons ``< <= > >=`` (giving 1.0 or 0.0);
* the functions of :data:`FUNCTIONS` with a fixed number of arguments; the steps
  ``ramp``, ``smoothstep``, ``smootherstep`` and ``pulse`` need t1 > t0 when both are
  numbers (a zero-length ramp is 0/0).

Each expression is also compiled with NumPy functions (:meth:`Expression.numpy`), so
that a scenario's time functions are checked on the host, without JAX compiling
anything (:mod:`~ancf_jax.scenario.checks`: finite on the run's time steps and output times).

Limits: at most :data:`MAX_LENGTH` characters and :data:`MAX_NODES` syntax nodes.
"""

from __future__ import annotations

import ast
import dataclasses
import math
from typing import Callable

import jax.numpy as jnp
import numpy as np

#: longest accepted expression (characters)
MAX_LENGTH = 400
#: largest accepted syntax tree (nodes)
MAX_NODES = 200


def _ramp(t, t0, t1, xp=jnp):
    """0 before t0, linear to 1 at t1, 1 after (t1 > t0). ``xp``: jax.numpy or numpy."""
    return xp.clip((t - t0) / (t1 - t0), 0.0, 1.0)


def _smoothstep(t, t0, t1, xp=jnp):
    """Cubic step 3x² − 2x³ from 0 at t0 to 1 at t1 (continuous first derivative)."""
    x = _ramp(t, t0, t1, xp)
    return x * x * (3.0 - 2.0 * x)


def _smootherstep(t, t0, t1, xp=jnp):
    """Quintic step 6x⁵ − 15x⁴ + 10x³ (continuous first and second derivatives)."""
    x = _ramp(t, t0, t1, xp)
    return x * x * x * (x * (6.0 * x - 15.0) + 10.0)


def _step(t, t0, xp=jnp):
    """Heaviside step: 0 before t0, 1 from t0 on."""
    return xp.where(t >= t0, 1.0, 0.0)


def _pulse(t, t0, t1, xp=jnp):
    """1 for t0 <= t < t1, else 0."""
    return xp.where((t >= t0) & (t < t1), 1.0, 0.0)


#: name → (function, number of arguments, one-line description)
FUNCTIONS: dict[str, tuple[Callable, int, str]] = {
    "sin": (jnp.sin, 1, "sine (argument in rad)"),
    "cos": (jnp.cos, 1, "cosine (argument in rad)"),
    "tan": (jnp.tan, 1, "tangent (argument in rad)"),
    "exp": (jnp.exp, 1, "exponential"),
    "log": (jnp.log, 1, "natural logarithm"),
    "sqrt": (jnp.sqrt, 1, "square root"),
    "abs": (jnp.abs, 1, "absolute value"),
    "sign": (jnp.sign, 1, "sign (−1, 0, 1)"),
    "tanh": (jnp.tanh, 1, "hyperbolic tangent"),
    "min": (jnp.minimum, 2, "smaller of two values"),
    "max": (jnp.maximum, 2, "larger of two values"),
    "clip": (jnp.clip, 3, "clip(x, lo, hi): x limited to [lo, hi]"),
    "step": (_step, 2, "step(t, t0): 0 before t0, 1 from t0 on"),
    "pulse": (_pulse, 3, "pulse(t, t0, t1): 1 on [t0, t1), else 0"),
    "ramp": (_ramp, 3, "ramp(t, t0, t1): 0 before t0, linear to 1 at t1, then 1"),
    "smoothstep": (_smoothstep, 3, "smoothstep(t, t0, t1): cubic 0→1 step, C¹"),
    "smootherstep": (_smootherstep, 3, "smootherstep(t, t0, t1): quintic 0→1 step, C²"),
}

#: the functions with t0, t1 arguments that need t1 > t0
INTERVALS = ("ramp", "smoothstep", "smootherstep", "pulse")


def _numpy_function(name: str) -> Callable:
    """The NumPy twin of ``FUNCTIONS[name]`` (same formula, evaluated on the host)."""
    fn = FUNCTIONS[name][0]
    if fn in (_ramp, _smoothstep, _smootherstep, _step, _pulse):
        return lambda *args: fn(*args, xp=np)
    return getattr(np, fn.__name__)


#: name → NumPy function, for host-side checks (see :meth:`Expression.numpy`)
NUMPY_FUNCTIONS: dict[str, Callable] = {name: _numpy_function(name) for name in FUNCTIONS}

#: names that may appear other than function names
CONSTANTS = {"pi": math.pi}
VARIABLE = "t"

_BINARY = {ast.Add: "add", ast.Sub: "subtract", ast.Mult: "multiply", ast.Div: "divide",
           ast.Pow: "power"}
_COMPARE = {ast.Lt: "less", ast.LtE: "less_equal", ast.Gt: "greater", ast.GtE: "greater_equal"}


@dataclasses.dataclass(frozen=True)
class _Backend:
    """The array functions an expression is compiled with: jax.numpy (traced) or
    numpy (host checks)."""

    xp: object
    functions: dict

#: what the language accepts, in one line (used in error messages and the docs)
ACCEPTED = ("numbers, t, pi, + - * / **, unary -, comparisons < <= > >=, and the "
            "functions " + ", ".join(FUNCTIONS))


class ExpressionError(ValueError):
    """An expression outside the safe set (message says which construct)."""


def _describe(node: ast.AST) -> str:
    """A construct outside the safe set, in words (for messages)."""
    names = {ast.Attribute: "attribute access", ast.Subscript: "a subscript",
             ast.Lambda: "a lambda", ast.ListComp: "a comprehension", ast.SetComp: "a comprehension",
             ast.DictComp: "a comprehension", ast.GeneratorExp: "a comprehension",
             ast.JoinedStr: "a string", ast.BoolOp: "'and'/'or'", ast.IfExp: "'if ... else'",
             ast.List: "a list", ast.Tuple: "a tuple", ast.Dict: "a dict", ast.Set: "a set",
             ast.Starred: "a starred argument", ast.NamedExpr: "an assignment (:=)",
             ast.Await: "await", ast.Yield: "yield", ast.YieldFrom: "yield"}
    for cls, text in names.items():
        if isinstance(node, cls):
            return text
    return type(node).__name__


def _uses_t(node: ast.AST) -> bool:
    return any(isinstance(n, ast.Name) and n.id == VARIABLE for n in ast.walk(node))


def _compile(node: ast.AST, be: _Backend) -> Callable:
    """Closure t ↦ value for one checked node (recursive), with the functions of ``be``."""
    xp = be.xp
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            what = "a string" if isinstance(node.value, (str, bytes)) else repr(node.value)
            raise ExpressionError(f"{what} is not allowed (only numbers)")
        try:
            value = float(node.value)
        except OverflowError:
            raise ExpressionError("number too large") from None
        return lambda t: value
    if isinstance(node, ast.Name):
        if node.id == VARIABLE:
            return lambda t: t
        if node.id in CONSTANTS:
            value = CONSTANTS[node.id]
            return lambda t: value
        if node.id in FUNCTIONS:
            raise ExpressionError(f"function {node.id!r} must be called, e.g. {node.id}(t)")
        raise ExpressionError(f"unknown name {node.id!r} (names: t, pi)")
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        arg = _compile(node.operand, be)
        if isinstance(node.op, ast.USub):
            return lambda t: xp.negative(arg(t))
        return arg
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        op, left, right = getattr(xp, _BINARY[type(node.op)]), _compile(node.left, be), _compile(node.right, be)
        return lambda t: op(left(t), right(t))
    if isinstance(node, ast.BinOp):
        raise ExpressionError(f"operator {type(node.op).__name__} is not allowed (+ - * / ** only)")
    if isinstance(node, ast.Compare):
        if len(node.ops) != 1 or type(node.ops[0]) not in _COMPARE:
            raise ExpressionError("only single comparisons < <= > >= are allowed")
        op = getattr(xp, _COMPARE[type(node.ops[0])])
        left, right = _compile(node.left, be), _compile(node.comparators[0], be)
        return lambda t: xp.where(op(left(t), right(t)), 1.0, 0.0)
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name):
            raise ExpressionError(f"only calls of the named functions are allowed, not of {_describe(node.func)}")
        name = node.func.id
        if name not in FUNCTIONS:
            raise ExpressionError(f"unknown function {name!r}")
        if node.keywords:
            raise ExpressionError(f"keyword arguments are not allowed in {name}()")
        _, arity, _ = FUNCTIONS[name]
        fn = be.functions[name]
        if len(node.args) != arity:
            raise ExpressionError(f"{name}() takes {arity} argument{'s' if arity > 1 else ''}, "
                                  f"got {len(node.args)}")
        args = [_compile(a, be) for a in node.args]
        if name in INTERVALS and not any(map(_uses_t, node.args[1:])):
            with np.errstate(all="ignore"):
                t0, t1 = (float(_compile(a, _NUMPY)(0.0)) for a in node.args[1:])
            if not t1 > t0:
                raise ExpressionError(f"{name}(t, t0, t1) needs t1 > t0, got t0 = {t0:g}, t1 = {t1:g}"
                                      + (" (a zero-length step)" if t1 == t0 else ""))
        return lambda t: fn(*(a(t) for a in args))
    raise ExpressionError(f"{_describe(node)} is not allowed")


@dataclasses.dataclass(frozen=True)
class Expression:
    """A checked time function ``f(t)`` (JAX-traceable), compared and hashed by its
    source text so that equal scenarios give equal (cache-sharing) systems."""

    source: str
    _fn: Callable = dataclasses.field(compare=False, hash=False, repr=False)
    _np: Callable = dataclasses.field(compare=False, hash=False, repr=False, default=None)

    def __call__(self, t):
        return jnp.asarray(self._fn(jnp.asarray(t, float)), float)

    def numpy(self, t) -> np.ndarray:
        """f(t) evaluated with NumPy on the host (no JAX, nothing compiled), for
        checks; overflow and division by zero give inf/NaN silently."""
        with np.errstate(all="ignore"):
            return np.broadcast_to(np.asarray(self._np(np.asarray(t, float)), float), np.shape(t))


def compile_expression(source: str) -> Expression:
    """Parse and check ``source`` (see module docstring) and return it as a callable.

    Raises:
        ExpressionError: syntax error, too long, or a construct outside the safe set.
    """
    if not isinstance(source, str):
        raise ExpressionError("an expression must be a string")
    if len(source) > MAX_LENGTH:
        raise ExpressionError(f"expression longer than {MAX_LENGTH} characters")
    if not source.strip():
        raise ExpressionError("empty expression")
    try:
        tree = ast.parse(source.strip(), mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError) as e:
        msg = getattr(e, "msg", None) or str(e) or type(e).__name__
        raise ExpressionError(f"invalid syntax ({msg})") from None
    if sum(1 for _ in ast.walk(tree)) > MAX_NODES:
        raise ExpressionError(f"expression has more than {MAX_NODES} syntax nodes")
    try:
        fn = _compile(tree.body, _JAX)
        host = _compile(tree.body, _NUMPY)
    except RecursionError:
        raise ExpressionError("expression nested too deeply") from None
    return Expression(source.strip(), fn, host)


_JAX = _Backend(jnp, {name: f for name, (f, _, _) in FUNCTIONS.items()})
_NUMPY = _Backend(np, NUMPY_FUNCTIONS)
