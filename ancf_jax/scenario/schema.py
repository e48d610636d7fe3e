"""The typed schema of a scenario file (pydantic v2): every key, its type, unit,
default and range.

One class per TOML table; unknown keys are rejected (``extra="forbid"``) and types are
strict (a string is not a number, ``true`` is not 1). Units are SI and are stored on
each field (``unit``) for messages and for the generated documentation
(``docs/scenario-format.md``). Checks that involve several keys or names of other
entities (a joint naming a beam that does not exist, an arc length outside a beam)
are in :mod:`ancf_jax.scenario.checks`.
"""

from __future__ import annotations

import dataclasses

from typing import Annotated, ClassVar, Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field

from ..element.laws import NO_REST
from ..element.strain_energy import AXIAL_STRAINS, CURVATURES, METRICS, Formulation
from ..fatigue.analysis import METHODS as FATIGUE_METHODS, FatigueSettings
from ..fatigue.sn import CORRECTIONS, EUROCODE
from ..fatigue.stress import LAYOUTS
from ..outputs import COMPONENTS, DERIVATIVES
from ..integrate import DEFAULT_DT, RunOptions
from ..integrators.diffrax_solvers import DiffraxSolver
from ..integrators.generalized_alpha import GeneralizedAlpha
from ..integrators.explicit import RK4
from ..models.catenary import CUTOFF, CatenaryDesign, PantographDesign, Wire
from ..newton import ModifiedNewton
from ..simulation import DEFAULT_SOLVER, SOLVERS
from ..sliding import DEFAULT_REGULARIZATION
from ..statics import DEFAULTS as STATIC_DEFAULTS
from .types import Nodes4, Numbers, Points2, Quadrature, Side, TimeFunction, Vec2

#: current version of the file format
FORMAT_VERSION = 1
#: most elements of one beam
MAX_ELEMENTS = 2000


def key(default=..., *, unit: str = "", doc: str, **constraints):
    """A schema field with its unit [SI] and a one-line description."""
    return Field(default, description=doc, json_schema_extra={"unit": unit}, **constraints)


class Table(BaseModel):
    """Base of every table: strict types, unknown keys rejected, immutable."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


# ----------------------------------------------------------------------------- points
class PointRef(Table):
    """A point, named by entity: ``{ ground = [x, y] }``, ``{ body = "b" }`` (its centre),
    ``{ body = "b", local = [x, y] }``, ``{ body = "b", point = "p1" }`` (a named body
    point), ``{ beam = "a", node = -1 }`` (a node; −1 is the last) or
    ``{ beam = "a", s = 0.2 }`` (the material point at reference arc length s)."""

    accepts: ClassVar[str] = "a point (see Points)"

    ground: Optional[Vec2] = key(None, unit="m", doc="a fixed point of the ground")
    body: Optional[str] = key(None, doc="a rigid body's name")
    local: Optional[Vec2] = key(None, unit="m", doc="with body: point in the body frame (default its centre)")
    point: Optional[str] = key(None, doc="with body: name of a point of the body (its `points` table)")
    beam: Optional[str] = key(None, doc="a beam's name")
    node: Optional[int] = key(None, doc="with beam: node index, 0 the first, −1 the last")
    s: Optional[float] = key(None, unit="m", ge=0.0, allow_inf_nan=False,
                             doc="with beam: reference arc length from the first node")


# ----------------------------------------------------------------------------- beams
class Straight(Table):
    """A straight stress-free beam."""

    type: Literal["straight"] = key(doc="geometry type")
    start: Vec2 = key((0.0, 0.0), unit="m", doc="position of the first node")
    direction: Vec2 = key((1.0, 0.0), doc="direction from the first node (any non-zero length)")
    length: float = key(unit="m", gt=0.0, allow_inf_nan=False, doc="length L")


class ThroughPoints(Table):
    """A stress-free beam through given points with given slopes (one element per
    interval; element lengths are the arc lengths of the Hermite cubics)."""

    type: Literal["points"] = key(doc="geometry type")
    points: Points2 = key(unit="m", doc="node positions, at least 2")
    slopes: Points2 = key(doc="tangent directions at the nodes (normalized), as many as points")


class Arc(Table):
    """A stress-free circular arc, counter-clockwise if end_angle > start_angle."""

    type: Literal["arc"] = key(doc="geometry type")
    center: Vec2 = key(unit="m", doc="centre of the circle")
    radius: float = key(unit="m", gt=0.0, allow_inf_nan=False, doc="radius")
    start_angle: float = key(unit="rad", allow_inf_nan=False, doc="angle of the first node")
    end_angle: float = key(unit="rad", allow_inf_nan=False, doc="angle of the last node (≠ start_angle)")


Geometry = Annotated[Union[Straight, ThroughPoints, Arc], Field(discriminator="type")]


class SectionSpec(Table):
    """Cross-section and material. Give either E with A and I, or a diameter (solid
    circle) from which missing A and I follow; or the stiffnesses EA and EI as Exudyn
    takes them (then E is optional, for stresses only); and exactly one of
    mass_per_length, density, mass (density needs A)."""

    E: Optional[float] = key(None, unit="Pa", gt=0.0, allow_inf_nan=False,
                             doc="Young's modulus (required with A, I or diameter; with EA and EI "
                                 "only for stresses)")
    A: Optional[float] = key(None, unit="m²", gt=0.0, allow_inf_nan=False,
                             doc="area (default π d²/4 from diameter)")
    I: Optional[float] = key(None, unit="m⁴", gt=0.0, allow_inf_nan=False,
                             doc="second moment of area (default π d⁴/64 from diameter)")
    diameter: Optional[float] = key(None, unit="m", gt=0.0, allow_inf_nan=False,
                                    doc="diameter d of a solid circular section")
    mass_per_length: Optional[float] = key(None, unit="kg/m", gt=0.0, allow_inf_nan=False,
                                           doc="ρA")
    density: Optional[float] = key(None, unit="kg/m³", gt=0.0, allow_inf_nan=False,
                                   doc="ρ (ρA = ρ·A)")
    mass: Optional[float] = key(None, unit="kg", gt=0.0, allow_inf_nan=False,
                                doc="total mass of the beam (ρA = mass / L)")
    fibre: Optional[float] = key(None, unit="m", gt=0.0, allow_inf_nan=False,
                                 doc="outer-fibre distance for stresses (default d/2, else √(2I/A))")
    EA: Optional[float] = key(None, unit="N", gt=0.0, allow_inf_nan=False,
                              doc="axial stiffness (instead of E·A; give EI too)")
    EI: Optional[float] = key(None, unit="N·m²", gt=0.0, allow_inf_nan=False,
                              doc="bending stiffness (instead of E·I; give EA too)")


class FormulationSpec(Table):
    """Strain measures and quadrature rules of the element energy (paper Eq. 8)."""

    axial_strain: Literal[AXIAL_STRAINS] = key(Formulation.axial_strain, doc="axial strain measure")
    curvature: Literal[CURVATURES] = key(Formulation.curvature, doc="curvature: exact (Eq. 16), material, "
                                                                   "small_strain (Eq. 17, straight beams only)")
    axial_quadrature: Quadrature = key(Formulation.axial_quadrature, doc="[kind, points] of the axial term")
    bending_quadrature: Quadrature = key(Formulation.bending_quadrature, doc="[kind, points] of the bending term")
    metric: Literal[METRICS] = key(Formulation.metric, doc="strains per unit reference arc length, or per unit "
                                                          "element parameter (Exudyn's strainIsRelativeToReference)")


class LinearLawSpec(Table):
    """Linear elastic: N = EA ε (axial), M = EI (κ − κ₀) (bending), the default."""

    type: Literal["linear"] = key(doc="law type")


class StrainRateDampedLawSpec(Table):
    """Linear elastic with strain-rate damping, N = EA (ε − ε₀) + d ε̇ (Exudyn's axialDamping
    and bendingDamping, referenceAxialStrain and referenceCurvature); the rate term is a
    dissipation."""

    type: Literal["strain_rate_damped"] = key(doc="law type")
    damping: float = key(unit="N·s or N·m²·s", ge=0.0, allow_inf_nan=False, doc="d (d_A axial, d_K bending)")
    rest: float = key(NO_REST, unit="- or 1/m", allow_inf_nan=False,
                      doc="natural strain ε₀ or curvature change κ₀ where the law is stress-free")


class BilinearLawSpec(Table):
    """Different stiffness in tension and compression: N = k_t γ (γ ≥ 0), k_c γ (γ < 0);
    the section's EA or EI is not used."""

    type: Literal["bilinear"] = key(doc="law type")
    tension: float = key(unit="N or N·m²", gt=0.0, allow_inf_nan=False, doc="k_t")
    compression: float = key(unit="N or N·m²", gt=0.0, allow_inf_nan=False, doc="k_c")


