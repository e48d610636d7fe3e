"""Named outputs of a run: what goes into the CSV columns.

An :class:`Output` names one scalar history computed from a
:class:`~ancf_jax.results.Results`: a coordinate of a beam node or material point, a
body pose, a sliding coordinate, a bending stress, a joint reaction or an energy. The
built-in models (M1, M2) and scenario files describe their CSV columns with these.

Positions (node, point, body, sliding and sliding-point outputs) can be asked for as
their time derivatives (``derivative`` 1: velocity, 2: acceleration, e.g. an
accelerometer): with y = f(q), ẏ = f_q q̇ and ÿ = f_q q̈ + (f_q q̇)_q q̇, by forward-mode
autodiff of the same f (:func:`output_value`, traceable, also used by the fits of
:mod:`ancf_jax.identification`), from the run's q, q̇ and q̈.
"""

from __future__ import annotations

import csv
import dataclasses
import functools
from pathlib import Path
from typing import Iterable, Optional

import jax
import jax.numpy as jnp
import numpy as np

from .errors import ModelError
from .results import Results
from .system import System

KINDS = ("node", "point", "body", "sliding", "sliding_point", "stress", "axial", "bending", "reaction", "energy",
         "member", "friction", "drive", "contact", "load")
COMPONENTS = {
    "node": ("x", "y", "slope_x", "slope_y"),
    "point": ("x", "y"),
    "body": ("x", "y", "theta"),
    "sliding": ("s",),
    "sliding_point": ("x", "y"),
    "stress": ("sigma",),
    "axial": ("force", "strain"),
    "bending": ("moment", "curvature"),
    "reaction": ("normal", "tangential", "fx", "fy", "moment", "0", "1", "2", "3"),
    "member": ("tension", "engaged"),
    "friction": ("force", "normal"),
    "drive": ("force",),
    "contact": ("force", "gap", "engaged", "s", "friction"),
    "load": ("y", "x", "s", "on_beam"),
    "energy": ("kinetic", "gravity", "strain", "springs", "dissipated", "external", "constraint",
               "total", "balance_error"),
}
#: kinds that are functions of the coordinates alone (traceable by :func:`output_value`;
#: the outputs a fit can use)
POSITION_KINDS = ("node", "point", "body", "sliding", "sliding_point", "stress")
#: kinds whose time derivatives are outputs too (``Output.derivative``)
DIFFERENTIABLE_KINDS = ("node", "point", "body", "sliding", "sliding_point")
#: names of ``Output.derivative`` 0, 1, 2 (scenario key ``derivative``)
DERIVATIVES = ("position", "velocity", "acceleration")
#: SI unit of each kind's values, by component where it differs ("-": none; a joint's
#: multipliers are forces or, for rotational constraints, moments)
UNITS = {"node": {"x": "m", "y": "m", "slope_x": "-", "slope_y": "-"}, "point": "m",
         "body": {"x": "m", "y": "m", "theta": "rad"}, "sliding": "m", "sliding_point": "m",
         "stress": "Pa", "axial": {"force": "N", "strain": "-"},
         "bending": {"moment": "N*m", "curvature": "1/m"}, "reaction": {"normal": "N", "tangential": "N", "fx": "N", "fy": "N", "moment": "N*m"}, "member": {"tension": "N", "engaged": "-"},
         "friction": "N", "drive": "N", "energy": "J",
         "contact": {"force": "N", "gap": "m", "engaged": "-", "s": "m", "friction": "N"},
         "load": {"y": "m", "x": "m", "s": "m", "on_beam": "-"}}


