"""Measured samples: reading and checking ``t,y`` data before anything is compiled.

A data file is CSV with a header row naming at least the columns ``t`` (time [s]) and
``y`` (the measured quantity, SI units; for model M1 the tip Y-displacement [m]); an
optional column ``w`` holds non-negative weights (relative inverse variances, default
1). Blank lines and lines starting with ``#`` are skipped. Samples may be at any times
(not necessarily on the solver's grid) but must be strictly increasing.

Every problem raises :class:`DataError` with one line naming the file and the line or
column, e.g. ``data.csv: line 17: t = 0.5 is not after the previous time 0.6 (line 16)``.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from ..errors import ModelError

#: fewest samples a fit accepts (inside the time window)
MIN_SAMPLES = 10
#: largest data file read [bytes]
MAX_DATA_BYTES = 64 * 1024 * 1024


class DataError(ModelError):
    """Bad measured data (one line: file, line or column, what is wrong)."""


@dataclasses.dataclass(frozen=True)
class Measurements:
    """Measured samples (host NumPy arrays, SI units).

    Attributes:
        t: sample times [s], strictly increasing, shape (N,).
        y: measured values (M1: tip Y-displacement [m]), shape (N,).
        w: weights ≥ 0 (relative inverse variances; 1 by default), shape (N,).
        lines: line number of every sample in its file (None for arrays), shape (N,).
        source: file name or label used in messages.
    """

    t: np.ndarray
    y: np.ndarray
    w: np.ndarray
    lines: Optional[np.ndarray] = None
    source: str = "data"

    def __len__(self) -> int:
        return len(self.t)

    def where(self, i: int) -> str:
        """``FILE: line L`` (or ``LABEL: sample i``) of sample i, for messages."""
        if self.lines is not None:
            return f"{self.source}: line {int(self.lines[i])}"
        return f"{self.source}: sample {i}"

    @classmethod
    def from_arrays(cls, t, y, w=None, *, source: str = "data") -> "Measurements":
        """Checked measurements from arrays (messages name the 0-based sample index)."""
        t = _column(t, "t", source)
        y = _column(y, "y", source)
        if y.shape != t.shape:
            raise DataError(f"{source}: t has {t.size} samples but y has {y.size}")
        if w is None:
            w = np.ones_like(t)
        else:
            w = _column(w, "w", source)
            if w.shape != t.shape:
                raise DataError(f"{source}: t has {t.size} samples but w has {w.size}")
        m = cls(t, y, w, None, source)
        m._check()
        return m

    def _check(self) -> None:
        for name, col in (("t", self.t), ("y", self.y), ("w", self.w)):
            bad = np.nonzero(~np.isfinite(col))[0]
            if bad.size:
                i = int(bad[0])
                what = "NaN" if np.isnan(col[i]) else "infinite"
                raise DataError(f"{self.where(i)}: column {name} is {what} (leave missing samples "
                                "out rather than writing NaN)")
        neg = np.nonzero(self.w < 0)[0]
        if neg.size:
            i = int(neg[0])
            raise DataError(f"{self.where(i)}: column w = {self.w[i]:g} is negative (weights must be >= 0)")
        back = np.nonzero(np.diff(self.t) <= 0)[0]
        if back.size:
            i = int(back[0]) + 1
            prev = self.where(i - 1).rsplit(": ", 1)[-1]
            raise DataError(f"{self.where(i)}: t = {self.t[i]:.10g} is not after the previous time "
                            f"{self.t[i - 1]:.10g} ({prev}); times must be strictly increasing")
        if len(self.t) < MIN_SAMPLES:
            raise DataError(f"{self.source}: {len(self.t)} samples; at least {MIN_SAMPLES} are needed")

    def window(self, start: Optional[float] = None, end: Optional[float] = None) -> "Measurements":
        """The samples with start <= t <= end (None: unbounded), at least MIN_SAMPLES of
        them with a positive weight."""
        lo = -math.inf if start is None else float(start)
        hi = math.inf if end is None else float(end)
        if not lo < hi:
            raise DataError(f"{self.source}: time window [{lo:g}, {hi:g}] s is empty")
        keep = (self.t >= lo) & (self.t <= hi)
        out = Measurements(self.t[keep], self.y[keep], self.w[keep],
                           None if self.lines is None else self.lines[keep], self.source)
        n = int(np.sum(out.w > 0))
        if n < MIN_SAMPLES:
            span = "" if (start is None and end is None) else f" in the time window [{lo:g}, {hi:g}] s"
            weighted = " with a positive weight" if np.any(out.w == 0) else ""
            raise DataError(f"{self.source}: {n} samples{weighted}{span}; at least {MIN_SAMPLES} are needed")
        return out

    def check_span(self, t0: float, t_end: float) -> None:
        """Every sample time t [s] must lie in the simulated span, t0 ≤ t ≤ t_end."""
        tol = 1e-9 * max(1.0, abs(t_end))
        early = np.nonzero(self.t < t0 - tol)[0]
        if early.size:
            i = int(early[0])
            raise DataError(f"{self.where(i)}: t = {self.t[i]:.10g} s is before the start of the "
                            f"simulation at t = {t0:g} s")
        late = np.nonzero(self.t > t_end + tol)[0]
        if late.size:
            i = int(late[0])
            raise DataError(f"{self.where(i)}: t = {self.t[i]:.10g} s is after the end of the simulated "
                            f"span [{t0:g}, {t_end:g}] s (simulate longer with --t-end, or drop the "
                            "sample or use a time window)")


def _column(values, name: str, source: str) -> np.ndarray:
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{source}: column {name} must be numbers") from None
    if arr.ndim != 1:
        raise DataError(f"{source}: column {name} must be one-dimensional, got shape {arr.shape}")
    return arr


def read_csv(path, *, y_column: str = "y", weight_column: str = "w") -> Measurements:
    """Read and check a data file (see module docstring).

    Args:
        path: the CSV file.
        y_column: name of the measured column (default ``y``).
        weight_column: name of the optional weight column (default ``w``).

    Raises:
        DataError: unreadable file, missing or duplicated column, a field that is not a
            number, NaN or infinite values, times not strictly increasing, negative
            weights, fewer than :data:`MIN_SAMPLES` samples. The message names the line
            (1-based, as an editor shows it) or the column.
    """
    path = Path(path)
    src = str(path)
    try:
        size = path.stat().st_size
        if size > MAX_DATA_BYTES:
            raise DataError(f"{src}: file is {size} bytes, larger than {MAX_DATA_BYTES}")
        text = path.read_text(encoding="utf-8-sig")
    except DataError:
        raise
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"{src}: cannot read the data file ({e.__class__.__name__}: "
                        f"{getattr(e, 'strerror', None) or e})") from None
    rows = [(k, r) for k, r in enumerate(csv.reader(text.splitlines()), start=1)
            if r and any(f.strip() for f in r) and not r[0].lstrip().startswith("#")]
    if not rows:
        raise DataError(f"{src}: line 1: no header; expected a header row with the columns t and {y_column}")
    header_line, header = rows[0]
    names = [h.strip() for h in header]
    for i, n in enumerate(names):
        if n in names[:i]:
            raise DataError(f"{src}: line {header_line}: column {n!r} appears twice in the header")
    for need in ("t", y_column):
        if need not in names:
            if all(_is_number(n) for n in names):
                raise DataError(f"{src}: line {header_line}: no header row; expected the columns t and "
                                f"{y_column} named in the first row")
            raise DataError(f"{src}: line {header_line}: missing column {need!r} (header: "
                            f"{', '.join(names)}; expected columns t and {y_column})")
    cols = {"t": names.index("t"), "y": names.index(y_column)}
    if weight_column in names:
        cols["w"] = names.index(weight_column)
    label = {"t": "t", "y": y_column, "w": weight_column}
    data = {k: [] for k in cols}
    lines = []
    for line, row in rows[1:]:
        if len(row) != len(names):
            raise DataError(f"{src}: line {line}: {len(row)} fields, but the header has {len(names)} "
                            f"({', '.join(names)})")
        for key, j in cols.items():
            field = row[j].strip()
            try:
                x = float(field)
            except ValueError:
                what = "empty" if not field else f"{field!r} is not a number"
                raise DataError(f"{src}: line {line}: column {label[key]}: {what}") from None
            data[key].append(x)
        lines.append(line)
    if not lines:
        raise DataError(f"{src}: no samples after the header; at least {MIN_SAMPLES} are needed")
    t = np.asarray(data["t"])
    m = Measurements(t, np.asarray(data["y"]), np.asarray(data["w"]) if "w" in data else np.ones_like(t),
                     np.asarray(lines), src)
    try:
        m._check()
    except DataError as e:
        msg = str(e)
        if y_column != "y":
            msg = msg.replace("column y ", f"column {y_column} ")
        raise DataError(msg) from None
    return m


def _is_number(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def write_csv(path, t: Sequence[float], y: Sequence[float], *, precision: int = 12) -> None:
    """Write ``t,y`` samples (SI units) with a header row."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t", "y"])
        for a, b in zip(np.asarray(t, float), np.asarray(y, float)):
            w.writerow([f"{a:.{precision}g}", f"{b:.{precision}g}"])
