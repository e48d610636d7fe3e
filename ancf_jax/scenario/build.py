"""From a checked scenario to the builder: :func:`make_model` and :func:`make_outputs`.

Every name has been resolved by :mod:`~.checks`; here the tables become
:class:`~ancf_jax.model.Model` calls in file order (beams, bodies, moving masses,
chains, joints, loads), so the assembled system lists its constraints in the order of
the file.
"""

from __future__ import annotations

import dataclasses
import math

import jax.numpy as jnp
import numpy as np

from .. import mesh as _mesh
from ..beam import Beam
from ..element import laws
from ..element.strain_energy import Formulation
from ..errors import ModelError
from ..functions import ConstantSpeed
from ..model import Model, beam_point, body_point, ground, node
from ..outputs import DERIVATIVES, Output
from ..section import Section
from . import schema as S
from .errors import ScenarioError
from .geometry import first_node, make_mesh


@dataclasses.dataclass(frozen=True)
class PointPath:
    """t ↦ (x(t), y(t)) [m] of a prescribed point (hashable: equal specs, equal systems)."""

    x: object
    y: object

    def __call__(self, t):
        return jnp.stack([jnp.asarray(self.x(t), float), jnp.asarray(self.y(t), float)])


def path_of(item) -> ConstantSpeed:
    """The :class:`~ancf_jax.functions.ConstantSpeed` path start + speed·t + profile(t)
    [m] of a moving force, moving mass or chain (start and speed are data: a run is
    differentiable with respect to them; the profile is a checked time function)."""
    return ConstantSpeed(item.start, item.speed, item.profile)


def local_of(spec: S.ScenarioSpec, ref: S.PointRef) -> tuple[float, float]:
    """Body-frame coordinates [m] of a body point reference."""
    if ref.point is not None:
        return spec.bodies[ref.body].points[ref.point]
    return ref.local if ref.local is not None else (0.0, 0.0)


def point_ref(spec: S.ScenarioSpec, lengths: dict[str, float], ref: S.PointRef):
    """The builder's point reference for a scenario point (arc lengths limited to the
    mesh length ``lengths[beam]``, see :func:`on_beam`)."""
    if ref.ground is not None:
        return ground(*ref.ground)
    if ref.body is not None:
        return body_point(ref.body, local_of(spec, ref))
    if ref.node is not None:
        return node(ref.beam, ref.node)
    return beam_point(ref.beam, on_beam(ref.s, lengths[ref.beam]))


def on_beam(s: float, length: float) -> float:
    """``s`` limited to the mesh length: the checks accept s up to L (1 + 1e-12), and
    the sum of a straight beam's element lengths L/n may fall an ulp short of L."""
    return min(float(s), length)


def section_of(beam: S.BeamSpec, length: float) -> Section:
    """The beam's :class:`Section` (from E, A, I or from EA, EI); ρA from
    mass_per_length, density·A or mass/L."""
    sec = beam.section
    if sec.EA is not None:
        mpl = sec.mass_per_length if sec.mass_per_length is not None else sec.mass / length
        return Section.from_stiffness(sec.EA, sec.EI, mpl, fibre_distance=sec.fibre,
                                      youngs_modulus=sec.E)
    d = sec.diameter
    area = sec.A if sec.A is not None else math.pi * d * d / 4.0
    inertia = sec.I if sec.I is not None else math.pi * d**4 / 64.0
    if sec.mass_per_length is not None:
        mpl = sec.mass_per_length
    elif sec.density is not None:
        mpl = sec.density * area
    else:
        mpl = sec.mass / length
    fibre = sec.fibre if sec.fibre is not None else (d / 2.0 if d is not None else None)
    return Section(sec.E, area, inertia, mpl, fibre_distance=fibre)


def law_of(spec):
    """The :mod:`ancf_jax.element.laws` law of a law table (None: none given)."""
    if spec is None:
        return None
    if spec.type == "linear":
        return laws.LinearElastic()
    if spec.type == "strain_rate_damped":
        return laws.StrainRateDamped(spec.damping, spec.rest)
    if spec.type == "bilinear":
        return laws.Bilinear(spec.tension, spec.compression)
    table = np.asarray(spec.table, float)
    return laws.Tabulated(table[:, 0], table[:, 1])


