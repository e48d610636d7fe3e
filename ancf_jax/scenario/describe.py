"""What each schema key accepts, in words: for error messages and for the docs.

:func:`accepted` turns a field's type and constraints into a phrase such as
``a number > 0 [Pa]``; :func:`locate` follows a pydantic error location through the
schema, dropping the union tags pydantic inserts, to give the TOML key path and the
field there.
"""

from __future__ import annotations

import dataclasses
import json
import types
import typing
from typing import Any, Literal, Optional, Union

import annotated_types as at
from pydantic import BaseModel
from pydantic.fields import FieldInfo

from .types import Accepts


def show(value: Any, limit: int = 60) -> str:
    """A value as TOML-like text, shortened."""
    try:
        text = json.dumps(value, default=str, ensure_ascii=False)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def unwrap(tp) -> tuple[Any, list]:
    """(bare type, metadata) of a possibly Annotated type."""
    meta: list = []
    while typing.get_origin(tp) is typing.Annotated:
        args = typing.get_args(tp)
        tp, meta = args[0], meta + list(args[1:])
    return tp, meta


def _is_union(tp) -> bool:
    return typing.get_origin(tp) in (Union, types.UnionType)


def _non_none(tp):
    args = [a for a in typing.get_args(tp) if a is not type(None)]
    return args[0] if len(args) == 1 else None


def discriminated_members(tp, meta) -> Optional[dict[str, type]]:
    """{tag: model} if ``tp`` is a union discriminated by ``type``."""
    if not _is_union(tp):
        return None
    if not any(isinstance(m, FieldInfo) and m.discriminator for m in meta):
        return None
    out = {}
    for member in typing.get_args(tp):
        field = member.model_fields["type"]
        for tag in typing.get_args(field.annotation):
            out[tag] = member
    return out


def _literal(values) -> str:
    return ", ".join(json.dumps(v) for v in values)


def _bounds(meta) -> str:
    parts = []
    lo = next(((">", m.gt) for m in meta if isinstance(m, at.Gt)), None) or \
        next(((">=", m.ge) for m in meta if isinstance(m, at.Ge)), None)
    hi = next(((" <", m.lt) for m in meta if isinstance(m, at.Lt)), None) or \
        next(((" <=", m.le) for m in meta if isinstance(m, at.Le)), None)
    if lo and hi and lo[0] == ">=" and hi[0] == " <=":
        return f" {lo[1]:g} .. {hi[1]:g}"
    if lo:
        parts.append(f" {lo[0]} {lo[1]:g}")
    if hi:
        parts.append(f"{' and' if lo else ''}{hi[0]} {hi[1]:g}")
    return "".join(parts)


def accepted(tp, info: FieldInfo | None = None, *, unit: bool = True, short: bool = False) -> str:
    """What a value of type ``tp`` (with the constraints of ``info``) may be; ``short``:
    the documentation's wording, which refers to the page's sections for long forms."""
    tp, meta = unwrap(tp)
    if info is not None:
        meta = meta + list(info.metadata) + ([info] if info.discriminator else [])
    u = ""
    if unit and info is not None and isinstance(info.json_schema_extra, dict):
        u = info.json_schema_extra.get("unit", "")
    suffix = f" [{u}]" if u else ""
    for m in meta:
        if isinstance(m, Accepts):
            return (m.short if short and m.short else m.text) + suffix
    if _is_union(tp) and discriminated_members(tp, meta) is None:
        inner = _non_none(tp)
        if inner is not None:
            return accepted(inner, info, unit=unit, short=short)
    members = discriminated_members(tp, meta)
    if members is not None:
        return f"a table with type = {_literal(members)}"
    origin = typing.get_origin(tp)
    if origin is Literal:
        return "one of " + _literal(typing.get_args(tp))
    if tp is bool:
        return "true or false"
    if tp is int:
        return "an integer" + _bounds(meta)
    if tp is float:
        return "a number" + _bounds(meta) + suffix
    if tp is str:
        return "a string"
    if origin is dict:
        value = typing.get_args(tp)[1]
        return f"a table of named entries, each {accepted(value, unit=False)}" + suffix
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        if short and getattr(tp, "accepts", None):
            return tp.accepts
        return "a table with keys " + ", ".join(tp.model_fields)
    return str(tp)


@dataclasses.dataclass
class Location:
    """Where an error location points in the schema.

    Attributes:
        path: TOML key path (union tags removed).
        model: the table class containing the last key, if any.
        field: the field of the last key (None for unknown keys or dict entries).
        annotation: the type at the location.
    """

    path: tuple
    model: Optional[type] = None
    field: Optional[FieldInfo] = None
    annotation: Any = None


def locate(root: type[BaseModel], loc) -> Location:
    """Follow a pydantic error location ``loc`` from the root model: keys of tables
    and of named entries are kept, the union tags pydantic inserts are dropped."""
    tp: Any = root
    field: Optional[FieldInfo] = None
    model: Optional[type] = None
    path: list = []
    for item in loc:
        base, meta = unwrap(tp)
        if _is_union(base) and _non_none(base) is not None:  # Optional[X]
            base, meta = unwrap(_non_none(base))
        members = discriminated_members(base, meta)
        if members is not None and item in members:  # a union tag, not a key
            tp, field = members[item], None
            continue
        path.append(item)
        if isinstance(base, type) and issubclass(base, BaseModel):
            model = base
            field = base.model_fields.get(item) if isinstance(item, str) else None
            tp = None
            if field is not None:  # the field's type with its constraints and discriminator
                tp = typing.Annotated[field.annotation, *field.metadata, field]
        elif typing.get_origin(base) is dict:
            tp, model, field = typing.get_args(base)[1], None, None
        else:
            tp, model, field = None, None, None
    return Location(tuple(path), model, field, tp)