@dataclasses.dataclass(frozen=True)
class Output:
    """One named scalar output history (SI units).

    Attributes:
        name: column name.
        kind: ``"node"`` (beam node coordinate), ``"point"`` (material point of a beam at
            arc length ``s``), ``"body"`` (pose), ``"sliding"`` (sliding coordinate s),
            ``"sliding_point"`` (position of a sliding joint's point on its beam),
            ``"stress"`` (bending stress, Eq. 18), ``"axial"`` (axial force N [N],
            tension positive, elastic and rate part of the axial law, or axial strain ε
            in the formulation's measure, at arc length ``s``), ``"bending"`` (bending
            moment M [N·m] of the bending law, elastic and rate part, or the curvature
            change κ − κ₀ [1/m], at arc length ``s``), ``"reaction"`` (joint multiplier
            component, normal/tangential reaction of a sliding joint on its body, or
            ``fx``/``fy``: the force the joint applies in global x, y,
            :meth:`~ancf_jax.results.Results.joint_force`; ``moment``: the moment a
            clamp or fixed joint applies to its beam node,
            :meth:`~ancf_jax.results.Results.joint_moment`), ``"energy"``,
            ``"member"`` (force [N] and engaged state of a spring-damper named ``target``),
            ``"friction"`` (friction force and normal reaction [N] of a sliding
            friction), ``"drive"`` (tangential force [N] of a sliding drive; the drive
            ``NAME.drive`` of a moving mass: its horizontal force along x,
            :meth:`~ancf_jax.results.Results.drive_force`),
            ``"contact"`` (normal force [N], gap [m], engaged state, contact arc length
            [m] of a unilateral contact), ``"load"`` (position y, x [m] and arc length
            s [m] of the beam point under a moving force, and whether it is on the beam).
        target: beam, body or joint name (unused for energy).
        component: see :data:`COMPONENTS`.
        node: node index (``"node"``); negative counts from the last node.
        s: arc length [m] (``"point"``, ``"axial"``, ``"bending"``; ``"stress"`` if
            ``element`` is None).
        element, xi: element index (0-based) and ξ = x/l ∈ [0, 1] (``"stress"``).
        fibre: fibre distance y [m] (``"stress"``; default the outer fibre).
        measure: curvature measure of a stress (``"exact"``, ``"small_strain"``).
        local: body-frame point [m] (``"body"``, components x, y): its position instead
            of the centre's.
        derivative: 0 (default): the value; 1: its velocity; 2: its acceleration
            [unit/s, unit/s²] (kinds in :data:`DIFFERENTIABLE_KINDS`).
    """

    name: str
    kind: str
    target: str = ""
    component: str = ""
    node: Optional[int] = None
    s: Optional[float] = None
    element: Optional[int] = None
    xi: Optional[float] = None
    fibre: Optional[float] = None
    measure: str = "exact"
    local: Optional[tuple] = None
    derivative: int = 0

    @property
    def unit(self) -> str:
        """SI unit of the values (:data:`UNITS`; per s or per s² for derivatives)."""
        u = UNITS[self.kind]
        u = u.get(self.component, "N or N*m") if isinstance(u, dict) else u
        if self.derivative:
            u = ("1" if u == "-" else u) + ("/s", "/s^2")[self.derivative - 1]
        return u

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ModelError(f"output {self.name!r}: kind must be one of {KINDS}, got {self.kind!r}")
        comp = self.component or COMPONENTS[self.kind][0]
        if comp not in COMPONENTS[self.kind]:
            raise ModelError(f"output {self.name!r}: component of a {self.kind} output must be one of "
                             f"{COMPONENTS[self.kind]}, got {self.component!r}")
        object.__setattr__(self, "component", comp)
        if isinstance(self.derivative, bool) or self.derivative not in (0, 1, 2):
            raise ModelError(f"output {self.name!r}: derivative must be 0, 1 or 2 ({', '.join(DERIVATIVES)}), "
                             f"got {self.derivative!r}")
        if self.derivative and self.kind not in DIFFERENTIABLE_KINDS:
            raise ModelError(f"output {self.name!r}: a {self.kind} output has no derivative output; "
                             f"derivatives exist for {', '.join(DIFFERENTIABLE_KINDS)}")