class TabulatedLawSpec(Table):
    """A nonlinear elastic law N(γ) piecewise linear through [γ, N] rows (increasing, through
    [0, 0]), extended with the end slopes; the energy is its exact integral."""

    type: Literal["tabulated"] = key(doc="law type")
    table: Points2 = key(unit="-, N or 1/m, N·m", doc="rows [strain, force] (axial) or [curvature change, moment]")


Law = Annotated[Union[LinearLawSpec, StrainRateDampedLawSpec, BilinearLawSpec, TabulatedLawSpec],
                Field(discriminator="type")]


class BeamInitial(Table):
    """Initial shape and velocity of a beam (default: its stress-free reference, at rest)."""

    shape: Literal["reference", "catenary", "nodes"] = key(
        "reference", doc="reference: stress-free geometry; catenary: inextensible catenary "
                         "between start and end (a guess for a slack cable); nodes: given")
    start: Optional[Vec2] = key(None, unit="m", doc="catenary: first end (default the first node)")
    end: Optional[Vec2] = key(None, unit="m", doc="catenary: last end (required), right of start")
    nodes: Optional[Nodes4] = key(None, unit="m, -", doc="nodes: initial nodal coordinates, (n+1) rows")
    velocity: Vec2 = key((0.0, 0.0), unit="m/s", doc="uniform initial velocity of every node")
    velocities: Optional[Nodes4] = key(None, unit="m/s, 1/s",
                                       doc="initial nodal velocities, (n+1) rows (instead of velocity)")


class AttachedMassSpec(Table):
    """A point mass fixed to a material point of the beam (a clamp or spacer on a wire),
    translation only: consistent added mass m Sᵀ S and its weight."""

    s: float = key(unit="m", ge=0.0, allow_inf_nan=False, doc="reference arc length (0..L)")
    mass: float = key(unit="kg", gt=0.0, allow_inf_nan=False, doc="m")


class BeamSpec(Table):
    """An ANCF beam or cable (paper Eqs. 1–11)."""

    geometry: Geometry = key(doc="stress-free reference geometry: type = straight, points or arc")
    elements: Optional[int] = key(None, ge=1, le=MAX_ELEMENTS,
                                  doc="number of elements (points: one per interval, the default)")
    section: SectionSpec = key(doc="cross-section and material")
    alpha: float = key(0.0, unit="1/s", ge=0.0, allow_inf_nan=False,
                       doc="Rayleigh mass-proportional damping α (Eq. 11)")
    beta: float = key(0.0, unit="s", ge=0.0, allow_inf_nan=False,
                      doc="Rayleigh stiffness-proportional damping β (Eq. 11)")
    formulation: FormulationSpec = key(FormulationSpec(), doc="strain measures and quadrature")
    initial: BeamInitial = key(BeamInitial(), doc="initial shape and velocity")
    gravity: bool = key(True, doc="whether gravity acts on this beam")
    axial_law: Optional[Law] = key(None, doc="material law N(ε, ε̇) (default linear: N = EA ε)")
    bending_law: Optional[Law] = key(None, doc="material law M(κ, κ̇) (default linear: M = EI (κ − κ₀); "
                                               "others need curvature exact or material)")
    masses: list[AttachedMassSpec] = key([], doc="point masses fixed to the beam (clamps), "
                                                 "as [[beams.NAME.masses]] tables")


# ----------------------------------------------------------------------------- bodies
class BodySpec(Table):
    """A rigid body (paper Eq. 14): coordinates x, y of its centre and angle θ; or, with
    point_mass = true, a point mass (translation only, no inertia, angle or points)."""

    mass: float = key(unit="kg", gt=0.0, allow_inf_nan=False, doc="mass m")
    inertia: Optional[float] = key(None, unit="kg·m²", gt=0.0, allow_inf_nan=False,
                                   doc="moment of inertia J about the centre (required unless point_mass)")
    position: Optional[Vec2] = key(None, unit="m", doc="initial position of the centre (default [0, 0])")
    at: Optional[PointRef] = key(None, doc="instead of position: the centre starts at this point of a "
                                           "beam's initial shape or of a body declared earlier")
    angle: float = key(0.0, unit="rad", allow_inf_nan=False, doc="initial angle θ")
    velocity: Optional[Vec2] = key(None, unit="m/s", doc="initial velocity of the centre (default: not "
                                                         "given, set by the joints, else 0)")
    angular_velocity: Optional[float] = key(None, unit="rad/s", allow_inf_nan=False,
                                            doc="initial angular velocity (default: not given, set by "
                                                "the joints, else 0)")
    points: dict[str, Vec2] = key({}, unit="m", doc="named points in the body frame, e.g. { hook = [0, 0.5] }")
    point_mass: bool = key(False, doc="a point mass (Exudyn's MassPoint2D): translation only; fixed joints, "
                                      "torques and points away from the centre are refused")
    gravity: bool = key(True, doc="whether gravity acts on this body")


# ----------------------------------------------------------------------------- joints
class ClampSpec(Table):
    """Clamp a beam node to the ground at its initial position and slope."""

    type: Literal["clamp"] = key(doc="joint type")
    beam: str = key(doc="beam name")
    node: int = key(0, doc="node index (−1: the last)")
    mode: Literal["full", "direction", "exudyn"] = key(
        "full", doc="full: slope vector fixed (4 equations); direction: slope direction only (3); "
                    "exudyn: x, y and r'_y fixed (3, Exudyn's clamp)")


class PinSpec(Table):
    """Pin a point to the ground: position fixed, rotation free."""

    type: Literal["pin"] = key(doc="joint type")
    point: PointRef = key(doc="the pinned point")
    location: Optional[Vec2] = key(None, unit="m", doc="ground location (default: the point's initial position)")


