"""Reading a scenario: file or shipped name → TOML (or JSON, for a ``.json`` file) →
``--set`` overrides → schema → cross-checks → :class:`~.scenario.Scenario`.

Everything here runs on the host with the standard library, pydantic and NumPy:
nothing is built, traced or compiled before the whole file is known to be valid.
Every problem raises :class:`~.errors.ScenarioError` with one line
``FILE: key.path: message (accepted: ...)``.
"""

from __future__ import annotations

import importlib.resources
import json
import re
import tomllib
from pathlib import Path
from typing import Iterable

from pydantic import ValidationError

from . import schema as S
from .checks import check
from .describe import accepted, locate, show
from .errors import Invalid, ScenarioError

#: largest scenario file read [bytes]
MAX_SCENARIO_BYTES = 1024 * 1024
_PACKAGE = "ancf_jax.models"
#: suffixes of scenario files (a name without one and without a path separator is a
#: shipped scenario); ``.json`` files are read as JSON, any other as TOML
SUFFIXES = (".toml", ".json")


def shipped_scenarios() -> list[str]:
    """Names of the scenario files shipped in the package (``m1``, ``m2``, ...)."""
    files = importlib.resources.files(_PACKAGE)
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".toml"))


def resolve(source) -> Path:
    """The file of a scenario given by path or by shipped name.

    A string without a path separator and without a ``.toml`` or ``.json`` suffix names
    a shipped scenario (``"m1"``); anything else is a path.
    """
    text = str(source)
    if (isinstance(source, str) and not text.lower().endswith(SUFFIXES) and "/" not in text
            and "\\" not in text):
        if text in shipped_scenarios():
            return Path(str(importlib.resources.files(_PACKAGE) / f"{text}.toml"))
        raise ScenarioError(text, (), "no such shipped scenario (and not a .toml or .json path)",
                            f"a path to a .toml or .json file or one of {', '.join(shipped_scenarios())}")
    return Path(text)