def unit_suffix(unit: str) -> str:
    """The suffix of a JSON key holding a scalar in ``unit`` (the units convention of
    every output file: ``max_abs_sigma_e1_mid_Pa``, ``tip_y_min_m``, ``dt_s``): ``"_Pa"``,
    ``"_m"``, ``"_N"``, ``"_Nm"`` (N*m), ``"_per_m"`` (1/m), ``"_m_per_s2"`` (m/s^2); ``""``
    for a dimensionless (``"-"``) or mixed unit (``"N or N*m"``), whose key the file's
    ``units`` map then explains."""
    u = unit.replace("*", "").replace("·", "").replace("^", "").replace("²", "2").strip()
    if u in ("", "-") or " " in u:
        return ""
    num, _, den = u.partition("/")
    num = "" if num == "1" else num
    return f"_{num}" + (f"{'_' if num else ''}per_{den}" if den else "")


def output_units(outputs: Iterable[Output]) -> dict[str, str]:
    """Units of the columns of :func:`evaluate` (``t`` first), for the ``units`` map
    that accompanies every output file."""
    return {"t": "s", **{o.name: o.unit for o in outputs}}


@functools.partial(jax.jit, static_argnums=(0, 2))
def _history(fn, system, output, q, v, acc):
    """``fn(system, output, q, v, acc)`` at every row (compiled once per function,
    output and shapes; later evaluations of the same column reuse it)."""
    return jax.vmap(lambda qq, vv, aa: fn(system, output, qq, vv, aa))(q, v, acc)


def section_value(system: System, output: Output, q, v, acc=None):
    """Axial force [N] or strain [-] of an ``"axial"`` output, bending moment [N·m] or
    curvature change [1/m] of a ``"bending"`` output, at q, v (traceable)."""
    b = system.beam_names.index(output.target)
    beam, nodes, s = system.beams[b], system.beam_nodes(q, b), float(output.s)
    if output.component == "strain":
        return beam.axial_strain(nodes, s)
    if output.component == "curvature":
        return beam.curvature_change(nodes, s)
    rate = system.beam_nodes(v, b)
    if output.component == "moment":
        return beam.bending_moment_with_rate(nodes, rate, s)
    return beam.axial_force_with_rate(nodes, rate, s)


def position_value(system: System, output: Output, q):
    """Value of an output of a kind in :data:`POSITION_KINDS` at coordinates q
    (traceable; ``output.derivative`` is ignored here)."""
    kind, comp = output.kind, output.component
    if kind == "node":
        b = system.beam_names.index(output.target)
        i = -1 if output.node is None else output.node
        if i < 0:  # from the last active node (n_elements is array data: meshes may be padded)
            i = system.beams[b].mesh.n_elements + 1 + i
        return system.beam_nodes(q, b)[i, COMPONENTS["node"].index(comp)]
    if kind == "point":
        b = system.beam_names.index(output.target)
        return system.beams[b].position(system.beam_nodes(q, b), float(output.s))["xy".index(comp)]
    if kind == "body":
        k = system.body_names.index(output.target)
        pose = system.body_pose(q, k)
        if output.local is not None and comp != "theta":
            c, s = jnp.cos(pose[2]), jnp.sin(pose[2])
            lx, ly = output.local
            return pose[0] + c * lx - s * ly if comp == "x" else pose[1] + s * lx + c * ly
        return pose["x y theta".split().index(comp)]
    if kind == "sliding":
        return system.sliding(q, system.sliding_names.index(output.target))
    if kind == "sliding_point":
        from .joints import SlidingJoint
        joint = next(c for c in system.constraints if isinstance(c, SlidingJoint) and c.name == output.target)
        s = system.sliding(q, joint.sliding)
        return system.beams[joint.beam].position(system.beam_nodes(q, joint.beam), s)["xy".index(comp)]
    if kind != "stress":
        raise ModelError(f"output {output.name!r}: a {kind} output is not a function of the coordinates "
                         f"alone ({', '.join(POSITION_KINDS)} are)")
    b = system.beam_names.index(output.target)
    beam, nodes = system.beams[b], system.beam_nodes(q, b)
    if output.element is not None:
        return beam.element_stress(nodes, output.element, 0.5 if output.xi is None else output.xi,
                                   output.fibre, output.measure)
    return beam.stress(nodes, float(output.s), output.fibre, output.measure)


