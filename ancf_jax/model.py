"""Model builder: named beams, bodies, joints and forces → an assembled :class:`System`.

The thin user-facing layer over the functional core. Every entity has a unique name;
joints and forces refer to entities by name and to points with :func:`ground`,
:func:`body_point`, :func:`node` and :func:`beam_point`. All input is checked when it
is added and all names are resolved in :meth:`Model.build`, before anything is traced
or compiled; :meth:`Model.build` then checks the constraint Jacobian for redundant or
conflicting joints and returns the system with a consistent initial state.

Example (model M1 in a few lines)::

    m = Model(gravity=(0.0, -9.81))
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), 0.402, 6),
               Section.circle(1e-3, 200e9, mass_per_length=0.0025 / 0.402), alpha=0.02)
    m.add_body("tip", mass=0.02, inertia=1.58e-6, position=(0.402, 0.0))
    m.clamp("support", "beam", node=0)
    m.fixed("tip_joint", node("beam", -1), body="tip")
    system, state = m.build()
"""

from __future__ import annotations

import dataclasses
import warnings
from typing import Any, Callable, Optional

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import dae
from . import joints as J
from . import points as P
from .beam import AttachedMasses, Beam
from .bodies import RigidBodies
from .element.laws import check_law
from .element.strain_energy import Formulation
from .errors import ConstraintError, ModelError, VelocityProjectionWarning
from .contact import AtArcLength, AtHorizontalPosition, ContactFriction, MovingForce, UnilateralContact
from .forces import (AbstractForceSet, BeamMassLoad, BodyMassLoad, CompressionOnlySpringDamper, DirectedSpringDamper,
                     NodeSpringSet, PointForce, PointTorque, SpeedSquaredForce,
                     SpringDamper, TensionOnlySpringDamper)
from .linalg import AbstractChainLayout, InterleavedChain, SequentialChain, within_two_blocks
from .mesh import BeamMesh, pad
from .newton import ModifiedNewton
from .section import Section
from .functions import AbstractPath, Constant, ConstantSpeed
from .sliding import DEFAULT_REGULARIZATION, SlidingDriveForce, SlidingFriction, SlidingServo
from .statics import DEFAULTS as STATIC_DEFAULTS
from .system import State, System
from .validation import (check_choice, check_finite, check_nonnegative, check_positive, coincide_tolerance,
                         check_vector)


def _flag(what: str, value) -> bool:
    """A bool option, checked (``True`` or ``False``, not 1 or "yes")."""
    if not isinstance(value, (bool, np.bool_)):
        raise ModelError(f"{what} must be True or False, got {value!r}")
    return bool(value)


# ---------------------------------------------------------------------- point references
@dataclasses.dataclass(frozen=True)
class PointRef:
    """A point named by entity: resolved to a :mod:`ancf_jax.points` object at build."""

    kind: str
    target: Optional[str]
    value: Any


def ground(x: float, y: float) -> PointRef:
    """A fixed ground point [m]."""
    return PointRef("ground", None, tuple(check_vector("ground point", (x, y), 2)))


def body_point(body: str, local=(0.0, 0.0)) -> PointRef:
    """The point ``local`` [m] (body frame) of rigid body ``body``; default its centre."""
    return PointRef("body", body, tuple(check_vector(f"local point of body {body!r}", local, 2)))


def node(beam: str, index: int) -> PointRef:
    """Node ``index`` of beam ``beam``; negative indices count from the last node (−1)."""
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
        raise ModelError(f"node index of beam {beam!r} must be an integer, got {index!r}")
    return PointRef("node", beam, int(index))


def beam_point(beam: str, s: float) -> PointRef:
    """The material point of beam ``beam`` at reference arc length ``s`` [m]."""
    return PointRef("beam", beam, check_nonnegative(f"arc length s on beam {beam!r}", s, "m"))


def describe_point(ref: PointRef) -> str:
    """A point reference in words, for messages: ``node -1 of beam 'arm'``."""
    if ref.kind == "ground":
        return f"ground point {tuple(ref.value)}"
    if ref.kind == "body":
        return f"body {ref.target!r}" + ("" if tuple(ref.value) == (0.0, 0.0) else f" at local {tuple(ref.value)}")
    if ref.kind == "node":
        return f"node {ref.value} of beam {ref.target!r}"
    return f"s = {ref.value:g} m on beam {ref.target!r}"


#: default constraint residual max|Φ| [m or rad] of an initial state accepted without
#: position projection, and required after it (:meth:`Model.build`, :func:`assemble_state`)
ASSEMBLY_TOLERANCE = 1e-10

#: default relative change of a given initial velocity that is warned about
#: (:func:`project_velocities`, :func:`assemble_state`)
VELOCITY_WARN_TOLERANCE = 1e-6

#: clamp modes (:class:`ancf_jax.joints.Clamp`)
CLAMP_MODES = ("full", "direction", "exudyn")
#: coordinates of a beam node and of a body, in the order of q (:meth:`Model.coordinate`)
#: where a moving load's path is measured: horizontal coordinate or reference arc length
ALONG = ("x", "arc_length")

#: a contact's default stiffness over the beam's static stiffness where it touches
#: (:meth:`Model.contact`): the contact spring in series adds 1/100 to the beam's
#: compliance there (its penetration is 1 % of the beam's deflection under the same force)
CONTACT_STIFFNESS_FACTOR = 100.0
#: most active coordinates for which :meth:`Model.build` derives a contact's default
#: stiffness (:func:`~ancf_jax.modal.contact_point_stiffness` factors the dense reduced
#: stiffness, O(n³) time and n² memory: 2,000 coordinates take seconds, the 10-span
#: catenary's 9,600 would take minutes and GBs); above it a stiffness must be given
CONTACT_STIFFNESS_MAX_COORDINATES = 2000


def _as_path(what: str, path) -> AbstractPath:
    """A path: an AbstractPath as is; a function of t as ``ConstantSpeed(0, 0, f)``."""
    if isinstance(path, AbstractPath):
        return path
    if callable(path):
        return ConstantSpeed(0.0, 0.0, path)
    raise ModelError(f"{what} must be a path (e.g. ancf_jax.functions.ConstantSpeed(start, speed)) or a "
                     f"function of t [m], got {path!r}")


def _hermite(nodes, lengths, s):
    """r(s) [m] of the cubic Hermite (ANCF) curve of ``nodes`` (n + 1, 4), NumPy."""
    edges = np.concatenate([[0.0], np.cumsum(lengths)])
    k = int(np.clip(np.searchsorted(edges, s, side="right") - 1, 0, len(lengths) - 1))
    l, xi = lengths[k], (s - edges[k]) / lengths[k]
    a, b = nodes[k], nodes[k + 1]
    return ((1 - 3 * xi**2 + 2 * xi**3) * a[:2] + l * (xi - 2 * xi**2 + xi**3) * a[2:]
            + (3 * xi**2 - 2 * xi**3) * b[:2] + l * (xi**3 - xi**2) * b[2:])


def _arc_length_at_x(nodes, lengths, x, what: str) -> float:
    """Reference arc length of the point of the Hermite curve at horizontal coordinate
    x (Brent's method, ``scipy.optimize.brentq``; the curve's x monotonic), NumPy."""
    from scipy.optimize import brentq
    total = float(np.sum(lengths))
    xa, xb = _hermite(nodes, lengths, 0.0)[0], _hermite(nodes, lengths, total)[0]
    if not min(xa, xb) <= x <= max(xa, xb):
        raise ModelError(f"{what} starts at x = {x:g} m, off the beam (accepted {min(xa, xb):g}..{max(xa, xb):g} m)")
    return brentq(lambda s: _hermite(nodes, lengths, s)[0] - x, 0.0, total, xtol=1e-15 * max(1.0, total))


NODE_COMPONENTS = ("x", "y", "slope_x", "slope_y")
BODY_COMPONENTS = ("x", "y", "theta")


@dataclasses.dataclass
class _BeamSpec:
    mesh: BeamMesh
    section: Section
    alpha: float
    beta: float
    formulation: Formulation
    initial_nodes: Optional[np.ndarray]
    initial_velocities: Optional[np.ndarray]
    gravity: bool = True
    axial_law: Any = None
    bending_law: Any = None


@dataclasses.dataclass
class _BodySpec:
    mass: float
    inertia: float
    pose: np.ndarray
    velocity: np.ndarray  # (3,): ẋ, ẏ, θ̇; 0 where not given
    given: np.ndarray  # (3,) bool: which of ẋ, ẏ, θ̇ were given
    gravity: bool = True
    point_mass: bool = False  # translation only: θ held by the constraint "<name>.rotation"


