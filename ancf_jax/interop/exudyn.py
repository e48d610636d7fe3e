"""An ancf_jax :class:`~ancf_jax.model.Model` from an assembled planar Exudyn system.

:func:`from_exudyn` reads the items of an Exudyn ``MainSystem`` (through
``mbs.GetNode``/``GetObject``/``GetMarker``/``GetLoad``; Exudyn itself is not imported
here) and writes the same model with the builder:

| Exudyn | ancf_jax |
| --- | --- |
| `NodePoint2DSlope1` + chains of `ANCFCable2D` | one beam per chain (straight, equally spaced, unit slopes), `Section.from_stiffness`, the formulation of `useReducedOrderIntegration`, `axialDamping`/`bendingDamping` as `StrainRateDamped` laws |
| `MassPoint2D` (`NodePoint2D`) | `Model.add_point_mass` |
| `RigidBody2D` (`NodeRigidBody2D`) | `Model.add_body` |
| `CoordinateConstraint` to a ground coordinate | `Model.coordinate` |
| `RevoluteJoint2D` | `Model.revolute` |
| `SpringDamper` | `Model.spring_damper` |
| `LoadForceVector` | `Model.point_force` |
| `LoadMassProportional` | the model's gravity when every item carries the same one, else `Model.mass_proportional_load` |

Names: a body is named after its Exudyn object, a beam after its first element, a
joint, spring or load after its Exudyn item. Initial positions and velocities are the
Exudyn reference plus initial coordinates. Anything else (other item types, Python
user functions, inactive connectors, follower loads, reference strains) raises a
one-line :class:`~ancf_jax.errors.ModelError` naming the item.
"""

from __future__ import annotations

import numpy as np

from ..element.laws import StrainRateDamped
from ..element.strain_energy import Formulation
from ..errors import ModelError
from .. import mesh as _mesh
from ..model import Model, beam_point, body_point, ground, node
from ..section import Section

#: quadrature rules (axial, bending) of Exudyn's ``useReducedOrderIntegration`` 0, 1, 2
#: (identified against Exudyn 1.13's elastic force, benchmarks/EXUDYN.md)
CABLE_RULES = {0: (("gauss", 5), ("gauss", 3)), 1: (("gauss", 4), ("gauss", 2)), 2: (("lobatto", 3), ("gauss", 2))}

#: node coordinates in the order of Exudyn's ODE2 coordinates
_NODE_COMPONENTS = {"Point2DSlope1": ("x", "y", "slope_x", "slope_y"), "Point2D": ("x", "y"),
                    "RigidBody2D": ("x", "y", "theta")}


def cable_formulation(mode: int) -> Formulation:
    """The :class:`Formulation` equal to Exudyn's cable with ``useReducedOrderIntegration = mode``."""
    if mode not in CABLE_RULES:
        raise ModelError(f"useReducedOrderIntegration must be one of {sorted(CABLE_RULES)}, got {mode!r}")
    ax, be = CABLE_RULES[mode]
    return Formulation(axial_strain="engineering", curvature="material", axial_quadrature=ax,
                       bending_quadrature=be)


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
    for i, nd in enumerate(nodes):
        if nd["nodeType"] not in _NODE_COMPONENTS and nd["nodeType"] != "PointGround":
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
        for key in ("referenceAxialStrain", "referenceCurvature", "strainIsRelativeToReference"):
            if float(o.get(key, 0.0)) != 0.0:
                raise _unsupported("object", k, o, f": {key} = {o[key]} (a straight stress-free reference only)")
        a, b = (int(n) for n in o["nodeNumbers"])
        if a in next_of:
            raise _unsupported("object", k, o, ": a node that starts two elements (branched cables)")
        next_of[a] = (b, k)
        starts.add(a)
    ends = {b for b, _ in next_of.values()}
    element_of: dict[int, tuple[str, int]] = {}  # object index -> (beam, position in chain)
    node_of: dict[int, tuple[str, int]] = {}     # node index -> (beam, node index)
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
    other_loads = []
    for i, ld in enumerate(loads):
        _no_user_function("load", i, ld, "loadVectorUserFunction")
        vec = np.asarray(ld["loadVector"], float)
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
                 "useReducedOrderIntegration")
        for k in chain_elems:
            if any(float(objects[k][p]) != float(o0[p]) for p in props):
                raise _unsupported("object", k, objects[k], f": properties that differ from those of {name!r} "
                                                            "in one chain of cable elements")
        ref = np.array([np.asarray(nodes[i]["referenceCoordinates"], float) for i in chain_nodes])
        lengths = np.array([float(objects[k]["length"]) for k in chain_elems])
        n = len(chain_elems)
        total = float(np.sum(lengths))
        direction = ref[-1, :2] - ref[0, :2]
        beam_mesh = _mesh.straight(tuple(ref[0, :2]), tuple(direction), total, n)
        if np.max(np.abs(np.asarray(beam_mesh.reference_nodes) - ref)) > 1e-12 * max(total, 1.0):
            raise _unsupported("object", chain_elems[0], o0, ": a reference that is not straight with equal "
                                                           "element lengths and unit slopes along it")
        x0 = np.array([state(i)[0] for i in chain_nodes])
        v0 = np.array([state(i)[1] for i in chain_nodes])
        d_a, d_k = float(o0["axialDamping"]), float(o0["bendingDamping"])
        m.add_beam(name, beam_mesh,
                   Section.from_stiffness(float(o0["axialStiffness"]), float(o0["bendingStiffness"]),
                                          float(o0["massPerLength"])),
                   formulation=cable_formulation(int(o0["useReducedOrderIntegration"])),
                   initial_nodes=x0, initial_velocities=v0,
                   axial_law=StrainRateDamped(d_a) if d_a else None,
                   bending_law=StrainRateDamped(d_k) if d_k else None)
        for j, i in enumerate(chain_nodes):
            node_of[i] = (name, j)
        for j, k in enumerate(chain_elems):
            element_of[k] = (name, j)

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

    # ---- connectors
    for k, o in enumerate(objects):
        t = o["objectType"]
        if t in ("ANCFCable2D", "MassPoint2D", "RigidBody2D", "Ground"):
            continue
        what = f"Exudyn object {k} ({o['name']!r})"
        if t in ("ConnectorCoordinate", "JointRevolute2D", "ConnectorSpringDamper") and not o.get("activeConnector", True):
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
    return m