def nominal_length(beam: S.BeamSpec, mesh: _mesh.BeamMesh) -> float:
    """L [m]: the given length of a straight beam, else the sum of element lengths."""
    if isinstance(beam.geometry, S.Straight):
        return float(beam.geometry.length)
    return float(np.sum(np.asarray(mesh.element_lengths)))


def initial_nodes(beam: S.BeamSpec, mesh: _mesh.BeamMesh, length: float):
    """(initial nodal coordinates or None, initial nodal velocities or None)."""
    ini = beam.initial
    n = int(mesh.n_elements)
    nodes = None
    if ini.shape == "catenary":
        start = ini.start if ini.start is not None else first_node(beam)
        nodes = _mesh.catenary_nodes(start, ini.end, length, n)
    elif ini.shape == "nodes":
        nodes = np.asarray(ini.nodes, float)
    vel = None
    if ini.velocities is not None:
        vel = np.asarray(ini.velocities, float)
    elif ini.velocity != (0.0, 0.0):
        vel = np.zeros((n + 1, 4))
        vel[:, :2] = ini.velocity
    return nodes, vel


def pantograph_start(spec: S.ScenarioSpec) -> float:
    """x of the (leading) pantograph at t = 0 [m]: ``pantograph.start`` or
    :func:`~ancf_jax.models.catenary.default_start` (the last pantograph at a tenth of
    the first dropper's distance from the first pole)."""
    from ..models.catenary import default_start
    p = spec.pantograph
    return default_start(spec.catenary.design(), p.trailing or ()) if p.start is None else float(p.start)


def pantograph_run_time(spec: S.ScenarioSpec) -> float:
    """Duration [s] of a pantograph run (:func:`~ancf_jax.models.catenary.pantograph_run_time`:
    the last pantograph one span, at least 3 / cutoff seconds of travel, past the
    evaluated spans, or the leading one half the first dropper distance before the
    line's end)."""
    from ..models.catenary import pantograph_run_time as run_time
    p = spec.pantograph
    return run_time(spec.catenary.design(), start=pantograph_start(spec), speed=p.speed_kmh / 3.6,
                    trailing=p.trailing or (), spans=p.spans, cutoff=p.cutoff, t_end=spec.solver.t_end)


def run_end(spec: S.ScenarioSpec) -> float:
    """End time [s] of the scenario's run: ``solver.t_end``, or for a pantograph run
    the earlier :func:`pantograph_run_time` (the run that :class:`~.scenario.Scenario`
    makes and the time grid that the checks evaluate the time functions on)."""
    return spec.solver.t_end if spec.pantograph is None else pantograph_run_time(spec)