class Model:
    """Builder of a planar multibody system with ANCF beams (see module docstring)."""

    def __init__(self, gravity=(0.0, -9.81)):
        self.gravity = check_vector("gravity", gravity, 2)
        self._beams: dict[str, _BeamSpec] = {}
        self._bodies: dict[str, _BodySpec] = {}
        self._sliders: dict[str, dict] = {}
        self._joints: list[tuple[str, str, dict]] = []
        self._forces: list[tuple[str, str, dict]] = []
        self._attached: list[tuple[str, str, float, float]] = []
        self._friction: list[tuple[str, str, dict]] = []
        self._drives: list[tuple[str, str, str, dict]] = []
        self._names: set[str] = set()

    # ------------------------------------------------------------------ entities
    def _claim(self, name: str, what: str) -> None:
        if not isinstance(name, str) or not name:
            raise ModelError(f"{what} name must be a non-empty string, got {name!r}")
        if name in self._names:
            raise ModelError(f"duplicate name {name!r}: names of beams, bodies, joints and "
                             "forces must be unique")
        self._names.add(name)

    def add_beam(self, name: str, mesh: BeamMesh, section: Section, *, alpha=0.0, beta=0.0,
                 formulation: Formulation | None = None, initial_nodes=None,
                 initial_velocities=None, gravity: bool = True, axial_law=None,
                 bending_law=None) -> str:
        """Add a beam.

        Args:
            name: unique name.
            mesh: reference (stress-free) geometry, from :mod:`ancf_jax.mesh`.
            section: cross-section and material.
            alpha: Rayleigh mass-proportional damping coefficient α (Eq. 11) [1/s], >= 0.
            beta: Rayleigh stiffness-proportional damping coefficient β (Eq. 11) [s], >= 0.
            formulation: strain measures and quadrature (default :class:`Formulation`).
            initial_nodes: initial nodal coordinates (n + 1, 4); default the reference.
            initial_velocities: initial nodal velocities (n + 1, 4); default zero.
            gravity: whether the model's gravity acts on this beam (for a load on some
                items only, see also :meth:`mass_proportional_load`).
            axial_law: material law N(ε, ε̇) from :mod:`ancf_jax.element.laws` (e.g.
                ``StrainRateDamped(d)``, Exudyn's cable damping); None: linear elastic.
            bending_law: material law M(κ, κ̇), likewise.
        """
        if not isinstance(mesh, BeamMesh):
            raise ModelError(f"mesh of beam {name!r} must be a BeamMesh (see ancf_jax.mesh)")
        if not isinstance(section, Section):
            raise ModelError(f"section of beam {name!r} must be a Section")
        n = int(mesh.n_elements)
        shape = (n + 1, 4)
        nodes0 = None if initial_nodes is None else check_finite(f"initial_nodes of beam {name!r}", initial_nodes)
        vel0 = None if initial_velocities is None else check_finite(
            f"initial_velocities of beam {name!r}", initial_velocities)
        for label, arr in (("initial_nodes", nodes0), ("initial_velocities", vel0)):
            if arr is not None and arr.shape != shape:
                raise ModelError(f"{label} of beam {name!r} must have shape {shape}, got {arr.shape}")
        alpha = check_nonnegative(f"alpha of beam {name!r}", alpha, "1/s")
        beta = check_nonnegative(f"beta of beam {name!r}", beta, "s")
        axial_law = check_law(f"axial_law of beam {name!r}", axial_law)
        bending_law = check_law(f"bending_law of beam {name!r}", bending_law)
        if bending_law is not None and (formulation or Formulation()).curvature == "small_strain":
            raise ModelError(f"bending_law of beam {name!r} needs curvature 'exact' or 'material', "
                             "not 'small_strain'")
        self._claim(name, "beam")
        self._beams[name] = _BeamSpec(mesh, section, alpha, beta, formulation or Formulation(),
                                      nodes0, vel0, _flag(f"gravity of beam {name!r}", gravity),
                                      axial_law, bending_law)
        return name

    def add_body(self, name: str, *, mass, inertia, position=(0.0, 0.0), angle=0.0,
                 velocity=None, angular_velocity=None, gravity: bool = True) -> str:
        """Add a rigid body (paper Eq. 14: coordinates x, y, θ).

        Args:
            name: unique name.
            mass: m [kg] > 0.
            inertia: J about the centre [kg·m²] > 0.
            position: centre (x, y) [m].
            angle: θ [rad].
            velocity: centre velocity [m/s], shape (2,); None (default): not given.
            angular_velocity: θ̇ [rad/s]; None (default): not given.
            gravity: whether the model's gravity acts on this body.

        A velocity that is not given starts at 0 and is then set by the joints (the
        body moves with what it is joined to, e.g. the point of a cable it rides on);
        a given one is kept as far as the joints allow (see :func:`project_velocities`).
        """
        m = check_positive(f"mass of body {name!r}", mass, "kg")
        j = check_positive(f"inertia of body {name!r}", inertia, "kg*m^2")
        pose = np.concatenate([check_vector(f"position of body {name!r}", position, 2),
                               [check_finite(f"angle of body {name!r}", angle).item()]])
        vel = np.zeros(3)
        given = np.array([velocity is not None] * 2 + [angular_velocity is not None])
        if velocity is not None:
            vel[:2] = check_vector(f"velocity of body {name!r}", velocity, 2)
        if angular_velocity is not None:
            w = check_finite(f"angular_velocity of body {name!r}", angular_velocity)
            if w.shape != ():
                raise ModelError(f"angular_velocity of body {name!r} must be a number, got {angular_velocity!r}")
            vel[2] = float(w)
        self._claim(name, "body")
        self._bodies[name] = _BodySpec(m, j, pose, vel, given, _flag(f"gravity of body {name!r}", gravity))
        return name

    def add_point_mass(self, name: str, *, mass, position=(0.0, 0.0), velocity=None,
                       gravity: bool = True) -> str:
        """Add a point mass (translation only; Exudyn's ``MassPoint2D``).

        It is a body whose rotation carries no inertia and is held at θ = 0 by the
        constraint ``"<name>.rotation"`` (θ = 0, appended after the joints; its
        multiplier is zero, as nothing acts on θ), so the system keeps three coordinates
        per body and x, y move exactly as a particle of mass m. Joints and loads that
        need a rotation refuse it: a fixed joint, a torque, a body point other than its
        centre, a prescribed or constrained θ.

        Args:
            name: unique name (it is a body: joints and loads refer to it as one).
            mass: m [kg] > 0.
            position: (x, y) [m].
            velocity: initial velocity [m/s], shape (2,); None: not given (set by the
                joints, else 0).
            gravity: whether the model's gravity acts on it.
        """
        m = check_positive(f"mass of point mass {name!r}", mass, "kg")
        pose = np.concatenate([check_vector(f"position of point mass {name!r}", position, 2), [0.0]])
        vel = np.zeros(3)
        given = np.array([velocity is not None] * 2 + [True])
        if velocity is not None:
            vel[:2] = check_vector(f"velocity of point mass {name!r}", velocity, 2)
        self._claim(name, "body")
        self._bodies[name] = _BodySpec(m, 0.0, pose, vel, given,
                                       _flag(f"gravity of point mass {name!r}", gravity), point_mass=True)
        return name

    def mass_proportional_load(self, name: str, item: str, acceleration, time_function=None) -> str:
        """A load m·a·f(t) on one beam or body only (Exudyn's ``LoadMassProportional``):
        on a body m·a at its centre, on a beam the consistent load ∫ ρA Sᵀ a dx.

        Args:
            name: unique name.
            item: a beam or body name.
            acceleration: a [m/s²], shape (2,).
            time_function: optional JAX-traceable scale ``t -> f(t)`` (default 1).
        """
        acc = tuple(check_vector(f"acceleration of {name!r}", acceleration, 2))
        if time_function is not None and not callable(time_function):
            raise ModelError(f"time_function of load {name!r} must be callable")
        self._claim(name, "force")
        self._forces.append(("mass_proportional", name, dict(item=item, acceleration=acc,
                                                             time_function=time_function)))
        return name

    def attached_mass(self, name: str, beam: str, s: float, mass: float) -> str:
        """A point mass ``mass`` [kg] > 0 fixed to the material point of ``beam`` at
        reference arc length ``s`` [m] (a clamp or spacer on a wire), translation only:
        consistent added mass m Sᵀ S and its weight, see
        :class:`~ancf_jax.beam.AttachedMasses`."""
        m = check_positive(f"mass of attached mass {name!r}", mass, "kg")
        s0 = check_nonnegative(f"arc length s of attached mass {name!r}", s, "m")
        self._claim(name, "attached mass")
        self._attached.append((name, beam, float(s0), float(m)))
        return name

    # ------------------------------------------------------------------ joints
    def clamp(self, name: str, beam: str, node: int = 0, *, mode: str = "full") -> str:
        """Clamp a beam node to the ground at its initial position and slope.

        ``mode="full"`` fixes the slope vector (4 equations), ``"direction"`` only its
        direction (3 equations), ``"exudyn"`` the coordinates x, y and r'_y (3 equations,
        Exudyn's clamp; see :class:`~ancf_jax.joints.Clamp`).
        """
        check_choice(f"mode of clamp {name!r}", mode, CLAMP_MODES)
        self._claim(name, "joint")
        self._joints.append(("clamp", name, dict(beam=beam, node=node, mode=mode)))
        return name

    def pin(self, name: str, point: PointRef, location=None) -> str:
        """Pin a point to the ground (position fixed, rotation free) at ``location``
        (default: the point's initial position)."""
        loc = None if location is None else tuple(check_vector(f"location of pin {name!r}", location, 2))
        self._claim(name, "joint")
        self._joints.append(("pin", name, dict(point=point, location=loc)))
        return name

    def revolute(self, name: str, a: PointRef, b: PointRef) -> str:
        """Revolute joint: two points of bodies/beams coincide, rotation free."""
        self._claim(name, "joint")
        self._joints.append(("revolute", name, dict(a=a, b=b)))
        return name

    def fixed(self, name: str, point: PointRef, body: str, local=None) -> str:
        """Fixed joint of a beam node (or body point) to rigid body ``body``.

        The body point ``local`` [m] (body frame) stays at ``point`` and the body rotates
        with the beam slope there. Without ``local``, the body's centre must start at
        ``point`` (within 1e-9 of the model's size): a body placed elsewhere would be
        welded on through an invisible rigid arm, so :meth:`build` refuses it; give
        ``local`` (the body point at the joint) for an intended arm.
        """
        loc = None if local is None else tuple(check_vector(f"local point of joint {name!r}", local, 2))
        self._claim(name, "joint")
        self._joints.append(("fixed", name, dict(point=point, body=body, local=loc)))
        return name

    def slider(self, name: str, body: str, beam: str, s: float, *, local=(0.0, 0.0),
               hold: bool = False, rate: float | None = None) -> str:
        """Sliding joint (paper §4): the body point ``local`` stays on beam ``beam`` at
        the sliding coordinate named ``name``, initially at arc length ``s`` [m].
        ``hold=True`` adds the constraint ``s = s₀`` (named ``"<name>.hold"``),
        released by :meth:`System` rebuilds with ``hold=False``.

        ``rate`` is the initial ṡ [m/s]. Given, it is kept exactly (ṡ has no mass, Eq. 21:
        the body's and the beam's velocities adjust to it); None (default): ṡ is set by
        the joints and the given velocities of the body and the beam.
        """
        s0 = check_nonnegative(f"initial arc length s of sliding joint {name!r}", s, "m")
        lp = tuple(check_vector(f"local point of sliding joint {name!r}", local, 2))
        if rate is not None:
            r = check_finite(f"rate of sliding joint {name!r}", rate)
            if r.shape != ():
                raise ModelError(f"rate of sliding joint {name!r} must be a number, got {rate!r}")
            rate = float(r)
        self._claim(name, "joint")
        self._sliders[name] = dict(body=body, beam=beam, s=s0, local=lp, hold=bool(hold), rate=rate)
        return name

    def coordinate(self, name: str, point: PointRef, component: str, *, value=None,
                   function: Callable | None = None) -> str:
        """Constrain one coordinate (Exudyn's ``CoordinateConstraint`` to the ground).

        Args:
            name: unique name.
            point: a beam node (:func:`node`; components ``"x"``, ``"y"``,
                ``"slope_x"``, ``"slope_y"``: r_x, r_y, r'_x, r'_y) or a body
                (:func:`body_point` at its centre; components ``"x"``, ``"y"``,
                ``"theta"``).
            component: the coordinate.
            value: the value held [m, -, rad]; default its initial value.
            function: instead of ``value``, a JAX-traceable ``t -> value`` it follows.
        """
        if not isinstance(point, PointRef) or point.kind not in ("node", "body"):
            raise ModelError(f"point of coordinate constraint {name!r} must be node(beam, i) or "
                             f"body_point(body), got {point!r}")
        if point.kind == "body" and tuple(point.value) != (0.0, 0.0):
            raise ModelError(f"point of coordinate constraint {name!r} must be a body's centre "
                             "(body_point(body) without local)")
        check_choice(f"component of coordinate constraint {name!r}", component,
                     NODE_COMPONENTS if point.kind == "node" else BODY_COMPONENTS)
        if value is not None and function is not None:
            raise ModelError(f"coordinate constraint {name!r}: give value or function, not both")
        if function is not None and not callable(function):
            raise ModelError(f"function of coordinate constraint {name!r} must be callable")
        if value is not None:
            value = float(check_finite(f"value of coordinate constraint {name!r}", value))
        self._claim(name, "joint")
        self._joints.append(("coordinate", name, dict(point=point, component=component, value=value,
                                                      function=function)))
        return name

    def slider_friction(self, name: str, slider: str, *, mu, regularization=DEFAULT_REGULARIZATION,
                        viscous=0.0) -> str:
        """Coulomb friction on sliding joint ``slider``: −μ N tanh(u / v_ε) − c u [N] on
        the body along the beam, N the joint's normal reaction, u the sliding speed
        (:class:`~ancf_jax.sliding.SlidingFriction`).

        Args:
            mu: friction coefficient μ >= 0.
            regularization: v_ε [m/s] > 0 (default 1e-3): a body held by friction
                creeps at v_ε artanh(F / (μN)) under a tangential load F < μN.
            viscous: c [N·s/m] >= 0.
        """
        mu = check_nonnegative(f"mu of friction {name!r}", mu)
        ve = check_positive(f"regularization of friction {name!r}", regularization, "m/s")
        c = check_nonnegative(f"viscous of friction {name!r}", viscous, "N*s/m")
        self._claim(name, "force")
        self._friction.append((name, slider, dict(mu=mu, regularization=ve, viscous=c)))
        return name

    def slider_drive(self, name: str, slider: str, *, position: Callable | None = None,
                     force=None, time_function: Callable | None = None, speed=None, gain=None,
                     max_force=None) -> str:
        """Drive sliding joint ``slider`` (give exactly one of ``position``, ``force``,
        ``speed``; :mod:`ancf_jax.sliding`):

        * ``position``: the arc length follows s(t) = ``position(t)`` [m] (a joint named
          ``name``; the drive force is its reaction, the work the constraint work);
        * ``force``: a tangential force F [N] on the body along +s (reaction on the
          beam), scaled by ``time_function(t)`` if given;
        * ``speed``: a velocity servo F = F_max tanh(k (u* − u)/F_max) to the sliding
          speed u* [m/s] (a number or a function of t), with ``gain`` k [N·s/m] > 0 and
          ``max_force`` F_max [N] > 0.
        """
        given = [k for k, x in (("position", position), ("force", force), ("speed", speed)) if x is not None]
        if len(given) != 1:
            raise ModelError(f"drive {name!r} needs exactly one of position, force, speed, got "
                             f"{', '.join(given) or 'none'}")
        kind = given[0]
        if kind == "position":
            if not callable(position):
                raise ModelError(f"position of drive {name!r} must be a callable s(t) [m]")
            a = dict(function=position)
        elif kind == "force":
            f = float(check_finite(f"force of drive {name!r}", force))
            if time_function is not None and not callable(time_function):
                raise ModelError(f"time_function of drive {name!r} must be callable")
            a = dict(force=f, time_function=time_function)
        else:
            if not callable(speed):
                u = float(check_finite(f"speed of drive {name!r}", speed))
                speed = Constant(u)
            a = dict(speed=speed, gain=check_positive(f"gain of drive {name!r}", gain, "N*s/m"),
                     max_force=check_positive(f"max_force of drive {name!r}", max_force, "N"))
        self._claim(name, "joint" if kind == "position" else "force")
        self._drives.append((kind, name, slider, a))
        return name

    def prescribe_point(self, name: str, point: PointRef, function: Callable) -> str:
        """The point follows ``function(t) -> (x, y)`` [m] (JAX-traceable)."""
        if not callable(function):
            raise ModelError(f"function of prescribed motion {name!r} must be callable")
        self._claim(name, "joint")
        self._joints.append(("prescribe_point", name, dict(point=point, function=function)))
        return name

    def prescribe_body(self, name: str, body: str, coordinate: str, function: Callable) -> str:
        """Coordinate ``"x"``, ``"y"`` or ``"theta"`` of a body follows ``function(t)``
        (a JAX-traceable function, static, or an
        :class:`~ancf_jax.functions.AbstractPath` such as ``ConstantSpeed(x0, v)``,
        whose parameters are data: differentiable, batchable)."""
        check_choice(f"coordinate of prescribed motion {name!r}", coordinate, ("x", "y", "theta"))
        if not callable(function):
            raise ModelError(f"function of prescribed motion {name!r} must be callable")
        self._claim(name, "joint")
        self._joints.append(("prescribe_body", name, dict(body=body, coordinate=coordinate,
                                                          function=function)))
        return name

    # ------------------------------------------------------------------ forces
    def point_force(self, name: str, point: PointRef, force, time_function=None) -> str:
        """A force [N] at a point, optionally scaled by ``time_function(t)``."""
        f = tuple(check_vector(f"force of {name!r}", force, 2))
        if time_function is not None and not callable(time_function):
            raise ModelError(f"time_function of force {name!r} must be callable")
        self._claim(name, "force")
        self._forces.append(("point_force", name, dict(point=point, force=f, time_function=time_function)))
        return name

    def speed_squared_force(self, name: str, point: PointRef, *, static: float, coefficient: float, path,
                            direction=(0.0, 1.0)) -> str:
        """A force (F₀ + c ṗ²) e [N] at a point, ṗ [m/s] the speed of ``path`` (an
        :class:`~ancf_jax.functions.AbstractPath`, e.g. the ``ConstantSpeed`` of a
        moving chain: its data, so batches and gradients over the speed move the force
        too): a pantograph's static plus aerodynamic uplift
        (:class:`~ancf_jax.forces.SpeedSquaredForce`).

        Args:
            static: F₀ [N] (finite).
            coefficient: c [N/(m/s)²] (finite).
            direction: e, shape (2,) (default +y).
        """
        f0 = float(check_finite(f"static force of {name!r}", static))
        c = float(check_finite(f"coefficient of force {name!r}", coefficient))
        e = tuple(check_vector(f"direction of force {name!r}", direction, 2))
        p = _as_path(f"path of force {name!r}", path)
        self._claim(name, "force")
        self._forces.append(("speed_squared_force", name, dict(point=point, static=f0, coefficient=c, path=p,
                                                               direction=e)))
        return name

    def torque(self, name: str, body: str, torque: float, time_function=None) -> str:
        """A torque [N·m] on a body, optionally scaled by ``time_function(t)``."""
        tau = float(check_finite(f"torque of {name!r}", torque))
        self._claim(name, "force")
        self._forces.append(("torque", name, dict(body=body, torque=tau, time_function=time_function)))
        return name

    def spring_damper(self, name: str, a: PointRef, b: PointRef, *, stiffness, damping=0.0,
                      rest_length=None, acts: str = "both") -> str:
        """Linear spring-damper between two points; rest length defaults to the
        initial distance. The two points must be apart at the initial state (at zero
        length the spring's direction, the gradient of its length, is undefined):
        :meth:`build` refuses coinciding ends.

        ``acts``: ``"both"`` (default, :class:`~ancf_jax.forces.SpringDamper`),
        ``"tension"`` (a rope, dropper or hanger: slack while shorter than the rest
        length) or ``"compression"`` (a stop or buffer: open while longer), see
        :class:`~ancf_jax.forces.AbstractOneSidedSpringDamper`.
        """
        k = check_nonnegative(f"stiffness of {name!r}", stiffness, "N/m")
        c = check_nonnegative(f"damping of {name!r}", damping, "N*s/m")
        l0 = None if rest_length is None else check_nonnegative(f"rest_length of {name!r}", rest_length, "m")
        check_choice(f"acts of spring-damper {name!r}", acts, ("both", "tension", "compression"))
        if isinstance(a, PointRef) and a == b:
            raise ModelError(f"spring-damper {name!r}: both ends are {describe_point(a)}: its length is 0, where "
                             "its direction (the gradient of the length) is undefined; join two different points")
        self._claim(name, "force")
        self._forces.append(("spring_damper", name, dict(a=a, b=b, stiffness=k, damping=c, rest_length=l0,
                                                         acts=acts)))
        return name

    def spring_damper_set(self, name: str, members: dict, *, stiffness, rest_length, damping=0.0,
                          acts: str = "both") -> str:
        """Many spring-dampers of one law evaluated together
        (:class:`~ancf_jax.forces.NodeSpringSet`): ``members`` maps each member's name
        to its ends ``(a, b)``, ``a`` a node of one beam (the same for all) or a
        ground point, ``b`` a node of one beam (the same for all). ``stiffness``,
        ``damping`` and ``rest_length`` are one value for all or one per member;
        ``acts`` as for :meth:`spring_damper`. The Newton matrix holds one 8 × 8 (or
        4 × 4) block per member: with the wires interleaved, a catenary's droppers
        stay in the block-tridiagonal chain, and a set of m members costs O(m) where
        m separate elements are m traced copies."""
        check_choice(f"acts of spring-damper set {name!r}", acts, ("both", "tension", "compression"))
        if not members:
            raise ModelError(f"spring-damper set {name!r} needs at least one member")
        m = len(members)

        def per_member(label, values, unit, check):
            vals = np.broadcast_to(np.asarray(values, float), (m,)) if np.ndim(values) == 0 else np.asarray(
                values, float)
            if vals.shape != (m,):
                raise ModelError(f"{label} of spring-damper set {name!r} must be one value or one per member "
                                 f"({m}), got shape {vals.shape}")
            for v in vals:
                check(f"{label} of spring-damper set {name!r}", v, unit)
            return vals.copy()

        k = per_member("stiffness", stiffness, "N/m", check_nonnegative)
        c = per_member("damping", damping, "N*s/m", check_nonnegative)
        l0 = per_member("rest_length", rest_length, "m", check_nonnegative)
        for member, ends in members.items():
            a, b = ends
            if a.kind not in ("node", "ground") or b.kind != "node":
                raise ModelError(f"member {member!r} of spring-damper set {name!r} must join a beam node or a "
                                 "ground point (a) to a beam node (b)")
            self._claim(member, "force")
        self._claim(name, "force")
        self._forces.append(("spring_set", name, dict(members=dict(members), stiffness=k, damping=c,
                                                      rest_length=l0, acts=acts)))
        return name

    # ------------------------------------------------------------------ moving loads, contact
    def moving_force(self, name: str, beam: str, force, *, path, along: str = "x",
                     time_function: Callable | None = None) -> str:
        """A point force [N] (fixed direction) that moves along ``beam``
        (:class:`~ancf_jax.contact.MovingForce`), zero while it is off the beam.

        Args:
            force: F [N], shape (2,), scaled by ``time_function(t)`` if given.
            path: where it is at time t: an :class:`~ancf_jax.functions.AbstractPath`
                (``ConstantSpeed(start, speed)``: differentiable in the speed) or a
                JAX-traceable function of t [m].
            along: ``"x"`` (default): the path is the horizontal coordinate x(t) of the
                loaded point (a vehicle at x = v t); ``"arc_length"``: the reference arc
                length s(t).
        """
        f = tuple(check_vector(f"force of moving force {name!r}", force, 2))
        check_choice(f"along of moving force {name!r}", along, ALONG)
        p = _as_path(f"path of moving force {name!r}", path)
        if time_function is not None and not callable(time_function):
            raise ModelError(f"time_function of moving force {name!r} must be callable")
        self._claim(name, "force")
        self._forces.append(("moving_force", name, dict(beam=beam, force=f, path=p, along=along,
                                                        time_function=time_function)))
        return name

    def moving_mass(self, name: str, beam: str, *, mass, path, along: str = "x",
                    gravity: bool = True) -> str:
        """A point mass [kg] that moves along ``beam`` at a prescribed position: a point
        mass ``name`` on the sliding joint ``"<name>.slider"`` whose arc length
        (``along="arc_length"``) or horizontal coordinate (``"x"``, default) follows
        ``path`` (the constraint ``"<name>.drive"``: its reaction is the force that
        keeps the mass moving). The sliding joint carries the mass's inertia, with the
        convective terms of the moving point, exactly. The path must keep the mass on
        the beam for the whole run.

        Args:
            mass: m [kg] > 0.
            path: an :class:`~ancf_jax.functions.AbstractPath` or a function of t [m].
            gravity: whether the model's gravity acts on the mass.
        """
        check_choice(f"along of moving mass {name!r}", along, ALONG)
        p = _as_path(f"path of moving mass {name!r}", path)
        if beam not in self._beams:
            raise ModelError(f"moving mass {name!r} refers to beam {beam!r}, which does not exist "
                             f"(beams: {', '.join(map(repr, self._beams)) or 'none'})")
        if along == "x":
            self._check_monotonic_x(beam, f'moving mass {name!r} along="x"', '"arc_length", or ')
        spec = self._beams[beam]
        nodes = np.asarray(spec.mesh.reference_nodes if spec.initial_nodes is None else spec.initial_nodes)
        lengths = np.asarray(spec.mesh.element_lengths)[: int(spec.mesh.n_elements)]
        p0 = float(p(0.0))
        s0 = p0 if along == "arc_length" else _arc_length_at_x(nodes, lengths, p0, f"moving mass {name!r}")
        length = float(np.sum(lengths))
        if not 0.0 <= s0 <= length:
            raise ModelError(f"moving mass {name!r} starts off beam {beam!r}: arc length {s0:g} m "
                             f"(accepted 0..{length:g} m)")
        self.add_point_mass(name, mass=mass, position=_hermite(nodes, lengths, s0), gravity=gravity)
        self.slider(f"{name}.slider", name, beam, s0)
        if along == "arc_length":
            self.slider_drive(f"{name}.drive", f"{name}.slider", position=p)
        else:
            self.prescribe_body(f"{name}.drive", name, "x", p)
        return name

    def contact(self, name: str, point: PointRef, beam: str, *, stiffness=None, damping=0.0, side: int = 1,
                offset=0.0, mu=0.0, regularization=DEFAULT_REGULARIZATION, viscous=0.0) -> str:
        """Unilateral penalty contact between ``point`` and ``beam`` at the beam's
        closest point (:class:`~ancf_jax.contact.UnilateralContact`): normal force
        k δ + max(c δ̇, −k δ) while the penetration δ > 0, else 0 (never pulls); with
        ``mu`` or ``viscous`` > 0, friction −μ F_n tanh(u / v_ε) − c u along the beam
        (:class:`~ancf_jax.contact.ContactFriction`, the law of
        :meth:`slider_friction`).

        Args:
            stiffness: k [N/m] > 0; None (default): :data:`CONTACT_STIFFNESS_FACTOR`
                (100) times the static stiffness of the beam where the point touches
                it, k_b = F / w for a normal point force F there, supports and joints
                included, in the built configuration
                (:func:`~ancf_jax.modal.contact_point_stiffness`), set by
                :meth:`build`: the contact then adds 1 % to the beam's compliance
                there (docs/moving-loads.md, "Contact stiffness"). A beam held rigidly
                there (every node clamped) or not held at all has no such default,
                nor has a model of more than :data:`CONTACT_STIFFNESS_MAX_COORDINATES`
                coordinates (the derivation is a dense solve): :meth:`build` raises.
            damping: c [N·s/m] >= 0.
            side: +1 if the point is on the side of the beam's left normal (above a
                beam running in +x), −1 if on the other side (below it: a pantograph
                under a contact wire).
            offset: gap g₀ [m] >= 0 at which contact begins (radii).
            mu: friction coefficient μ >= 0 (default 0: frictionless).
            regularization: v_ε [m/s] > 0 of the friction (default 1e-3).
            viscous: c [N·s/m] >= 0, viscous friction along the beam.
        """
        k = None if stiffness is None else check_positive(f"stiffness of contact {name!r}", stiffness, "N/m")
        c = check_nonnegative(f"damping of contact {name!r}", damping, "N*s/m")
        g0 = check_nonnegative(f"offset of contact {name!r}", offset, "m")
        mu = check_nonnegative(f"mu of contact {name!r}", mu)
        ve = check_positive(f"regularization of contact {name!r}", regularization, "m/s")
        cv = check_nonnegative(f"viscous of contact {name!r}", viscous, "N*s/m")
        if side not in (1, -1) or isinstance(side, bool):
            raise ModelError(f"side of contact {name!r} must be 1 (left of the beam, above a beam "
                             f"running in +x) or -1 (right, below), got {side!r}")
        self._claim(name, "force")
        friction = dict(mu=mu, regularization=ve, viscous=cv) if mu > 0.0 or cv > 0.0 else None
        self._forces.append(("contact", name, dict(point=point, beam=beam, stiffness=k, damping=c,
                                                   side=float(side), offset=g0, friction=friction)))
        return name

    def _default_contact_stiffness(self, system: System, q) -> System:
        """``system`` with the stiffness of every contact added without one set to
        CONTACT_STIFFNESS_FACTOR k_b (:meth:`contact`)."""
        from .modal import contact_point_stiffness

        for kind, name, a in self._forces:
            if kind != "contact" or a["stiffness"] is not None:
                continue
            n = int(np.sum(~np.asarray(system.inactive_mask())))
            if n > CONTACT_STIFFNESS_MAX_COORDINATES:
                raise ModelError(
                    f"stiffness of contact {name!r} has no default in a model of {n} coordinates (the default's "
                    f"dense solve is limited to {CONTACT_STIFFNESS_MAX_COORDINATES}): give stiffness [N/m] > 0 "
                    f"(docs/moving-loads.md, \"Contact stiffness\")")
            i = next(i for i, f in enumerate(system.forces) if f.name == name)
            kb = contact_point_stiffness(system, q, system.forces[i])
            if not 0.0 < kb < np.inf:
                held = "holds it rigidly" if kb == np.inf else "does not hold it"
                raise ModelError(
                    f"stiffness of contact {name!r} has no default: nothing derives one where beam "
                    f"{a['beam']!r} meets the point (its static stiffness there is {kb:g} N/m: the model {held}); "
                    f"give stiffness [N/m] > 0, e.g. the expected contact force over the penetration "
                    f"you accept (docs/moving-loads.md, \"Contact stiffness\")")
            system = eqx.tree_at(lambda s: s.forces[i].stiffness, system,
                                 jnp.asarray(CONTACT_STIFFNESS_FACTOR * kb, float))
        return system

    def lumped_chain(self, name: str, *, base, heights, masses, stiffness, damping=None,
                     forces=None, path=None, gravity: bool = True) -> tuple[str, ...]:
        """A vertical chain of point masses joined by spring-dampers: a current collector
        (pantograph) or a suspension. Mass i (``"<name>.<i>"``, i = 1 at the bottom) is
        at height ``heights[i-1]`` [m] above ``base`` (x, y) [m]; stage i
        (``"<name>.stage<i>"``, a :class:`~ancf_jax.forces.DirectedSpringDamper` along
        +y, unstressed as built) joins mass i to mass i − 1 (stage 1: to the base);
        ``forces[i-1]`` [N] acts on mass i along +y (e.g. the static uplift on the
        frame). The masses move vertically; their x is held at the base's x, or
        follows ``path`` (an :class:`~ancf_jax.functions.AbstractPath` or a function
        of t: a vehicle at x = x₀ + v t; the base stage works along y wherever the
        masses are). Returns the mass names, bottom first.

        Args:
            heights: y of each mass above the base [m], increasing.
            masses: m_i [kg] > 0.
            stiffness: k_i [N/m] >= 0 of each stage.
            damping: c_i [N·s/m] >= 0 of each stage (default 0).
            forces: constant forces [N] along +y on each mass (default 0).
        """
        b = check_vector(f"base of chain {name!r}", base, 2)
        h = check_finite(f"heights of chain {name!r}", heights).reshape(-1)
        n = h.shape[0]
        if n < 1 or np.any(np.diff(np.concatenate([[0.0], h])) <= 0.0):
            raise ModelError(f"heights of chain {name!r} must be positive and increasing [m], got {list(h)}")
        def per_mass(label, values, default, check):
            if values is None:
                return [default] * n
            vals = np.atleast_1d(np.asarray(values, float))
            if vals.shape != (n,):
                raise ModelError(f"{label} of chain {name!r} must have one value per mass ({n}), got {values!r}")
            return [float(check(f"{label} {i + 1} of chain {name!r}", v)) for i, v in enumerate(vals)]
        m = per_mass("masses", masses, None, lambda w, v: check_positive(w, v, "kg"))
        k = per_mass("stiffness", stiffness, None, lambda w, v: check_nonnegative(w, v, "N/m"))
        c = per_mass("damping", damping, 0.0, lambda w, v: check_nonnegative(w, v, "N*s/m"))
        f = per_mass("forces", forces, 0.0, lambda w, v: check_finite(w, v))
        p = None if path is None else _as_path(f"path of chain {name!r}", path)
        names = []
        for i in range(n):
            mass = f"{name}.{i + 1}"
            self.add_point_mass(mass, mass=m[i], position=(b[0] if p is None else float(p(0.0)), b[1] + h[i]),
                                gravity=gravity)
            if p is None:
                self.coordinate(f"{mass}.x", body_point(mass), "x")
            else:
                self.prescribe_body(f"{mass}.x", mass, "x", p)
            below = ground(float(b[0]), float(b[1])) if i == 0 else body_point(names[-1])
            self._claim(f"{name}.stage{i + 1}", "force")
            self._forces.append(("directed_spring", f"{name}.stage{i + 1}", dict(
                a=below, b=body_point(mass), direction=(0.0, 1.0), stiffness=k[i], damping=c[i],
                rest_length=float(h[i] - (h[i - 1] if i else 0.0)))))
            if f[i] != 0.0:
                self.point_force(f"{mass}.force", body_point(mass), (0.0, f[i]))
            names.append(mass)
        return tuple(names)

    # ------------------------------------------------------------------ names
    @property
    def beam_names(self) -> tuple[str, ...]:
        return tuple(self._beams)

    @property
    def body_names(self) -> tuple[str, ...]:
        return tuple(self._bodies)

    @property
    def slider_names(self) -> tuple[str, ...]:
        return tuple(self._sliders)

    def given_velocities(self, system: System) -> np.ndarray:
        """Which initial velocities of ``system`` (built from this model) were given,
        shape (n,) bool, in the order of q: a body's centre velocity and angular
        velocity if not None, every beam coordinate (nodal velocities default to
        "given, at rest"), a sliding coordinate if its joint's ``rate`` is not None."""
        given = np.ones(system.n_coordinates, bool)
        for k, name in enumerate(system.body_names):
            o = system.body_offset(k)
            given[o:o + 3] = self._bodies[name].given
        for j, name in enumerate(system.sliding_names):
            given[system.sliding_offset + j] = self._sliders[name]["rate"] is not None
        return given

    # ------------------------------------------------------------------ build
    def _beam_length(self, name: str) -> float:
        mesh = self._beams[name].mesh
        n = int(mesh.n_elements)
        return float(np.asarray(mesh.element_lengths)[:n].sum())

    def _check_references(self) -> None:
        """Check every name, node index and arc length with host data only (no JAX)."""
        beams, bodies = list(self._beams), list(self._bodies)

        def beam(name, what):
            if name not in self._beams:
                known = ", ".join(map(repr, beams)) or "none"
                raise ModelError(f"{what} refers to beam {name!r}, which does not exist (beams: {known})")

        def body(name, what):
            if name not in self._bodies:
                known = ", ".join(map(repr, bodies)) or "none"
                raise ModelError(f"{what} refers to body {name!r}, which does not exist (bodies: {known})")

        def node_ok(name, index, what):
            beam(name, what)
            n = int(self._beams[name].mesh.n_elements)
            i = index if index >= 0 else n + 1 + index
            if not 0 <= i <= n:
                raise ModelError(f"{what}: node {index} of beam {name!r} is out of range "
                                 f"(the beam has nodes 0..{n}, or -1..{-(n + 1)})")

        def arc_ok(name, s, what, label="arc length"):
            length = self._beam_length(name)
            if not 0.0 <= s <= length * (1.0 + 1e-12):
                raise ModelError(f"{what}: {label} {s} is outside beam {name!r} "
                                 f"(accepted 0..{length:g} m)")

        def rotating(name, what, needs):
            body(name, what)
            if self._bodies[name].point_mass:
                raise ModelError(f"{what} needs {needs}, but {name!r} is a point mass (translation "
                                 "only); use add_body with an inertia")

        def point(ref, what):
            if not isinstance(ref, PointRef):
                raise ModelError(f"{what}: a point must be given with ground(), body_point(), "
                                 f"node() or beam_point(), got {ref!r}")
            if ref.kind == "body":
                body(ref.target, what)
                if tuple(ref.value) != (0.0, 0.0):
                    rotating(ref.target, what, "a body point away from the centre")
            elif ref.kind == "node":
                node_ok(ref.target, ref.value, what)
            elif ref.kind == "beam":
                beam(ref.target, what)
                arc_ok(ref.target, ref.value, what)

        for kind, name, a in self._joints:
            what = f"joint {name!r}"
            if kind == "clamp":
                node_ok(a["beam"], a["node"], what)
            if kind == "fixed":
                rotating(a["body"], what, "a rotation (fixed joint)")
                if a["point"].kind == "body":
                    rotating(a["point"].target, what, "a rotation (fixed joint)")
            if kind == "prescribe_body":
                body(a["body"], what)
                if a["coordinate"] == "theta":
                    rotating(a["body"], what, "a rotation (prescribed theta)")
            if kind == "coordinate" and a["point"].kind == "body" and a["component"] == "theta":
                rotating(a["point"].target, what, "a rotation (constrained theta)")
            for key in ("point", "a", "b"):
                if key in a:
                    point(a[key], what)
        for name, a in self._sliders.items():
            what = f"sliding joint {name!r}"
            body(a["body"], what)
            if tuple(a["local"]) != (0.0, 0.0):
                rotating(a["body"], what, "a body point away from the centre")
            beam(a["beam"], what)
            arc_ok(a["beam"], a["s"], what, "initial arc length s =")
        for name, slider, _ in self._friction:
            if slider not in self._sliders:
                raise ModelError(f"friction {name!r} refers to sliding joint {slider!r}, which does not exist "
                                 f"(sliding joints: {', '.join(map(repr, self._sliders)) or 'none'})")
        for _, name, slider, _ in self._drives:
            if slider not in self._sliders:
                raise ModelError(f"drive {name!r} refers to sliding joint {slider!r}, which does not exist "
                                 f"(sliding joints: {', '.join(map(repr, self._sliders)) or 'none'})")
        for name, b, s, _ in self._attached:
            what = f"attached mass {name!r}"
            beam(b, what)
            arc_ok(b, s, what)
        for kind, name, a in self._forces:
            what = f"force {name!r}"
            if kind == "torque":
                rotating(a["body"], what, "a rotation (torque)")
            if kind in ("moving_force", "contact"):
                beam(a["beam"], what)
            if kind == "moving_force" and a["along"] == "x":
                self._check_monotonic_x(a["beam"], f'moving force {name!r} along="x"', '"arc_length", or ')
            if kind == "contact":
                self._check_monotonic_x(a["beam"], f"contact {name!r} (its search starts under the point's x)")
            if kind == "mass_proportional" and a["item"] not in self._beams and a["item"] not in self._bodies:
                known = ", ".join(map(repr, beams + bodies)) or "none"
                raise ModelError(f"{what} refers to {a['item']!r}, which is no beam or body "
                                 f"(beams and bodies: {known})")
            for key in ("point", "a", "b"):
                if key in a:
                    point(a[key], what)
            for member, (pa, pb) in a.get("members", {}).items():
                point(pa, f"member {member!r} of {what}")
                point(pb, f"member {member!r} of {what}")

    def _check_monotonic_x(self, beam: str, what: str, alternative: str = "") -> None:
        """Moving loads along x and contacts find the element under a horizontal
        position from the nodes' x: the x of the beam's initial shape must be strictly
        monotonic along it (ModelError naming ``what`` otherwise)."""
        spec = self._beams[beam]
        nodes = np.asarray(spec.mesh.reference_nodes if spec.initial_nodes is None else spec.initial_nodes)
        x = nodes[: int(spec.mesh.n_elements) + 1, 0]
        dx = np.diff(x)
        if not (np.all(dx > 0.0) or np.all(dx < 0.0)):
            shown = ", ".join(f"{v:g}" for v in x[:8]) + (", ..." if len(x) > 8 else "")
            raise ModelError(f"{what} needs beam {beam!r} to run left to right or right to left, but the x of its "
                             f"nodes is not strictly monotonic (x = {shown} m); accepted: {alternative}a beam whose "
                             f"node x increases or decreases along it (a track, rope or wire)")

    def build(self, *, pad_to: dict | int | None = None, hold: bool | None = None,
              assemble: bool = True, tolerance: float = ASSEMBLY_TOLERANCE,
              layout: AbstractChainLayout | None = None) -> tuple[System, State]:
        """Resolve names, check the constraints and return ``(system, initial_state)``.

        Args:
            pad_to: pad beams to this many element slots (one int for all beams or a
                dict beam name → n_max), so systems of different element counts batch.
            hold: override the ``hold`` flag of every sliding joint (None: as added).
            assemble: project the initial state onto Φ = 0 and Φ̇ = 0 (velocities by
                the kinetic-energy projection of :func:`project_velocities`: given
                velocities and rates are kept as far as the joints allow).
            tolerance: constraint residual accepted without projection [m].
            layout: order of the beam coordinates in the solvers' chain
                (:class:`~ancf_jax.linalg.SequentialChain` or
                :class:`~ancf_jax.linalg.InterleavedChain`); None: interleaved when
                beams with equal node slots are coupled by force elements that the
                interleaved chain holds (a catenary's droppers), else sequential
                (:func:`chain_structure`).

        Raises:
            ModelError: unknown names, points outside a beam, bad indices.
            ConstraintError: redundant or conflicting joints, or given rates that the
                joints do not allow (e.g. a held sliding joint given a non-zero rate).
        """
        self._check_references()
        beam_names = list(self._beams)
        body_names = list(self._bodies)
        slider_names = list(self._sliders)
        beam_index = {n: i for i, n in enumerate(beam_names)}
        body_index = {n: i for i, n in enumerate(body_names)}

        # ---- beams (padding) and initial beam state
        beams, nodes0, vel0 = [], [], []
        for name in beam_names:
            spec = self._beams[name]
            mesh = spec.mesh
            n = int(mesh.n_elements)
            if pad_to is not None:
                target = pad_to.get(name) if isinstance(pad_to, dict) else pad_to
                if target is not None:
                    if int(target) < n:
                        raise ModelError(f"pad_to for beam {name!r} must be >= its {n} elements, got {target}")
                    mesh = pad(mesh, int(target))
            on_beam = [(s, m) for _, b, s, m in self._attached if b == name]
            attached = (AttachedMasses(jnp.asarray([s for s, _ in on_beam], float),
                                       jnp.asarray([m for _, m in on_beam], float)) if on_beam else None)
            beams.append(Beam(mesh, spec.section, alpha=spec.alpha, beta=spec.beta,
                              formulation=spec.formulation, axial_law=spec.axial_law,
                              bending_law=spec.bending_law, attached=attached))
            ref = np.asarray(mesh.reference_nodes)
            x0 = ref.copy()
            if spec.initial_nodes is not None:
                x0[: n + 1] = spec.initial_nodes
            v0 = np.zeros_like(ref)
            if spec.initial_velocities is not None:
                v0[: n + 1] = spec.initial_velocities
            nodes0.append(x0)
            vel0.append(v0)

        # names, indices and arc lengths were checked by _check_references
        def beam_of(name, what=None):
            return beam_index[name]

        def body_of(name, what=None):
            return body_index[name]

        def node_index(beam_name, index, what=None):
            n = int(self._beams[beam_name].mesh.n_elements)
            return beam_index[beam_name], (index if index >= 0 else n + 1 + index)

        def resolve(ref: PointRef, what=None):
            if ref.kind == "ground":
                return P.GroundPoint(jnp.asarray(ref.value, float))
            if ref.kind == "body":
                return P.BodyPoint(body_index[ref.target], jnp.asarray(ref.value, float))
            if ref.kind == "node":
                b, i = node_index(ref.target, ref.value)
                return P.BeamNode(b, jnp.asarray(i, jnp.int32))
            return P.BeamPoint(beam_index[ref.target], jnp.asarray(ref.value, float))

        # ---- bodies and sliding coordinates
        poses = np.array([self._bodies[n].pose for n in body_names]).reshape(-1, 3)
        body_vel = np.array([self._bodies[n].velocity for n in body_names]).reshape(-1, 3)
        bodies = RigidBodies(jnp.asarray([self._bodies[n].mass for n in body_names], float).reshape(-1),
                             jnp.asarray([self._bodies[n].inertia for n in body_names], float).reshape(-1))
        s0 = np.array([self._sliders[n]["s"] for n in slider_names], float)
        s_rate = np.array([self._sliders[n]["rate"] or 0.0 for n in slider_names], float)

        skeleton = System(bodies, tuple(beams), (), (), jnp.asarray(self.gravity, float),
                          n_sliding=len(slider_names), body_names=tuple(body_names),
                          beam_names=tuple(beam_names), sliding_names=tuple(slider_names))
        q0 = np.asarray(skeleton.pack(poses, nodes0, s0))

        def initial_position(pt):
            return np.asarray(pt.position(skeleton, jnp.asarray(q0)))

        def initial_direction(pt):
            return np.asarray(pt.direction(skeleton, jnp.asarray(q0)))

        # the model's size, for tolerances of initial distances (points that must coincide)
        size = max([float(np.max(np.abs(x[:, :2]))) for x in nodes0 if x.size]
                   + [float(np.max(np.abs(poses[:, :2]))) if poses.size else 0.0])
        coincide = coincide_tolerance(size)

        # ---- constraints
        constraints = []
        for kind, name, a in self._joints:
            what = f"joint {name!r}"
            if kind == "clamp":
                b, i = node_index(a["beam"], a["node"], what)
                pt = P.BeamNode(b, jnp.asarray(i, jnp.int32))
                d = initial_direction(pt)
                slope = d if a["mode"] == "full" else d / np.linalg.norm(d)
                constraints.append(J.Clamp(name, pt, jnp.asarray(initial_position(pt)),
                                           jnp.asarray(slope), mode=a["mode"]))
            elif kind == "pin":
                pt = resolve(a["point"], what)
                loc = initial_position(pt) if a["location"] is None else np.asarray(a["location"])
                constraints.append(J.Coincident(name, pt, P.GroundPoint(jnp.asarray(loc, float))))
            elif kind == "revolute":
                constraints.append(J.Coincident(name, resolve(a["a"], what), resolve(a["b"], what)))
            elif kind == "fixed":
                pt = resolve(a["point"], what)
                k = body_of(a["body"], what)
                pose = poses[k]
                c, s = np.cos(pose[2]), np.sin(pose[2])
                rot_t = np.array([[c, s], [-s, c]])
                arm = initial_position(pt) - pose[:2]
                if a["local"] is None and np.linalg.norm(arm) > coincide:
                    raise ModelError(
                        f"fixed joint {name!r}: body {a['body']!r} starts {np.linalg.norm(arm):.4g} m from "
                        f"{describe_point(a['point'])}, where the joint holds it; without local it would be welded "
                        "on through an invisible rigid arm: place the body at the point, or give local (the body "
                        "point at the joint, in the body frame) for an intended arm")
                local = rot_t @ arm if a["local"] is None else np.asarray(a["local"])
                d = initial_direction(pt)
                u0 = rot_t @ (d / np.linalg.norm(d))
                constraints.append(J.FixedJoint(name, pt, P.BodyPoint(k, jnp.asarray(local, float)),
                                                jnp.asarray(u0, float)))
            elif kind == "coordinate":
                ref = a["point"]
                if ref.kind == "node":
                    b, i = node_index(ref.target, ref.value)
                    idx = skeleton.beam_offset(b) + 4 * i + NODE_COMPONENTS.index(a["component"])
                else:
                    idx = skeleton.body_offset(body_of(ref.target)) + BODY_COMPONENTS.index(a["component"])
                if a["function"] is not None:
                    constraints.append(_prescribed(name, idx, a["function"]))
                else:
                    value = q0[idx] if a["value"] is None else a["value"]
                    constraints.append(J.FixedCoordinate(name, idx, jnp.asarray(value, float)))
            elif kind == "prescribe_point":
                constraints.append(J.PrescribedPoint(name, resolve(a["point"], what), a["function"]))
            elif kind == "prescribe_body":
                k = body_of(a["body"], what)
                idx = 3 * k + {"x": 0, "y": 1, "theta": 2}[a["coordinate"]]
                constraints.append(_prescribed(name, idx, a["function"]))
        for j, name in enumerate(slider_names):
            a = self._sliders[name]
            what = f"sliding joint {name!r}"
            k = body_of(a["body"], what)
            b = beam_of(a["beam"], what)
            constraints.append(J.SlidingJoint(name, b, j, P.BodyPoint(k, jnp.asarray(a["local"], float))))
            driven = any(kind == "position" and sl == name for kind, _, sl, _ in self._drives)
            if (a["hold"] if hold is None else hold) and not driven:  # a position drive holds it
                constraints.append(J.SlidingHold(f"{name}.hold", j, jnp.asarray(a["s"], float)))
        for k, name in enumerate(body_names):
            if self._bodies[name].point_mass:
                constraints.append(J.FixedCoordinate(f"{name}.rotation", skeleton.body_offset(k) + 2,
                                                     jnp.zeros(())))
        for kind, name, slider, a in self._drives:
            if kind == "position":
                constraints.append(_prescribed(name, skeleton.sliding_offset + slider_names.index(slider),
                                               a["function"]))
        joint_index = {c.name: k for k, c in enumerate(constraints)}
        reaction_forces = tuple(
            SlidingFriction(name, joint_index[slider], jnp.asarray(a["mu"], float),
                            jnp.asarray(a["regularization"], float), jnp.asarray(a["viscous"], float))
            for name, slider, a in self._friction)

        # ---- forces
        forces = []
        for kind, name, a in self._forces:
            what = f"force {name!r}"
            if kind == "point_force":
                forces.append(PointForce(name, resolve(a["point"], what), jnp.asarray(a["force"], float),
                                         a["time_function"]))
            elif kind == "speed_squared_force":
                forces.append(SpeedSquaredForce(name, resolve(a["point"], what), jnp.asarray(a["direction"], float),
                                                jnp.asarray(a["static"], float), jnp.asarray(a["coefficient"], float),
                                                a["path"]))
            elif kind == "torque":
                forces.append(PointTorque(name, body_of(a["body"], what), jnp.asarray(a["torque"], float),
                                          a["time_function"]))
            elif kind == "spring_damper":
                pa, pb = resolve(a["a"], what), resolve(a["b"], what)
                length = float(np.linalg.norm(initial_position(pa) - initial_position(pb)))
                if length <= coincide:
                    raise ModelError(
                        f"spring-damper {name!r}: its ends ({describe_point(a['a'])} and {describe_point(a['b'])}) "
                        f"coincide at the initial state (length {length:.3g} m), where its direction (the gradient "
                        "of the length) is undefined; join points that start apart")
                l0 = a["rest_length"]
                if l0 is None:
                    l0 = length
                law = {"both": SpringDamper, "tension": TensionOnlySpringDamper,
                       "compression": CompressionOnlySpringDamper}[a["acts"]]
                forces.append(law(name, pa, pb, jnp.asarray(a["stiffness"], float),
                                  jnp.asarray(a["damping"], float), jnp.asarray(l0, float)))
            elif kind == "spring_set":
                ends = list(a["members"].values())
                kinds_a = {e[0].kind for e in ends}
                beams_a = {e[0].target for e in ends if e[0].kind == "node"}
                beams_b = {e[1].target for e in ends}
                if len(kinds_a) != 1 or len(beams_a) > 1 or len(beams_b) != 1:
                    raise ModelError(f"spring-damper set {name!r}: all members must join the same beam (or the "
                                     "ground) to the same beam")
                ground_a = kinds_a == {"ground"}
                nodes_a = [0 if ground_a else node_index(e[0].target, e[0].value)[1] for e in ends]
                nodes_b = [node_index(e[1].target, e[1].value)[1] for e in ends]
                ground = np.array([e[0].value if ground_a else (0.0, 0.0) for e in ends], float)
                forces.append(NodeSpringSet(
                    name, tuple(a["members"]), -1 if ground_a else beam_of(next(iter(beams_a))),
                    beam_of(next(iter(beams_b))), jnp.asarray(nodes_a), jnp.asarray(nodes_b), jnp.asarray(ground),
                    jnp.asarray(a["stiffness"]), jnp.asarray(a["damping"]), jnp.asarray(a["rest_length"]),
                    {"both": 0.0, "tension": 1.0, "compression": -1.0}[a["acts"]]))
            elif kind == "moving_force":
                where = (AtHorizontalPosition if a["along"] == "x" else AtArcLength)(a["path"])
                forces.append(MovingForce(name, beam_of(a["beam"]), where, jnp.asarray(a["force"], float),
                                          a["time_function"]))
            elif kind == "contact":
                fr = a["friction"]
                forces.append(UnilateralContact(
                    name, resolve(a["point"], what), beam_of(a["beam"]), a["side"],
                    jnp.asarray(0.0 if a["stiffness"] is None else a["stiffness"], float),
                    jnp.asarray(a["damping"], float), jnp.asarray(a["offset"], float),
                    None if fr is None else ContactFriction(*(jnp.asarray(fr[k], float)
                                                              for k in ("mu", "regularization", "viscous")))))
            elif kind == "directed_spring":
                forces.append(DirectedSpringDamper(
                    name, resolve(a["a"], what), resolve(a["b"], what),
                    stiffness=jnp.asarray(a["stiffness"], float), damping=jnp.asarray(a["damping"], float),
                    rest_length=jnp.asarray(a["rest_length"], float),
                    direction=jnp.asarray(a["direction"], float)))
            elif kind == "mass_proportional":
                acc = jnp.asarray(a["acceleration"], float)
                if a["item"] in self._bodies:
                    forces.append(BodyMassLoad(name, body_of(a["item"]), acc, a["time_function"]))
                else:
                    forces.append(BeamMassLoad(name, beam_of(a["item"]), acc, a["time_function"]))

        for kind, name, slider, a in self._drives:
            j = slider_names.index(slider)
            b = beam_of(self._sliders[slider]["beam"])
            if kind == "force":
                forces.append(SlidingDriveForce(name, b, j, jnp.asarray(a["force"], float), a["time_function"]))
            elif kind == "speed":
                forces.append(SlidingServo(name, b, j, a["speed"], jnp.asarray(a["gain"], float),
                                           jnp.asarray(a["max_force"], float)))

        gravity_off = tuple(n for n in body_names if not self._bodies[n].gravity) + tuple(
            n for n in beam_names if not self._beams[n].gravity)
        system = System(bodies, tuple(beams), tuple(constraints), tuple(forces),
                        jnp.asarray(self.gravity, float), n_sliding=len(slider_names),
                        body_names=tuple(body_names), beam_names=tuple(beam_names),
                        sliding_names=tuple(slider_names), gravity_off=gravity_off,
                        reaction_forces=reaction_forces)
        system = chain_structure(system, jnp.asarray(q0), layout)
        system = self._default_contact_stiffness(system, jnp.asarray(q0))
        v0 = np.asarray(system.pack(body_vel, vel0, s_rate))
        state = State(jnp.asarray(q0), jnp.asarray(v0), jnp.zeros(()))
        if assemble:
            state = assemble_state(system, state, tolerance=tolerance,
                                   given=self.given_velocities(system))
        return system, state


