"""Sweep designs: which parameter values each member of a sweep gets.

A :class:`Param` is one dotted scenario key (as ``--set`` takes it) with a range
``LOW:HIGH`` (optionally ``:log``) or a list of values. :func:`make_design` turns
parameters into member values by a full grid, uniform random sampling, a Latin
hypercube or a scrambled Sobol sequence (``scipy.stats.qmc``), or a Saltelli design
(SALib) for Sobol sensitivity indices. Everything here runs on the host; nothing is
built or compiled.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import re
import tomllib
from typing import Sequence

import numpy as np

from ..errors import ModelError

DESIGNS = ("grid", "random", "lhs", "sobol", "saltelli")


class SweepError(ModelError):
    """A bad sweep definition (one line naming the parameter and what is accepted)."""


@dataclasses.dataclass(frozen=True)
class Param:
    """One swept scenario key.

    Attributes:
        key: dotted scenario key (``beams.beam.alpha``), as for ``--set``.
        low, high: range bounds (``values`` is None).
        log: sample the range uniformly in log space (needs ``low > 0``).
        values: the list of values (instead of a range).
    """

    key: str
    low: float | None = None
    high: float | None = None
    log: bool = False
    values: tuple | None = None

    def __post_init__(self):
        if not re.match(r"^[A-Za-z0-9_-]+(\.[A-Za-z0-9_-]+)*$", self.key or ""):
            raise SweepError(f"--param {self.key}: bad key path (accepted: a dotted scenario key such as "
                             f"beams.beam.alpha)")
        if self.values is not None:
            if len(self.values) == 0:
                raise SweepError(f"--param {self.key}: the list of values is empty (accepted: [V1, V2, ...])")
            return
        for name, x in (("LOW", self.low), ("HIGH", self.high)):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise SweepError(f"--param {self.key}: {name} must be a finite number, got {x!r} "
                                 f"(accepted: KEY=LOW:HIGH with LOW < HIGH)")
        if self.low >= self.high:
            raise SweepError(f"--param {self.key}: LOW must be < HIGH, got {self.low:g}:{self.high:g} "
                             f"(accepted: KEY=LOW:HIGH with LOW < HIGH)")
        if self.log and self.low <= 0:
            raise SweepError(f"--param {self.key}: a log range needs LOW > 0, got {self.low:g} "
                             f"(accepted: KEY=LOW:HIGH:log with 0 < LOW < HIGH)")

    @property
    def is_range(self) -> bool:
        return self.values is None

    @property
    def integer(self) -> bool:
        """Element counts (``...elements``) take integer values."""
        return self.key.split(".")[-1] == "elements"

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Values at unit-cube coordinates u in [0, 1)."""
        u = np.asarray(u, float)
        if self.values is not None:
            idx = np.minimum((u * len(self.values)).astype(int), len(self.values) - 1)
            return np.asarray(self.values, dtype=object)[idx]
        if self.log:
            x = np.exp(np.log(self.low) + u * (np.log(self.high) - np.log(self.low)))
        else:
            x = self.low + u * (self.high - self.low)
        return np.rint(x).astype(int) if self.integer else x

    def levels(self, n: int) -> list:
        """``n`` grid levels of a range (geometric for log ranges), or the list."""
        if self.values is not None:
            return list(self.values)
        x = np.geomspace(self.low, self.high, n) if self.log else np.linspace(self.low, self.high, n)
        if self.integer:
            return sorted({int(v) for v in np.rint(x)})
        return [float(v) for v in x]

    def to_dict(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in dataclasses.asdict(self).items()}

    @classmethod
    def from_dict(cls, d: dict) -> "Param":
        d = dict(d)
        if d.get("values") is not None:
            d["values"] = tuple(d["values"])
        return cls(**d)