class RevoluteSpec(Table):
    """Two points (of bodies or beams) coincide, rotation free."""

    type: Literal["revolute"] = key(doc="joint type")
    a: PointRef = key(doc="first point")
    b: PointRef = key(doc="second point")


class FixedSpec(Table):
    """Rigid connection of a beam node (or body point) to a body: the body rotates with
    the beam slope there. Without ``local`` the body's centre must start at ``point``
    (a body placed elsewhere would be welded on through an invisible rigid arm, so it
    is refused); give ``local`` for an intended arm."""

    type: Literal["fixed"] = key(doc="joint type")
    point: PointRef = key(doc="the beam node (or body point) the body is fixed to")
    body: str = key(doc="body name")
    local: Optional[Vec2] = key(None, unit="m", doc="the body point held at `point`, in the body frame (default: "
                                                    "the centre, which must then start at `point`); give it for "
                                                    "a rigid arm between the body and the point")


class FrictionSpec(Table):
    """Regularized Coulomb friction along a beam: F = −μ N tanh(u/v_ε) − c u, u the
    sliding speed; on a sliding joint (named ``JOINT.friction``) N is the joint's normal
    reaction and F acts on the body, on a contact N is the contact's normal force and F
    acts on the point."""

    mu: float = key(unit="-", ge=0.0, allow_inf_nan=False, doc="friction coefficient μ")
    regularization: float = key(DEFAULT_REGULARIZATION, unit="m/s", gt=0.0, allow_inf_nan=False,
                                doc="v_ε: a body held by friction creeps at v_ε artanh(F/(μN))")
    viscous: float = key(0.0, unit="N·s/m", ge=0.0, allow_inf_nan=False, doc="c, a viscous part")


class DriveSpec(Table):
    """A drive of a sliding joint (named ``JOINT.drive``), exactly one of: ``position``
    (the arc length s(t) is prescribed; the drive force is its reaction), ``force`` (a
    tangential force on the body along +s, scaled by ``time_function``) or ``speed`` (a
    velocity servo F = F_max tanh(k (u* − u)/F_max), with ``gain`` and ``max_force``)."""

    position: Optional[TimeFunction] = key(None, unit="m", doc="s(t)")
    force: Optional[float] = key(None, unit="N", allow_inf_nan=False, doc="tangential force F along +s")
    time_function: Optional[TimeFunction] = key(None, doc="with force: scale f(t) (default 1)")
    speed: Optional[TimeFunction] = key(None, unit="m/s", doc="servo: the sliding speed u*(t) along +s")
    gain: Optional[float] = key(None, unit="N·s/m", gt=0.0, allow_inf_nan=False, doc="servo: gain k")
    max_force: Optional[float] = key(None, unit="N", gt=0.0, allow_inf_nan=False, doc="servo: force limit F_max")


class SlidingSpec(Table):
    """Sliding joint (paper §4, Eqs. 19–21): a body point stays on a beam's centre line
    at the sliding coordinate s; frictionless and free unless ``friction`` or ``drive``
    is given."""

    type: Literal["sliding"] = key(doc="joint type")
    body: str = key(doc="body name")
    beam: str = key(doc="beam name")
    s: float = key(unit="m", ge=0.0, allow_inf_nan=False, doc="initial arc length s₀ along the beam (0..L)")
    local: Vec2 = key((0.0, 0.0), unit="m", doc="the sliding point in the body frame")
    rate: Optional[float] = key(None, unit="m/s", allow_inf_nan=False,
                                doc="initial ṡ, kept exactly (default: not given, set by the joints "
                                    "and the given velocities)")
    hold: bool = key(False, doc="false: held at s₀ only while the static equilibrium is found "
                                "(initial.mode = static), free from t = 0; true: held for the whole run")
    friction: Optional[FrictionSpec] = key(None, doc="Coulomb friction (default none)")
    drive: Optional[DriveSpec] = key(None, doc="a drive (default none: free)")


class CoordinateSpec(Table):
    """One coordinate of a beam node or a body held at a value or following a function
    of time (Exudyn's CoordinateConstraint to the ground)."""

    type: Literal["coordinate"] = key(doc="joint type")
    point: PointRef = key(doc="a beam node { beam, node } or a body's centre { body }")
    component: Literal["x", "y", "slope_x", "slope_y", "theta"] = key(
        doc="node: x, y, slope_x, slope_y (r_x, r_y, r'_x, r'_y); body: x, y, theta")
    value: Optional[float] = key(None, unit="m, -, rad", allow_inf_nan=False,
                                 doc="value held (default the initial value)")
    function: Optional[TimeFunction] = key(None, unit="m, -, rad", doc="instead of value: the value over time")


class PrescribedPointSpec(Table):
    """A point follows (x(t), y(t)) [m]."""

    type: Literal["prescribed_point"] = key(doc="joint type")
    point: PointRef = key(doc="the driven point")
    x: TimeFunction = key(unit="m", doc="x(t)")
    y: TimeFunction = key(unit="m", doc="y(t)")


class PrescribedBodySpec(Table):
    """A coordinate of a body follows a function of time."""

    type: Literal["prescribed_body"] = key(doc="joint type")
    body: str = key(doc="body name")
    coordinate: Literal["x", "y", "theta"] = key(doc="the driven coordinate")
    value: TimeFunction = key(unit="m or rad", doc="its value over time")


Joint = Annotated[Union[ClampSpec, PinSpec, RevoluteSpec, FixedSpec, SlidingSpec,
                        PrescribedPointSpec, PrescribedBodySpec, CoordinateSpec],
                  Field(discriminator="type")]


# ----------------------------------------------------------------------------- loads
class PointForceSpec(Table):
    """A force of fixed direction at a point, F·f(t)."""

    type: Literal["point_force"] = key(doc="load type")
    point: PointRef = key(doc="where it acts")
    force: Vec2 = key(unit="N", doc="force vector F")
    time_function: Optional[TimeFunction] = key(None, doc="scale f(t) (default 1)")


class TorqueSpec(Table):
    """A torque τ·f(t) on a body."""

    type: Literal["torque"] = key(doc="load type")
    body: str = key(doc="body name")
    torque: float = key(unit="N·m", allow_inf_nan=False, doc="torque τ (counter-clockwise positive)")
    time_function: Optional[TimeFunction] = key(None, doc="scale f(t) (default 1)")


class SpringDamperSpec(Table):
    """Linear spring-damper between two points: tension k (ℓ − ℓ₀) + c ℓ̇. The points must
    start apart (at zero length the spring's direction is undefined: refused)."""

    type: Literal["spring_damper"] = key(doc="load type")
    a: PointRef = key(doc="first point")
    b: PointRef = key(doc="second point")
    stiffness: float = key(unit="N/m", ge=0.0, allow_inf_nan=False, doc="k")
    damping: float = key(0.0, unit="N·s/m", ge=0.0, allow_inf_nan=False, doc="c")
    rest_length: Optional[float] = key(None, unit="m", ge=0.0, allow_inf_nan=False,
                                       doc="ℓ₀ (default: the initial distance)")
    acts: Literal["both", "tension", "compression"] = key(
        "both", doc="both; tension: a rope, dropper or hanger (slack while ℓ < ℓ₀); compression: "
                    "a stop or buffer (open while ℓ > ℓ₀). One-sided members damp only while engaged "
                    "and never push (pull)")