# ---------------------------------------------------------------------- chain structure
def _banded(system: System, q, layout: AbstractChainLayout) -> tuple[int, ...]:
    """Indices of the force elements whose coordinates at q lie in two neighbouring
    blocks of the chain in ``layout``."""
    trial = dataclasses.replace(system, layout=layout, banded_forces=())
    position = np.argsort(dae.solver_permutation(trial))
    n_chain, size = trial.chain_size, layout.block_size(len(system.beams))
    out = []
    for i, f in enumerate(system.forces):
        # a set of force elements is banded when every member is
        rows = f.member_coordinates(trial, q, 0.0) if isinstance(f, AbstractForceSet) else f.coordinates(trial, q, 0.0)
        if rows is None:
            continue
        pos = position[np.asarray(rows, int)]
        pos = pos if isinstance(f, AbstractForceSet) else pos[None]
        if pos.size and pos.max() < n_chain and all(within_two_blocks(p, size) for p in pos):
            out.append(i)
    return tuple(out)


def chain_structure(system: System, q, layout: AbstractChainLayout | None = None) -> System:
    """The system with its chain layout and banded force elements set (at q).

    A force element whose coordinates all lie in two neighbouring blocks of the
    chain (a support spring on a beam, a dropper between two interleaved wires) has
    its Newton matrix added to the block-tridiagonal chain; any other is a low-rank
    border term, whose cost grows with the cube of the number of such elements.
    ``layout`` None chooses :class:`~ancf_jax.linalg.InterleavedChain` when the beams
    have equal node slots and it holds more force elements in the chain than the
    sequential layout does."""
    if not system.beams:
        return system
    if layout is None:
        layout = SequentialChain()
        banded = _banded(system, q, layout)
        sizes = {b.n_coordinates for b in system.beams}
        if len(system.beams) > 1 and len(sizes) == 1:
            inter = _banded(system, q, InterleavedChain())
            if len(inter) > len(banded):
                layout, banded = InterleavedChain(), inter
    else:
        banded = _banded(system, q, layout)
    return dataclasses.replace(system, layout=layout, banded_forces=banded)


