"""Checks of a scenario that involve several keys or the names of other entities.

Run on the validated schema (:class:`~.schema.ScenarioSpec`) with host data only:
names and their uniqueness, references to beams, bodies, joints and body points,
node indices, arc lengths inside beams, keys that exclude or require each other, the
output interval inside the run, and every time function finite at the run's time
steps and output times (evaluated with NumPy: nothing is compiled).
The first problem raises :class:`~.errors.Invalid` with its key path.
"""

from __future__ import annotations

import re

import numpy as np

from . import schema as S
from ..errors import ModelError
from ..simulation import time_grid
from ..validation import coincide_tolerance
from .errors import Invalid
from .types import TimeFunctionSpec
from .geometry import element_count, first_node, initial_node_positions, reference_length

NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]{0,63}$")
NAME_RULE = "a name of letters, digits, '_' and '-', starting with a letter or '_', at most 64 characters"
POINT_FORMS = ('{ ground = [x, y] }, { body = "name" } with optional local = [x, y] or point = "p", '
               '{ beam = "name", node = i } or { beam = "name", s = arc length }')
#: most output times at which the time functions are checked (a longer grid is sampled)
MAX_CHECKED_TIMES = 100_001
#: most time steps at which the time functions are checked (a longer grid is sampled)
MAX_CHECKED_STEPS = 1_000_001
#: constraint equations of each joint type (clamp: by mode)
JOINT_SIZE = {"pin": 2, "revolute": 2, "fixed": 3, "sliding": 2, "prescribed_point": 2,
              "prescribed_body": 1}
#: joint types whose first two equations are a point's position (force outputs fx, fy)
POINT_JOINTS = ("pin", "revolute", "clamp", "fixed", "sliding", "prescribed_point")
#: the groups of named entities (names unique across them)
GROUPS = ("beams", "bodies", "moving_masses", "chains", "joints", "loads")
#: output types that read a load of [loads], and the load type each needs
LOAD_OUTPUTS = {"member": "spring_damper", "contact": "contact", "load": "moving_force"}


def host_values(f: TimeFunctionSpec, times) -> np.ndarray:
    """A time function's values at ``times`` [s] with NumPy (nothing compiled)."""
    times = np.asarray(times, float)
    if f.kind == "expression":
        return f.function.numpy(times)
    if f.kind == "constant":
        return np.full(times.shape, f.function.value)
    return np.interp(times, f.function.times, f.function.values)


def path_values(item, times) -> np.ndarray:
    """p(t) = start + speed·t + profile(t) [m] of a moving force, moving mass or chain
    at ``times`` (NumPy)."""
    times = np.asarray(times, float)
    p = item.start + item.speed * times
    return p if item.profile is None else p + host_values(item.profile, times)


def _names(names) -> str:
    names = list(names)
    return ", ".join(f'"{n}"' for n in names) if names else "none defined"