class MassProportionalSpec(Table):
    """A load m·a·f(t) on one beam or body only (Exudyn's LoadMassProportional): on a body
    at its centre, on a beam the consistent load of ρA·a."""

    type: Literal["mass_proportional"] = key(doc="load type")
    item: str = key(doc="a beam's or body's name")
    acceleration: Vec2 = key(unit="m/s²", doc="acceleration a")
    time_function: Optional[TimeFunction] = key(None, doc="scale f(t) (default 1)")


PROFILE_DOC = "a deviation [m] added to start + speed·t (default none)"


class MovingForceSpec(Table):
    """A force of fixed direction F·f(t) that moves along a beam: it acts at the material
    point under the position p(t) = start + speed·t (+ profile(t)) [m], the horizontal
    coordinate x of the loaded point (along = "x": a vehicle at x = x₀ + v t) or its
    reference arc length (along = "arc_length"); zero while that point is off the beam (a
    load entering at one end and leaving at the other). With along = "x" the beam's x must
    be monotonic along it (a track, rope or wire)."""

    type: Literal["moving_force"] = key(doc="load type")
    beam: str = key(doc="beam name")
    force: Vec2 = key(unit="N", doc="force vector F")
    along: Literal["x", "arc_length"] = key("x", doc="x: p is the loaded point's horizontal coordinate; "
                                                     "arc_length: its reference arc length")
    start: float = key(unit="m", allow_inf_nan=False, doc="p(0)")
    speed: float = key(unit="m/s", allow_inf_nan=False, doc="v, dp/dt without the profile")
    profile: Optional[TimeFunction] = key(None, unit="m", doc=PROFILE_DOC)
    time_function: Optional[TimeFunction] = key(None, doc="scale f(t) (default 1)")


class ContactSpec(Table):
    """Unilateral penalty contact between a point and a beam at the beam's closest point:
    normal force k δ + max(c δ̇, −k δ) while the penetration δ > 0, else 0 (it never pulls);
    gap g = side·n̂·(p − r(s*)) − offset, n̂ the beam's left normal. No contact while the
    closest point is beyond an end of the beam. The beam's x must be monotonic along it
    (the search starts under the point's x)."""

    type: Literal["contact"] = key(doc="load type")
    point: PointRef = key(doc="the contacting point (e.g. the head of a chain: { body = \"pan.2\" })")
    beam: str = key(doc="beam name")
    stiffness: Optional[float] = key(None, unit="N/m", gt=0.0, allow_inf_nan=False,
                                     doc="penalty stiffness k (default: 100 times the beam's static stiffness "
                                         "where the point touches it, docs/moving-loads.md)")
    damping: float = key(0.0, unit="N·s/m", ge=0.0, allow_inf_nan=False, doc="c")
    side: Side = key(1, doc="the side of the beam the point is on: 1 on the side of the left normal "
                            "(above a beam running in +x), -1 the other (below: a pantograph under a wire)")
    offset: float = key(0.0, unit="m", ge=0.0, allow_inf_nan=False,
                        doc="g₀, the gap at which contact begins (radii)")
    friction: Optional[FrictionSpec] = key(None, doc="Coulomb friction along the beam (default none)")


Load = Annotated[Union[PointForceSpec, TorqueSpec, SpringDamperSpec, MassProportionalSpec, MovingForceSpec,
                       ContactSpec],
                 Field(discriminator="type")]


# ----------------------------------------------------------------------------- moving masses, chains
class MovingMassSpec(Table):
    """A point mass (a body named NAME, translation only) moving along a beam at a
    prescribed position p(t) = start + speed·t (+ profile(t)) [m]: the horizontal
    coordinate x of the mass (along = "x") or its reference arc length
    (along = "arc_length"). It rides on the sliding joint NAME.slider (which carries its
    inertia, with the convective terms of the moving point) driven by the constraint
    NAME.drive. The path must keep the mass on the beam for the whole run."""

    beam: str = key(doc="beam name")
    mass: float = key(unit="kg", gt=0.0, allow_inf_nan=False, doc="m")
    along: Literal["x", "arc_length"] = key("x", doc="x: p is the mass's horizontal coordinate; "
                                                     "arc_length: its reference arc length on the beam")
    start: float = key(unit="m", allow_inf_nan=False, doc="p(0): where the mass starts")
    speed: float = key(unit="m/s", allow_inf_nan=False, doc="v, dp/dt without the profile")
    profile: Optional[TimeFunction] = key(None, unit="m", doc=PROFILE_DOC)
    gravity: bool = key(True, doc="whether gravity acts on the mass")


class ChainSpec(Table):
    """A vertical chain of point masses joined by spring-dampers: a current collector
    (pantograph) or a suspension. The i-th mass (a point-mass body named NAME.i, i = 1 at
    the bottom) starts at the i-th height above the base; stage i (NAME.stage<i>, a
    spring-damper along +y, unstressed as built) joins mass i to mass i − 1 (stage 1: to
    the base point); the i-th force acts on mass i along +y (e.g. the static uplift). The
    masses move vertically; their x is held at the base's x, or follows
    start + speed·t (+ profile(t)) when speed or profile is given (a vehicle)."""

    base: Vec2 = key(unit="m", doc="the base point (x, y)")
    heights: Numbers = key(unit="m", doc="y of each mass above the base, positive and increasing")
    masses: Numbers = key(unit="kg", doc="m_i > 0, one per height")
    stiffness: Numbers = key(unit="N/m", doc="k_i >= 0 of each stage, one per height")
    damping: Optional[Numbers] = key(None, unit="N·s/m", doc="c_i >= 0 of each stage (default 0)")
    forces: Optional[Numbers] = key(None, unit="N", doc="constant force along +y on each mass (default 0)")
    start: Optional[float] = key(None, unit="m", allow_inf_nan=False,
                                 doc="with speed or profile: x of the masses at t = 0 (default the base's x)")
    speed: Optional[float] = key(None, unit="m/s", allow_inf_nan=False,
                                 doc="horizontal speed v of the masses (default: x held at the base's x)")
    profile: Optional[TimeFunction] = key(None, unit="m", doc=PROFILE_DOC)
    gravity: bool = key(True, doc="whether gravity acts on the masses")


# ----------------------------------------------------------------------------- catenary, pantograph
_CAT, _PAN = CatenaryDesign(), PantographDesign()


class WireSpec(Table):
    """A pre-tensioned wire of a catenary."""

    tension: float = key(unit="N", gt=0.0, allow_inf_nan=False, doc="horizontal tension H of the design state")
    mass_per_length: float = key(unit="kg/m", gt=0.0, allow_inf_nan=False, doc="ρA")
    axial_stiffness: float = key(unit="N", gt=0.0, allow_inf_nan=False, doc="EA")
    bending_stiffness: float = key(unit="N·m²", gt=0.0, allow_inf_nan=False, doc="EI")


def _wire(w) -> WireSpec:
    return WireSpec(**dataclasses.asdict(w))