# ---------------------------------------------------------------------- assembly checks
# module-level jits: systems of the same structure reuse the compiled code (one jit per
# call would recompile Φ, Φ_q and Φ_t on every build, Φ_q twice)
_CONSTRAINT = jax.jit(lambda sys, q, t: sys.constraint(q, t))
_JACOBIAN = jax.jit(lambda sys, q, t: sys.constraint_jacobian(q, t))
_TIME_DERIVATIVE = jax.jit(lambda sys, q, t: sys.constraint_time_derivative(q, t))
# one program each instead of ~30 single operations dispatched and compiled one by one
# (M1 at a mesh size new to the process: build 1.2 s instead of 3.4 s)
_MASS_MATRIX = jax.jit(lambda sys: sys.mass_matrix())
_INACTIVE = jax.jit(lambda sys: sys.inactive_mask())


#: root finder of the initial position projection (:func:`assemble_state`): full
#: Newton (Φ_q refreshed at every iteration) on the optimality conditions of the
#: nearest consistent configuration, to corrections of 1e-12 m
ASSEMBLY_NEWTON = ModifiedNewton(tolerance=1e-12, max_iterations=50, contraction=0.0)


@eqx.filter_jit
def _prescribed(name: str, index: int, function):
    """A coordinate following a function of t: PathCoordinate for a path (data),
    PrescribedCoordinate for a plain (static) function."""
    if isinstance(function, AbstractPath):
        return J.PathCoordinate(name, index, function)
    return J.PrescribedCoordinate(name, index, function)