def parse_override(item: str) -> tuple[tuple[str, ...], object]:
    """``"solver.dt=1e-4"`` → (("solver", "dt"), 1e-4). The value is read as a TOML
    value (number, boolean, string in quotes, array, inline table); text that is not
    valid TOML is taken as a plain string (``solver.name=rk4``)."""
    if not isinstance(item, str) or "=" not in item:
        raise ValueError("expected KEY=VALUE")
    key, _, value = item.partition("=")
    if "\n" in value or "\r" in value:
        raise ValueError("the value must be on one line")
    parts = tuple(p.strip() for p in key.strip().split("."))
    if not parts or any(not re.match(r"^[A-Za-z0-9_-]+$", p) for p in parts):
        raise ValueError(f"bad key path {key.strip()!r}")
    try:
        parsed = tomllib.loads(f"v = {value.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value.strip()
    return parts, parsed


def apply_overrides(data: dict, overrides: Iterable[str], file: str) -> dict[tuple, str]:
    """Set each ``KEY=VALUE`` in ``data`` (in place); returns {key path: item}."""
    done = {}
    for item in overrides or ():
        try:
            path, value = parse_override(item)
        except ValueError as e:
            raise ScenarioError(file, f"--set {item}", str(e),
                                "KEY=VALUE with a dotted key path, e.g. solver.dt=1e-4") from None
        node = data
        for i, part in enumerate(path[:-1]):
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ScenarioError(file, path[: i + 1], f"--set {item}: this key is not a table",
                                    "a key path through tables")
        node[path[-1]] = value
        done[path] = item
    return done


def _toml_error(file: str, err: tomllib.TOMLDecodeError) -> ScenarioError:
    msg = str(err)
    m = re.match(r"Cannot declare \((.*)\) twice \(at (line \d+), column \d+\)", msg)
    if m:
        names = re.findall(r"'((?:[^'\\]|\\.)*)'", m.group(1))
        return ScenarioError(file, tuple(names), f"duplicate name: declared twice ({m.group(2)})",
                             "each table or name declared once")
    where = re.search(r"\(at (.*)\)$", msg)
    what = re.sub(r"\s*\(at .*\)$", "", msg)
    return ScenarioError(file, where.group(1) if where else "TOML", f"invalid TOML: {what}",
                         "TOML 1.0 syntax, duplicate keys not allowed")


def _json_error(file: str, err: json.JSONDecodeError) -> ScenarioError:
    return ScenarioError(file, f"line {err.lineno}, column {err.colno}", f"invalid JSON: {err.msg}",
                         "JSON (RFC 8259) with an object at the top, as the TOML format's tables")


def _parse(file: str, path: Path, text: str) -> dict:
    """The file's tables: JSON for a ``.json`` file, else TOML."""
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as e:
            raise _json_error(file, e) from None
        if not isinstance(data, dict):
            raise ScenarioError(file, (), f"the top level is a JSON {type(data).__name__}, not an object",
                                "a JSON object with the tables of the format")
        return data
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise _toml_error(file, e) from None


def _check_version(file: str, version) -> None:
    """A file of another format version is refused with what this release reads (the
    changes between versions: docs/scenario-format.md, "Changelog")."""
    if isinstance(version, int) and not isinstance(version, bool) and version != S.FORMAT_VERSION:
        from .._version import __version__
        newer = "a newer ancf_jax wrote it" if version > S.FORMAT_VERSION else "no such version"
        raise ScenarioError(file, ("version",), f"format version {version} ({newer}); ancf_jax {__version__} "
                                                f"reads version {S.FORMAT_VERSION}",
                            f"version = {S.FORMAT_VERSION} (the changes between versions: "
                            "docs/scenario-format.md, Changelog)")


def _schema_error(file: str, err: dict) -> ScenarioError:
    kind, ctx = err["type"], err.get("ctx") or {}
    where = locate(S.ScenarioSpec, err["loc"])
    path = where.path
    if kind == "extra_forbidden":
        keys = list(where.model.model_fields) if where.model is not None else []
        return ScenarioError(file, path, "unknown key", "keys " + ", ".join(keys))
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        text = accepted(where.annotation, where.field).replace("a table with ", "")
        if kind == "union_tag_not_found":
            return ScenarioError(file, path + ("type",), "missing required key", text)
        return ScenarioError(file, path + ("type",), f"unknown type {show(ctx.get('tag'))}", text)
    text = accepted(where.annotation, where.field) if where.annotation is not None else "see the documentation"
    if kind == "missing":
        return ScenarioError(file, path, "missing required key", text)
    got = show(err.get("input"))
    bounds = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<", "less_than_equal": "<="}
    if kind in bounds:
        limit = next(iter(ctx.values()))
        return ScenarioError(file, path, f"must be {bounds[kind]} {limit:g}, got {got}", text)
    if kind == "finite_number":
        return ScenarioError(file, path, f"must be finite, got {got}", text)
    if kind in ("vector", "matrix", "numbers", "side", "expression", "time_function", "quadrature"):
        return ScenarioError(file, path, err["msg"], text)
    if kind == "literal_error":
        return ScenarioError(file, path, f"got {got}", text)
    if kind.endswith("_type") or kind.endswith("_parsing") or kind == "model_attributes_type":
        return ScenarioError(file, path, f"wrong type: got {got}", text)
    return ScenarioError(file, path, f"{err['msg']}, got {got}", text)


def validate(data: dict, file: str, *, base_dir: Path | None = None,
             overridden: dict | None = None) -> tuple[S.ScenarioSpec, object]:
    """Schema and cross-checks of parsed TOML ``data``; returns (spec, checker)."""
    overridden = overridden or {}

    def note(error: ScenarioError) -> ScenarioError:
        hit = [v for k, v in overridden.items() if error.path[: len(k)] == k or k[: len(error.path)] == error.path]
        if hit and error.path:
            return ScenarioError(error.file, error.path, f"{error.reason} (from --set {hit[0]})", error.accepted)
        return error

    try:
        spec = S.ScenarioSpec.model_validate(data, context={"base_dir": base_dir})
    except ValidationError as e:
        raise note(_schema_error(file, e.errors(include_url=False)[0])) from None
    try:
        checker = check(spec)
    except Invalid as e:
        raise note(ScenarioError(file, e.path, e.message, e.accepted)) from None
    return spec, checker


def load_scenario(source, overrides: Iterable[str] = ()):
    """Read, override, validate and check a scenario; nothing is built or compiled.

    Args:
        source: a path to a ``.toml`` or ``.json`` file (the same tables in JSON), or
            the name of a shipped scenario (see :func:`shipped_scenarios`).
        overrides: ``"key.path=value"`` items (the CLI's ``--set``), applied to the
            TOML data before validation.

    Returns:
        a :class:`~ancf_jax.scenario.Scenario`.

    Raises:
        ScenarioError: one line ``FILE: key.path: message (accepted: ...)``.
    """
    from .scenario import Scenario
    path = resolve(source)
    file = str(path)
    try:
        if not path.is_file():
            raise OSError("no such file")
        if path.stat().st_size > MAX_SCENARIO_BYTES:
            raise OSError(f"file larger than {MAX_SCENARIO_BYTES} bytes")
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        raise ScenarioError(file, (), f"cannot read the scenario file: {reason}",
                            f"a readable UTF-8 .toml or .json file or a shipped name: "
                            f"{', '.join(shipped_scenarios())}") from None
    data = _parse(file, path, text)
    overridden = apply_overrides(data, overrides, file)
    _check_version(file, data.get("version", S.FORMAT_VERSION))
    spec, checker = validate(data, file, base_dir=path.parent, overridden=overridden)
    return Scenario(spec, path=path, overrides=tuple(overrides or ()), lengths=checker.lengths,
                    elements=checker.elements)