class CatenarySpec(Table):
    """A simple railway catenary along +x from x = 0 (beams catenary.contact and
    catenary.messenger, droppers catenary.dropper<k>; see docs/pantograph-catenary.md),
    started in its design equilibrium and solved statically at t = 0
    (initial.mode = "static"). Defaults: the model data of the shipped
    pantograph_catenary scenario."""

    spans: int = key(_CAT.spans, ge=1, le=100, doc="number of equal spans")
    span_length: float = key(_CAT.span_length, unit="m", gt=0.0, allow_inf_nan=False, doc="distance between poles")
    height: float = key(_CAT.height, unit="m", gt=0.0, allow_inf_nan=False, doc="contact-wire height at the poles")
    encumbrance: float = key(_CAT.encumbrance, unit="m", gt=0.0, allow_inf_nan=False,
                             doc="messenger height above the contact wire at the poles")
    presag: float = key(_CAT.presag, unit="m", ge=0.0, allow_inf_nan=False,
                        doc="contact-wire sag at mid-span (parabola through the droppers)")
    droppers: Numbers = key(_CAT.droppers, unit="m", doc="dropper positions in a span from its first pole, "
                                                         "increasing, inside the span")
    dropper_stiffness: float = key(_CAT.dropper_stiffness, unit="N/m", gt=0.0, allow_inf_nan=False,
                                   doc="dropper stiffness in tension (slack in compression)")
    dropper_damping: float = key(_CAT.dropper_damping, unit="N·s/m", ge=0.0, allow_inf_nan=False,
                                 doc="dropper damping while taut")
    dropper_mass: float = key(_CAT.dropper_mass, unit="kg", ge=0.0, allow_inf_nan=False,
                              doc="dropper mass, half at each end")
    contact_clamp_mass: float = key(_CAT.contact_clamp_mass, unit="kg", ge=0.0, allow_inf_nan=False,
                                    doc="dropper clamp on the contact wire")
    messenger_clamp_mass: float = key(_CAT.messenger_clamp_mass, unit="kg", ge=0.0, allow_inf_nan=False,
                                      doc="dropper clamp on the messenger")
    contact: WireSpec = key(_wire(_CAT.contact), doc="the contact wire")
    messenger: WireSpec = key(_wire(_CAT.messenger), doc="the messenger wire")
    support_stiffness: float = key(_CAT.support_stiffness, unit="N/m", gt=0.0, allow_inf_nan=False,
                                   doc="vertical stiffness of the messenger's intermediate supports")
    steady_arm_stiffness: float = key(_CAT.steady_arm_stiffness, unit="N/m", ge=0.0, allow_inf_nan=False,
                                      doc="vertical stiffness of a steady arm (0: none)")
    steady_arm_mass: float = key(_CAT.steady_arm_mass, unit="kg", ge=0.0, allow_inf_nan=False,
                                 doc="steady-arm mass on the contact wire")
    element_length: float = key(_CAT.element_length, unit="m", gt=0.0, allow_inf_nan=False,
                                doc="longest element of both wires")
    alpha: float = key(_CAT.alpha, unit="1/s", ge=0.0, allow_inf_nan=False, doc="Rayleigh α of both wires")
    beta: float = key(_CAT.beta, unit="s", ge=0.0, allow_inf_nan=False, doc="Rayleigh β of both wires")

    def design(self) -> CatenaryDesign:
        """The builder's :class:`~ancf_jax.models.catenary.CatenaryDesign`."""
        d = self.model_dump()
        d["droppers"] = tuple(d["droppers"])
        d["contact"], d["messenger"] = Wire(**d["contact"]), Wire(**d["messenger"])
        return CatenaryDesign(**d)


class PantographSpec(Table):
    """A lumped-mass pantograph (point masses pantograph.1 … bottom to head) running
    under the catenary's contact wire at speed_kmh, in penalty contact with it
    (pantograph.contact), pushed up by F0 + c_aero v², and trailing pantographs of
    the same design (pantograph2, ...). The run ends when the last pantograph is one
    span past the evaluated spans (or at solver.t_end if earlier); `ancf-jax run`
    writes statistics.json, contact_force.csv and the figures, and with
    `--set pantograph.speed_kmh=[V1, V2, ...]` runs the speeds as single runs over threads
    (docs/pantograph-catenary.md)."""

    masses: Numbers = key(_PAN.masses, unit="kg", doc="m_i > 0 from the bottom (frame) to the head")
    stiffness: Numbers = key(_PAN.stiffness, unit="N/m", doc="k_i >= 0 of the stage below each mass")
    damping: Numbers = key(_PAN.damping, unit="N·s/m", doc="c_i >= 0 of the stage below each mass")
    uplift: float = key(_PAN.uplift, unit="N", gt=0.0, allow_inf_nan=False,
                        doc="static uplift force F0 on the bottom mass (the masses carry no weight)")
    aero_coefficient: float = key(_PAN.aero_coefficient, unit="N/(m/s)²", allow_inf_nan=False,
                                  doc="aerodynamic uplift c_aero: the uplift is F0 + c_aero v² at speed v "
                                      "(EN 50367; negative: a downforce)")
    contact_stiffness: float = key(_PAN.contact_stiffness, unit="N/m", gt=0.0, allow_inf_nan=False,
                                   doc="penalty stiffness of the head-wire contact")
    contact_damping: float = key(_PAN.contact_damping, unit="N·s/m", ge=0.0, allow_inf_nan=False,
                                 doc="damping of the head-wire contact")
    speed_kmh: float = key(250.0, unit="km/h", gt=0.0, le=600.0, allow_inf_nan=False, doc="train speed")
    start: Optional[float] = key(None, unit="m", gt=0.0, allow_inf_nan=False,
                                 doc="x of the (leading) pantograph at t = 0 (default: the last pantograph at "
                                     "a tenth of the first dropper's distance)")
    trailing: Optional[Numbers] = key(None, unit="m", doc="trailing pantographs of the same design (pantograph2, "
                                                         "...): their distances behind the leading one, "
                                                         "increasing (e.g. [200.0]: double traction)")
    spans: Optional[list[int]] = key(None, doc="[first, last] evaluated span, 1-based (default the two "
                                               "central spans of four or more, else the last)")
    cutoff: float = key(CUTOFF, unit="Hz", gt=0.0, allow_inf_nan=False, doc="low-pass cut-off of the statistics")

    def design(self) -> PantographDesign:
        """The builder's :class:`~ancf_jax.models.catenary.PantographDesign`."""
        return PantographDesign(masses=tuple(self.masses), stiffness=tuple(self.stiffness),
                                damping=tuple(self.damping), uplift=self.uplift,
                                aero_coefficient=self.aero_coefficient, contact_stiffness=self.contact_stiffness,
                                contact_damping=self.contact_damping)


# ----------------------------------------------------------------------------- state, solvers
class InitialSpec(Table):
    """How the initial state is obtained."""

    mode: Literal["given", "static"] = key(
        "given", doc="given: as written (assembled onto the joints); static: static equilibrium "
                     "under the loads at t = 0 with every sliding joint held, with the given "
                     "velocities and rates (default at rest) projected onto the joints")