def _project_position(system, q, t, root_finder):
    return dae.project_position(system, q, t, chain_factor=dae.mass_chain_factor(system),
                                root_finder=root_finder, implicit=False)


def _jitted(system):
    return _CONSTRAINT, _JACOBIAN, _TIME_DERIVATIVE


#: a combination of dependent constraint equations whose residuals differ by more than
#: this is conflicting, not redundant [m or rad] (see check_constraint_rank)
CONFLICT_TOLERANCE = 1e-8


def check_constraint_rank(system: System, q, t=0.0, *, rtol: float = 1e-9,
                          conflict_tolerance: float = CONFLICT_TOLERANCE) -> None:
    """Raise :class:`ConstraintError` if Φ_q(q) is rank deficient, naming the joints
    whose equations are linearly dependent.

    Dependent equations are *redundant* when they agree (the left null space of Φ_q is
    orthogonal to Φ(q): one Newton step can satisfy them all) and *conflicting* when
    they do not (a combination of residuals larger than ``conflict_tolerance``
    [m or rad], e.g. a pin 0.1 m from a clamp on the same node): the message says
    which.
    """
    if system.n_constraints == 0:
        return
    phi_fn, jac_fn, _ = _jitted(system)
    jac = np.asarray(jac_fn(system, jnp.asarray(q), jnp.asarray(t, float)))
    u, sv, _ = np.linalg.svd(jac)
    scale = sv[0] if sv.size else 1.0
    rank = int(np.sum(sv > rtol * max(scale, 1e-300)))
    m = jac.shape[0]
    if rank < m:
        null = u[:, rank:]  # left null space: combinations of dependent equations
        owners = system.constraint_owner()
        labels = system.constraint_labels()
        phi = np.asarray(phi_fn(system, jnp.asarray(q), jnp.asarray(t, float)))
        mismatch = null.T @ phi
        if not np.all(np.isfinite(mismatch)) or np.max(np.abs(mismatch)) > conflict_tolerance:
            k = int(np.argmax(np.where(np.isfinite(mismatch), np.abs(mismatch), np.inf)))
            rows = [i for i in range(m) if abs(null[i, k]) > 1e-6]
            names = sorted({owners[i] for i in rows}, key=owners.index)
            raise ConstraintError(
                f"conflicting constraints: the joints {', '.join(names)} cannot be satisfied together "
                f"(equations {', '.join(labels[i] for i in rows)} are linearly dependent and disagree by "
                f"{abs(mismatch[k]):.3g}; rank of Phi_q is {rank} of {m}). Remove one of them or make "
                "them agree (e.g. put the point where the other joint holds it).")
        involved_eq = [labels[i] for i in range(m) if np.max(np.abs(null[i])) > 1e-6]
        involved = sorted({owners[i] for i in range(m) if np.max(np.abs(null[i])) > 1e-6},
                          key=owners.index)
        raise ConstraintError(
            f"redundant constraints: {m - rank} of the {m} constraint equations are linearly "
            f"dependent (rank of Phi_q is {rank}); joints involved: {', '.join(involved)} "
            f"(equations {', '.join(involved_eq)}). Remove one of them or use a joint with "
            "fewer equations (e.g. clamp mode='direction').")


