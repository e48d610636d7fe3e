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
``beams.beam.section.E``, ``bodies.tip.mass``, ``chains.NAME.speed``); any other key (an element count, a
length: they change the model's shapes or its construction) is refused. Parameters are changed on a built
:class:`~ancf_jax.system.System` with ``equinox.tree_at``, so they can be traced
(differentiated, batched) without rebuilding or recompiling anything.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax.numpy as jnp

from ..errors import ModelError
from ..system import System

#: kind -> (unit, what)
KINDS = {
    "alpha": ("1/s", "Rayleigh mass-proportional damping coefficient"),
    "beta": ("s", "Rayleigh stiffness-proportional damping coefficient"),
    "E": ("Pa", "Young's modulus"),
    "mass": ("kg", "rigid-body mass"),
    "speed": ("m/s", "speed of a moving force, moving mass or chain (its ConstantSpeed path)"),
}
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

    @property
    def unit(self) -> str:
        return KINDS[self.kind][0]

    def get(self, system: System):
        """Current value (a JAX scalar)."""
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
    ``name`` (a moving mass's ``NAME.drive``, a chain's ``NAME.i.x``), in system order."""
    from ..contact import MovingForce
    from ..functions import ConstantSpeed
    from ..joints import PathCoordinate

    found = [f.location.path for f in system.forces if isinstance(f, MovingForce) and f.name == name]
    found += [c.path for c in system.constraints if isinstance(c, PathCoordinate)
              and (c.name == f"{name}.drive" or (c.name.startswith(f"{name}.") and c.name.endswith(".x")))]
    found = [p for p in found if isinstance(p, ConstantSpeed)]
    if not found:
        raise ModelError(f"parameter speed.{name}: no moving force, moving mass or chain named {name!r} "
                         "with a constant-speed path")
    return tuple(found)


def resolve(system: System, names) -> tuple[Parameter, ...]:
    """Parameters of ``system`` named ``names`` (see module docstring).

    Raises:
        ModelError: an unknown kind or target, an ambiguous name, a repeated parameter.
    """
    if isinstance(names, str):
        names = [n for n in names.split(",")]
    out: list[Parameter] = []
    for raw in names:
        name = str(raw).strip()
        # a dotted scenario key (beams.beam.alpha, bodies.tip.mass): its parameter
        scenario_key = name.startswith(("beams.", "bodies.", "loads.", "moving_masses.", "chains."))
        kind, _, target = (from_scenario_key(name) if scenario_key else name).partition(".")
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
        if any((q.kind, q.index) == (p.kind, p.index) for q in out):
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
    raise ModelError(f"{key}: no derivative with respect to this key; differentiable keys: "
                     f"{', '.join(SCENARIO_KEYS)}")
