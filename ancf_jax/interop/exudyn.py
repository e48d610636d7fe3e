"""Planar Exudyn models in ancf_jax and back: :func:`from_exudyn` and :func:`to_exudyn`.

:func:`from_exudyn` reads the items of an assembled Exudyn ``MainSystem`` (through
``mbs.GetNode``/``GetObject``/``GetMarker``/``GetLoad``; Exudyn itself is not imported
for it) and writes the same model with the builder:

| Exudyn | ancf_jax |
| --- | --- |
| `NodePoint2DSlope1` + chains of `ANCFCable2D` | one beam per chain, `Section.from_stiffness`, the formulation of `useReducedOrderIntegration`, `axialDamping`/`bendingDamping` and `referenceAxialStrain`/`referenceCurvature` as `StrainRateDamped(d, rest)` laws; element lengths as given (`mesh.from_nodes`) |
| `strainIsRelativeToReference` 0 (stress-free: straight, unit slopes) | a straight stress-free mesh of the element lengths, the Exudyn configuration as initial nodes |
| `strainIsRelativeToReference` 1 (stress-free: the reference, e.g. curved) | the reference as the mesh, `Formulation(metric="parameter")` |
| `MassPoint2D` (`NodePoint2D`) | `Model.add_point_mass` |
| `RigidBody2D` (`NodeRigidBody2D`) | `Model.add_body` |
| `CoordinateConstraint` to a ground coordinate | `Model.coordinate` |
| `RevoluteJoint2D` | `Model.revolute` |
| `JointSliding2D` (classical formulation, over a whole cable) | `Model.slider` |
| `SpringDamper` | `Model.spring_damper` |
| `LoadForceVector` | `Model.point_force` |
| `LoadTorqueVector` (about z, on a rigid body) | `Model.torque` |
| `LoadMassProportional` | the model's gravity when every item carries the same one, else `Model.mass_proportional_load` |

Names: a body is named after its Exudyn object, a beam after its first element, a
joint, spring or load after its Exudyn item. Initial positions and velocities are the
Exudyn reference plus initial coordinates. Anything else (other item types, Python
user functions, inactive connectors, follower loads, a fractional
``strainIsRelativeToReference``) raises a one-line :class:`~ancf_jax.errors.ModelError` naming the item.

:func:`to_exudyn` goes the other way, from an ancf_jax model (or an assembled system
and state) to a new Exudyn ``MainSystem`` of the same discrete problem, for the subset
Exudyn has (its docstring lists it); :func:`simulation_settings` gives Exudyn's
generalized-α the settings of an ancf_jax run. Exudyn is imported by these two only
(``pip install exudyn``): importing this module does not load it.
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import Any

import numpy as np

from .. import joints as J
from .. import mesh as _mesh
from .. import points as P
from ..element.laws import LinearElastic, StrainRateDamped
from ..element.strain_energy import Formulation
from ..errors import ModelError
from ..forces import BeamMassLoad, BodyMassLoad, PointForce, PointTorque, SpringDamper
from ..model import Model, beam_point, body_point, ground, node
from ..section import Section

#: quadrature rules (axial, bending) of Exudyn's ``useReducedOrderIntegration`` 0, 1, 2
#: (identified against Exudyn 1.13's elastic force, benchmarks/EXUDYN.md)
CABLE_RULES = {0: (("gauss", 5), ("gauss", 3)), 1: (("gauss", 4), ("gauss", 2)), 2: (("lobatto", 3), ("gauss", 2))}

#: node coordinates in the order of Exudyn's ODE2 coordinates
_NODE_COMPONENTS = {"Point2DSlope1": ("x", "y", "slope_x", "slope_y"), "Point2D": ("x", "y"),
                    "RigidBody2D": ("x", "y", "theta")}

#: relative tolerance of the geometric checks (straight, unit slopes, offsets)
_GEOMETRY_TOLERANCE = 1e-12


def cable_formulation(mode: int, metric: str = "arc_length") -> Formulation:
    """The :class:`Formulation` equal to Exudyn's cable with ``useReducedOrderIntegration = mode``
    (``metric="parameter"``: with ``strainIsRelativeToReference = 1``; on straight
    unit-slope references both metrics are Exudyn's cable)."""
    if mode not in CABLE_RULES:
        raise ModelError(f"useReducedOrderIntegration must be one of {sorted(CABLE_RULES)}, got {mode!r}")
    ax, be = CABLE_RULES[mode]
    return Formulation(axial_strain="engineering", curvature="material", axial_quadrature=ax,
                       bending_quadrature=be, metric=metric)


def integration_mode(formulation: Formulation) -> int:
    """Exudyn's ``useReducedOrderIntegration`` equal to an ancf_jax formulation.

    Raises:
        ModelError: the formulation has no Exudyn equivalent.
    """
    if formulation.axial_strain != "engineering" or formulation.curvature != "material":
        raise ModelError("Exudyn's ANCFCable2D uses axial_strain='engineering' and curvature='material'; got "
                         f"{formulation.axial_strain!r}, {formulation.curvature!r} (use cable_formulation())")
    for mode, (ax, be) in CABLE_RULES.items():
        if tuple(formulation.axial_quadrature) == ax and tuple(formulation.bending_quadrature) == be:
            return mode
    raise ModelError(f"quadrature {formulation.axial_quadrature}/{formulation.bending_quadrature} "
                     f"is none of Exudyn's rules {CABLE_RULES}")


def straight_unit(nodes, lengths) -> bool:
    """Whether reference nodes (n + 1, 4) with element lengths (n,) lie on one straight
    line with equal unit slopes along it and node distances equal to the element
    lengths: the stress-free state of Exudyn's cable (element parameter = arc length)."""
    nodes, lengths = np.asarray(nodes, float), np.asarray(lengths, float)
    scale = _GEOMETRY_TOLERANCE * max(1.0, float(np.sum(lengths)))
    t = nodes[:, 2:]
    if np.max(np.abs(np.linalg.norm(t, axis=1) - 1.0)) > _GEOMETRY_TOLERANCE or np.max(np.abs(t - t[0])) > \
            _GEOMETRY_TOLERANCE:
        return False
    steps = nodes[1:, :2] - nodes[:-1, :2]
    return bool(np.max(np.abs(steps - lengths[:, None] * t[0])) <= scale)


def hermite(xi, length):
    """Cubic Hermite shape functions of the cable element and their first and second
    derivatives by the parameter x = ξ l, at ξ ∈ [0, 1] (NumPy; order: node-0 position,
    node-0 slope, node-1 position, node-1 slope), each (P, 4)."""
    xi = np.atleast_1d(np.asarray(xi, float))
    s = np.stack([1 - 3 * xi**2 + 2 * xi**3, length * (xi - 2 * xi**2 + xi**3),
                  3 * xi**2 - 2 * xi**3, length * (-xi**2 + xi**3)], axis=-1)
    s1 = np.stack([(-6 * xi + 6 * xi**2) / length, 1 - 4 * xi + 3 * xi**2,
                   (6 * xi - 6 * xi**2) / length, -2 * xi + 3 * xi**2], axis=-1)
    s2 = np.stack([(-6 + 12 * xi) / length**2, (-4 + 6 * xi) / length,
                   (6 - 12 * xi) / length**2, (-2 + 6 * xi) / length], axis=-1)
    return s, s1, s2


def _count(mbs, what):
    return int(getattr(mbs.systemData, f"NumberOf{what}")())


def _unsupported(kind, index, item, why=""):
    return ModelError(f"Exudyn {kind} {index} ({item.get('name', '')!r}, type "
                      f"{item.get(kind + 'Type', '?')!r}) is not translated to ancf_jax{why}")


def _no_user_function(kind, index, item, *keys):
    for k in keys:
        if item.get(k, 0) not in (0, None):
            raise _unsupported(kind, index, item, f": Python user function {k} (write it as a JAX law or "
                                                  "force element)")


def from_exudyn(mbs) -> Model:
    """Build an ancf_jax :class:`~ancf_jax.model.Model` equal to an assembled planar
    Exudyn ``MainSystem`` (see the module docstring for what maps to what).

    Returns:
        the model (build it with :meth:`~ancf_jax.model.Model.build`).

    Raises:
        ModelError: an item that is not translated, named with its index and name.
    """
    nodes = [mbs.GetNode(i) for i in range(_count(mbs, "Nodes"))]
    objects = [mbs.GetObject(i) for i in range(_count(mbs, "Objects"))]
    markers = [mbs.GetMarker(i) for i in range(_count(mbs, "Markers"))]
    loads = [mbs.GetLoad(i) for i in range(_count(mbs, "Loads"))]
    for i, nd in enumerate(nodes):  # data nodes belong to sliding joints (checked there)
        if nd["nodeType"] not in _NODE_COMPONENTS and nd["nodeType"] not in ("PointGround", "GenericData"):
            raise _unsupported("node", i, nd)

    def state(i):
        nd = nodes[i]
        return (np.asarray(nd["referenceCoordinates"], float) + np.asarray(nd["initialCoordinates"], float),
                np.asarray(nd["initialVelocities"], float))

    # ---- cables: chains of elements
    cables = {k: o for k, o in enumerate(objects) if o["objectType"] == "ANCFCable2D"}
    next_of, starts = {}, set()
    for k, o in cables.items():
        _no_user_function("object", k, o, "axialForceUserFunction", "bendingMomentUserFunction")
        if float(o.get("strainIsRelativeToReference", 0.0)) not in (0.0, 1.0):
            raise _unsupported("object", k, o, f": strainIsRelativeToReference = "
                                                f"{o['strainIsRelativeToReference']} (0 or 1 only)")
        a, b = (int(n) for n in o["nodeNumbers"])
        if a in next_of:
            raise _unsupported("object", k, o, ": a node that starts two elements (branched cables)")
        next_of[a] = (b, k)
        starts.add(a)
    ends = {b for b, _ in next_of.values()}
    element_of: dict[int, tuple[str, int]] = {}  # object index -> (beam, position in chain)
    node_of: dict[int, tuple[str, int]] = {}     # node index -> (beam, node index)
    chain_of: dict[str, tuple[list, np.ndarray]] = {}  # beam -> (element objects, element lengths)
    beams = []
    for first in sorted(starts - ends, key=lambda a: next_of[a][1]):
        chain_nodes, chain_elems = [first], []
        while chain_nodes[-1] in next_of:
            b, k = next_of[chain_nodes[-1]]
            chain_nodes.append(b)
            chain_elems.append(k)
        beams.append((chain_nodes, chain_elems))
    if sum(len(e) for _, e in beams) != len(cables):
        raise ModelError("Exudyn cables that form a closed loop are not translated to ancf_jax")

    # ---- loads (collected first: gravity is the model's when every item carries it)
    mass_loads: dict[int, np.ndarray] = {}  # object index -> summed acceleration
    other_loads, torques = [], []
    for i, ld in enumerate(loads):
        _no_user_function("load", i, ld, "loadVectorUserFunction")
        vec = np.asarray(ld["loadVector"], float)
        if ld["loadType"] == "TorqueVector":
            if np.any(vec[:2] != 0.0):
                raise _unsupported("load", i, ld, ": x or y components (planar models: a torque about z only)")
            torques.append((i, ld, float(vec[2])))
            continue
        if vec.shape[0] > 2 and vec[2] != 0.0:
            raise _unsupported("load", i, ld, ": a z component (planar models only)")
        if ld["loadType"] == "MassProportional":
            mk = markers[int(ld["markerNumber"])]
            if mk["markerType"] != "BodyMass":
                raise _unsupported("load", i, ld, f": on a {mk['markerType']} marker")
            k = int(mk["bodyNumber"])
            mass_loads[k] = mass_loads.get(k, np.zeros(2)) + vec[:2]
        elif ld["loadType"] == "ForceVector":
            if ld.get("bodyFixed", False):
                raise _unsupported("load", i, ld, ": bodyFixed (follower) loads")
            other_loads.append((i, ld, vec[:2]))
        else:
            raise _unsupported("load", i, ld)

    masses = [k for k, o in enumerate(objects) if o["objectType"] in ("MassPoint2D", "RigidBody2D")]
    items = [tuple(e) for _, e in beams] + [(k,) for k in masses]

    def item_load(elems):
        vecs = [mass_loads.get(k, np.zeros(2)) for k in elems]
        if any(np.any(v != vecs[0]) for v in vecs):
            raise ModelError(f"Exudyn objects {list(elems)}: different mass-proportional loads on the elements "
                             "of one cable are not translated to ancf_jax")
        return vecs[0]

    per_item = [item_load(e) for e in items]
    uniform = bool(per_item) and all(np.array_equal(v, per_item[0]) for v in per_item)
    m = Model(gravity=tuple(per_item[0]) if uniform else (0.0, 0.0))

    # ---- beams
    for (chain_nodes, chain_elems) in beams:
        o0 = objects[chain_elems[0]]
        name = o0["name"]
        props = ("massPerLength", "axialStiffness", "bendingStiffness", "axialDamping", "bendingDamping",
                 "useReducedOrderIntegration", "strainIsRelativeToReference", "referenceAxialStrain",
                 "referenceCurvature")
        for k in chain_elems:
            if any(float(objects[k][p]) != float(o0[p]) for p in props):
                raise _unsupported("object", k, objects[k], f": properties that differ from those of {name!r} "
                                                            "in one chain of cable elements")
        ref = np.array([np.asarray(nodes[i]["referenceCoordinates"], float) for i in chain_nodes])
        lengths = np.array([float(objects[k]["length"]) for k in chain_elems])
        relative = float(o0["strainIsRelativeToReference"]) == 1.0
        if relative or straight_unit(ref, lengths):
            # the stress-free state is the reference itself (measured per element
            # parameter: metric "parameter"; on a straight unit-slope reference that is
            # Exudyn's default cable as well)
            beam_mesh = _mesh.from_nodes(ref, lengths)
        else:
            # stress-free: straight with unit slopes over the element lengths; the
            # (curved or stretched) reference is only the initial configuration
            s_nodes = np.concatenate([[0.0], np.cumsum(lengths)])
            beam_mesh = _mesh.from_nodes(np.column_stack([ref[0, 0] + s_nodes, np.full_like(s_nodes, ref[0, 1]),
                                                          np.ones_like(s_nodes), np.zeros_like(s_nodes)]), lengths)
        x0 = np.array([state(i)[0] for i in chain_nodes])
        v0 = np.array([state(i)[1] for i in chain_nodes])
        d_a, d_k = float(o0["axialDamping"]), float(o0["bendingDamping"])
        eps0, kappa0 = float(o0["referenceAxialStrain"]), float(o0["referenceCurvature"])
        m.add_beam(name, beam_mesh,
                   Section.from_stiffness(float(o0["axialStiffness"]), float(o0["bendingStiffness"]),
                                          float(o0["massPerLength"])),
                   formulation=cable_formulation(int(o0["useReducedOrderIntegration"]),
                                                 "parameter" if relative else "arc_length"),
                   initial_nodes=x0, initial_velocities=v0,
                   axial_law=StrainRateDamped(d_a, eps0) if d_a or eps0 else None,
                   bending_law=StrainRateDamped(d_k, kappa0) if d_k or kappa0 else None)
        for j, i in enumerate(chain_nodes):
            node_of[i] = (name, j)
        for j, k in enumerate(chain_elems):
            element_of[k] = (name, j)
        chain_of[name] = (chain_elems, lengths)

    # ---- bodies
    body_of_node: dict[int, str] = {}
    for k in masses:
        o = objects[k]
        i = int(o["nodeNumber"])
        q, v = state(i)
        if o["objectType"] == "MassPoint2D":
            if nodes[i]["nodeType"] != "Point2D":
                raise _unsupported("object", k, o, f": a mass point on a {nodes[i]['nodeType']} node")
            m.add_point_mass(o["name"], mass=float(o["mass"]), position=tuple(q[:2]), velocity=tuple(v[:2]))
        else:
            if np.any(np.asarray(o.get("centerOfMass", (0.0, 0.0)), float) != 0.0):
                raise _unsupported("object", k, o, ": a centre of mass away from the node")
            m.add_body(o["name"], mass=float(o["mass"]), inertia=float(o["inertia"]), position=tuple(q[:2]),
                       angle=float(q[2]), velocity=tuple(v[:2]), angular_velocity=float(v[2]))
        body_of_node[i] = o["name"]
    if not uniform:
        for elems, vec in zip(items, per_item):
            if np.any(vec != 0.0):
                target = element_of[elems[0]][0] if elems[0] in element_of else objects[elems[0]]["name"]
                m.mass_proportional_load(f"{target}.mass_load", target, tuple(vec))

    # ---- points of markers
    def point(mi, what):
        mk = markers[mi]
        kind = mk["markerType"]
        if kind == "NodePosition":
            i = int(mk["nodeNumber"])
            if i in node_of:
                return node(*node_of[i])
            if i in body_of_node:
                return body_point(body_of_node[i])
            if nodes[i]["nodeType"] == "PointGround":
                return ground(*np.asarray(nodes[i]["referenceCoordinates"], float)[:2])
        elif kind == "BodyPosition":
            k = int(mk["bodyNumber"])
            local = np.asarray(mk["localPosition"], float)
            o = objects[k]
            if o["objectType"] == "Ground":
                p = np.asarray(o["referencePosition"], float)[:2] + local[:2]
                return ground(*p)
            if o["objectType"] == "RigidBody2D":
                return body_point(o["name"], tuple(local[:2]))
            if o["objectType"] == "MassPoint2D" and not np.any(local):
                return body_point(o["name"])
            if k in element_of and local[1] == 0.0:
                beam, j = element_of[k]
                s = sum(float(objects[e]["length"]) for e, (b, jj) in element_of.items() if b == beam and jj < j)
                return beam_point(beam, s + float(local[0]))
        raise ModelError(f"{what}: Exudyn marker {mi} ({mk.get('name', '')!r}, type {kind!r}) is not "
                         "translated to ancf_jax")

    def body_of_marker(mi, what):
        """(body name, local point) of a position marker on a rigid body or mass point."""
        mk = markers[mi]
        if mk["markerType"] == "NodePosition" and int(mk["nodeNumber"]) in body_of_node:
            return body_of_node[int(mk["nodeNumber"])], (0.0, 0.0)
        if mk["markerType"] == "BodyPosition":
            o = objects[int(mk["bodyNumber"])]
            local = tuple(float(x) for x in np.asarray(mk["localPosition"], float)[:2])
            if o["objectType"] == "RigidBody2D" or (o["objectType"] == "MassPoint2D" and not any(local)):
                return o["name"], local
        raise ModelError(f"{what}: Exudyn marker {mi} ({mk.get('name', '')!r}, type {mk['markerType']!r}) is not "
                         "a point of a rigid body or mass point (ancf_jax slides bodies along beams)")

    def sliding_joint(k, o):
        what = f"Exudyn object {k} ({o['name']!r})"
        if not o.get("useClassicalFormulation", True):
            raise _unsupported("object", k, o, ": useClassicalFormulation = False (the classical formulation only)")
        if o.get("constrainRotation", False):
            raise _unsupported("object", k, o, ": constrainRotation")
        if float(o.get("axialForce", 0.0)) != 0.0:
            raise _unsupported("object", k, o, ": an axialForce (use Model.slider_drive)")
        sliding = [markers[int(mi)] for mi in o["slidingMarkerNumbers"]]
        if not sliding or any(mk["markerType"] != "BodyCable2DCoordinates" or int(mk["bodyNumber"]) not in element_of
                              for mk in sliding):
            raise _unsupported("object", k, o, ": sliding markers that are not cable elements "
                                                "(MarkerBodyCable2DCoordinates)")
        elems = [element_of[int(mk["bodyNumber"])] for mk in sliding]
        beam = elems[0][0]
        chain, lengths = chain_of[beam]
        offsets = np.asarray(o["slidingMarkerOffsets"], float)
        s_nodes = np.concatenate([[0.0], np.cumsum(lengths)])[:-1]
        if (any(b != beam for b, _ in elems) or [j for _, j in elems] != list(range(len(chain)))
                or offsets.shape != s_nodes.shape
                or np.max(np.abs(offsets - s_nodes)) > _GEOMETRY_TOLERANCE * max(1.0, float(s_nodes[-1]))):
            raise _unsupported("object", k, o, f": sliding markers and offsets that are not the elements of cable "
                                                f"{beam!r} in order with their arc lengths (ancf_jax slides along "
                                                "a whole beam)")
        data = nodes[int(o["nodeNumber"])]
        if data["nodeType"] != "GenericData" or int(data["numberOfDataCoordinates"]) != 2:
            raise _unsupported("object", k, o, ": a data node that is not NodeGenericData with 2 coordinates")
        s0 = float(np.asarray(data["initialCoordinates"], float)[1])
        body, local = body_of_marker(int(o["markerNumbers"][0]), what)
        m.slider(o["name"], body, beam, s0, local=local)

    # ---- connectors
    for k, o in enumerate(objects):
        t = o["objectType"]
        if t in ("ANCFCable2D", "MassPoint2D", "RigidBody2D", "Ground"):
            continue
        what = f"Exudyn object {k} ({o['name']!r})"
        if t in ("ConnectorCoordinate", "JointRevolute2D", "ConnectorSpringDamper", "JointSliding2D") and \
                not o.get("activeConnector", True):
            raise _unsupported("object", k, o, ": an inactive connector")
        if t == "ConnectorCoordinate":
            _no_user_function("object", k, o, "offsetUserFunction", "offsetUserFunction_t")
            if o.get("velocityLevel", False):
                raise _unsupported("object", k, o, ": velocityLevel (index-2 constraints)")
            ends_ = [markers[int(mi)] for mi in o["markerNumbers"]]
            on_ground = [mk["markerType"] == "NodeCoordinate" and nodes[int(mk["nodeNumber"])]["nodeType"] == "PointGround"
                         for mk in ends_]
            if on_ground.count(True) != 1 or any(mk["markerType"] != "NodeCoordinate" for mk in ends_):
                raise _unsupported("object", k, o, ": a coordinate constraint between two moving coordinates")
            side = on_ground.index(False)
            mk = ends_[side]
            i, c = int(mk["nodeNumber"]), int(mk["coordinate"])
            factor, offset = float(o["factor1"]), float(o["offset"])
            # Exudyn: factor1·q_m1 − q_m0 − offset = 0 on displacement coordinates
            if side == 1:
                if factor == 0.0:
                    raise _unsupported("object", k, o, ": factor1 = 0")
                displacement = offset / factor
            else:
                displacement = -offset
            value = float(np.asarray(nodes[i]["referenceCoordinates"], float)[c]) + displacement
            component = _NODE_COMPONENTS[nodes[i]["nodeType"]][c]
            target = node(*node_of[i]) if i in node_of else body_point(body_of_node[i])
            m.coordinate(o["name"], target, component, value=value)
        elif t == "JointRevolute2D":
            a, b = (point(int(mi), what) for mi in o["markerNumbers"])
            m.revolute(o["name"], a, b)
        elif t == "JointSliding2D":
            sliding_joint(k, o)
        elif t == "ConnectorSpringDamper":
            _no_user_function("object", k, o, "springForceUserFunction")
            if float(o.get("force", 0.0)) != 0.0 or float(o.get("velocityOffset", 0.0)) != 0.0:
                raise _unsupported("object", k, o, ": a force or velocityOffset")
            a, b = (point(int(mi), what) for mi in o["markerNumbers"])
            m.spring_damper(o["name"], a, b, stiffness=float(o["stiffness"]), damping=float(o["damping"]),
                            rest_length=float(o["referenceLength"]))
        else:
            raise _unsupported("object", k, o)

    for i, ld, vec in other_loads:
        m.point_force(ld["name"], point(int(ld["markerNumber"]), f"Exudyn load {i} ({ld['name']!r})"), tuple(vec))
    for i, ld, tau in torques:
        mk = markers[int(ld["markerNumber"])]
        if mk["markerType"] == "BodyRigid" and objects[int(mk["bodyNumber"])]["objectType"] == "RigidBody2D":
            body = objects[int(mk["bodyNumber"])]["name"]
        elif mk["markerType"] == "NodeRigid" and int(mk["nodeNumber"]) in body_of_node:
            body = body_of_node[int(mk["nodeNumber"])]
        else:
            raise _unsupported("load", i, ld, f": on a {mk['markerType']} marker (a rigid body's only)")
        m.torque(ld["name"], body, tau)
    return m


# ====================================================================== ancf_jax -> Exudyn
def _exudyn():
    try:
        import exudyn
        from exudyn import itemInterface
    except ImportError as err:
        raise ImportError("to_exudyn needs Exudyn (pip install exudyn)") from err
    return exudyn, itemInterface


@dataclasses.dataclass
class ExudynSystem:
    """An Exudyn system translated from an ancf_jax system by :func:`to_exudyn`.

    Attributes:
        sc, mbs: Exudyn ``SystemContainer`` and its assembled ``MainSystem``.
        system, state: the ancf_jax system and initial state it was translated from.
        beam_nodes, beam_elements: per beam (system order), Exudyn node and object numbers.
        beam_reference: per beam, the Exudyn reference nodal coordinates (n + 1, 4)
            (Exudyn's node coordinates are displacements from it).
        body_nodes, body_objects: per body, Exudyn node and object numbers.
        body_reference: (n_bodies, 3) reference poses (x, y, θ) (the initial poses).
        sliders: per sliding joint, the ``ObjectJointSliding2D`` number.
        items: ancf_jax joint or force name -> the Exudyn object numbers that make it
            (loads: load numbers).
        sensors: Exudyn sensor numbers (internal storage) by kind: ``beam_q``,
            ``beam_v`` (per beam, per node), ``body_q``, ``body_v``, ``sliding_s``,
            ``sliding_p``; empty when built without sensors.
        integration: ``useReducedOrderIntegration`` of each beam.
    """

    sc: Any
    mbs: Any
    system: Any
    state: Any
    beam_nodes: list
    beam_elements: list
    beam_reference: list
    body_nodes: list
    body_objects: list
    body_reference: np.ndarray
    sliders: list
    items: dict
    sensors: dict
    integration: list

    def _pack(self, beam, body, sliding):
        s = self.system
        return np.asarray(s.pack(body.reshape(-1, 3), beam, sliding), float)

    def coordinates(self) -> np.ndarray:
        """The ancf_jax coordinates q (n_coordinates,) of Exudyn's current state."""
        exu, _ = _exudyn()
        ovt = exu.OutputVariableType.Coordinates
        beams = [np.array([self.mbs.GetNodeOutput(nd, ovt) for nd in nodes]) + ref
                 for nodes, ref in zip(self.beam_nodes, self.beam_reference)]
        bodies = self._body_poses(lambda nd: self.mbs.GetNodeOutput(nd, ovt)) + self.body_reference
        s = np.array([self.mbs.GetObjectOutput(j, exu.OutputVariableType.SlidingCoordinate) for j in self.sliders])
        return self._pack(beams, bodies, s.reshape(-1))

    def _body_poses(self, read):
        out = np.zeros((len(self.body_nodes), 3))
        for k, nd in enumerate(self.body_nodes):
            x = np.asarray(read(nd), float)
            out[k, :x.shape[0]] = x
        return out

    def solve_dynamic(self, *, t_end: float, h: float, output_dt: float | None = None, **settings):
        """Integrate with Exudyn's fixed-step generalized-α from the translated initial
        state to ``t_end`` [s] at step ``h`` [s] (:func:`simulation_settings`: the
        other keywords; sensors every ``output_dt`` [s], default h) and return
        :meth:`history`, (t (N,), q (N, n_coordinates)).

        Raises:
            ModelError: ``t_end`` is not a whole number of steps, or Exudyn's solve failed.
        """
        exu, _ = _exudyn()
        n_steps = int(round(t_end / h))
        if n_steps < 1 or abs(n_steps * h - t_end) > 1e-9 * max(1.0, t_end):
            raise ModelError(f"t_end = {t_end!r} s must be a positive whole number of steps h = {h!r} s")
        ok = exu.SolveDynamic(self.mbs, simulation_settings(t_end=t_end, h=h, n_steps=n_steps,
                                                            output_dt=h if output_dt is None else output_dt,
                                                            **settings))
        if ok is False:
            raise ModelError(f"Exudyn's SolveDynamic failed (t_end = {t_end:g} s, h = {h:g} s, {settings})")
        return self.history()

    def history(self):
        """(t (N,), q (N, n_coordinates)) of the ancf_jax coordinates at Exudyn's sensor
        times after a solve (built with ``sensors=True``)."""
        if not self.sensors:
            raise ModelError("this Exudyn system was built without sensors (to_exudyn(..., sensors=True))")

        def stored(sensor):
            return np.asarray(self.mbs.GetSensorStoredData(sensor))

        t = stored(self.sensors["beam_q"][0][0] if self.beam_nodes else self.sensors["body_q"][0])[:, 0]
        beams = [np.stack([stored(k)[:, 1:] for k in ks], axis=1) + ref[None]
                 for ks, ref in zip(self.sensors["beam_q"], self.beam_reference)]
        nb = len(self.body_nodes)
        bodies = np.zeros((t.size, nb, 3))
        for k, sensor in enumerate(self.sensors["body_q"]):
            x = stored(sensor)[:, 1:]
            bodies[:, k, :x.shape[1]] = x
        bodies += self.body_reference[None]
        s = (np.stack([stored(k)[:, 1] for k in self.sensors["sliding_s"]], axis=1) if self.sliders
             else np.zeros((t.size, 0)))
        q = np.stack([self._pack([b[i] for b in beams], bodies[i], s[i]) for i in range(t.size)])
        return t, q


def _sliding_compensation(joints, lengths, size, first_node):
    """forceUserFunction of an ObjectGenericODE2 over the nodes of a cable: +Δs S'(s)ᵀλ
    on the right-hand side for each sliding joint, cancelling :func:`sliding_term`."""
    cache = {}

    def force(mbs, t, item, q, q_t):
        sd = mbs.systemData
        if not cache:
            for j in joints:
                data_node = mbs.GetObjectParameter(j, "nodeNumber")
                cache[j] = (np.asarray(sd.GetObjectLTGAE(j), int), np.asarray(sd.GetNodeLTGData(data_node), int),
                            np.asarray(mbs.GetObjectParameter(j, "slidingMarkerOffsets"), float))
        z = sd.GetAECoordinates()
        x = sd.GetDataCoordinates()
        f = np.zeros(size)
        for j in joints:
            ae, data, offsets = cache[j]
            k = int(round(x[data[0]]))
            ds = z[ae[2]]
            s_el = ds + x[data[1]] - offsets[k]
            _, s1, _ = hermite(s_el / lengths[k], lengths[k])
            f[first_node[k]: first_node[k] + 8] += sliding_term(ds, s1[0], (z[ae[0]], z[ae[1]]))
        return f

    return force


def sliding_term(ds: float, slope_shape, force) -> np.ndarray:
    """The extra generalized force in Exudyn 1.13's ``ObjectJointSliding2D``
    (classical formulation), on the 8 coordinates of the current cable element.

    Exudyn adds C_qᵀ z to the equations of motion for *all* algebraic coordinates z of
    a constraint (``CSystem::ComputeODE2ProjectedReactionForces``). The sliding joint's
    third algebraic coordinate is not a multiplier but the sliding increment Δs of the
    step, and its equation row is λ·r'(s) = 0, whose ODE2 Jacobian is λᵀS'(s). So the
    cable equations carry the extra term Δs S'(s)ᵀλ on their left-hand side (Δs the
    increment since the start of the step, λ the joint force). It vanishes at rest and
    is O(h) in the step: a first-order error of Exudyn's joint, not of the model
    (benchmarks/EXUDYN.md).

    Args:
        ds: sliding increment Δs [m]; slope_shape: S'(s) (4,) in Exudyn's order;
        force: (λx, λy) [N].
    Returns:
        (8,) term on [r0x, r0y, r0'x, r0'y, r1x, r1y, r1'x, r1'y].
    """
    slope_shape = np.asarray(slope_shape, float)
    out = np.zeros(8)
    out[0::2] = ds * slope_shape * force[0]
    out[1::2] = ds * slope_shape * force[1]
    return out


def cancel_sliding_term(mbs, joints) -> int:
    """Add to an Exudyn system a generalized force that cancels the extra term
    :func:`sliding_term` of its ``ObjectJointSliding2D`` joints (numbers ``joints``, all
    sliding along the same chain of ``ANCFCable2D`` elements): one ``ObjectGenericODE2``
    (no mass) over the chain's nodes with a Python ``forceUserFunction`` reading the
    joints' algebraic and data coordinates. A cross-check device (Python in Exudyn's
    loop), not a model item. Call before ``mbs.Assemble()``; returns the object number.
    """
    exu, eii = _exudyn()
    joints = [int(j) for j in joints]
    elements = [int(mbs.GetMarker(int(mi))["bodyNumber"]) for mi in mbs.GetObject(joints[0])["slidingMarkerNumbers"]]
    for j in joints[1:]:
        if [int(mbs.GetMarker(int(mi))["bodyNumber"]) for mi in mbs.GetObject(j)["slidingMarkerNumbers"]] != elements:
            raise ModelError("cancel_sliding_term: the joints must slide along the same cable elements")
    cable_nodes = [int(mbs.GetObject(e)["nodeNumbers"][0]) for e in elements]
    cable_nodes.append(int(mbs.GetObject(elements[-1])["nodeNumbers"][1]))
    lengths = np.array([float(mbs.GetObject(e)["length"]) for e in elements])
    size = 4 * len(cable_nodes)
    zero = exu.MatrixContainer()
    zero.SetWithSparseMatrix(np.zeros((0, 3)), numberOfRows=size, numberOfColumns=size)

    def no_jacobian(mbs_, t, item, q, q_t, f_ode2, f_ode2_t):
        # the compensating force depends on algebraic and data coordinates only: no
        # ODE2 Jacobian (spares Exudyn's numerical differentiation)
        jac = exu.MatrixContainer()
        jac.SetWithSparseMatrix(np.zeros((0, 3)), numberOfRows=size, numberOfColumns=size)
        return jac

    return mbs.AddObject(eii.ObjectGenericODE2(
        nodeNumbers=cable_nodes, massMatrix=zero,
        forceUserFunction=_sliding_compensation(joints, lengths, size, 4 * np.arange(len(elements))),
        jacobianUserFunction=no_jacobian))


def _mass_matrix(exu, mbs) -> np.ndarray:
    """Exudyn's own system mass matrix (ODE2 coordinates), computed without a run."""
    ss = exu.SimulationSettings()
    ss.staticSolver.verboseMode = 0
    ss.solution.file.write = False
    ss.solution.sensors.active = False
    solver = exu.MainSolverStatic()
    solver.InitializeSolver(mbs, ss)
    solver.ComputeMassMatrix(mbs)
    return np.array(solver.GetSystemMassMatrix())


def _not_translated(what: str, why: str) -> ModelError:
    return ModelError(f"{what} is not translated to Exudyn: {why}")


#: names of the form Exudyn gives unnamed items ('object3', 'node0[...]'), which it
#: refuses for named ones
_EXUDYN_AUTO_NAME = re.compile(r"^(node|object|marker|load|sensor)[0-9]")


def _exudyn_name(name: str) -> str:
    """An ancf_jax name as an Exudyn item name (Exudyn's own automatic names, which an
    imported model carries for unnamed items, get the prefix ``ancf_``)."""
    return f"ancf_{name}" if _EXUDYN_AUTO_NAME.match(name) else name


def to_exudyn(model, state=None, *, integration: int | None = None, sensors: bool = True,
              cancel_sliding: bool = False) -> ExudynSystem:
    """Build a new Exudyn ``MainSystem`` equal to an ancf_jax model, to cross-check it
    in Exudyn (the inverse of :func:`from_exudyn` on the subset both have).

    Args:
        model: a :class:`~ancf_jax.model.Model` (built here with its defaults) or an
            assembled :class:`~ancf_jax.system.System`, then with its ``state``.
        state: the initial :class:`~ancf_jax.system.State` (only with a System).
        integration: override every cable's ``useReducedOrderIntegration`` (default:
            the mode equal to each beam's formulation; one without an Exudyn equivalent
            raises).
        sensors: add internally stored sensors of every node and sliding joint
            (:meth:`ExudynSystem.history`).
        cancel_sliding: cancel Exudyn's extra sliding-joint term
            (:func:`cancel_sliding_term`; a Python user function in Exudyn's loop).

    Translated (ancf_jax -> Exudyn 1.13):

    ==============================  ===========================================================
    beam node (r, r')               ``NodePoint2DSlope1``: reference = the stress-free mesh,
                                    initial coordinates = q₀ − reference
    beam element                    ``ObjectANCFCable2D`` (EA, EI, ρA, length,
                                    ``useReducedOrderIntegration`` of the quadrature rules;
                                    ``strainIsRelativeToReference = 1`` for a mesh that is not
                                    straight with unit slopes, with ``metric="parameter"``)
    ``StrainRateDamped`` laws       ``axialDamping`` d_A, ``bendingDamping`` d_K and the
                                    natural strains ``referenceAxialStrain``,
                                    ``referenceCurvature``
    Rayleigh α (β = 0)              ``ObjectGenericODE2`` over the beam's nodes with
                                    ``dampingMatrix`` = α·M (Exudyn's own mass matrix)
    rigid body / point mass         ``NodeRigidBody2D`` + ``RigidBody2D`` / ``NodePoint2D`` +
                                    ``MassPoint2D``
    gravity (items with it on)      ``LoadMassProportional`` on every element and body
    clamp ("full", "exudyn";        one ``CoordinateConstraint`` per held coordinate to a
    "direction" along an axis),     ground coordinate (offset = value − reference)
    pin of a node, coordinate
    revolute, pin (other points)    ``RevoluteJoint2D`` between position markers (a point
                                    inside an element: ``MarkerBodyPosition`` on it)
    fixed joint node – body         ``ObjectJointGeneric`` (x, y, rotation z) between the
                                    node's slope frame and the body frame
    sliding joint                   ``ObjectJointSliding2D`` (classical) over all elements,
                                    data node [element, s₀]
    spring-damper (both ways)       ``ConnectorSpringDamper``
    point force, torque             ``LoadForceVector``, ``LoadTorqueVector``
    mass-proportional load          ``LoadMassProportional`` on the item
    ==============================  ===========================================================

    Anything else (other laws, β, attached masses, time functions, prescribed motions,
    held sliding joints, one-sided springs, friction, drives, other force elements)
    raises a one-line :class:`~ancf_jax.errors.ModelError` naming the item; Exudyn
    would need a Python user function or has no such item.
    """
    exu, eii = _exudyn()
    if isinstance(model, Model):
        if state is not None:
            raise ModelError("to_exudyn: give a Model alone, or an assembled System with its state")
        system, state = model.build()
    else:
        if state is None:
            raise ModelError("to_exudyn: an assembled System needs its initial state (to_exudyn(system, state))")
        system = model
    q0 = np.asarray(state.q, float)
    v0 = np.asarray(state.v, float)
    g = np.asarray(system.gravity, float)
    gravity = [float(g[0]), float(g[1]), 0.0]
    items: dict[str, list] = {}

    # ---- everything that has no Exudyn item, refused before anything is built
    for f in system.reaction_forces:
        raise _not_translated(f"force {f.name!r} ({type(f).__name__})", "Exudyn's sliding joint has no friction")
    point_masses = set()
    for c in system.constraints:
        if isinstance(c, J.FixedCoordinate) and c.name.endswith(".rotation"):
            body = c.name[: -len(".rotation")]
            if body in system.body_names and c.index == system.body_offset(system.body_names.index(body)) + 2:
                point_masses.add(system.body_names.index(body))
    for k in range(system.n_bodies):
        if float(system.bodies.inertia[k]) == 0.0 and k not in point_masses:
            raise _not_translated(f"body {system.body_names[k]!r}", "zero inertia without a point mass's rotation "
                                                                   "constraint")

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground_node = mbs.AddNode(eii.NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    ground_coord = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
    ground_obj = mbs.AddObject(eii.ObjectGround(referencePosition=[0.0, 0.0, 0.0]))

    def gravity_on(name):
        return np.any(g != 0.0) and name not in system.gravity_off

    # ---- beams
    beam_nodes, beam_elements, beam_reference, modes = [], [], [], []
    for b, beam in enumerate(system.beams):
        bname = system.beam_names[b] if system.beam_names else str(b)
        what = f"beam {bname!r}"
        n = int(beam.mesh.n_elements)
        if n != beam.mesh.n_max:
            raise _not_translated(what, "padded beams (build without pad_to)")
        if float(beam.beta) != 0.0:
            raise _not_translated(what, "stiffness-proportional damping beta (Exudyn's cable damps strain "
                                        "rates: StrainRateDamped laws)")
        if beam.attached is not None:
            raise _not_translated(what, "attached masses")
        mode = integration_mode(beam.formulation) if integration is None else int(integration)
        if mode not in CABLE_RULES:
            raise ModelError(f"integration must be one of {sorted(CABLE_RULES)}, got {integration!r}")
        ref = np.asarray(beam.mesh.reference_nodes, float)
        lengths = np.asarray(beam.mesh.element_lengths, float)
        relative = 0.0
        if not straight_unit(ref, lengths):
            if beam.formulation.metric != "parameter":
                raise _not_translated(what, "a reference that is not straight with unit slopes under "
                                            "metric='arc_length' (Exudyn measures strains per element parameter: "
                                            "use Formulation(metric='parameter'))")
            relative = 1.0
        damping = {}
        for key, rest, law in (("axialDamping", "referenceAxialStrain", beam.axial_law),
                               ("bendingDamping", "referenceCurvature", beam.bending_law)):
            if isinstance(law, StrainRateDamped):
                damping[key] = float(law.damping)
                damping[rest] = float(law.rest)
            elif law is not None and not isinstance(law, LinearElastic):
                raise _not_translated(what, f"material law {type(law).__name__} (Exudyn needs a Python user "
                                            "function)")
        x0 = np.asarray(system.beam_nodes(q0, b), float)
        xv = np.asarray(system.beam_nodes(v0, b), float)
        sec = beam.section
        nodes = [mbs.AddNode(eii.NodePoint2DSlope1(name=_exudyn_name(f"{bname}.node{i}"),
                                                   referenceCoordinates=list(ref[i]),
                                                   initialCoordinates=list(x0[i] - ref[i]),
                                                   initialVelocities=list(xv[i])))
                 for i in range(n + 1)]
        elements = []
        for i in range(n):
            e = mbs.AddObject(eii.ObjectANCFCable2D(
                name=_exudyn_name(bname if i == 0 else f"{bname}.element{i}"),
                nodeNumbers=[nodes[i], nodes[i + 1]], length=float(lengths[i]),
                massPerLength=float(sec.mass_per_length), axialStiffness=float(sec.axial_stiffness),
                bendingStiffness=float(sec.bending_stiffness), useReducedOrderIntegration=mode,
                strainIsRelativeToReference=relative, **damping))
            if gravity_on(bname):
                mbs.AddLoad(eii.LoadMassProportional(
                    name=_exudyn_name(f"{bname}.gravity{i}"),
                    markerNumber=mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=e)),
                    loadVector=gravity))
            elements.append(e)
        beam_nodes.append(nodes)
        beam_elements.append(elements)
        beam_reference.append(ref)
        modes.append(mode)

    # ---- bodies and point masses (reference = initial pose)
    body_nodes, body_objects = [], []
    poses = np.array([np.asarray(system.body_pose(q0, k)) for k in range(system.n_bodies)]).reshape(-1, 3)
    vels = np.array([np.asarray(system.body_pose(v0, k)) for k in range(system.n_bodies)]).reshape(-1, 3)
    for k in range(system.n_bodies):
        name = system.body_names[k]
        if k in point_masses:
            nd = mbs.AddNode(eii.NodePoint2D(name=_exudyn_name(f"{name}.node"), referenceCoordinates=list(poses[k, :2]),
                                             initialVelocities=list(vels[k, :2])))
            ob = mbs.AddObject(eii.MassPoint2D(name=_exudyn_name(name), nodeNumber=nd,
                                               mass=float(system.bodies.mass[k])))
        else:
            nd = mbs.AddNode(eii.NodeRigidBody2D(name=_exudyn_name(f"{name}.node"), referenceCoordinates=list(poses[k]),
                                                 initialVelocities=list(vels[k])))
            ob = mbs.AddObject(eii.ObjectRigidBody2D(name=_exudyn_name(name), mass=float(system.bodies.mass[k]),
                                                     inertia=float(system.bodies.inertia[k]), nodeNumber=nd))
        if gravity_on(name):
            mbs.AddLoad(eii.LoadMassProportional(name=_exudyn_name(f"{name}.gravity"),
                                                 markerNumber=mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=ob)),
                                                 loadVector=gravity))
        body_nodes.append(nd)
        body_objects.append(ob)

    # ---- markers
    def node_index(pt):
        i = int(np.asarray(pt.node))
        return i if i >= 0 else int(system.beams[pt.beam].mesh.n_elements) + 1 + i

    def coordinate_of(index, what):
        """(Exudyn node, coordinate, reference value) of ancf_jax coordinate ``index``."""
        if index < 3 * system.n_bodies:
            k, c = divmod(index, 3)
            if k in point_masses and c == 2:
                raise _not_translated(what, "a point mass has no rotation")
            return body_nodes[k], c, poses[k, c]
        for b in range(len(system.beams)):
            o = system.beam_offset(b)
            if o <= index < o + system.beams[b].n_coordinates:
                i, c = divmod(index - o, 4)
                return beam_nodes[b][i], c, beam_reference[b][i, c]
        raise _not_translated(what, "a constraint on a sliding coordinate (release held sliding joints)")

    def fix(index, value, label, what):
        nd, c, ref = coordinate_of(index, what)
        m = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=nd, coordinate=c))
        return mbs.AddObject(eii.ObjectConnectorCoordinate(name=_exudyn_name(label), markerNumbers=[ground_coord, m],
                                                           offset=float(value - ref)))

    def position_marker(pt, what):
        if isinstance(pt, P.BodyPoint):
            local = [*map(float, np.asarray(pt.local)), 0.0]
            if pt.body in point_masses:
                if any(local):
                    raise _not_translated(what, "a point of a point mass away from its centre")
                return mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=body_nodes[pt.body]))
            return mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=body_objects[pt.body], localPosition=local))
        if isinstance(pt, P.BeamNode):
            return mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=beam_nodes[pt.beam][node_index(pt)]))
        if isinstance(pt, P.BeamPoint):
            mesh = system.beams[pt.beam].mesh
            k, x = mesh.locate(float(np.asarray(pt.s)))
            k, x = int(k), float(x)
            return mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=beam_elements[pt.beam][k],
                                                        localPosition=[x, 0.0, 0.0]))
        if isinstance(pt, P.GroundPoint):
            loc = np.asarray(pt.location, float)
            return mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=ground_obj, localPosition=[loc[0], loc[1], 0.0]))
        raise _not_translated(what, f"a point of type {type(pt).__name__}")

    # ---- joints
    sliders, slider_beams = [], []
    for c in system.constraints:
        what = f"joint {c.name!r} ({type(c).__name__})"
        made = []
        if isinstance(c, J.Clamp):
            b, i = c.node.beam, node_index(c.node)
            o = system.beam_offset(b) + 4 * i
            target = np.concatenate([np.asarray(c.location, float), np.asarray(c.slope, float)])
            if c.mode == "full":
                held = [(0, target[0]), (1, target[1]), (2, target[2]), (3, target[3])]
            elif c.mode == "exudyn":
                held = [(0, target[0]), (1, target[1]), (3, target[3])]
            elif abs(target[3]) <= _GEOMETRY_TOLERANCE * abs(target[2]):  # direction along x: r'_y = 0
                held = [(0, target[0]), (1, target[1]), (3, 0.0)]
            elif abs(target[2]) <= _GEOMETRY_TOLERANCE * abs(target[3]):  # along y: r'_x = 0
                held = [(0, target[0]), (1, target[1]), (2, 0.0)]
            else:
                raise _not_translated(what, "mode 'direction' at a slope off the axes (not a coordinate constraint)")
            made = [fix(o + k, v, f"{c.name}[{j}]", what) for j, (k, v) in enumerate(held)]
        elif isinstance(c, J.FixedCoordinate):
            body = c.name[: -len(".rotation")] if c.name.endswith(".rotation") else None
            if body in system.body_names and system.body_names.index(body) in point_masses:
                continue  # the point mass's own θ = 0 (MassPoint2D has no rotation)
            made = [fix(c.index, float(c.value), c.name, what)]
        elif isinstance(c, J.Coincident):
            a, bb = c.a, c.b
            if isinstance(bb, P.GroundPoint) and isinstance(a, P.BeamNode):
                a, bb = bb, a
            if isinstance(a, P.GroundPoint) and isinstance(bb, P.BeamNode):
                o = system.beam_offset(bb.beam) + 4 * node_index(bb)
                loc = np.asarray(a.location, float)
                made = [fix(o + k, loc[k], f"{c.name}[{k}]", what) for k in range(2)]
            else:
                made = [mbs.AddObject(eii.ObjectJointRevolute2D(
                    name=_exudyn_name(c.name), markerNumbers=[position_marker(a, what), position_marker(bb, what)]))]
        elif isinstance(c, J.FixedJoint):
            if not isinstance(c.point, P.BeamNode):
                raise _not_translated(what, "a fixed joint other than beam node - rigid body")
            if c.body_point.body in point_masses:
                raise _not_translated(what, "a point mass has no rotation")
            m_node = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=beam_nodes[c.point.beam][node_index(c.point)]))
            bp = c.body_point
            m_body = mbs.AddMarker(eii.MarkerBodyRigid(
                bodyNumber=body_objects[bp.body], localPosition=[*map(float, np.asarray(bp.local)), 0.0]))
            u = np.asarray(c.direction_local, float)  # the slope direction in the body frame
            phi = math.atan2(float(u[1]), float(u[0]))
            cphi, sphi = math.cos(phi), math.sin(phi)
            made = [mbs.AddObject(eii.ObjectJointGeneric(
                name=_exudyn_name(c.name), markerNumbers=[m_node, m_body], constrainedAxes=[1, 1, 0, 0, 0, 1],
                rotationMarker1=[[cphi, -sphi, 0.0], [sphi, cphi, 0.0], [0.0, 0.0, 1.0]]))]
        elif isinstance(c, J.SlidingJoint):
            b = c.beam
            n = int(system.beams[b].mesh.n_elements)
            s_nodes = np.asarray(system.beams[b].mesh.node_arc_lengths, float)
            s0 = float(q0[system.sliding_offset + c.sliding])
            k0 = int(np.clip(np.searchsorted(s_nodes, s0, side="right") - 1, 0, n - 1))
            cable_markers = [mbs.AddMarker(eii.MarkerBodyCable2DCoordinates(bodyNumber=e)) for e in beam_elements[b]]
            data = mbs.AddNode(eii.NodeGenericData(name=_exudyn_name(f"{c.name}.data"),
                                                   initialCoordinates=[float(k0), s0],
                                                   numberOfDataCoordinates=2))
            made = [mbs.AddObject(eii.ObjectJointSliding2D(
                name=_exudyn_name(c.name), markerNumbers=[position_marker(c.body_point, what), cable_markers[k0]],
                slidingMarkerNumbers=cable_markers, slidingMarkerOffsets=list(s_nodes[:n]),
                nodeNumber=data, useClassicalFormulation=True))]
            sliders.append(made[0])
            slider_beams.append(b)
        elif isinstance(c, J.SlidingHold):
            raise _not_translated(what, "held sliding joints (build with hold=False)")
        elif isinstance(c, (J.PrescribedCoordinate, J.PrescribedPoint, J.PathCoordinate)):
            raise _not_translated(what, "a motion prescribed by a function of time (Exudyn needs a Python user "
                                        "function)")
        else:
            raise _not_translated(what, "no Exudyn joint is mapped to it")
        items[c.name] = made

    # ---- forces
    for f in system.forces:
        what = f"force {f.name!r} ({type(f).__name__})"
        if getattr(f, "time_function", None) is not None:
            raise _not_translated(what, "a time function (Exudyn needs a Python user function)")
        if type(f) is PointForce:
            fv = np.asarray(f.force, float)
            made = [mbs.AddLoad(eii.LoadForceVector(name=_exudyn_name(f.name),
                                                    markerNumber=position_marker(f.point, what),
                                                    loadVector=[fv[0], fv[1], 0.0]))]
        elif type(f) is PointTorque:
            if f.body in point_masses:
                raise _not_translated(what, "a point mass has no rotation")
            marker = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=body_objects[f.body], localPosition=[0.0, 0.0, 0.0]))
            made = [mbs.AddLoad(eii.LoadTorqueVector(name=_exudyn_name(f.name), markerNumber=marker,
                                                     loadVector=[0.0, 0.0, float(f.torque)]))]
        elif type(f) is SpringDamper:
            made = [mbs.AddObject(eii.ObjectConnectorSpringDamper(
                name=_exudyn_name(f.name), markerNumbers=[position_marker(f.a, what), position_marker(f.b, what)],
                stiffness=float(f.stiffness), damping=float(f.damping), referenceLength=float(f.rest_length)))]
        elif type(f) in (BodyMassLoad, BeamMassLoad):
            acc = np.asarray(f.acceleration, float)
            targets = [body_objects[f.body]] if type(f) is BodyMassLoad else beam_elements[f.beam]
            made = [mbs.AddLoad(eii.LoadMassProportional(
                name=_exudyn_name(f"{f.name}{'' if len(targets) == 1 else j}"),
                markerNumber=mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=e)), loadVector=[acc[0], acc[1], 0.0]))
                for j, e in enumerate(targets)]
        else:
            raise _not_translated(what, "no Exudyn item is mapped to it")
        items[f.name] = made

    # ---- per beam one ObjectGenericODE2 over its nodes (no mass): α·M, M Exudyn's own
    # consistent mass matrix of those coordinates (a constant matrix, in Exudyn's
    # Newton matrix analytically)
    mbs.Assemble()
    damped = [b for b, beam in enumerate(system.beams) if float(beam.alpha) > 0.0]
    mass = _mass_matrix(exu, mbs) if damped else None
    for b in damped:
        ltg = np.concatenate([np.asarray(mbs.systemData.GetNodeLTGODE2(nd), int) for nd in beam_nodes[b]])
        size = len(ltg)
        mb = float(system.beams[b].alpha) * mass[np.ix_(ltg, ltg)]
        rows, cols = np.nonzero(mb)
        dmat = exu.MatrixContainer()
        dmat.SetWithSparseMatrix(np.column_stack([rows, cols, mb[rows, cols]]), numberOfRows=size,
                                 numberOfColumns=size)
        zero = exu.MatrixContainer()
        zero.SetWithSparseMatrix(np.zeros((0, 3)), numberOfRows=size, numberOfColumns=size)
        mbs.AddObject(eii.ObjectGenericODE2(name=_exudyn_name(f"{system.beam_names[b]}.alpha"),
                                            nodeNumbers=beam_nodes[b],
                                            massMatrix=zero, dampingMatrix=dmat))
    if cancel_sliding:
        for b in sorted(set(slider_beams)):
            cancel_sliding_term(mbs, [j for j, bb in zip(sliders, slider_beams) if bb == b])

    # ---- sensors (stored internally, no files)
    sensor_ids: dict = {}
    if sensors:
        ovt = exu.OutputVariableType

        def node_sensor(nd, kind):
            return mbs.AddSensor(eii.SensorNode(nodeNumber=nd, outputVariableType=kind, storeInternal=True,
                                                writeToFile=False))

        def object_sensor(ob, kind):
            return mbs.AddSensor(eii.SensorObject(objectNumber=ob, outputVariableType=kind, storeInternal=True,
                                                  writeToFile=False))

        sensor_ids = dict(
            beam_q=[[node_sensor(nd, ovt.Coordinates) for nd in nodes] for nodes in beam_nodes],
            beam_v=[[node_sensor(nd, ovt.Coordinates_t) for nd in nodes] for nodes in beam_nodes],
            body_q=[node_sensor(nd, ovt.Coordinates) for nd in body_nodes],
            body_v=[node_sensor(nd, ovt.Coordinates_t) for nd in body_nodes],
            sliding_s=[object_sensor(j, ovt.SlidingCoordinate) for j in sliders],
            sliding_p=[object_sensor(j, ovt.Position) for j in sliders])
    mbs.Assemble()
    return ExudynSystem(sc=sc, mbs=mbs, system=system, state=state, beam_nodes=beam_nodes,
                        beam_elements=beam_elements, beam_reference=beam_reference, body_nodes=body_nodes,
                        body_objects=body_objects, body_reference=poses, sliders=sliders, items=items,
                        sensors=sensor_ids, integration=modes)