def solve_weighted_correction(weight, jac, rhs, *, rtol: float = 1e-12):
    """Minimize ½ xᵀ W x subject to J x = rhs with one dense KKT system.

    The unknowns are equilibrated first (unit weight on the diagonal; a massless one
    scaled by its column of J) and the equations normalized, then the KKT matrix
    [[W, Jᵀ], [J, 0]] is solved by SVD (least squares: dependent consistent rows of J
    are allowed, their multipliers are not needed).

    Args:
        weight: W, shape (k, k), symmetric positive semi-definite.
        jac: J, shape (m, k).
        rhs: shape (m,).
        rtol: singular values below rtol × the largest count as zero.

    Returns:
        (x (k,), undetermined (k,) bool): ``undetermined`` marks the unknowns that the
        problem leaves free (W singular on the null space of J); all False when the
        minimizer is unique.
    """
    w, jac, rhs = np.asarray(weight, float), np.asarray(jac, float), np.asarray(rhs, float)
    k, m = w.shape[0], jac.shape[0]
    diag = np.diag(w).copy()
    col = np.linalg.norm(jac, axis=0) if m else np.zeros(k)
    d = np.where(diag > 0, 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0)),
                 np.where(col > 0, 1.0 / np.where(col > 0, col, 1.0), 1.0))
    js = jac * d[None, :]
    row = np.linalg.norm(js, axis=1)
    r = np.where(row > 0, 1.0 / np.where(row > 0, row, 1.0), 1.0)
    js = r[:, None] * js
    kkt = np.block([[d[:, None] * w * d[None, :], js.T], [js, np.zeros((m, m))]])
    b = np.concatenate([np.zeros(k), r * rhs])
    u, sv, vt = np.linalg.svd(kkt)
    keep = sv > rtol * (sv[0] if sv.size else 1.0)
    sol = vt[keep].T @ ((u[:, keep].T @ b) / sv[keep])
    null_x = vt[~keep][:, :k]  # null vectors of the KKT matrix, their x parts
    undetermined = np.any(np.abs(null_x) > 1e-6, axis=0) if null_x.size else np.zeros(k, bool)
    return d * sol[:k], undetermined


