"""Identifiable parameters of a built system: names, units, reading and setting them.

A parameter is named ``KIND`` or ``KIND.TARGET``:

==============  ===============================================  ======
``alpha``       Rayleigh mass-proportional coefficient α of a beam   1/s
``beta``        Rayleigh stiffness-proportional coefficient β       s
``E``           Young's modulus of a beam                            Pa
``tip_mass``    mass of a rigid body (``mass.BODY`` for any body)    kg
``speed.NAME``  speed of a moving load, moving mass or chain         m/s
==============  ===============================================  ======

Without ``.TARGET``, a beam parameter needs a system with exactly one beam; ``tip_mass``
means the body named ``tip``, else the only body. The dotted scenario keys of the same
quantities name them too (:data:`SCENARIO_KEYS`: ``beams.beam.alpha``,
``beams.beam.section.E``, ``bodies.tip.mass``, ``chains.NAME.speed``).

**Any other scalar of a scenario file** is a parameter by its dotted key
(``beams.beam.section.I``, ``beams.cable.section.EA``, ``bodies.tip.inertia``,
``joints.NAME.stiffness``, ``loads.NAME.value`` …) when the problem is built from the
scenario (:func:`resolve` with ``rebuild``). How the built model depends on the key is
*probed*: the scenario is rebuilt at the key's value v₀ and at v₀ + k·s (k = 1, 2, …,
s = v₀/10, or 1/10 of the key's unit at v₀ = 0), and every array of the built system
and initial state that changes is fitted by a polynomial in the key of the lowest degree
(up to :data:`MAX_DEGREE`) that reproduces all probes to :data:`PROBE_RTOL`, with at
least one probe more than the degree needs (a check, not a fit). The parameter then
sets those arrays to that polynomial of its traced value (:class:`KeyProbe`): exact
wherever the scenario's construction is polynomial in the key — a stiffness, mass,
inertia, damping coefficient, load, section property (EA, EI, ρA, or A, I) enters
linearly, a node coordinate linearly in a length — and refused with the array's path
otherwise (the initial state of ``mode = "static"`` depends on most keys through the
static solve). A key that changes array shapes or the model's structure (an element
count, a joint type), that is not a number, or that changes nothing in the built model
(a solver or output setting) is refused with a clear error. Parameters are changed on a
built :class:`~ancf_jax.system.System` with ``equinox.tree_at``, so they can be traced
(differentiated, batched) without rebuilding or recompiling anything.
"""

from __future__ import annotations

import dataclasses
import re

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from ..system import System