def output_value(system: System, output: Output, q, v=None, acc=None):
    """Value of an output (kinds in :data:`POSITION_KINDS`) or of its time derivative
    (``output.derivative``) at coordinates q, velocities v and accelerations acc, each
    shape (n,) (traceable): y = f(q), ẏ = f_q v, ÿ = f_q acc + (f_q v)_q v."""
    def f(qq):
        return position_value(system, output, qq)

    if output.derivative == 0:
        return f(q)
    if output.derivative == 1:
        return jax.jvp(f, (q,), (v,))[1]
    rate = lambda qq: jax.jvp(f, (qq,), (v,))[1]  # noqa: E731
    return jax.jvp(rate, (q,), (v,))[1] + jax.jvp(f, (q,), (acc,))[1]


def evaluate(results: Results, outputs: Iterable[Output]) -> dict[str, np.ndarray]:
    """Histories of the outputs, each shape (N,), keyed by name (with ``t`` first)."""
    out = {"t": np.asarray(results.t)}
    energy = None
    for o in outputs:
        if o.derivative or o.kind in ("axial", "bending"):
            fn = output_value if o.derivative else section_value
            val = _history(fn, results.system, o, jnp.asarray(results.q), jnp.asarray(results.v),
                           jnp.asarray(results.acc))
        elif o.kind == "node":
            col = "x y slope_x slope_y".split().index(o.component)
            val = results.node(o.target, -1 if o.node is None else o.node)[:, col]
        elif o.kind == "point":
            val = results.point(o.target, float(o.s))[:, "xy".index(o.component)]
        elif o.kind == "body":
            pose = results.body(o.target)
            if o.local is not None and o.component != "theta":
                c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
                lx, ly = o.local
                val = pose[:, 0] + c * lx - s * ly if o.component == "x" else pose[:, 1] + s * lx + c * ly
            else:
                val = pose[:, "x y theta".split().index(o.component)]
        elif o.kind == "sliding":
            val = results.sliding(o.target)
        elif o.kind == "sliding_point":
            val = results.sliding_point(o.target)[:, "xy".index(o.component)]
        elif o.kind == "stress":
            if o.element is not None:
                val = results.element_stress(o.target, o.element, 0.5 if o.xi is None else o.xi,
                                             o.fibre, o.measure)
            else:
                val = results.stress(o.target, float(o.s), o.fibre, o.measure)
        elif o.kind == "reaction":
            if o.component in ("normal", "tangential"):
                val = results.sliding_reaction(o.target)[:, 0 if o.component == "normal" else 1]
            elif o.component in ("fx", "fy"):
                val = results.joint_force(o.target)[:, 0 if o.component == "fx" else 1]
            elif o.component == "moment":
                val = results.joint_moment(o.target)
            else:
                val = results.multipliers(o.target)[:, int(o.component)]
        elif o.kind == "friction":
            val = results.friction(o.target)[:, 0 if o.component == "force" else 1]
        elif o.kind == "drive":
            val = results.drive_force(o.target)
        elif o.kind == "contact":
            val = results.contact(o.target)[:, COMPONENTS["contact"].index(o.component)]
        elif o.kind == "load":
            val = results.moving_load(o.target)[:, ("s", "x", "y", "on_beam").index(o.component)]
        elif o.kind == "member":
            val = results.member(o.target)[:, 0 if o.component == "tension" else 1]
        else:
            energy = results.energy() if energy is None else energy
            val = energy[o.component]
        out[o.name] = np.asarray(val, float)
    return out


def write_csv(path: str | Path, columns: dict[str, np.ndarray], precision: int | None = None) -> None:
    """Write equal-length columns with a header row (SI units).

    Args:
        precision: significant digits (1..17); None (default): the shortest text that
            reads back to the same double (``repr``: a full round trip).
    """
    if precision is not None and (isinstance(precision, bool) or not isinstance(precision, int)
                                  or not 1 <= precision <= 17):
        from .errors import ModelError
        raise ModelError(f"precision of CSV output must be an integer 1..17 or None, got {precision!r}")
    names = list(columns)
    data = np.column_stack([np.asarray(columns[k], float) for k in names])
    fmt = repr if precision is None else (lambda x: f"{x:.{precision}g}")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        for row in data:
            w.writerow([fmt(float(x)) for x in row])