def _coordinate_entities(system: System) -> list[str]:
    """For each coordinate of ``system``, the entity it belongs to (for messages)."""
    out = [f"body {name!r}" for name in system.body_names for _ in range(3)]
    for b, name in enumerate(system.beam_names):
        out += [f"beam {name!r}"] * system.beams[b].n_coordinates
    out += [f"sliding joint {name!r}" for name in system.sliding_names]
    return out


def project_velocities(system: System, q, v, t=0.0, *, given=None,
                       warn_tolerance: float = VELOCITY_WARN_TOLERANCE,
                       feasibility_tolerance: float = 1e-8) -> np.ndarray:
    """Kinetic-energy projection of initial velocities onto Φ_q v + Φ_t = 0.

    With M the system mass matrix (bodies diag(m, m, J), beams their consistent mass),
    g the coordinates whose velocity was given and u those whose velocity was not, the
    velocities are found in two stages (dense KKT systems on the host, solved by
    :func:`solve_weighted_correction`), given velocities taking precedence:

    1. the given velocities change as little as possible in kinetic energy,
       min ½ Δv_gᵀ M_gg Δv_g, subject to the part of the constraints that the unset
       velocities cannot meet (the equations projected onto the complement of the
       range of Φ_q,u);
    2. the unset velocities then meet the rest with the least kinetic energy,
       min ½ v_uᵀ M_uu v_u subject to Φ_q,u v_u = −Φ_t − Φ_q,g v_g.

    This is the limit of one weighted projection in which an unset velocity weighs
    ε → 0 times its mass. Rules:

    * padding coordinates (:meth:`System.inactive_mask`) never change;
    * a sliding coordinate has no mass (Eq. 21): if its rate was given it is kept
      exactly, else it is free and set by the joints;
    * a body velocity not given (it is 0 in ``v``) is set by the joints, e.g. a body
      on a sliding joint with a given rate and a cable at rest moves with r'(s)·ṡ,
      and stays 0 where nothing determines it;
    * a given velocity is kept as far as the joints allow; if it changes by more than
      ``warn_tolerance`` × the largest given velocity magnitude (mixed units: m/s,
      rad/s, 1/s), a :class:`~ancf_jax.errors.VelocityProjectionWarning` names the
      bodies, beams and sliding joints concerned (not when every given velocity is
      zero, e.g. a model at rest whose prescribed motion starts moving it).

    Args:
        system: the assembled system.
        q: positions that satisfy Φ(q, t) = 0, shape (n,).
        v: initial velocities, shape (n,) (0 where not given).
        t: time [s].
        given: which velocities were given, shape (n,) bool (default: all, see
            :meth:`Model.given_velocities`).
        warn_tolerance: relative change of a given velocity that is warned about.
        feasibility_tolerance: relative residual of Φ_q v + Φ_t accepted.

    Returns:
        the projected velocities, shape (n,).

    Raises:
        ConstraintError: the joints leave velocities undetermined, or the given rates
            cannot satisfy them (e.g. a held sliding joint given a non-zero rate).
    """
    v_in = np.array(v, float)
    if system.n_constraints == 0:
        return v_in
    _, jac_fn, phit_fn = _jitted(system)
    tq, qq = jnp.asarray(t, float), jnp.asarray(q, float)
    jac = np.asarray(jac_fn(system, qq, tq))
    phit = np.asarray(phit_fn(system, qq, tq))
    n = system.n_coordinates
    given = np.ones(n, bool) if given is None else np.asarray(given, bool)
    if given.shape != (n,):
        raise ModelError(f"given must have shape ({n},), got {given.shape}")
    active = ~np.asarray(_INACTIVE(system))
    sliding = np.zeros(n, bool)
    sliding[system.sliding_offset:] = True
    free = active & ~(sliding & given)  # given rates and padding are kept
    owners = system.constraint_owner()
    entities = _coordinate_entities(system)

    mass = np.asarray(_MASS_MATRIX(system))
    rhs = -(jac @ v_in + phit)
    g, u = free & given, free & ~given
    jg, ju = jac[:, g], jac[:, u]
    # stage 1: the equations the unset velocities cannot meet (left null space of Φ_q,u)
    if u.any():
        left, sv, _ = np.linalg.svd(ju, full_matrices=True)
        rank = int(np.sum(sv > 1e-12 * sv[0])) if sv.size and sv[0] > 0 else 0
        perp = left[:, rank:]
    else:
        perp = np.eye(jac.shape[0])
    dg, _ = solve_weighted_correction(mass[np.ix_(g, g)], perp.T @ jg, perp.T @ rhs)
    # stage 2: the unset velocities meet the rest with the least kinetic energy
    du, undetermined = solve_weighted_correction(mass[np.ix_(u, u)], ju, rhs - jg @ dg)
    if np.any(undetermined):
        cols = np.flatnonzero(u)[undetermined]
        names = sorted({owners[i] for i in range(len(owners)) if np.any(jac[i, cols] != 0)},
                       key=owners.index)
        what = sorted({entities[c] for c in cols}, key=entities.index)
        raise ConstraintError(
            f"initial velocities are not determined: the KKT system of the velocity "
            f"projection is singular for {', '.join(what)}; joints involved: "
            f"{', '.join(names) or 'none'}. Give the rate of the sliding joint or the velocity.")
    dv = np.zeros(n)
    dv[g], dv[u] = dg, du
    dv = dv[free]
    out = v_in.copy()
    out[free] += dv
    residual = jac @ out + phit
    scale = np.max(np.abs(jac), axis=1) * max(np.max(np.abs(out)), np.max(np.abs(v_in))) + np.abs(phit)
    bad = np.abs(residual) > feasibility_tolerance * np.maximum(scale, 1e-300)
    if np.any(bad) or not np.all(np.isfinite(out)):
        names = sorted({owners[i] for i in np.flatnonzero(bad | ~np.isfinite(residual))}, key=owners.index)
        raise ConstraintError(
            f"the given initial velocities cannot satisfy the joints (largest residual of "
            f"Phi_q v + Phi_t {np.max(np.abs(residual)):.3g}); joints involved: "
            f"{', '.join(names)} (e.g. a held sliding joint given a non-zero rate)")

    kept = given & active
    change = np.abs(out - v_in) * kept
    largest_given = np.max(np.abs(v_in) * kept, initial=0.0)
    reference = max(largest_given, np.max(np.abs(out) * kept, initial=0.0))
    # nothing non-zero given (the default rest): what the joints set (prescribed motion)
    # is no change of a user's input, so no warning
    if largest_given > 0.0 and np.max(change, initial=0.0) > warn_tolerance * reference:
        worst: dict[str, float] = {}
        for i in np.flatnonzero(change > warn_tolerance * reference):
            worst[entities[i]] = max(worst.get(entities[i], 0.0), float(change[i]))
        listed = ", ".join(f"{e} by {c:.3g}" for e, c in worst.items())
        warnings.warn(
            f"the joints changed given initial velocities (kinetic-energy projection): {listed} "
            f"(largest given {np.max(np.abs(v_in) * kept, initial=0.0):.3g}; m/s, rad/s or 1/s)",
            VelocityProjectionWarning, stacklevel=3)
    return out