def parse_param(text: str) -> Param:
    """``KEY=LOW:HIGH``, ``KEY=LOW:HIGH:log`` or ``KEY=[V1, V2, ...]`` (a TOML array, as
    in ``--set``) → :class:`Param`. Raises :class:`SweepError` with one line."""
    accepted = "KEY=LOW:HIGH, KEY=LOW:HIGH:log or KEY=[V1, V2, ...]"
    if not isinstance(text, str) or "=" not in text:
        raise SweepError(f"--param {text}: expected {accepted}")
    key, _, value = text.partition("=")
    key, value = key.strip(), value.strip()
    if not key:
        raise SweepError(f"--param {text}: missing KEY (accepted: {accepted})")
    if value.startswith("["):
        try:
            values = tomllib.loads(f"v = {value}")["v"]
        except tomllib.TOMLDecodeError as e:
            raise SweepError(f"--param {key}: the list is not a TOML array ({e}) (accepted: {accepted})") from None
        return Param(key, values=tuple(values))
    parts = value.split(":")
    log = False
    if len(parts) == 3 and parts[2].strip().lower() == "log":
        log, parts = True, parts[:2]
    if len(parts) != 2:
        raise SweepError(f"--param {key}: expected a range LOW:HIGH or a list, got {value!r} (accepted: {accepted})")
    try:
        low, high = (float(p) for p in parts)
    except ValueError:
        raise SweepError(f"--param {key}: LOW and HIGH must be numbers, got {value!r} "
                         f"(accepted: {accepted})") from None
    return Param(key, low, high, log)


def override(key: str, value) -> str:
    """The ``--set`` item of one member value (TOML literal)."""
    if isinstance(value, (bool, np.bool_)):
        return f"{key}={'true' if value else 'false'}"
    if isinstance(value, (int, np.integer)):
        return f"{key}={int(value)}"
    if isinstance(value, (float, np.floating)):
        return f"{key}={float(value)!r}"
    if isinstance(value, str):
        return f"{key}={_toml_string(value)}"
    if isinstance(value, (list, tuple)):
        return f"{key}=[{', '.join(override('v', v)[2:] for v in value)}]"
    raise SweepError(f"--param {key}: unsupported value {value!r} (numbers, strings, booleans, lists)")


def _toml_string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def make_design(params: Sequence[Param], design: str = "lhs", *, samples: int | None = None,
                levels: int = 3, seed: int = 0) -> dict[str, list]:
    """Member values of each parameter: {key: [value per member]}.

    Args:
        params: the swept parameters (distinct keys).
        design: ``"grid"`` (every combination; ranges at ``levels`` points, lists at
            their values), ``"random"`` (uniform), ``"lhs"`` (Latin hypercube),
            ``"sobol"`` (scrambled Sobol sequence), ``"saltelli"`` (SALib's Saltelli
            design of ``samples * (d + 2)`` members for first-order and total Sobol indices; ranges only).
        samples: number of members (random, lhs, sobol), base samples (saltelli).
        levels: grid levels of each range (grid).
        seed: random seed (random, lhs, sobol, saltelli).
    """
    params = list(params)
    if not params:
        raise SweepError("--param: give at least one parameter (accepted: KEY=LOW:HIGH or KEY=[V1, ...])")
    keys = [p.key for p in params]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise SweepError(f"--param {dup[0]}: given twice (accepted: each key once)")
    if design not in DESIGNS:
        raise SweepError(f"--design: must be one of {', '.join(DESIGNS)}, got {design!r}")
    if design == "grid":
        if isinstance(levels, bool) or not isinstance(levels, int) or levels < 2:
            raise SweepError(f"--levels: must be an integer >= 2, got {levels!r}")
        axes = [p.levels(levels) for p in params]
        combos = list(itertools.product(*axes))
        return {p.key: [c[i] for c in combos] for i, p in enumerate(params)}
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise SweepError(f"--samples: must be an integer >= 1 for the {design} design, got {samples!r}")
    d = len(params)
    if design == "saltelli":
        bad = [p.key for p in params if not p.is_range]
        if bad:
            raise SweepError(f"--param {bad[0]}: the saltelli design needs ranges (accepted: KEY=LOW:HIGH)")
        from .sensitivity import saltelli_unit
        u = saltelli_unit(d, samples, seed)
    elif design == "random":
        u = np.random.default_rng(seed).random((samples, d))
    else:
        from scipy.stats import qmc
        import warnings
        sampler = qmc.LatinHypercube(d=d, seed=seed) if design == "lhs" else qmc.Sobol(d=d, scramble=True, seed=seed)
        with warnings.catch_warnings():  # Sobol: balance is best at powers of 2, any count works
            warnings.filterwarnings("ignore", message=".*balance properties.*")
            u = sampler.random(samples)
    return {p.key: [_plain(v) for v in p.from_unit(u[:, i])] for i, p in enumerate(params)}


def _plain(v):
    """NumPy scalars → Python scalars (JSON, TOML)."""
    return v.item() if isinstance(v, np.generic) else v
