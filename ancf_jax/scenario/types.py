"""Value types of scenario keys: vectors, matrices, names and time functions.

Each type is a :data:`typing.Annotated` pydantic type whose validator raises one clear
error for the whole value, and carries an :class:`Accepts` marker: the phrase used
both in error messages (``accepted: ...``) and in the generated documentation.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Annotated, Any, Union

import jax.numpy as jnp
from pydantic import PlainValidator, ValidationInfo
from pydantic_core import PydanticCustomError

from ..functions import Constant
from .expressions import ACCEPTED as EXPRESSION_SET
from .expressions import ExpressionError, compile_expression
from .tables import PATH_RULE, TableError, table_from_csv, table_from_rows


@dataclasses.dataclass(frozen=True)
class Accepts:
    """What a key accepts, in words: ``text`` for errors, ``short`` (if given) for the
    documentation's tables, which explain the long forms once."""

    text: str
    short: str | None = None


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _error(kind: str, message: str):
    return PydanticCustomError(kind, message)


def _vector(n: int):
    def check(value):
        if not isinstance(value, (list, tuple)) or len(value) != n or not all(map(_is_number, value)):
            raise _error("vector", f"must be an array of {n} numbers, got {value!r}")
        if not all(math.isfinite(x) for x in value):
            raise _error("vector", f"must be finite, got {value!r}")
        return tuple(float(x) for x in value)
    return check


def _matrix(columns: int, what: str):
    def check(value):
        if (not isinstance(value, (list, tuple)) or len(value) < 1
                or not all(isinstance(r, (list, tuple)) and len(r) == columns and all(map(_is_number, r))
                           for r in value)):
            raise _error("matrix", f"must be an array of rows {what}, each {columns} numbers")
        if not all(math.isfinite(x) for r in value for x in r):
            raise _error("matrix", "must be finite")
        return tuple(tuple(float(x) for x in r) for r in value)
    return check


Vec2 = Annotated[tuple[float, float], PlainValidator(_vector(2)), Accepts("[x, y]: two finite numbers")]
Points2 = Annotated[tuple[tuple[float, float], ...], PlainValidator(_matrix(2, "[x, y]")),
                    Accepts("an array of [x, y] rows")]
Nodes4 = Annotated[tuple[tuple[float, float, float, float], ...],
                   PlainValidator(_matrix(4, "[r_x, r_y, r_x', r_y']")),
                   Accepts("an array of [r_x, r_y, r_x', r_y'] rows, one per node")]


#: most values of a :data:`Numbers` array (e.g. masses of a lumped chain)
MAX_NUMBERS = 100


def _numbers(value):
    if (not isinstance(value, (list, tuple)) or len(value) < 1 or len(value) > MAX_NUMBERS
            or not all(map(_is_number, value))):
        raise _error("numbers", f"must be an array of 1 to {MAX_NUMBERS} numbers, got {value!r}")
    if not all(math.isfinite(x) for x in value):
        raise _error("numbers", f"must be finite, got {value!r}")
    return tuple(float(x) for x in value)

Numbers = Annotated[tuple[float, ...], PlainValidator(_numbers),
                    Accepts(f"an array of 1 to {MAX_NUMBERS} finite numbers", "an array of numbers")]


def _side(value):
    if not _is_number(value) or not isinstance(value, int) or value not in (1, -1):
        raise _error("side", f"must be the integer 1 or -1, got {value!r}")
    return int(value)


Side = Annotated[int, PlainValidator(_side),
                 Accepts("1 (the point on the side of the beam's left normal: above a beam running "
                         "in +x) or -1 (the other side: below it)", "1 or -1")]


@dataclasses.dataclass(frozen=True)
class TimeFunctionSpec:
    """A checked time function: an :class:`~.expressions.Expression`, a constant or a
    :class:`~.tables.Table`; ``function`` is the JAX-traceable callable."""

    kind: str  # "expression" | "constant" | "table" | "file"
    text: str  # the source as written (for summaries)
    function: Any

    def __call__(self, t):
        return self.function(t)


TIME_FUNCTION_ACCEPTED = (f"an expression in t ({EXPRESSION_SET}), a number, "
                          "{ table = [[t, value], ...] } or { file = \"data.csv\" } "
                          f"({PATH_RULE})")


def _time_function(value, info: ValidationInfo):
    if isinstance(value, str):
        try:
            expr = compile_expression(value)
        except ExpressionError as e:
            raise _error("expression", f"expression {value!r} is not in the safe set: {e}") from None
        return TimeFunctionSpec("expression", expr.source, expr)
    if _is_number(value):
        if not math.isfinite(value):
            raise _error("time_function", f"must be finite, got {value!r}")
        return TimeFunctionSpec("constant", repr(float(value)), Constant(value))
    if isinstance(value, dict) and len(value) == 1 and ("table" in value or "file" in value):
        try:
            if "table" in value:
                return TimeFunctionSpec("table", "table", table_from_rows(value["table"]))
            base = (info.context or {}).get("base_dir")
            if base is None:
                raise TableError("data files can only be read from a scenario file")
            return TimeFunctionSpec("file", str(value["file"]), table_from_csv(value["file"], Path(base)))
        except TableError as e:
            raise _error("time_function", str(e)) from None
    raise _error("time_function", f"is not a time function: {value!r}")


TimeFunction = Annotated[Union[TimeFunctionSpec, str, float, dict],
                         PlainValidator(_time_function),
                         Accepts(TIME_FUNCTION_ACCEPTED, "a time function: an expression in t, a number, "
                                 "{ table = ... } or { file = ... } (see Time functions)")]


def _quadrature(value):
    from ..element.quadrature import RULES
    ok = (isinstance(value, (list, tuple)) and len(value) == 2 and value[0] in RULES
          and isinstance(value[1], int) and not isinstance(value[1], bool))
    if not ok or not (2 if value[0] == "lobatto" else 1) <= value[1] <= 10:
        raise _error("quadrature", f"is not a quadrature rule: {value!r}")
    return (str(value[0]), int(value[1]))


Quadrature = Annotated[tuple[str, int], PlainValidator(_quadrature),
                       Accepts('["gauss", 1..10] or ["lobatto", 2..10]')]