def make_model(spec: S.ScenarioSpec, file: str = "") -> Model:
    """The :class:`Model` of a checked scenario (host work plus small eager JAX ops
    to place bodies on beams; nothing is compiled for the system)."""
    m = Model(gravity=spec.gravity)
    shapes: dict[str, tuple[Beam, np.ndarray]] = {}
    lengths: dict[str, float] = {}  # as the builder measures them
    for name, b in spec.beams.items():
        with _located(file, ("beams", name)):
            mesh = make_mesh(b)
            lengths[name] = float(np.asarray(mesh.element_lengths)[: int(mesh.n_elements)].sum())
            length = nominal_length(b, mesh)
            section = section_of(b, length)
            f = b.formulation
            formulation = Formulation(axial_strain=f.axial_strain, curvature=f.curvature,
                                      axial_quadrature=tuple(f.axial_quadrature),
                                      bending_quadrature=tuple(f.bending_quadrature), metric=f.metric)
            nodes, vel = initial_nodes(b, mesh, length)
            m.add_beam(name, mesh, section, alpha=b.alpha, beta=b.beta, formulation=formulation,
                       initial_nodes=nodes, initial_velocities=vel, gravity=b.gravity,
                       axial_law=law_of(b.axial_law), bending_law=law_of(b.bending_law))
            shapes[name] = (Beam(mesh, section), np.asarray(mesh.reference_nodes) if nodes is None else nodes)
            for i, pm in enumerate(b.masses):
                m.attached_mass(f"{name}.masses[{i}]", name, on_beam(pm.s, lengths[name]), pm.mass)

    poses: dict[str, tuple[float, float, float]] = {}
    for name, b in spec.bodies.items():
        with _located(file, ("bodies", name)):
            if b.at is not None:
                position = _initial_position(spec, b.at, shapes, poses, lengths)
            else:
                position = b.position if b.position is not None else (0.0, 0.0)
            poses[name] = (position[0], position[1], b.angle)
            if b.point_mass:
                m.add_point_mass(name, mass=b.mass, position=position, velocity=b.velocity,
                                 gravity=b.gravity)
            else:
                m.add_body(name, mass=b.mass, inertia=b.inertia, position=position, angle=b.angle,
                           velocity=b.velocity, angular_velocity=b.angular_velocity, gravity=b.gravity)

    for name, mm in spec.moving_masses.items():
        with _located(file, ("moving_masses", name)):
            m.moving_mass(name, mm.beam, mass=mm.mass, path=path_of(mm), along=mm.along, gravity=mm.gravity)

    for name, c in spec.chains.items():
        with _located(file, ("chains", name)):
            path = None  # x held at the base's x
            if c.speed is not None or c.profile is not None:
                path = ConstantSpeed(c.base[0] if c.start is None else c.start,
                                     0.0 if c.speed is None else c.speed, c.profile)
            m.lumped_chain(name, base=c.base, heights=c.heights, masses=c.masses, stiffness=c.stiffness,
                           damping=c.damping, forces=c.forces, path=path, gravity=c.gravity)

    if spec.catenary is not None:
        from ..models.catenary import add_catenary, add_pantograph, pantograph_name
        with _located(file, ("catenary",)):
            names = add_catenary(m, spec.catenary.design())
        if spec.pantograph is not None:
            p = spec.pantograph
            with _located(file, ("pantograph",)):
                x0 = pantograph_start(spec)
                for k, d in enumerate((0.0,) + tuple(p.trailing or ())):
                    add_pantograph(m, names, p.design(), start=x0 - d, speed=p.speed_kmh / 3.6,
                                   name=pantograph_name(k + 1))

    for name, j in spec.joints.items():
        with _located(file, ("joints", name)):
            if j.type == "clamp":
                m.clamp(name, j.beam, j.node, mode=j.mode)
            elif j.type == "pin":
                m.pin(name, point_ref(spec, lengths, j.point), j.location)
            elif j.type == "revolute":
                m.revolute(name, point_ref(spec, lengths, j.a), point_ref(spec, lengths, j.b))
            elif j.type == "fixed":
                m.fixed(name, point_ref(spec, lengths, j.point), j.body, j.local)
            elif j.type == "sliding":
                m.slider(name, j.body, j.beam, on_beam(j.s, lengths[j.beam]), local=j.local, hold=j.hold,
                         rate=j.rate)
                if j.friction is not None:
                    f = j.friction
                    m.slider_friction(f"{name}.friction", name, mu=f.mu, regularization=f.regularization,
                                      viscous=f.viscous)
                if j.drive is not None:
                    d = j.drive
                    m.slider_drive(f"{name}.drive", name, position=d.position, force=d.force,
                                   time_function=d.time_function, speed=d.speed, gain=d.gain,
                                   max_force=d.max_force)
            elif j.type == "coordinate":
                m.coordinate(name, point_ref(spec, lengths, j.point), j.component, value=j.value,
                             function=j.function)
            elif j.type == "prescribed_point":
                m.prescribe_point(name, point_ref(spec, lengths, j.point), PointPath(j.x, j.y))
            else:
                m.prescribe_body(name, j.body, j.coordinate, j.value)

    for name, f in spec.loads.items():
        with _located(file, ("loads", name)):
            if f.type == "point_force":
                m.point_force(name, point_ref(spec, lengths, f.point), f.force, f.time_function)
            elif f.type == "torque":
                m.torque(name, f.body, f.torque, f.time_function)
            elif f.type == "mass_proportional":
                m.mass_proportional_load(name, f.item, f.acceleration, f.time_function)
            elif f.type == "moving_force":
                m.moving_force(name, f.beam, f.force, path=path_of(f), along=f.along,
                               time_function=f.time_function)
            elif f.type == "contact":
                fr = {} if f.friction is None else dict(mu=f.friction.mu, regularization=f.friction.regularization,
                                                        viscous=f.friction.viscous)
                m.contact(name, point_ref(spec, lengths, f.point), f.beam, stiffness=f.stiffness,
                          damping=f.damping, side=f.side, offset=f.offset, **fr)
            else:
                m.spring_damper(name, point_ref(spec, lengths, f.a), point_ref(spec, lengths, f.b),
                                stiffness=f.stiffness, damping=f.damping, rest_length=f.rest_length,
                                acts=f.acts)
    return m


