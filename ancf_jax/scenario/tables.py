"""Tabulated time functions and the file-path rule of scenario files.

A table is a list of (t [s], value) rows with strictly increasing t, interpolated
linearly and held constant outside its range (:func:`jax.numpy.interp`). It is given
inline (``{ table = [[0, 0], [1, 2]] }``) or as a CSV file (``{ file = "push.csv" }``)
with two numeric columns and an optional header row.

File-path rule: a path in a scenario is relative to the scenario file's directory and
must stay inside it: no absolute path, no drive, no ``..`` component, and, once
symbolic links are resolved, still inside that directory. Only regular files up to
:data:`MAX_FILE_BYTES` are read, and only as numbers.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
from pathlib import Path, PurePosixPath, PureWindowsPath

import jax.numpy as jnp
import numpy as np

#: largest data file read [bytes]
MAX_FILE_BYTES = 16 * 1024 * 1024
#: most rows of a table
MAX_ROWS = 1_000_000

PATH_RULE = ("a relative path to a file inside the scenario's directory (no absolute path, "
             "no '..', no link leading outside)")


class TableError(ValueError):
    """A bad table or a path that breaks the file-path rule."""


@dataclasses.dataclass(frozen=True, eq=False)
class Table:
    """A piecewise-linear time function from rows (t, value), JAX-traceable.

    Attributes:
        times: strictly increasing times [s], shape (N,), N >= 2.
        values: values at those times, shape (N,).
        source: where the rows came from (for messages and equality).
    """

    times: np.ndarray
    values: np.ndarray
    source: str = "inline"

    def __call__(self, t):
        return jnp.interp(jnp.asarray(t, float), jnp.asarray(self.times), jnp.asarray(self.values))

    def _key(self):
        return (self.times.tobytes(), self.values.tobytes())

    def __eq__(self, other):
        return isinstance(other, Table) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())


def table_from_rows(rows, source: str = "inline") -> Table:
    """Check rows [[t, value], ...] and return a :class:`Table`."""
    if not isinstance(rows, (list, tuple)) or len(rows) < 2:
        raise TableError("a table needs at least 2 rows [t, value]")
    if len(rows) > MAX_ROWS:
        raise TableError(f"a table may have at most {MAX_ROWS} rows")
    data = []
    for i, row in enumerate(rows):
        if (not isinstance(row, (list, tuple)) or len(row) != 2
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in row)):
            raise TableError(f"row {i} must be [t, value], two numbers, got {row!r}")
        if not all(math.isfinite(x) for x in row):
            raise TableError(f"row {i} must be finite, got {row!r}")
        data.append((float(row[0]), float(row[1])))
    arr = np.array(data)
    if np.any(np.diff(arr[:, 0]) <= 0.0):
        k = int(np.argmax(np.diff(arr[:, 0]) <= 0.0)) + 1
        raise TableError(f"times must increase strictly (row {k}: t = {arr[k, 0]:g} after {arr[k - 1, 0]:g})")
    return Table(arr[:, 0].copy(), arr[:, 1].copy(), source)


def resolve_data_path(name: str, base: Path) -> Path:
    """The file ``name`` inside the directory ``base``, following the file-path rule.

    Raises:
        TableError: the path is absolute, climbs out with ``..``, leads outside
            through a link, or is not a regular file.
    """
    if not isinstance(name, str) or not name or "\x00" in name:
        raise TableError("the file name must be a non-empty string")
    for flavour in (PurePosixPath, PureWindowsPath):
        p = flavour(name)
        if p.is_absolute() or p.drive or p.root or p.anchor:
            raise TableError(f"absolute path {name!r} is not allowed")
        if ".." in p.parts:
            raise TableError(f"path {name!r} leaves the scenario's directory ('..')")
    if name.startswith("~"):
        raise TableError(f"path {name!r} is not allowed ('~')")
    root = base.resolve()
    path = (root / PurePosixPath(name.replace("\\", "/"))).resolve()
    if not path.is_relative_to(root):
        raise TableError(f"path {name!r} leads outside the scenario's directory (through a link)")
    if not path.is_file():
        raise TableError(f"file {name!r} does not exist in {root}")
    if path.stat().st_size > MAX_FILE_BYTES:
        raise TableError(f"file {name!r} is larger than {MAX_FILE_BYTES} bytes")
    return path


def table_from_csv(name: str, base: Path) -> Table:
    """Read a two-column CSV (t [s], value; optional header row) named in a scenario."""
    path = resolve_data_path(name, base)
    text = path.read_text(encoding="utf-8", errors="strict")
    rows, header = [], False
    for i, row in enumerate(csv.reader(io.StringIO(text))):
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        if len(row) != 2:
            raise TableError(f"{name}: line {i + 1} must have 2 columns (t, value), got {len(row)}")
        try:
            vals = [float(c) for c in row]
        except ValueError:
            if not rows and not header:  # one header row before the data
                header = True
                continue
            raise TableError(f"{name}: line {i + 1} is not two numbers: {row!r}") from None
        rows.append(vals)
    try:
        return table_from_rows(rows, source=name)
    except TableError as e:
        raise TableError(f"{name}: {e}") from None