class Checker:
    """Runs every check on one scenario (see module docstring)."""

    def __init__(self, spec: S.ScenarioSpec):
        self.spec = spec
        self.lengths: dict[str, float] = {}
        self.elements: dict[str, int] = {}
        #: point masses the moving_masses and chains tables make: {body name: what made it}
        self.made_bodies: dict[str, str] = {}
        for name in spec.moving_masses:
            self.made_bodies[name] = f'moving mass "{name}"'
        for name, c in spec.chains.items():
            for i in range(len(c.heights)):
                self.made_bodies[f"{name}.{i + 1}"] = f'chain "{name}"'
        #: sliding joints of the moving masses: {joint name: moving mass}
        self.made_sliders = {f"{name}.slider": name for name in spec.moving_masses}

    # ------------------------------------------------------------------ helpers
    def beam(self, path, name):
        if name not in self.spec.beams:
            raise Invalid(path, f'beam "{name}" does not exist', f"the name of a beam: {_names(self.spec.beams)}")

    def body(self, path, name, before: str | None = None):
        known = list(self.spec.bodies)
        if before is not None:
            known = known[: known.index(before)]
        else:  # the point masses of moving_masses and chains (added after the bodies)
            known += list(self.made_bodies)
        if name not in known:
            extra = " declared before this one" if before is not None else ""
            if before is not None and name in self.spec.bodies:
                raise Invalid(path, f'body "{name}" is declared after this body',
                              f"the name of a body declared before: {_names(known)}")
            if before is not None and name in self.made_bodies:
                raise Invalid(path, f'body "{name}" is a point mass of {self.made_bodies[name]}, made after '
                              "the bodies", f"the name of a body declared before: {_names(known)}")
            raise Invalid(path, f'body "{name}" does not exist', f"the name of a body{extra}: {_names(known)}")

    def joint_type(self, name) -> str:
        """The type of a joint of [joints] or of a moving mass's sliding joint."""
        return "sliding" if name in self.made_sliders else self.spec.joints[name].type

    def joint(self, path, name, types=None):
        joints = {**{n: j.type for n, j in self.spec.joints.items()},
                  **{n: "sliding" for n in self.made_sliders}}
        known = [n for n, t in joints.items() if types is None or t in types]
        what = "a joint" if types is None else " or ".join(f"{t} joint" for t in types)
        if name not in known:
            exists = name in joints
            raise Invalid(path, f'joint "{name}" ' + ("is not a " + what if exists else "does not exist"),
                          f"the name of {what if types is None else 'a ' + what}: {_names(known)}")

    def node_index(self, path, beam, index):
        n = self.elements[beam]
        if not -(n + 1) <= index <= n:
            raise Invalid(path, f'node {index} is outside beam "{beam}" with {n} elements',
                          f"an integer 0 .. {n}, or -1 .. {-(n + 1)} from the last node")

    def arc_length(self, path, beam, s, what="arc length"):
        length = self.lengths[beam]
        if not 0.0 <= s <= length * (1 + 1e-12):
            raise Invalid(path, f'{what} {s:g} m is outside beam "{beam}"', f"0 .. {length:g} [m]")

    def point(self, path, ref: S.PointRef, *, before_body: str | None = None):
        given = [k for k in ("ground", "body", "beam") if getattr(ref, k) is not None]
        if len(given) != 1:
            raise Invalid(path, "a point needs exactly one of ground, body, beam"
                          + (f" (got {', '.join(given)})" if given else ""), POINT_FORMS)
        kind = given[0]
        allowed = {"ground": {"ground"}, "body": {"body", "local", "point"},
                   "beam": {"beam", "node", "s"}}[kind]
        for k in ("ground", "body", "local", "point", "beam", "node", "s"):
            if getattr(ref, k) is not None and k not in allowed:
                raise Invalid(path + (k,), f"key {k} does not go with {kind}", POINT_FORMS)
        if kind == "body":
            self.body(path + ("body",), ref.body, before_body)
            if ref.local is not None and ref.point is not None:
                raise Invalid(path + ("point",), "give local or point, not both", POINT_FORMS)
            if ref.point is not None:
                self.body_point(path + ("point",), ref.body, ref.point)
            if ref.local is not None and any(ref.local):
                self.rotating(path + ("local",), ref.body, "a body point away from the centre")
        elif kind == "beam":
            self.beam(path + ("beam",), ref.beam)
            if (ref.node is None) == (ref.s is None):
                raise Invalid(path, "a beam point needs exactly one of node, s", POINT_FORMS)
            if ref.node is not None:
                self.node_index(path + ("node",), ref.beam, ref.node)
            else:
                self.arc_length(path + ("s",), ref.beam, ref.s)

    def body_point(self, path, body, name):
        points = self.spec.bodies[body].points if body in self.spec.bodies else {}
        if name not in points:
            raise Invalid(path, f'body "{body}" has no point "{name}"',
                          f'a name in bodies.{body}.points: {_names(points)}')

    def initial_position(self, ref: S.PointRef, depth: int = 0):
        """The point's initial position [m] (host only) where the file fixes it: a ground
        point, a body point of a body with ``position`` (or ``at`` such a point), a node
        of a beam whose initial shape gives every node; None otherwise (the build
        checks those)."""
        if ref.ground is not None:
            return np.asarray(ref.ground, float)
        if ref.body is not None:
            b = self.spec.bodies.get(ref.body)
            if b is None or depth > len(self.spec.bodies):
                return None
            centre = (np.asarray(b.position, float) if b.position is not None else
                      self.initial_position(b.at, depth + 1) if b.at is not None else np.zeros(2))
            if centre is None:
                return None
            local = (np.asarray(b.points[ref.point], float) if ref.point is not None and ref.point in b.points
                     else np.asarray(ref.local or (0.0, 0.0), float))
            c, sn = np.cos(b.angle), np.sin(b.angle)
            return centre + np.array([[c, -sn], [sn, c]]) @ local
        if ref.beam is not None and ref.node is not None and ref.beam in self.spec.beams:
            n = self.elements[ref.beam]
            nodes = initial_node_positions(self.spec.beams[ref.beam], n, self.lengths[ref.beam])
            if len(nodes) != n + 1:
                return None
            return nodes[ref.node]
        return None

    def apart(self, path, a: S.PointRef, b: S.PointRef):
        """A spring-damper's ends must start apart (at zero length its direction, the
        gradient of its length, is undefined: the run would fail as 'state became NaN')."""
        pa, pb = self.initial_position(a), self.initial_position(b)
        if pa is None or pb is None:
            return
        d = float(np.linalg.norm(pa - pb))
        if d <= coincide_tolerance(max(float(np.max(np.abs(pa))), float(np.max(np.abs(pb))))):
            raise Invalid(path, f"its ends a and b coincide at the initial state ({pa[0]:g}, {pa[1]:g}) m: at zero "
                          "length the spring's direction (the gradient of its length) is undefined",
                          "two points that start apart")

    @staticmethod
    def exclusive(path, obj, keys, *, required=False):
        given = [k for k in keys if getattr(obj, k) is not None]
        if len(given) > 1:
            raise Invalid(path + (given[1],), f"{given[1]} cannot be given together with {given[0]}",
                          "one of " + ", ".join(keys))
        if required and not given:
            raise Invalid(path, f"missing key: give one of {', '.join(keys)}", "one of " + ", ".join(keys))

    # ------------------------------------------------------------------ sections
    def names(self):
        if self.spec.name is not None and not NAME.match(self.spec.name):
            raise Invalid(("name",), f"invalid scenario name {self.spec.name!r}", NAME_RULE)
        seen: dict[str, str] = {}
        for group in GROUPS:
            for name in getattr(self.spec, group):
                if not NAME.match(name):
                    raise Invalid((group, name), f"invalid name {name!r}", NAME_RULE)
                if name in seen:
                    raise Invalid((group, name), f'duplicate name "{name}": already used in {seen[name]}',
                                  "names unique across beams, bodies, joints and loads (and "
                                  "moving_masses, chains)")
                seen[name] = group
        for body, spec in self.spec.bodies.items():
            for p in spec.points:
                if not NAME.match(p):
                    raise Invalid(("bodies", body, "points", p), f"invalid name {p!r}", NAME_RULE)
        for name in self.spec.outputs.columns:
            if not NAME.match(name) or name == "t":
                raise Invalid(("outputs", "columns", name), f"invalid output name {name!r}",
                              NAME_RULE + ", not 't' (the time column)")

    def beams(self):
        for name, b in self.spec.beams.items():
            path = ("beams", name)
            g = b.geometry
            if isinstance(g, S.ThroughPoints):
                p, t = np.asarray(g.points), np.asarray(g.slopes)
                if len(p) < 2:
                    raise Invalid(path + ("geometry", "points"), f"{len(p)} point given", "at least 2 points")
                if t.shape != p.shape:
                    raise Invalid(path + ("geometry", "slopes"), f"{len(t)} slopes for {len(p)} points",
                                  "one slope per point")
                if np.any(np.linalg.norm(t, axis=1) == 0.0):
                    raise Invalid(path + ("geometry", "slopes"), "a slope is the zero vector", "non-zero vectors")
                if np.any(np.linalg.norm(np.diff(p, axis=0), axis=1) == 0.0):
                    raise Invalid(path + ("geometry", "points"), "two consecutive points coincide",
                                  "distinct consecutive points")
                if b.elements is not None and b.elements != len(p) - 1:
                    raise Invalid(path + ("elements",), f"{b.elements} elements for {len(p)} points",
                                  f"{len(p) - 1} (one element per interval) or no key")
            else:
                if b.elements is None:
                    raise Invalid(path + ("elements",), "missing required key", "an integer 1 .. 2000")
                if isinstance(g, S.Straight) and g.direction == (0.0, 0.0):
                    raise Invalid(path + ("geometry", "direction"), "the zero vector", "a non-zero [x, y]")
                if isinstance(g, S.Arc) and g.end_angle == g.start_angle:
                    raise Invalid(path + ("geometry", "end_angle"), "equal to start_angle",
                                  "an angle different from start_angle [rad]")
            self.elements[name] = element_count(b)
            self.lengths[name] = reference_length(g, self.elements[name])
            for i, pm in enumerate(b.masses):
                self.arc_length(path + ("masses", i, "s"), name, pm.s)
            self.section(path + ("section",), b.section)
            self.laws(path, b)
            if b.formulation.curvature == "small_strain" and not isinstance(g, S.Straight):
                raise Invalid(path + ("formulation", "curvature"),
                              "small_strain (Eq. 17) needs a straight reference geometry",
                              '"exact" or "material" for a curved beam')
            self.initial(path + ("initial",), name, b)

    def laws(self, path, b: S.BeamSpec):
        from ..element.laws import Tabulated
        for key in ("axial_law", "bending_law"):
            law = getattr(b, key)
            if law is None:
                continue
            if key == "bending_law" and b.formulation.curvature == "small_strain":
                raise Invalid(path + (key,), "a bending law needs the exact or material curvature",
                              'formulation.curvature = "exact" or "material", or no bending_law')
            if law.type == "tabulated":
                table = np.asarray(law.table, float)
                try:
                    Tabulated(table[:, 0], table[:, 1])
                except ModelError as err:
                    raise Invalid(path + (key, "table"), str(err).removeprefix("tabulated law: "),
                                  "at least 2 rows [strain, force], both increasing, through [0, 0]") from None

    def section(self, path, sec: S.SectionSpec):
        self.exclusive(path, sec, ("mass_per_length", "density", "mass"), required=True)
        stiff = [k for k in ("EA", "EI") if getattr(sec, k) is not None]
        geometric = [k for k in ("A", "I", "diameter") if getattr(sec, k) is not None]
        if stiff and geometric:
            raise Invalid(path + (geometric[0],), f"{geometric[0]} cannot be given together with "
                          f"{stiff[0]}", "either E with A and I (or diameter), or EA and EI")
        if stiff:
            if len(stiff) == 1:
                other = "EI" if stiff[0] == "EA" else "EA"
                raise Invalid(path + (other,), f"missing required key (given {stiff[0]})",
                              "EA [N] and EI [N·m²], both > 0")
            if sec.density is not None:
                raise Invalid(path + ("density",), "density needs the area A (the section is given "
                              "by EA and EI)", "mass_per_length or mass")
            return
        if sec.E is None:
            raise Invalid(path + ("E",), "missing required key: give E with A and I (or diameter), "
                          "or EA and EI", "a number > 0 [Pa]")
        for k in ("A", "I"):
            if getattr(sec, k) is None and sec.diameter is None:
                raise Invalid(path + (k,), "missing required key (no diameter given)",
                              "a number > 0 [m²]" if k == "A" else "a number > 0 [m⁴]")

    def initial(self, path, name, b: S.BeamSpec):
        ini, n = b.initial, self.elements[name]
        if ini.shape == "catenary":
            if ini.end is None:
                raise Invalid(path + ("end",), "missing required key for shape = catenary", "[x, y] [m]")
            start = ini.start if ini.start is not None else first_node(b)
            dx, dy = ini.end[0] - start[0], ini.end[1] - start[1]
            if dx <= 0.0:
                raise Invalid(path + ("end",), "the catenary's end must lie to the right of its start",
                              f"[x, y] with x > {start[0]:g} [m]")
            if np.hypot(dx, dy) >= self.lengths[name] * (1 - 1e-12):
                raise Invalid(path + ("end",), f"the chord {np.hypot(dx, dy):g} m is not shorter than "
                              f"the beam ({self.lengths[name]:g} m)", "an end closer to the start than L")
        for key in ("start", "end", "nodes"):
            if key == "nodes" and ini.shape == "nodes":
                continue
            if key in ("start", "end") and ini.shape == "catenary":
                continue
            if getattr(ini, key) is not None:
                raise Invalid(path + (key,), f"key {key} does not go with shape = {ini.shape}",
                              "start and end with catenary, nodes with nodes")
        if ini.shape == "nodes":
            if ini.nodes is None:
                raise Invalid(path + ("nodes",), "missing required key for shape = nodes",
                              f"{n + 1} rows [r_x, r_y, r_x', r_y']")
            if len(ini.nodes) != n + 1:
                raise Invalid(path + ("nodes",), f"{len(ini.nodes)} rows for {n} elements",
                              f"{n + 1} rows [r_x, r_y, r_x', r_y']")
        if ini.velocities is not None:
            if ini.velocity != (0.0, 0.0):
                raise Invalid(path + ("velocities",), "velocities cannot be given together with velocity",
                              "one of velocity, velocities")
            if len(ini.velocities) != n + 1:
                raise Invalid(path + ("velocities",), f"{len(ini.velocities)} rows for {n} elements",
                              f"{n + 1} rows")

    def bodies(self):
        for name, b in self.spec.bodies.items():
            path = ("bodies", name)
            self.exclusive(path, b, ("position", "at"))
            if b.point_mass:
                for k, unset in (("inertia", None), ("angle", 0.0), ("angular_velocity", None), ("points", {})):
                    if getattr(b, k) != unset:
                        raise Invalid(path + (k,), f"{k} does not go with point_mass = true",
                                      "mass, position or at, velocity, gravity")
            elif b.inertia is None:
                raise Invalid(path + ("inertia",), "missing required key", "a number > 0 [kg·m²] "
                              "(or point_mass = true)")
            if b.at is not None:
                self.point(path + ("at",), b.at, before_body=name)

    def joints(self):
        for name, j in self.spec.joints.items():
            path = ("joints", name)
            if j.type == "clamp":
                self.beam(path + ("beam",), j.beam)
                self.node_index(path + ("node",), j.beam, j.node)
            elif j.type in ("pin", "fixed", "prescribed_point"):
                self.point(path + ("point",), j.point)
            elif j.type == "revolute":
                self.point(path + ("a",), j.a)
                self.point(path + ("b",), j.b)
            elif j.type == "coordinate":
                self.coordinate(path, j)
            if j.type in ("fixed", "sliding", "prescribed_body"):
                self.body(path + ("body",), j.body)
            if j.type == "fixed":
                self.rotating(path + ("body",), j.body, "a fixed joint")
                self.no_hidden_arm(path, name, j)
            if j.type == "prescribed_body" and j.coordinate == "theta":
                self.rotating(path + ("body",), j.body, "a prescribed theta")
            if j.type == "sliding" and any(j.local):
                self.rotating(path + ("local",), j.body, "a sliding point away from the centre")
            if j.type == "sliding":
                self.beam(path + ("beam",), j.beam)
                self.arc_length(path + ("s",), j.beam, j.s, "initial arc length s =")
                d = j.drive
                if d is not None:
                    given = [k for k in ("position", "force", "speed") if getattr(d, k) is not None]
                    if len(given) != 1:
                        raise Invalid(path + ("drive",), f"{len(given)} of position, force, speed given"
                                      + (f" ({', '.join(given)})" if given else ""),
                                      "exactly one of position, force, speed")
                    for k in ("gain", "max_force"):
                        if (getattr(d, k) is None) == (given[0] == "speed"):
                            raise Invalid(path + ("drive", k), "missing for a speed servo" if given[0] == "speed"
                                          else f"only a speed servo takes it (this drive gives {given[0]})",
                                          "a number > 0 with speed, else no key")
                    if d.time_function is not None and given[0] != "force":
                        raise Invalid(path + ("drive", "time_function"),
                                      f"only a force drive takes it (this drive gives {given[0]})",
                                      "no key, or force = F")

    def no_hidden_arm(self, path, name, j: S.FixedSpec):
        """Without ``local``, a fixed joint's body must start at the joint's point: a body
        placed elsewhere would be welded on through an invisible rigid arm."""
        if j.local is not None:
            return
        at = self.initial_position(j.point)
        centre = self.initial_position(S.PointRef(body=j.body))
        if at is None or centre is None:
            return  # the build checks it
        d = float(np.linalg.norm(at - centre))
        if d > coincide_tolerance(max(float(np.max(np.abs(at))), float(np.max(np.abs(centre))))):
            raise Invalid(path + ("local",), f'missing: body "{j.body}" starts {d:.4g} m from the point the joint '
                          f"holds ({at[0]:g}, {at[1]:g}) m, and without local it would be welded on through an "
                          "invisible rigid arm", "local = [x, y], the body point at the joint in the body frame, "
                          "for an intended arm; or the body placed at the point")

    def rotating(self, path, body, what):
        if body in self.made_bodies:
            raise Invalid(path, f'"{body}" is a point mass of {self.made_bodies[body]} (translation only): '
                          f"{what} needs a rotation", "a rigid body with an inertia")
        if self.spec.bodies[body].point_mass:
            raise Invalid(path, f'"{body}" is a point mass (translation only): {what} needs a rotation',
                          "a rigid body with an inertia")

    def coordinate(self, path, j: S.CoordinateSpec):
        p = j.point
        node = p.beam is not None and p.node is not None and p.body is None and p.ground is None
        body = p.body is not None and p.local is None and p.point is None and p.beam is None and p.ground is None
        if not (node or body):
            raise Invalid(path + ("point",), "not a beam node or a body's centre",
                          '{ beam = "a", node = i } or { body = "b" }')
        self.point(path + ("point",), p)
        allowed = ("x", "y", "slope_x", "slope_y") if node else ("x", "y", "theta")
        if j.component not in allowed:
            raise Invalid(path + ("component",), f'"{j.component}" is not a coordinate of a '
                          f'{"beam node" if node else "body"}', ", ".join(allowed))
        self.exclusive(path, j, ("value", "function"))
        if body and j.component == "theta":
            self.rotating(path + ("point", "body"), p.body, "a constrained theta")

    def loads(self):
        for name, f in self.spec.loads.items():
            path = ("loads", name)
            if f.type == "point_force":
                self.point(path + ("point",), f.point)
            elif f.type == "torque":
                self.body(path + ("body",), f.body)
                self.rotating(path + ("body",), f.body, "a torque")
            elif f.type == "mass_proportional":
                items = [*self.spec.beams, *self.spec.bodies, *self.made_bodies]
                if f.item not in items:
                    raise Invalid(path + ("item",), f'"{f.item}" is no beam or body',
                                  f"the name of a beam or body: {_names(items)}")
            elif f.type == "moving_force":
                self.beam(path + ("beam",), f.beam)
                if f.along == "x":
                    self.monotonic(path + ("along",), f.beam)
            elif f.type == "contact":
                self.point(path + ("point",), f.point)
                self.beam(path + ("beam",), f.beam)
                if f.point.beam == f.beam:
                    raise Invalid(path + ("point",), f'a point of beam "{f.beam}" cannot contact that beam',
                                  "a body point, a ground point or a point of another beam")
                self.monotonic(path + ("beam",), f.beam, "a contact (its search starts under the point's x)",
                               "a beam running left to right or right to left (a track, rope or wire)")
            else:
                self.point(path + ("a",), f.a)
                self.point(path + ("b",), f.b)
                if f.type == "spring_damper":
                    self.apart(path, f.a, f.b)

    def monotonic(self, path, beam, needs='along = "x"',
                  accepted='"arc_length", or a beam running left to right or right to left (a track, rope or wire)'):
        """along = "x" (and a contact) needs a beam whose initial x is strictly
        monotonic along it."""
        x = self.initial_x(beam)
        dx = np.diff(x)
        if not (np.all(dx > 0.0) or np.all(dx < 0.0)):
            raise Invalid(path, f'{needs} needs a beam whose x is monotonic along it; the nodes of '
                          f'beam "{beam}" are at x = {", ".join(f"{v:g}" for v in x[:8])}'
                          + (", ..." if len(x) > 8 else ""), accepted)

    def initial_x(self, beam) -> np.ndarray:
        """x [m] of the nodes of a beam's initial shape (a catenary: its ends)."""
        return initial_node_positions(self.spec.beams[beam], self.elements[beam], self.lengths[beam])[:, 0]

    def moving_masses(self):
        """Each moving mass on its beam at every output time (along x: inside the x
        range of the beam's initial shape)."""
        times = self.output_times()
        for name, mm in self.spec.moving_masses.items():
            path = ("moving_masses", name)
            self.beam(path + ("beam",), mm.beam)
            self.profile(path, mm, times)
            p = path_values(mm, times)
            if mm.along == "arc_length":
                lo, hi, what = 0.0, self.lengths[mm.beam], "arc length"
            else:
                self.monotonic(path + ("along",), mm.beam)
                x = self.initial_x(mm.beam)
                lo, hi, what = float(x.min()), float(x.max()), "x"
            tol = 1e-12 * max(1.0, abs(lo), abs(hi))
            off = (p < lo - tol) | (p > hi + tol)
            if np.any(off):
                i = int(np.argmax(off))
                key = "start" if i == 0 else ("speed" if mm.profile is None else "profile")
                raise Invalid(path + (key,), f'the mass is off beam "{mm.beam}" at t = {times[i]:g} s '
                              f"({what} {p[i]:g} m)", f"a path with {what} in {lo:g} .. {hi:g} [m] at every "
                              f"output time 0 .. {self.run_end():g} s")

    def chains(self):
        for name, c in self.spec.chains.items():
            path = ("chains", name)
            h = np.asarray(c.heights)
            n = len(h)
            if np.any(np.diff(np.concatenate([[0.0], h])) <= 0.0):
                raise Invalid(path + ("heights",), f"not positive and increasing: {list(c.heights)}",
                              "an array of heights > 0 [m] above the base, increasing")
            for key, unit, strict in (("masses", "kg", True), ("stiffness", "N/m", False),
                                      ("damping", "N·s/m", False), ("forces", "N", None)):
                values = getattr(c, key)
                if values is None:
                    continue
                if len(values) != n:
                    raise Invalid(path + (key,), f"{len(values)} value{'s' if len(values) != 1 else ''} for {n} heights",
                                  f"{n} numbers [{unit}], one per mass")
                for i, v in enumerate(values):
                    if strict is not None and (v <= 0.0 if strict else v < 0.0):
                        raise Invalid(path + (key, i), f"must be {'>' if strict else '>='} 0, got {v:g}",
                                      f"a number {'>' if strict else '>='} 0 [{unit}]")
            if c.speed is None and c.profile is None and c.start is not None:
                raise Invalid(path + ("start",), "start needs speed or profile (without them the masses' x "
                              "is held at the base's x)", "no key, or start with speed or profile")
            self.profile(path, c, self.output_times())

    def profile(self, path, item, times):
        """A path's profile finite at the output times (tables and constants always are)."""
        if item.profile is not None and item.profile.kind == "expression":
            values = host_values(item.profile, times)
            bad = ~np.isfinite(values)
            if np.any(bad):
                i = int(np.argmax(bad))
                raise Invalid(path + ("profile",), f"{item.profile.text!r} is not finite at t = {times[i]:g} s "
                              f"(value {values[i]})", "a time function finite at every output time "
                              f"0 .. {self.run_end():g} s [m]")

    def solver(self):
        sol = self.spec.solver
        out = self.spec.outputs.dt
        if out is not None and out < sol.dt * (1 - 1e-9):
            raise Invalid(("outputs", "dt"), f"{out:g} s is shorter than solver.dt = {sol.dt:g} s",
                          f"a number >= {sol.dt:g} [s]")
        end = self.run_end()
        if out is not None and out > end * (1 + 1e-9):
            what = "solver.t_end" if end == sol.t_end else "the pantograph's run time"
            raise Invalid(("outputs", "dt"), f"{out:g} s is longer than the run, {what} = {end:g} s",
                          f"a number in {sol.dt:g} .. {end:g} [s]")

    def run_end(self) -> float:
        """End time [s] of the run (:func:`~.build.run_end`: a pantograph run ends
        before ``solver.t_end``); the catenary checks come first."""
        from .build import run_end
        return run_end(self.spec)

    def _time_grid(self):
        """:func:`ancf_jax.simulation.time_grid` of the run (an output interval shorter
        than the step, refused by :meth:`solver`, taken as the step here)."""
        sol, out = self.spec.solver, self.spec.outputs.dt
        return time_grid(self.run_end(), sol.dt, None if out is None else max(out, sol.dt))

    def output_times(self) -> np.ndarray:
        """The run's output times [s] (t = 0, every outputs.dt, t_end), as
        :func:`ancf_jax.simulation.time_grid` places them; at most
        :data:`MAX_CHECKED_TIMES` of them (evenly spread) on a longer grid."""
        n, _, _, out_dt = self._time_grid()
        if n + 1 > MAX_CHECKED_TIMES:
            return np.linspace(0.0, self.run_end(), MAX_CHECKED_TIMES)
        return out_dt * np.arange(n + 1)

    def step_times(self) -> np.ndarray:
        """The times [s] of the run's fixed steps (every h <= solver.dt between output
        times), as :func:`ancf_jax.simulation.time_grid` places them; at most
        :data:`MAX_CHECKED_STEPS` of them (evenly spread) on a longer grid."""
        n, sub, h, _ = self._time_grid()
        steps = n * sub
        if steps + 1 > MAX_CHECKED_STEPS:
            return np.linspace(0.0, self.run_end(), MAX_CHECKED_STEPS)
        return h * np.arange(steps + 1)

    def time_functions(self):
        """Every expression finite at the time steps, the output times and statics.time
        (a step between output times is where the solver evaluates it too: 1/(t − 0.005)
        with outputs every 0.01 s and steps of 0.001 s is infinite at the fifth step)."""
        times = np.unique(np.concatenate([self.step_times(), self.output_times(), [self.spec.statics.time]]))
        for group in ("moving_masses", "chains", "joints", "loads"):
            for name, item in getattr(self.spec, group).items():
                nested = getattr(item, "drive", None)
                fields = [(key, getattr(item, key)) for key in type(item).model_fields]
                if nested is not None:
                    fields += [(f"drive.{key}", getattr(nested, key)) for key in type(nested).model_fields]
                for key, f in fields:
                    if not isinstance(f, TimeFunctionSpec) or f.kind != "expression":
                        continue
                    values = f.function.numpy(times)
                    bad = ~np.isfinite(values)
                    if np.any(bad):
                        i = int(np.argmax(bad))
                        raise Invalid((group, name, key), f"{f.text!r} is not finite at t = {times[i]:g} s "
                                      f"(value {values[i]})", "a time function finite at every time step "
                                      f"and output time 0 .. {self.run_end():g} s and at statics.time [s]")

    def outputs(self):
        for name, o in self.spec.outputs.columns.items():
            path = ("outputs", "columns", name)
            if o.type in ("node", "point", "stress", "axial", "bending"):
                self.beam(path + ("beam",), o.beam)
            if o.type == "stress":
                sec = self.spec.beams[o.beam].section
                if sec.EA is not None and sec.E is None:
                    raise Invalid(path, f'a stress needs Young\'s modulus: beam "{o.beam}" has EA and EI only',
                                  f"key E in beams.{o.beam}.section (or no stress output)")
            if o.type == "node":
                self.node_index(path + ("node",), o.beam, o.node)
            elif o.type in ("point", "axial", "bending"):
                self.arc_length(path + ("s",), o.beam, o.s)
            elif o.type == "body":
                self.body(path + ("body",), o.body)
                self.exclusive(path, o, ("local", "point"))
                if o.point is not None:
                    self.body_point(path + ("point",), o.body, o.point)
                if (o.local is not None or o.point is not None) and o.component == "theta":
                    raise Invalid(path + ("component",), "theta is the body's angle, not a point's",
                                  '"x" or "y" with local or point')
            elif o.type in ("sliding", "sliding_point"):
                self.joint(path + ("joint",), o.joint, ("sliding",))
            elif o.type == "stress":
                self.exclusive(path, o, ("s", "element"), required=True)
                if o.s is not None:
                    self.arc_length(path + ("s",), o.beam, o.s)
                elif o.element >= self.elements[o.beam]:
                    n = self.elements[o.beam]
                    raise Invalid(path + ("element",), f'element {o.element} is outside beam "{o.beam}"',
                                  f"an integer 0 .. {n - 1}")
            elif o.type == "reaction":
                self.joint(path + ("joint",), o.joint)
                self.exclusive(path, o, ("component", "index"), required=True)
                kind = self.joint_type(o.joint)
                if o.component in ("normal", "tangential") and kind != "sliding":
                    raise Invalid(path + ("component",), f'normal and tangential need a sliding joint, '
                                  f'"{o.joint}" is a {kind} joint', "fx, fy, or index = 0 .. equations − 1")
                if o.component in ("fx", "fy") and kind not in POINT_JOINTS:
                    raise Invalid(path + ("component",), f'fx and fy need a joint that holds a point, '
                                  f'"{o.joint}" is a {kind} joint', "index = 0 .. equations − 1")
                j = self.spec.joints.get(o.joint)
                size = (4 if j.mode == "full" else 3) if kind == "clamp" else JOINT_SIZE[kind]
                if o.index is not None and o.index >= size:
                    raise Invalid(path + ("index",), f'joint "{o.joint}" has {size} equations',
                                  f"an integer 0 .. {size - 1}")

            elif o.type == "drive" and o.joint is None:
                self.exclusive(path, o, ("joint", "moving_mass"), required=True)
                if o.moving_mass not in self.spec.moving_masses:
                    raise Invalid(path + ("moving_mass",), f'"{o.moving_mass}" is not a moving mass',
                                  f"the name of a moving mass: {_names(self.spec.moving_masses)}")
            elif o.type in ("friction", "drive"):
                if o.type == "drive":
                    self.exclusive(path, o, ("joint", "moving_mass"))
                self.joint(path + ("joint",), o.joint, ("sliding",))
                if o.type == "drive" and o.joint in self.made_sliders:
                    mass = self.made_sliders[o.joint]
                    raise Invalid(path + ("joint",), f'sliding joint "{o.joint}" is moving mass "{mass}"\'s: '
                                  f'its drive is named by moving_mass = "{mass}"',
                                  "a sliding joint with a drive table, or moving_mass = NAME")
                if o.joint in self.made_sliders or getattr(self.spec.joints[o.joint], o.type) is None:
                    raise Invalid(path + ("joint",), f'sliding joint "{o.joint}" has no {o.type}',
                                  f"a sliding joint with a {o.type} table")
            elif o.type in LOAD_OUTPUTS:
                kind = LOAD_OUTPUTS[o.type]
                f = self.spec.loads.get(o.load)
                if f is None or f.type != kind:
                    known = ", ".join(f'"{n}"' for n, l in self.spec.loads.items() if l.type == kind) or "none"
                    raise Invalid(path + ("load",), f'"{o.load}" is not a {kind} of [loads]',
                                  f"the name of a {kind} load: {known}")

    def fatigue(self):
        f = self.spec.fatigue
        if f.mean_stress != "none" and f.ultimate_strength is None:
            raise Invalid(("fatigue", "ultimate_strength"), f"mean_stress = {f.mean_stress} needs it",
                          "a number > 0 [Pa]")
        for name, c in f.concentrations.items():
            path = ("fatigue", "concentrations", name)
            self.beam(path + ("beam",), c.beam)
            self.arc_length(path + ("s_min",), c.beam, c.s_min)
            self.arc_length(path + ("s_max",), c.beam, c.s_max)
            if c.s_max < c.s_min:
                raise Invalid(path + ("s_max",), f"{c.s_max:g} m is below s_min = {c.s_min:g} m",
                              f"a number >= {c.s_min:g} [m]")
        for name, p in f.points.items():
            path = ("fatigue", "points", name)
            self.beam(path + ("beam",), p.beam)
            self.arc_length(path + ("s",), p.beam, p.s)

    def catenary(self):
        """The catenary and pantograph tables: consistent with each other and with the
        builder's own checks (dropper positions, one value per pantograph mass)."""
        from ..errors import ModelError
        cat, pan = self.spec.catenary, self.spec.pantograph
        if pan is not None and cat is None:
            raise Invalid(("pantograph",), "a pantograph needs a catenary table", "a [catenary] table")
        if cat is None:
            return
        if self.spec.initial.mode != "static":
            raise Invalid(("initial", "mode"), f'"{self.spec.initial.mode}" with a catenary',
                          '"static" (a catenary starts in its static equilibrium)')
        clash = {"catenary.contact", "catenary.messenger"} & set(self.spec.beams)
        if clash:
            raise Invalid(("beams", sorted(clash)[0]), "the catenary makes this beam", "another name")
        try:
            design = cat.design()
            design.check()
        except ModelError as e:
            raise Invalid(("catenary",), str(e).removeprefix("catenary "), "see docs/pantograph-catenary.md") from None
        if pan is None:
            return
        try:
            pan.design().check()
        except ModelError as e:
            raise Invalid(("pantograph",), str(e).removeprefix("pantograph "), "see docs/pantograph-catenary.md") \
                from None
        if pan.start is not None and not pan.start < design.length:
            raise Invalid(("pantograph", "start"), f"{pan.start:g} m is past the line's end {design.length:g} m",
                          f"a position in (0, {design.length:g}) m")
        if pan.spans is not None and not (len(pan.spans) == 2 and 1 <= pan.spans[0] <= pan.spans[1] <= design.spans):
            raise Invalid(("pantograph", "spans"), f"{list(pan.spans)}",
                          f"[first, last] with 1 <= first <= last <= {design.spans}")
        if pan.trailing is not None:
            from ..models.catenary import check_trailing
            try:
                check_trailing(pan.trailing)
            except ModelError:
                raise Invalid(("pantograph", "trailing"), f"{list(pan.trailing)}",
                              "increasing distances > 0 m behind the leading pantograph") from None
        from .build import pantograph_run_time, pantograph_start
        if not pantograph_start(self.spec) < design.length:
            raise Invalid(("pantograph", "trailing"), f"{list(pan.trailing)} puts the leading pantograph past "
                          f"the line's end {design.length:g} m",
                          f"distances below {design.length - 0.1 * design.droppers[0]:g} m (or a start)")
        try:
            pantograph_run_time(self.spec)
        except ModelError as e:
            raise Invalid(("pantograph", "start"), str(e), "a start that keeps every pantograph on the line or "
                          "off it for the whole run") from None

    def run(self):
        self.names()
        self.catenary()
        self.beams()
        self.bodies()
        self.moving_masses()
        self.chains()
        self.joints()
        self.loads()
        self.solver()
        self.time_functions()
        self.outputs()
        self.fatigue()


def check(spec: S.ScenarioSpec) -> Checker:
    """Run every check (see module docstring); returns the checker with beam lengths
    and element counts. Raises :class:`~.errors.Invalid` on the first problem."""
    c = Checker(spec)
    c.run()
    return c