#: Exudyn's linear solvers :func:`simulation_settings` accepts
LINEAR_SOLVERS = ("EXUdense", "EigenSparse", "EigenDense")


def simulation_settings(*, t_end: float, h: float, n_steps: int, output_dt: float, rho_inf: float = 0.9,
                        relative_tolerance: float = 1e-8, absolute_tolerance: float = 1e-10,
                        modified_newton: bool = True, max_iterations: int = 25, linear_solver: str = "EXUdense",
                        discontinuous_tolerance: float = 1e-12, discontinuous_iterations: int = 5,
                        threads: int = 1, verbose: int = 0, index: int = 3):
    """Exudyn ``SimulationSettings`` for the fixed-step index-3 generalized-α run that
    ancf_jax's ``simulate(..., solver=make_solver("generalized-alpha", rho_inf=ρ∞,
    velocity_projection=False))`` takes: the same ρ∞ and step h [s] (``n_steps`` steps to ``t_end`` [s]), consistent
    initial accelerations, never an adapted step (a failed Newton iteration is an
    error), sensors every ``output_dt`` [s], no files.

    Newton: Exudyn stops when the residual norm falls below ``relative_tolerance``
    times the step's initial residual (or below ``absolute_tolerance``);
    ``modified_newton`` keeps the Jacobian across iterations and steps (Exudyn's
    default); ``False`` is full Newton. ``discontinuous_tolerance``: a sliding joint
    that leaves its element by more than this during a step repeats the step on the
    next element (Exudyn's default, 1 m, keeps the extrapolated old element;
    benchmarks/EXUDYN.md). ``index``: 3 (positions) or 2 (velocity-level constraints,
    ``useIndex2Constraints``; ancf_jax's ``GeneralizedAlpha(constraints=VelocityLevel())``), which
    Exudyn has for its Newmark method only: index 2 needs ρ∞ = 1, and runs Exudyn's
    Newmark with β = ¼, γ = ½ (the trapezoidal rule, generalized-α at ρ∞ = 1).
    """
    exu, _ = _exudyn()
    if index not in (2, 3):
        raise ModelError(f"index must be 2 or 3, got {index!r}")
    if index == 2 and rho_inf != 1.0:
        raise ModelError(f"index 2 needs rho_inf = 1 (Exudyn has velocity-level constraints for its Newmark "
                         f"method, the trapezoidal rule, only), got rho_inf = {rho_inf!r}")
    if linear_solver not in LINEAR_SOLVERS:
        raise ModelError(f"linear_solver must be one of {LINEAR_SOLVERS}, got {linear_solver!r}")
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.endTime = float(t_end)
    ti.numberOfSteps = int(n_steps)
    ti.verboseMode = int(verbose)
    ti.adaptiveStep = False
    ti.generalizedAlpha.spectralRadius = float(rho_inf)
    ti.generalizedAlpha.useIndex2Constraints = index == 2
    ti.generalizedAlpha.useNewmark = index == 2
    ti.generalizedAlpha.newmarkBeta = 0.25
    ti.generalizedAlpha.newmarkGamma = 0.5
    ti.generalizedAlpha.computeInitialAccelerations = True
    nt = ti.newton
    nt.relativeTolerance = float(relative_tolerance)
    nt.absoluteTolerance = float(absolute_tolerance)
    nt.useModifiedNewton = bool(modified_newton)
    nt.maxIterations = int(max_iterations)
    ti.discontinuous.iterationTolerance = float(discontinuous_tolerance)
    ti.discontinuous.maxIterations = int(discontinuous_iterations)
    ti.discontinuous.ignoreMaxIterations = False
    ss.linearSolver.solverType = getattr(exu.LinearSolverType, linear_solver)
    ss.parallel.numberOfThreads = int(threads)
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = float(output_dt)
    ss.show.computationTime = False
    return ss