#: kind -> (unit, what)
KINDS = {
    "alpha": ("1/s", "Rayleigh mass-proportional damping coefficient"),
    "beta": ("s", "Rayleigh stiffness-proportional damping coefficient"),
    "E": ("Pa", "Young's modulus"),
    "mass": ("kg", "rigid-body mass"),
    "speed": ("m/s", "speed of a moving force, moving mass or chain (its ConstantSpeed path)"),
    "key": ("", "any other scalar of a scenario file, by its dotted key (KeyProbe)"),
}
#: highest polynomial degree in a scenario key that a probed dependence may have
MAX_DEGREE = 4
#: relative tolerance of a probed polynomial on every probe (of the array's largest entry)
PROBE_RTOL = 1e-9
_ALIASES = {"youngs_modulus": "E", "tip_mass": "mass"}


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One identifiable parameter (hashable: a static part of compiled programs).

    Attributes:
        name: as the user wrote it (``alpha``, ``beta.cable``, ``tip_mass``, ...).
        kind: ``alpha``, ``beta``, ``E``, ``mass`` or ``speed``.
        target: beam or body name, or (``speed``) the name of a moving force, moving
            mass or chain; index: its index in the system (``speed``: unused).
    """

    name: str
    kind: str
    target: str
    index: int
    probe: "KeyProbe | None" = None

    @property
    def unit(self) -> str:
        return self.probe.unit if self.kind == "key" else KINDS[self.kind][0]

    @property
    def positive(self) -> bool:
        """Whether the parameter is positive (fitted on log p); a scenario key is when
        its value in the scenario is > 0, else it is fitted on p itself."""
        return self.kind != "key" or self.probe.value > 0

    def apply(self, system: System, state, value):
        """(system, state) with this parameter set to ``value`` (traceable); only a
        scenario key can change the initial state (a length moves the nodes)."""
        if self.kind == "key":
            return self.probe.apply(system, state, value)
        return self.set(system, value), state

    def get(self, system: System):
        """Current value (a JAX scalar; a scenario key: its value in the scenario)."""
        if self.kind == "key":
            return jnp.asarray(self.probe.value)
        if self.kind == "speed":
            return _paths(system, self.target)[0].speed
        if self.kind == "alpha":
            return system.beams[self.index].alpha
        if self.kind == "beta":
            return system.beams[self.index].beta
        if self.kind == "E":
            return system.beams[self.index].section.youngs_modulus
        return system.bodies.mass[self.index]

    def set(self, system: System, value) -> System:
        """A copy of ``system`` with this parameter set to ``value`` (traceable)."""
        k = self.index
        value = jnp.asarray(value, float)
        if self.kind == "key":
            raise ModelError(f"parameter {self.name}: a scenario key may change the initial state; "
                             "set it with Parameter.apply(system, state, value)")
        if self.kind == "speed":
            n = len(_paths(system, self.target))
            return eqx.tree_at(lambda s: tuple(p.speed for p in _paths(s, self.target)), system, (value,) * n)
        if self.kind == "alpha":
            return eqx.tree_at(lambda s: s.beams[k].alpha, system, value)
        if self.kind == "beta":
            # the Newton matrix's β-rate term is static: on for a fitted β (it may start at 0)
            system = eqx.tree_at(lambda s: s.beams[k], system, system.beams[k].with_rate_stiffness())
            return eqx.tree_at(lambda s: s.beams[k].beta, system, value)
        if self.kind == "E":
            return eqx.tree_at(lambda s: s.beams[k].section.youngs_modulus, system, value)
        return eqx.tree_at(lambda s: s.bodies.mass, system, system.bodies.mass.at[k].set(value))


def _paths(system: System, name: str) -> tuple:
    """The ConstantSpeed paths that move the moving force, moving mass or chain
    ``name`` (a moving mass's ``NAME.drive``, a chain's ``NAME.i.x``), in system order,
    and those of the forces ``NAME.…`` that grow with its speed
    (:class:`~ancf_jax.forces.SpeedSquaredForce`)."""
    from ..contact import MovingForce
    from ..forces import SpeedSquaredForce
    from ..functions import ConstantSpeed
    from ..joints import PathCoordinate

    found = [f.location.path for f in system.forces if isinstance(f, MovingForce) and f.name == name]
    found += [c.path for c in system.constraints if isinstance(c, PathCoordinate)
              and (c.name == f"{name}.drive" or (c.name.startswith(f"{name}.") and c.name.endswith(".x")))]
    if found:  # a force growing with the chain's speed (a pantograph's aerodynamic uplift) follows it
        found += [f.path for f in system.forces if isinstance(f, SpeedSquaredForce) and f.name.startswith(f"{name}.")]
    found = [p for p in found if isinstance(p, ConstantSpeed)]
    if not found:
        raise ModelError(f"parameter speed.{name}: no moving force, moving mass or chain named {name!r} "
                         "with a constant-speed path")
    return tuple(found)


def resolve(system: System, names, *, state=None, scenario=None) -> tuple[Parameter, ...]:
    """Parameters of ``system`` named ``names`` (see module docstring).

    Args:
        system: the built model.
        names: parameter names or dotted scenario keys (a sequence or ``"a,b"``).
        state: its initial state (needed for a scenario key other than
            :data:`SCENARIO_KEYS`).
        scenario: the loaded :class:`~ancf_jax.scenario.Scenario` that ``system`` and
            ``state`` were built from; with it, any scalar key of the file is a
            parameter (probed, :func:`probe_key`).

    Raises:
        ModelError: an unknown kind or target, an ambiguous name, a repeated parameter,
            a scenario key that cannot be a parameter (and why).
    """
    if isinstance(names, str):
        names = [n for n in names.split(",")]
    out: list[Parameter] = []
    for raw in names:
        name = str(raw).strip()
        head = name.split(".")[0]
        if ("." in name or _INDEXED.match(name)) and head not in KINDS and head not in _ALIASES:
            # a dotted scenario key: one of the known kinds' (beams.beam.alpha), else probed
            try:
                kind, _, target = from_scenario_key(name).partition(".")
            except ModelError:
                if scenario is None or state is None:
                    raise
                p = Parameter(name, "key", name, -1, probe_key(name, scenario, system, state))
                if any(q.name == name for q in out):
                    raise ModelError(f"parameter {name!r} is given twice") from None
                out.append(p)
                continue
        else:
            kind, _, target = name.partition(".")
        kind = _ALIASES.get(kind, kind)
        if kind not in KINDS:
            raise ModelError(f"unknown parameter {name!r}; known: alpha, beta, E, tip_mass "
                             "(optionally .BEAM or .BODY, e.g. alpha.beam, mass.tip), speed.NAME")
        if kind == "speed":
            _paths(system, target)  # it exists
            p = Parameter(name, kind, target, -1)
        elif kind == "mass":
            bodies = list(system.body_names)
            if not target:
                target = "tip" if "tip" in bodies else (bodies[0] if len(bodies) == 1 else "")
                if not target:
                    raise ModelError(f"parameter {name!r}: the system has {len(bodies)} bodies "
                                     f"({', '.join(bodies) or 'none'}); name one as mass.BODY")
            if target not in bodies:
                raise ModelError(f"parameter {name!r}: no body named {target!r} "
                                 f"(known: {', '.join(bodies) or 'none'})")
            p = Parameter(name, kind, target, bodies.index(target))
        else:
            beams = list(system.beam_names)
            if not target:
                if len(beams) != 1:
                    raise ModelError(f"parameter {name!r}: the system has {len(beams)} beams "
                                     f"({', '.join(beams) or 'none'}); name one as {kind}.BEAM")
                target = beams[0]
            if target not in beams:
                raise ModelError(f"parameter {name!r}: no beam named {target!r} "
                                 f"(known: {', '.join(beams) or 'none'})")
            p = Parameter(name, kind, target, beams.index(target))
        if any((q.kind, q.index, q.target) == (p.kind, p.index, p.target) if p.kind == "speed"
               else (q.kind, q.index) == (p.kind, p.index) for q in out):
            raise ModelError(f"parameter {name!r} is given twice")
        out.append(p)
    if not out:
        raise ModelError("no parameters to fit")
    return tuple(out)


#: the dotted scenario keys of the parameters (NAME: a beam or body of the file)
SCENARIO_KEYS = ("beams.NAME.alpha", "beams.NAME.beta", "beams.NAME.section.E", "bodies.NAME.mass",
                 "loads.NAME.speed", "moving_masses.NAME.speed", "chains.NAME.speed")


def from_scenario_key(key: str) -> str:
    """The parameter name (``KIND.TARGET``) of a dotted scenario key in
    :data:`SCENARIO_KEYS` (``beams.beam.alpha`` → ``alpha.beam``, ``bodies.tip.mass`` →
    ``mass.tip``); ModelError for any other key (its value is not a traced leaf of the
    built system, so nothing can be differentiated with respect to it)."""
    parts = str(key).split(".")
    if len(parts) == 3 and parts[0] == "beams" and parts[2] in ("alpha", "beta"):
        return f"{parts[2]}.{parts[1]}"
    if len(parts) == 4 and parts[0] == "beams" and parts[2:] == ["section", "E"]:
        return f"E.{parts[1]}"
    if len(parts) == 3 and parts[0] == "bodies" and parts[2] == "mass":
        return f"mass.{parts[1]}"
    if len(parts) == 3 and parts[0] in ("loads", "moving_masses", "chains") and parts[2] == "speed":
        return f"speed.{parts[1]}"
    raise ModelError(f"{key}: no derivative with respect to this key without its scenario; keys of "
                     f"a built system: {', '.join(SCENARIO_KEYS)} (with the scenario, e.g. "
                     "Problem.from_scenario, any scalar key of the file)")


# ---------------------------------------------------------------------------- any scenario key
@dataclasses.dataclass(frozen=True)
class KeyProbe:
    """How a built model depends on one scalar scenario key, probed by rebuilding.

    For every array of the flattened ``(system, state)`` that the key changes (indices
    ``leaves``), the polynomial a(v) = a(v₀) + Σ_{j=1..d} c_j u^j, u = (v − v₀)/s, that
    reproduces every probe build (see the module docstring). a(v₀) is taken from the
    system and state it is applied to (traced), the coefficients c_j are static data
    (hashable: stored as bytes, so a compiled program's cache key holds them).

    Attributes:
        key: the dotted key; value: v₀, its value in the scenario [unit]; scale: s
            [unit]; unit: the key's unit (from the scenario schema, '' if none).
        leaves: indices of the changed arrays in ``jax.tree.leaves((system, state))``;
        paths: their tree paths (for messages); degrees: d of each.
        coefficients: c_1..c_d of each, float64 bytes of shape (d, *leaf shape).
    """

    key: str
    value: float
    scale: float
    unit: str
    leaves: tuple
    paths: tuple
    degrees: tuple
    shapes: tuple
    coefficients: tuple

    def apply(self, system, state, value):
        """(system, state) with the key at ``value`` (a traced scalar [unit])."""
        leaves, treedef = jax.tree_util.tree_flatten((system, state))
        u = (jnp.asarray(value, float) - self.value) / self.scale
        for i, d, shape, raw in zip(self.leaves, self.degrees, self.shapes, self.coefficients):
            c = np.frombuffer(raw, dtype=np.float64).reshape((d,) + tuple(shape))
            leaves[i] = leaves[i] + sum(jnp.asarray(c[j]) * u ** (j + 1) for j in range(d))
        return jax.tree_util.tree_unflatten(treedef, leaves)


_INDEXED = re.compile(r"^(?P<key>.+)\[(?P<index>\d+)\]$")


def _split_index(key: str):
    """``loads.P.force[1]`` → (``loads.P.force``, 1); a key without an index → (key, None)."""
    m = _INDEXED.match(key)
    return (m["key"], int(m["index"])) if m else (key, None)


def _spec_value(scenario, key: str):
    """(value, unit) of a dotted key in a loaded scenario's validated tables; ``KEY[i]``
    is entry i of an array key (``gravity[1]``, ``loads.P.force[0]``)."""
    key, index = _split_index(key)
    node, field = scenario.spec, None
    for part in key.split("."):
        if isinstance(node, dict):
            if part not in node:
                raise ModelError(f"parameter {key}: the scenario has no {part!r} here "
                                 f"(known: {', '.join(map(str, node)) or 'none'})")
            node, field = node[part], None
            continue
        fields = getattr(type(node), "model_fields", {})
        match = [n for n, f in fields.items() if n == part or f.alias == part]
        if not match:
            raise ModelError(f"parameter {key}: no key {part!r} in this table "
                             f"(known: {', '.join(f.alias or n for n, f in fields.items()) or 'none'})")
        field = fields[match[0]]
        node = getattr(node, match[0])
    if index is not None:
        if not isinstance(node, (tuple, list)) or index >= len(node):
            size = len(node) if isinstance(node, (tuple, list)) else 0
            raise ModelError(f"parameter {key}[{index}]: {key} has {size} entries in this scenario "
                             f"(= {node!r}); the index must be 0 to {size - 1}" if size else
                             f"parameter {key}[{index}]: {key} is not an array in this scenario (= {node!r})")
        node = node[index]
    if isinstance(node, bool) or isinstance(node, (int, np.integer)):
        raise ModelError(f"parameter {key}: an integer key (= {node}) changes the model's shapes or "
                         "structure; only real-valued keys can be fitted")
    if not isinstance(node, (float, np.floating)) or not np.isfinite(node):
        raise ModelError(f"parameter {key}: not a number in this scenario (= {node!r}); only scalar "
                         "real-valued keys can be fitted")
    unit = ((field.json_schema_extra or {}) if field is not None else {}).get("unit", "")
    return float(node), unit


def _build_at(scenario, key: str, value: float):
    from ..scenario import load_scenario
    key, index = _split_index(key)
    if index is None:
        text = repr(float(value))
    else:  # the whole array, entry ``index`` replaced
        node = scenario.spec
        for part in key.split("."):
            node = node[part] if isinstance(node, dict) else getattr(node, _field_name(node, part))
        entries = [float(x) for x in node]
        entries[index] = float(value)
        text = "[" + ", ".join(map(repr, entries)) + "]"
    return load_scenario(scenario.path, tuple(scenario.overrides) + (f"{key}={text}",)).build()


def _field_name(node, part: str) -> str:
    fields = getattr(type(node), "model_fields", {})
    return next(n for n, f in fields.items() if n == part or f.alias == part)


def _poly(us: np.ndarray, values: np.ndarray, degree: int):
    """Least-squares coefficients c_1..c_d of a(u) − a(0) (u[0] = 0) and the largest
    misfit on the probes relative to the array's largest entry."""
    delta = (values - values[0]).reshape(len(us), -1)
    vand = np.stack([us ** (j + 1) for j in range(degree)], axis=1)
    c, *_ = np.linalg.lstsq(vand, delta, rcond=None)
    misfit = np.max(np.abs(vand @ c - delta)) / max(np.max(np.abs(values)), 1e-300)
    return c.reshape((degree,) + values.shape[1:]), misfit


def probe_key(key: str, scenario, system: System, state) -> KeyProbe:
    """Probe how ``(system, state)``, built from ``scenario``, depends on the scalar key
    ``key`` (module docstring); ModelError when it cannot be a parameter, saying why."""
    value, unit = _spec_value(scenario, key)
    base = jax.tree_util.tree_flatten_with_path((system, state))
    paths = [jax.tree_util.keystr(kp) for kp, _ in base[0]]
    arrays = [np.asarray(x) for _, x in base[0]]
    scale = 0.1 * abs(value) if value != 0 else 0.1
    for direction in (1.0, -1.0):
        builds, error = [], None
        for k in range(1, MAX_DEGREE + 2):
            try:
                built = _build_at(scenario, key, value + direction * k * scale)
            except (ModelError, ValueError) as e:
                error = f"at {key} = {value + direction * k * scale:g}: {e}"
                break
            flat = jax.tree_util.tree_flatten(built)
            if flat[1] != base[1] or any(np.shape(a) != np.shape(b) for a, b in zip(flat[0], arrays)):
                raise ModelError(f"parameter {key}: changing it changes the model's structure or array "
                                 "shapes; only keys that change values can be fitted")
            builds.append([np.asarray(x) for x in flat[0]])
            changed = [i for i in range(len(arrays)) if any(not np.array_equal(b[i], arrays[i]) for b in builds)]
            if not changed:
                if k == 1:
                    raise ModelError(f"parameter {key}: changing it changes nothing in the built model "
                                     "(a run or output setting?); it cannot be fitted")
            fits = {}
            for i in changed:
                if not np.issubdtype(arrays[i].dtype, np.floating):
                    raise ModelError(f"parameter {key}: it changes the integer array {paths[i]}; only "
                                     "keys that change real values can be fitted")
                us = direction * np.arange(k + 1.0)
                vals = np.stack([arrays[i]] + [b[i] for b in builds])
                for d in range(1, k):  # at least one probe more than the degree needs
                    c, misfit = _poly(us, vals, d)
                    if misfit <= PROBE_RTOL:
                        fits[i] = c
                        break
            if len(fits) == len(changed):
                idx = tuple(changed)
                return KeyProbe(key, value, scale, unit, idx, tuple(paths[i] for i in idx),
                                tuple(len(fits[i]) for i in idx), tuple(arrays[i].shape for i in idx),
                                tuple(np.ascontiguousarray(fits[i], np.float64).tobytes() for i in idx))
        if error is None:
            worst = next(i for i in changed if i not in fits)
            raise ModelError(f"parameter {key}: the built model depends on it through {paths[worst]} in a "
                             f"way that is not a polynomial of degree <= {MAX_DEGREE} (e.g. through the "
                             "static equilibrium of the initial state); it cannot be fitted")
    raise ModelError(f"parameter {key}: probing needs builds on either side of its value {value:g}, "
                     f"and the scenario cannot be built {error}")