class StaticsSpec(Table):
    """Static solver settings (initial.mode = static, and `ancf-jax static`): full Newton
    on the structured Newton matrix with load stepping, defaults those of
    `ancf_jax.statics.StaticSolver`."""

    load_steps: int = key(STATIC_DEFAULTS.load_steps, ge=1, le=1000, doc="equal load increments")
    time: float = key(0.0, unit="s", ge=0.0, allow_inf_nan=False,
                      doc="time at which time functions are evaluated by `ancf-jax static` and "
                          "modal about = equilibrium (the static initial state always uses t = 0)")
    tolerance: float = key(STATIC_DEFAULTS.tolerance, gt=0.0, allow_inf_nan=False,
                           doc="residual tolerance, relative to the largest load (also converged when "
                               f"the Newton correction is below {STATIC_DEFAULTS.step_tolerance:g} of the "
                               "model size)")


class ModalSpec(Table):
    """Modal analysis settings (`ancf-jax modal`)."""

    modes: int = key(10, ge=1, le=1000, doc="number of lowest modes reported")
    about: Literal["initial", "equilibrium"] = key(
        "initial", doc="initial: about the initial state (unloaded stiffness); equilibrium: about "
                       "the static equilibrium, with the stress stiffness")


def _default(cls, name: str) -> str:
    """The default of field ``name`` of a solver class, as the docs print it (the
    defaults are written once, in the classes)."""
    value = {f.name: f.default for f in dataclasses.fields(cls)}[name]
    return str(value).lower() if isinstance(value, bool) else f"{value:g}"


LINEAR_SOLVER_DOC = ("linear solver: auto (chosen from the structure: bordered for beams), bordered "
                     "(block-tridiagonal chain with a dense border), dense (LU of the whole matrix; "
                     "for GPU batches; on the CPU the bordered solver is faster, M1 included) (default auto)")


class GeneralizedAlphaOptions(Table):
    """Options of the generalized-α solver (each defaults to the solver's own default)."""

    rho_inf: Optional[float] = key(None, ge=0.0, le=1.0, allow_inf_nan=False,
                                   doc=f"spectral radius at infinity (default {_default(GeneralizedAlpha, 'rho_inf')})")
    newton_tol: Optional[float] = key(None, unit="m", gt=0.0, allow_inf_nan=False,
                                      doc="Newton tolerance on the position correction "
                                          f"(default {_default(ModifiedNewton, 'tolerance')})")
    max_iterations: Optional[int] = key(None, ge=1, le=1000, doc="Newton iterations per step "
                                        f"(default {_default(ModifiedNewton, 'max_iterations')})")
    refresh_every: Optional[int] = key(None, ge=1, le=1000, doc="refactor after this many iterations "
                                       f"(default {_default(ModifiedNewton, 'refresh_every')})")
    contraction: Optional[float] = key(None, ge=0.0, lt=1.0, allow_inf_nan=False,
                                       doc="refactor when a correction shrinks by less; 0: full Newton "
                                           f"(default {_default(ModifiedNewton, 'contraction')})")
    refresh_first: Optional[bool] = key(None, doc="refactor after the first correction of every step "
                                                  f"(default {_default(ModifiedNewton, 'refresh_first')}; "
                                                  "for steps whose predictor is far off)")
    velocity_projection: Optional[bool] = key(None, doc="project velocities onto the constraints "
                                              f"(default {_default(GeneralizedAlpha, 'velocity_projection')})")
    index: Optional[Literal[2, 3]] = key(None, doc="constraint level: 3 positions, 2 velocities (Exudyn's "
                                                   "useIndex2Constraints; positions drift at O(h²): raise "
                                                   "drift_tolerance) "
                                                   f"(default {GeneralizedAlpha().constraints.index})")
    linear_solver: Optional[Literal["auto", "bordered", "dense"]] = key(None, doc=LINEAR_SOLVER_DOC)
    reuse_factors: Optional[int] = key(None, ge=1, le=1000000,
                                       doc="carry the Newton matrix's factors across steps, refactoring after at "
                                           "most this many steps, when the step changes and when Newton contracts "
                                           "slowly (default: factored at every step; faster for taut cables "
                                           "moving little per step, slower for M1: docs/theory.md)")


class ExplicitOptions(Table):
    """Options of the explicit solvers (rk4, explicit-euler; the same defaults)."""

    projection: Optional[bool] = key(None, doc="project onto the constraints after each step "
                                     f"(default {_default(RK4, 'projection')})")
    baumgarte: Optional[float] = key(None, unit="rad/s", ge=0.0, allow_inf_nan=False,
                                     doc=f"Baumgarte ω (default {_default(RK4, 'baumgarte')})")
    linear_solver: Optional[Literal["auto", "bordered", "dense"]] = key(None, doc=LINEAR_SOLVER_DOC)


class DiffraxOptions(Table):
    """Options of the adaptive diffrax solvers (tsit5, dopri5, kvaerno5)."""

    rtol: Optional[float] = key(None, gt=0.0, allow_inf_nan=False,
                                doc=f"relative tolerance (default {_default(DiffraxSolver, 'rtol')})")
    atol: Optional[float] = key(None, gt=0.0, allow_inf_nan=False,
                                doc=f"absolute tolerance (default {_default(DiffraxSolver, 'atol')})")
    max_steps: Optional[int] = key(None, ge=1, doc="steps per output chunk "
                                   f"(default {_default(DiffraxSolver, 'max_steps')})")
    baumgarte: Optional[float] = key(None, unit="rad/s", ge=0.0, allow_inf_nan=False,
                                     doc=f"Baumgarte ω (default {_default(DiffraxSolver, 'baumgarte')})")
    linear_solver: Optional[Literal["auto", "bordered", "dense"]] = key(None, doc=LINEAR_SOLVER_DOC)


#: the options table that applies to each solver (the others are checked, not used)
SOLVER_TABLES = {"generalized-alpha": "generalized_alpha", "rk4": "rk4",
                 "explicit-euler": "explicit_euler", "tsit5": "diffrax",
                 "dopri5": "diffrax", "kvaerno5": "diffrax"}


class SolverSpec(Table):
    """Time integration: solver, step, span and tolerances. Each solver has its own
    options table; only the chosen solver's table is used, so `--set solver.name=...`
    switches solvers without editing the file."""

    name: Literal[SOLVERS] = key(DEFAULT_SOLVER, doc="time integrator")
    dt: float = key(DEFAULT_DT, unit="s", gt=0.0, allow_inf_nan=False,
                    doc="step (fixed-step solvers) or initial step (adaptive)")
    t_end: float = key(unit="s", gt=0.0, allow_inf_nan=False, doc="end time; the run starts at t = 0")
    drift_tolerance: float = key(RunOptions.drift_tolerance, unit="m", gt=0.0, allow_inf_nan=False,
                                 doc="stop when max|Φ| exceeds this")
    locate_crossings: bool = key(RunOptions.locate_crossings, doc="split steps at node crossings of sliding joints, slack/taut kinks of one-sided members and contacts, and friction reversals")
    generalized_alpha: GeneralizedAlphaOptions = key(GeneralizedAlphaOptions(),
                                                     doc="options used when name = generalized-alpha")
    rk4: ExplicitOptions = key(ExplicitOptions(), doc="options used when name = rk4")
    explicit_euler: ExplicitOptions = key(ExplicitOptions(), doc="options used when name = explicit-euler")
    diffrax: DiffraxOptions = key(DiffraxOptions(), doc="options used when name = tsit5, dopri5 or kvaerno5")