def _initial_position(spec, ref: S.PointRef, shapes, poses, lengths) -> tuple[float, float]:
    """Where a point is in the initial configuration (beams: their initial shape,
    evaluated with the element's cubic at the arc length; bodies: declared earlier)."""
    if ref.ground is not None:
        return ref.ground
    if ref.body is not None:
        x, y, th = poses[ref.body]
        lx, ly = local_of(spec, ref)
        c, s = math.cos(th), math.sin(th)
        return (x + (c * lx - s * ly), y + (s * lx + c * ly))
    beam, nodes = shapes[ref.beam]
    if ref.node is not None:
        return tuple(float(v) for v in nodes[ref.node, :2])
    return tuple(float(v) for v in beam.position(jnp.asarray(nodes), on_beam(ref.s, lengths[ref.beam])))


class _located:
    """Turn a builder error into a one-line ScenarioError at the entity's key path."""

    def __init__(self, file, path):
        self.file, self.path = file, path

    def __enter__(self):
        return self

    def __exit__(self, kind, err, tb):
        if err is not None and isinstance(err, ModelError) and not isinstance(err, ScenarioError):
            raise ScenarioError(self.file, self.path, str(err), "see docs/scenario-format.md") from err
        return False


def make_outputs(spec: S.ScenarioSpec) -> list[Output]:
    """The named output columns as :class:`~ancf_jax.outputs.Output` specs, in file order."""
    out = []
    for name, o in spec.outputs.columns.items():
        d = DERIVATIVES.index(o.derivative) if hasattr(o, "derivative") else 0
        if o.type == "node":
            out.append(Output(name, "node", o.beam, o.component, node=o.node, derivative=d))
        elif o.type == "point":
            out.append(Output(name, "point", o.beam, o.component, s=o.s, derivative=d))
        elif o.type == "body":
            local = None
            if o.point is not None or o.local is not None:
                local = local_of(spec, S.PointRef(body=o.body, point=o.point, local=o.local))
            out.append(Output(name, "body", o.body, o.component, local=local, derivative=d))
        elif o.type in ("sliding", "sliding_point"):
            out.append(Output(name, o.type, o.joint, o.component, derivative=d))
        elif o.type in ("axial", "bending"):
            out.append(Output(name, o.type, o.beam, o.component, s=o.s))
        elif o.type == "stress":
            out.append(Output(name, "stress", o.beam, "sigma", s=o.s, element=o.element,
                              xi=o.xi if o.element is not None else None, fibre=o.fibre,
                              measure=o.measure))
        elif o.type == "reaction":
            out.append(Output(name, "reaction", o.joint,
                              o.component if o.component is not None else str(o.index)))
        elif o.type == "drive" and o.moving_mass is not None:
            out.append(Output(name, "drive", f"{o.moving_mass}.drive", o.component))
        elif o.type in ("friction", "drive"):
            out.append(Output(name, o.type, f"{o.joint}.{o.type}", o.component))
        elif o.type in ("member", "contact", "load"):
            out.append(Output(name, o.type, o.load, o.component))
        else:
            out.append(Output(name, "energy", "", o.component))
    return out