def assemble_state(system: System, state: State, *, tolerance: float = ASSEMBLY_TOLERANCE,
                   given=None, warn_tolerance: float = VELOCITY_WARN_TOLERANCE) -> State:
    """Project an initial state onto Φ(q, t) = 0 and then its velocities onto Φ̇ = 0.

    Positions (after checking the rank of Φ_q): where max|Φ| exceeds ``tolerance``,
    the nearest configuration on the joints in the mass metric,
    argmin ½ |p − q|²_M subject to Φ(p, t) = 0 (:func:`ancf_jax.dae.project_position`,
    by the root finder of the time steps, :data:`ASSEMBLY_NEWTON`); padding
    coordinates do not move. Velocities: the kinetic-energy projection of
    :func:`project_velocities`.

    Args:
        system: the assembled system.
        state: the initial state as given.
        tolerance: constraint residual max|Φ| accepted without position projection,
            and required after it [m or rad].
        given: which velocities were given, shape (n,) bool (default all; see
            :meth:`Model.given_velocities`).
        warn_tolerance: relative change of a given velocity that is warned about
            (:class:`~ancf_jax.errors.VelocityProjectionWarning`).

    Raises:
        ConstraintError: redundant joints, joints that cannot be satisfied together
            (conflicting), naming those with the largest residuals, or given rates
            the joints do not allow.
    """
    phi_fn, jac_fn, phit_fn = _jitted(system)
    t = jnp.asarray(state.t, float)
    q = np.array(state.q, float)
    check_constraint_rank(system, q, t)
    if system.n_constraints == 0:
        return state
    phi = np.asarray(phi_fn(system, jnp.asarray(q), t))
    if not np.max(np.abs(phi)) <= tolerance:
        q = np.array(_project_position(system, jnp.asarray(q), t, ASSEMBLY_NEWTON))
        phi = np.asarray(phi_fn(system, jnp.asarray(q), t))
    if not (np.all(np.isfinite(q)) and np.max(np.abs(phi)) <= tolerance):
        owners = system.constraint_owner()
        bad = np.where(np.isfinite(phi), np.abs(phi), np.inf)
        worst = np.argsort(-bad)[:4]
        names = sorted({owners[i] for i in worst if bad[i] > tolerance}, key=owners.index)
        raise ConstraintError(
            f"conflicting constraints: the joints cannot all be satisfied (largest residual "
            f"{np.max(bad):.3g}); joints involved: {', '.join(names)}")
    check_constraint_rank(system, q, t)
    v = project_velocities(system, q, state.v, t, given=given, warn_tolerance=warn_tolerance)
    return State(jnp.asarray(q), jnp.asarray(v), state.t)


def build_in_equilibrium(model: Model, *, load_steps: int = STATIC_DEFAULTS.load_steps, pad_to=None,
                         tolerance: float = STATIC_DEFAULTS.tolerance, check_stability: bool = True,
                         hold: bool | None = False, root_finder: ModifiedNewton | None = None):
    """Static equilibrium with every sliding joint held, then released.

    Builds the system with the holds (``hold=True``), solves the statics from the
    model's initial guess, and returns the system without holds together with the
    equilibrium as its initial state (paper §4.3: the trolley is released at t = 0).
    The initial velocities are the model's given ones (bodies, beams, sliding rates;
    by default at rest) projected at the equilibrium positions onto the joints of the
    returned system (:func:`project_velocities`): a trolley given ``rate`` starts
    with ṡ = rate.

    Newton's method converges to stable and unstable equilibria alike (e.g. a cabin
    standing upside down on its hinge); with ``check_stability`` the tangent stiffness
    of the held equilibrium is checked (constraints eliminated, as in modal analysis)
    and an unstable equilibrium raises a :class:`~ancf_jax.errors.StaticsError`.

    Args:
        hold: holds of the returned system: False releases every sliding joint, None
            keeps those added with ``hold=True``.
        load_steps: load increments of the static solve
            (:func:`~ancf_jax.statics.solve_static`; defaults
            :class:`~ancf_jax.statics.StaticSolver`).
        tolerance: its residual tolerance.
        root_finder: its root finder (default: full Newton on the structured Newton
            matrix, linear in the element count; for thousands of elements
            ``check_stability``'s dense modal analysis is the costly part).

    Returns:
        (released system, initial State, StaticSolution of the held system).

    Raises:
        ConstraintError: the given velocities or rates cannot satisfy the joints of
            the returned system (e.g. a held sliding joint given a non-zero rate).
    """
    from .errors import StaticsError
    from .modal import modal_analysis
    from .statics import solve_static
    # the held guess is assembled at rest (a given rate would violate the holds)
    held, guess = model.build(pad_to=pad_to, hold=True, assemble=False)
    guess = assemble_state(held, State(guess.q, jnp.zeros_like(guess.v), guess.t),
                           given=np.zeros(held.n_coordinates, bool))
    sol = solve_static(held, guess, load_steps=load_steps, tolerance=tolerance, root_finder=root_finder)
    if check_stability:
        w = modal_analysis(held, sol.state.q, sol.multipliers).angular_frequencies
        w2 = np.sign(w) * w * w
        worst = float(w2.min())
        if worst < -max(1e-12 * float(np.abs(w2).max()), 1e-9):
            raise StaticsError(
                "the static solution is an unstable equilibrium (a mode with negative "
                f"stiffness, omega^2 = {worst:.3g} 1/s^2, e.g. a hanging body turned upside "
                "down); start from a better initial guess", load_step=load_steps - 1,
                load_factor=1.0, residual=float(sol.residuals[-1]), state=sol.state)
    released, given_state = model.build(pad_to=pad_to, hold=hold, assemble=False)
    v = project_velocities(released, sol.state.q, given_state.v, 0.0,
                           given=model.given_velocities(released))
    state = State(sol.state.q, jnp.asarray(v), jnp.zeros(()))
    return released, state, sol