# ----------------------------------------------------------------------------- outputs
class NodeOutput(Table):
    """A coordinate of a beam node."""

    type: Literal["node"] = key(doc="output type")
    beam: str = key(doc="beam name")
    node: int = key(-1, doc="node index (−1: the last, the tip)")
    component: Literal[COMPONENTS["node"]] = key("x", unit="m, -", doc="coordinate")
    derivative: Literal[DERIVATIVES] = key("position", doc="the value, or its velocity or acceleration (per s, per s²)")


class PointOutput(Table):
    """A coordinate of the material point of a beam at arc length s."""

    type: Literal["point"] = key(doc="output type")
    beam: str = key(doc="beam name")
    s: float = key(unit="m", ge=0.0, allow_inf_nan=False, doc="reference arc length")
    component: Literal[COMPONENTS["point"]] = key("x", unit="m", doc="coordinate")
    derivative: Literal[DERIVATIVES] = key("position", doc="the value, or its velocity or acceleration (per s, per s²)")


class BodyOutput(Table):
    """The pose of a body, or the position of one of its points."""

    type: Literal["body"] = key(doc="output type")
    body: str = key(doc="body name")
    component: Literal[COMPONENTS["body"]] = key("x", unit="m, rad", doc="coordinate")
    local: Optional[Vec2] = key(None, unit="m", doc="x, y of this body-frame point (default the centre)")
    point: Optional[str] = key(None, doc="x, y of this named point of the body")
    derivative: Literal[DERIVATIVES] = key("position", doc="the value, or its velocity or acceleration (per s, per s²)")


class SlidingOutput(Table):
    """The sliding coordinate s of a sliding joint."""

    type: Literal["sliding"] = key(doc="output type")
    joint: str = key(doc="sliding joint name")
    component: Literal[COMPONENTS["sliding"]] = key("s", unit="m", doc="the arc length s")
    derivative: Literal[DERIVATIVES] = key("position", doc="the value, or its velocity or acceleration (per s, per s²)")


class SlidingPointOutput(Table):
    """The position of a sliding joint's point on its beam."""

    type: Literal["sliding_point"] = key(doc="output type")
    joint: str = key(doc="sliding joint name")
    component: Literal[COMPONENTS["sliding_point"]] = key("x", unit="m", doc="coordinate")
    derivative: Literal[DERIVATIVES] = key("position", doc="the value, or its velocity or acceleration (per s, per s²)")


class AxialOutput(Table):
    """The axial force N (tension positive; the elastic and rate part of the axial law)
    or the axial strain ε (the formulation's measure) at arc length s."""

    type: Literal["axial"] = key(doc="output type")
    beam: str = key(doc="beam name")
    s: float = key(unit="m", ge=0.0, allow_inf_nan=False, doc="reference arc length")
    component: Literal[COMPONENTS["axial"]] = key("force", unit="N, -", doc="force or strain")


class BendingOutput(Table):
    """The bending moment M (of the bending law, elastic and rate part: any law) or the
    curvature change κ − κ₀ (the formulation's measure) at arc length s."""

    type: Literal["bending"] = key(doc="output type")
    beam: str = key(doc="beam name")
    s: float = key(unit="m", ge=0.0, allow_inf_nan=False, doc="reference arc length")
    component: Literal[COMPONENTS["bending"]] = key("moment", unit="N m, 1/m", doc="moment or curvature")


class StressOutput(Table):
    """Bending stress σ = −E y (κ − κ₀) (Eq. 18) at arc length s, or in an element at ξ."""

    type: Literal["stress"] = key(doc="output type")
    beam: str = key(doc="beam name")
    s: Optional[float] = key(None, unit="m", ge=0.0, allow_inf_nan=False, doc="reference arc length")
    element: Optional[int] = key(None, ge=0, doc="instead of s: element index (0 the first)")
    xi: float = key(0.5, ge=0.0, le=1.0, allow_inf_nan=False, doc="with element: local coordinate ξ = x/l")
    fibre: Optional[float] = key(None, unit="m", allow_inf_nan=False,
                                 doc="fibre distance y along the left normal (default the section's fibre)")
    measure: Literal[CURVATURES] = key("exact", doc="curvature: exact (Eq. 16) or small_strain (Eq. 17)")


class ReactionOutput(Table):
    """A joint reaction: a Lagrange multiplier component (index), the normal or
    tangential reaction of a sliding joint on its body [N], the force a joint applies
    in global x, y [N] (fx, fy: a pin or clamp on the point it holds, a sliding joint
    on its body, a revolute or fixed joint on its first point), or the moment [N·m] a
    clamp or a beam node's fixed joint applies to the node (moment)."""

    type: Literal["reaction"] = key(doc="output type")
    joint: str = key(doc="joint name")
    component: Optional[Literal["normal", "tangential", "fx", "fy", "moment"]] = key(
        None, unit="N or N*m", doc="normal, tangential (sliding joints), fx, fy (joints that hold a point), "
        "moment (clamps, fixed joints of beam nodes)")
    index: Optional[int] = key(None, ge=0, le=3, doc="multiplier index (0 .. equations − 1)")


class EnergyOutput(Table):
    """An energy history of the whole system [J]."""

    type: Literal["energy"] = key(doc="output type")
    component: Literal[COMPONENTS["energy"]] = key("total", unit="J", doc="which energy")


class MemberOutput(Table):
    """The force of a spring-damper (positive in tension) or its engaged state (1: taut
    or closed, 0: slack or open)."""

    type: Literal["member"] = key(doc="output type")
    load: str = key(doc="spring-damper name (in [loads])")
    component: Literal[COMPONENTS["member"]] = key("tension", unit="N, -", doc="force or state")


class FrictionOutput(Table):
    """The friction force of a sliding joint on its body along +s, or its normal reaction."""

    type: Literal["friction"] = key(doc="output type")
    joint: str = key(doc="sliding joint name (with friction)")
    component: Literal[COMPONENTS["friction"]] = key("force", unit="N", doc="force or normal")


class DriveOutput(Table):
    """The drive force of a sliding joint on its body along +s (``joint``), or of a
    moving mass (``moving_mass``; its drive NAME.drive): along = "x", the horizontal
    force [N] on the mass; along = "arc_length", the force on it along +s. Exactly one
    of joint and moving_mass."""

    type: Literal["drive"] = key(doc="output type")
    joint: Optional[str] = key(None, doc="sliding joint name (with a drive table)")
    moving_mass: Optional[str] = key(None, doc="moving mass name")
    component: Literal[COMPONENTS["drive"]] = key("force", unit="N", doc="the force")


class ContactOutput(Table):
    """The normal force of a contact (>= 0), its gap g (negative: penetration), its
    engaged state (1: closed), the arc length s* of the closest point on the beam, or
    its friction force on the point along the beam's tangent."""

    type: Literal["contact"] = key(doc="output type")
    load: str = key(doc="contact name (in [loads])")
    component: Literal[COMPONENTS["contact"]] = key("force", unit="N, m, -, m, N",
                                                    doc="force, gap, state, arc length or friction")


class LoadOutput(Table):
    """Where a moving force is: the position y or x of the beam point under it (y: the
    deflection under the load), its reference arc length s, or whether it is on the beam
    (1) or off it (0)."""

    type: Literal["load"] = key(doc="output type")
    load: str = key(doc="moving force name (in [loads])")
    component: Literal[COMPONENTS["load"]] = key("y", unit="m, m, m, -", doc="coordinate, arc length or state")


Output = Annotated[Union[NodeOutput, PointOutput, BodyOutput, SlidingOutput, SlidingPointOutput,
                         StressOutput, AxialOutput, BendingOutput, ReactionOutput, EnergyOutput, MemberOutput,
                         FrictionOutput,
                         DriveOutput, ContactOutput, LoadOutput],
                   Field(discriminator="type")]


class OutputsSpec(Table):
    """What is written: named CSV columns and the sample interval."""

    dt: Optional[float] = key(None, unit="s", gt=0.0, allow_inf_nan=False,
                              doc="sample interval (default every solver step)")
    columns: dict[str, Output] = key({}, doc="named output columns (the CSV header)")
    precision: Optional[int] = key(None, ge=1, le=17, doc="significant digits of the CSV values (default: "
                                                           "the shortest text that reads back to the same "
                                                           "double, a full round trip)")


# ----------------------------------------------------------------------------- fatigue
class SNCurveSpec(Table):
    """S–N curve N(Δσ): slope m1 through (reference_cycles, reference_range), a knee at
    knee_cycles, slope m2 to the cut-off at cutoff_cycles, no damage below (EN 1993-1-9
    Fig. 7.1; see `ancf_jax.fatigue.sn`). The defaults are Eurocode 3 detail category
    160 MPa; `inf` removes the knee (one slope), m2 = inf makes the knee an endurance
    limit, cutoff_cycles = inf removes the cut-off."""

    reference_range: float = key(160e6, unit="Pa", gt=0.0, allow_inf_nan=False,
                                 doc="Δσ_C, the range at reference_cycles (the Eurocode detail category)")
    reference_cycles: float = key(EUROCODE["reference_cycles"], gt=0.0, allow_inf_nan=False, doc="N_C")
    m1: float = key(EUROCODE["m1"], gt=0.0, allow_inf_nan=False, doc="first slope")
    knee_cycles: float = key(EUROCODE["knee_cycles"], gt=0.0, doc="N_D, start of the second slope (inf: one slope)")
    m2: float = key(EUROCODE["m2"], gt=0.0, doc="second slope (inf: endurance limit at the knee)")
    cutoff_cycles: float = key(EUROCODE["cutoff_cycles"], gt=0.0, doc="N_L, no damage below its range (inf: no cut-off)")


class ConcentrationSpec(Table):
    """A stress concentration factor on a stretch of a beam (multiplies `scf`)."""

    beam: str = key(doc="beam name")
    s_min: float = key(0.0, unit="m", ge=0.0, allow_inf_nan=False, doc="from arc length")
    s_max: float = key(unit="m", ge=0.0, allow_inf_nan=False, doc="to arc length")
    factor: float = key(gt=0.0, allow_inf_nan=False, doc="K_t")


class FatiguePointSpec(Table):
    """A chosen point of a beam for the fatigue assessment."""

    beam: str = key(doc="beam name")
    s: float = key(unit="m", ge=0.0, allow_inf_nan=False, doc="reference arc length")


class FatigueSpec(Table):
    """Fatigue assessment (`ancf-jax fatigue`): surface-fibre stress σ = K_t (N/A ± E c κ)
    along the beams, rainflow or Dirlik damage against an S–N curve, Miner sum, life."""

    method: Literal[FATIGUE_METHODS] = key(FatigueSettings.method, doc="rainflow (ASTM E1049-85, half cycles 0.5) or "
                                                             "dirlik (spectral; stationary records only)")
    sn_curve: SNCurveSpec = key(SNCurveSpec(), doc="the S–N curve")
    mean_stress: Literal[CORRECTIONS] = key(FatigueSettings.correction, doc="mean-stress correction (tensile means only)")
    ultimate_strength: Optional[float] = key(None, unit="Pa", gt=0.0, allow_inf_nan=False,
                                             doc="σ_u, needed by goodman and gerber")
    measure: Literal[CURVATURES] = key(FatigueSettings.measure, doc="curvature measure of the bending stress")
    fibre: Optional[float] = key(None, unit="m", gt=0.0, allow_inf_nan=False,
                                 doc="surface fibre distance c (default each section's outer fibre)")
    scf: float = key(FatigueSettings.scf, gt=0.0, allow_inf_nan=False, doc="stress concentration factor K_t everywhere")
    concentrations: dict[str, ConcentrationSpec] = key({}, doc="further K_t on stretches of beams, by name")
    layout: Literal[LAYOUTS] = key(FatigueSettings.layout, doc="points along every beam: the 2 Barlow points of each "
                                                 "element, or points_per_element uniform points")
    points_per_element: int = key(FatigueSettings.points_per_element, ge=2, le=50, doc="points per element of the uniform layout")
    points: dict[str, FatiguePointSpec] = key({}, doc="chosen points instead of the layout, by name")
    t_start: float = key(FatigueSettings.t_start, unit="s", ge=0.0, allow_inf_nan=False,
                         doc="ignore output rows before this time (a start-up transient)")
    hours_per_run: Optional[float] = key(None, unit="h", gt=0.0, allow_inf_nan=False,
                                         doc="hours of service one run represents (life in hours)")
    passes_per_run: Optional[float] = key(None, gt=0.0, allow_inf_nan=False,
                                          doc="passes (trips, crossings) one run represents (life in passes)")
    nperseg: Optional[int] = key(None, ge=16, doc="dirlik: Welch segment length in samples "
                                                   "(default one periodogram of the record)")


# ----------------------------------------------------------------------------- root
class ScenarioSpec(Table):
    """A whole scenario file."""

    version: Literal[FORMAT_VERSION] = key(FORMAT_VERSION, doc="file format version")
    name: Optional[str] = key(None, doc="scenario name (default: the file name)")
    description: str = key("", doc="free text")
    gravity: Vec2 = key((0.0, -9.81), unit="m/s²", doc="gravitational acceleration")
    beams: dict[str, BeamSpec] = key({}, doc="beams by name")
    bodies: dict[str, BodySpec] = key({}, doc="rigid bodies by name")
    moving_masses: dict[str, MovingMassSpec] = key({}, doc="point masses moving along beams at prescribed "
                                                         "positions, by name")
    chains: dict[str, ChainSpec] = key({}, doc="vertical chains of point masses and spring-dampers "
                                               "(pantographs), by name")
    catenary: Optional[CatenarySpec] = key(None, doc="a railway catenary (beams catenary.contact and "
                                                     "catenary.messenger)")
    pantograph: Optional[PantographSpec] = key(None, doc="a pantograph running under the catenary")
    joints: dict[str, Joint] = key({}, doc="joints by name")
    loads: dict[str, Load] = key({}, doc="applied loads and force elements by name")
    initial: InitialSpec = key(InitialSpec(), doc="initial state")
    statics: StaticsSpec = key(StaticsSpec(), doc="static solver")
    modal: ModalSpec = key(ModalSpec(), doc="modal analysis")
    solver: SolverSpec = key(doc="time integration")
    outputs: OutputsSpec = key(OutputsSpec(), doc="output columns and sampling")
    fatigue: FatigueSpec = key(FatigueSpec(), doc="fatigue assessment (`ancf-jax fatigue`)")
