"""Results of a simulation: state histories, diagnostics and post-processing.

A :class:`Results` holds NumPy arrays (one row per output time) and the system that
produced them. Derived quantities (energies, constraint violations, positions of
points, stresses, reactions) are computed on demand by jitted, vmapped functions of
the stored states.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .errors import ModelError
from .contact import MovingForce, UnilateralContact
from .forces import AbstractOneSidedSpringDamper, NodeSpringSet, SpringDamper
from .joints import (Clamp, Coincident, FixedJoint, PathCoordinate, PrescribedCoordinate, PrescribedPoint,
                     SlidingJoint)
from .sliding import AbstractSlidingDrive
from .points import BeamNode
from .system import System


#: units of the arrays every :meth:`Results.save_npz` file holds (its ``units`` entry)
NPZ_UNITS = {
    "t": "s",
    "q": "per coordinate_labels (m, rad, - for slopes)",
    "v": "per coordinate_labels, per s (m/s, rad/s, 1/s)",
    "acc": "per coordinate_labels, per s^2 (m/s^2, rad/s^2, 1/s^2)",
    "lam": "per constraint_labels: N for a position equation, N*m for a slope or angle equation",
    "work": "J",
    "iterations": "-",
    "coordinate_labels": "-", "work_labels": "-", "constraint_labels": "-", "body_names": "-",
    "beam_names": "-", "sliding_names": "-",
}


@eqx.filter_jit
def _energies(system: System, q, v, t):
    def one(qq, vv, tt):
        return jnp.stack([system.kinetic_energy(vv), system.gravity_potential(qq),
                          system.strain_energy(qq), system.force_potential(qq, tt)])
    return jax.vmap(one)(q, v, t)


@eqx.filter_jit
def _violations(system: System, q, v, t):
    def one(qq, vv, tt):
        if not system.n_constraints:
            return jnp.zeros(2)
        return jnp.stack([jnp.max(jnp.abs(system.constraint(qq, tt))),
                          jnp.max(jnp.abs(system.constraint_velocity(qq, vv, tt)))])
    return jax.vmap(one)(q, v, t)


@eqx.filter_jit
def _member_history(system: System, force, q, v):
    """(tension [N], engaged 0/1) of a spring-damper per row, shape (N, 2)."""
    def one(qq, vv):
        if isinstance(force, SpringDamper):
            ell = force.length(system, qq)
            ell_dot = jax.jvp(lambda z: force.length(system, z), (qq,), (vv,))[1]
            return jnp.stack([force.stiffness * (ell - force.rest_length) + force.damping * ell_dot,
                              jnp.ones(())])
        return jnp.stack([force.tension(system, qq, vv), force.engaged(system, qq).astype(qq.dtype)])
    return jax.vmap(one)(q, v)


@eqx.filter_jit
def _set_history(system: System, force, q, v):
    """(force [N], engaged 0/1) of every member of a spring-damper set per row, (N, m, 2)."""
    def one(qq, vv):
        return jnp.stack([force.member_forces(system, qq, vv),
                          force.member_engaged(system, qq).astype(qq.dtype)], axis=-1)
    return jax.vmap(one)(q, v)


@eqx.filter_jit
def _moment_history(system: System, k: int, q, lam, t):
    """Moment [N·m] a joint applies to the beam node it holds, per row: with f the
    generalized force −(∂Φ/∂r')ᵀλ of joint k on the node's slope r', the moment of a
    rotation δr' = δθ ẑ×r' is M = r' × f."""
    c = system.constraints[k]
    node = c.node if isinstance(c, Clamp) else c.point
    o = system.constraint_offset(k)

    def one(qq, ll, tt):
        idx = node.coordinates(system, qq)[2:4]
        jac = jax.jacfwd(lambda z: c.residual(system, qq.at[idx].set(z), tt))(qq[idx])
        f = -jac.T @ ll[o:o + c.size]
        r1 = qq[idx]
        return r1[0] * f[1] - r1[1] * f[0]
    return jax.vmap(one)(q, lam, t)


@eqx.filter_jit
def _contact_history(system: System, contact, q, v):
    """(normal force [N], gap [m], engaged 0/1, contact arc length s* [m], friction
    force [N]) per row."""
    def one(qq, vv):
        s, _ = contact.contact_point(system, qq)
        return jnp.stack([contact.normal_force(system, qq, vv), contact.gap(system, qq),
                          contact.engaged(system, qq).astype(qq.dtype), s,
                          contact.tangential_force(system, qq, vv)])
    return jax.vmap(one)(q, v)


@eqx.filter_jit
def _load_history(system: System, load, q, t):
    """(s [m], x [m], y [m], on the beam 0/1) of a moving force's point per row."""
    def one(qq, tt):
        s, r, on = load.load_point(system, qq, tt)
        return jnp.stack([s, r[0], r[1], on.astype(qq.dtype)])
    return jax.vmap(one)(q, t)


@eqx.filter_jit
def _friction_history(system: System, friction, q, v, lam):
    """(friction force, normal reaction) [N] per row, shape (N, 2)."""
    return jax.vmap(lambda qq, vv, ll: jnp.stack([friction.tangential_force(system, qq, vv, ll),
                                                  friction.normal_force(system, qq, ll)]))(q, v, lam)


@eqx.filter_jit
def _drive_history(system: System, drive, q, v, t):
    return jax.vmap(lambda qq, vv, tt: drive.tangential_force(system, qq, vv, tt))(q, v, t)


# jitted histories over the output rows; numeric parameters are traced (no recompiling
# per query), names and measures are static
@eqx.filter_jit
def _point_history(system: System, beam: int, q, s):
    """Positions at arc lengths s (one per row, shape (N,))."""
    return jax.vmap(lambda qq, ss: system.beams[beam].position(system.beam_nodes(qq, beam), ss))(q, s)


@eqx.filter_jit
def _slope_history(system: System, beam: int, q, s):
    return jax.vmap(lambda qq, ss: system.beams[beam].slope(system.beam_nodes(qq, beam), ss))(q, s)


@eqx.filter_jit
def _stress_history(system: System, beam: int, q, s, y, measure: str):
    return jax.vmap(lambda qq: system.beams[beam].stress(system.beam_nodes(qq, beam), s, y, measure))(q)


@eqx.filter_jit
def _axial_force_history(system: System, beam: int, q, s):
    return jax.vmap(lambda qq: system.beams[beam].axial_force(system.beam_nodes(qq, beam), s))(q)


@eqx.filter_jit
def _element_stress_history(system: System, beam: int, q, element, xi, y, measure: str):
    return jax.vmap(lambda qq: system.beams[beam].element_stress(
        system.beam_nodes(qq, beam), element, xi, y, measure))(q)


@eqx.filter_jit
def _stress_along_history(system: System, beam: int, q, points: int, y, measure: str):
    return jax.vmap(lambda qq: system.beams[beam].stress_along(
        system.beam_nodes(qq, beam), points, y, measure)[1])(q)


def _f(x):
    return None if x is None else jnp.asarray(x, float)


@dataclasses.dataclass
class Results:
    """Histories of a run (N output times).

    Attributes:
        system: the simulated system.
        t: output times [s], shape (N,).
        q: coordinates, shape (N, n) [m, -, rad, m for sliding coordinates].
        v: velocities, shape (N, n).
        acc: accelerations, shape (N, n).
        lam: Lagrange multipliers λ, shape (N, m) (constraint force −Φ_qᵀ λ).
        work: [dissipated, external work, constraint work] integrals [J], shape (N, 3).
        iterations: Newton iterations in each output interval, shape (N,).
        solver: solver name.
        dt: step [s] (initial step for adaptive solvers).
        wall_time_s: run time without compilation [s].
        compile_time_s: compilation time [s].
        status: ``"ok"`` or the failure reason.
        failure_time: when it failed [s] (None when ok).
        message: the failure message (empty when ok).
        info: further solver statistics.
        checkpoint: where a fixed-step run stopped, to continue it
            (:class:`~ancf_jax.integrate.Checkpoint`; None for adaptive solvers).
    """

    system: System
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    acc: np.ndarray
    lam: np.ndarray
    work: np.ndarray
    iterations: np.ndarray
    solver: str = ""
    dt: float = float("nan")
    wall_time_s: float = 0.0
    compile_time_s: float = 0.0
    status: str = "ok"
    failure_time: float | None = None
    message: str = ""
    info: dict = dataclasses.field(default_factory=dict)
    checkpoint: Any = None

    def until(self, t_end: float) -> "Results":
        """These results at the output times t <= ``t_end`` [s] only (to 1e-9 of the
        last output interval; the checkpoint dropped unless nothing is cut): a member
        of a batch run to a common end, cut at its own."""
        t = np.asarray(self.t)
        step = float(np.max(np.diff(t), initial=0.0))
        n = int(np.searchsorted(t, float(t_end) + 1e-9 * step, side="right"))
        if n >= t.shape[0]:
            return self
        cut = {k: getattr(self, k)[:n] for k in ("t", "q", "v", "acc", "lam", "work", "iterations")}
        return dataclasses.replace(self, checkpoint=None, **cut)

    # ------------------------------------------------------------------ lookup
    def _index(self, names: tuple, name: str, what: str) -> int:
        if name not in names:
            raise ModelError(f"no {what} named {name!r} (known: {', '.join(map(repr, names)) or 'none'})")
        return names.index(name)

    def body(self, name: str) -> np.ndarray:
        """Pose history (x, y, θ) of a rigid body, shape (N, 3)."""
        k = self._index(self.system.body_names, name, "body")
        o = self.system.body_offset(k)
        return self.q[:, o:o + 3]

    def nodes(self, beam: str) -> np.ndarray:
        """Nodal coordinates of a beam, shape (N, n_nodes, 4) (padding included)."""
        b = self._index(self.system.beam_names, beam, "beam")
        o = self.system.beam_offset(b)
        return self.q[:, o:o + self.system.beams[b].n_coordinates].reshape(len(self.t), -1, 4)

    def node(self, beam: str, index: int) -> np.ndarray:
        """History of one node (x, y, x', y'), shape (N, 4); index −1 is the last node."""
        b = self._index(self.system.beam_names, beam, "beam")
        n = int(self.system.beams[b].mesh.n_elements)
        i = index if index >= 0 else n + 1 + index
        if not 0 <= i <= n:
            raise ModelError(f"node {index} of beam {beam!r} is out of range (0..{n})")
        return self.nodes(beam)[:, i]

    def point(self, beam: str, s: float) -> np.ndarray:
        """Position history of the material point at arc length s [m], shape (N, 2)."""
        b = self._index(self.system.beam_names, beam, "beam")
        return np.asarray(_point_history(self.system, b, jnp.asarray(self.q),
                                         jnp.full(len(self.t), float(s))))

    def sliding(self, name: str) -> np.ndarray:
        """History of a sliding coordinate [m], shape (N,)."""
        j = self._index(self.system.sliding_names, name, "sliding joint")
        return self.q[:, self.system.sliding_offset + j]

    def sliding_point(self, name: str) -> np.ndarray:
        """Position of the point of beam at the sliding coordinate ``name``, shape (N, 2)."""
        joint = next((c for c in self.system.constraints
                      if isinstance(c, SlidingJoint) and c.name == name), None)
        if joint is None:
            raise ModelError(f"no sliding joint named {name!r}")
        b, j = joint.beam, joint.sliding
        s = self.q[:, self.system.sliding_offset + j]
        return np.asarray(_point_history(self.system, b, jnp.asarray(self.q), jnp.asarray(s)))

    def multipliers(self, joint: str) -> np.ndarray:
        """Lagrange multipliers of one joint, shape (N, size)."""
        start = 0
        for c in self.system.constraints:
            if c.name == joint:
                return self.lam[:, start:start + c.size]
            start += c.size
        names = [c.name for c in self.system.constraints]
        raise ModelError(f"no joint named {joint!r} (known: {', '.join(map(repr, names))})")

    def sliding_reaction(self, name: str) -> np.ndarray:
        """Reaction of a sliding joint on its body: (normal, tangential) components
        along the beam normal (left of the tangent) and tangent [N], shape (N, 2).

        Frictionless and undriven: the tangential component is zero up to round-off;
        otherwise it is the sum of the friction and drive forces.
        """
        joint = next((c for c in self.system.constraints
                      if isinstance(c, SlidingJoint) and c.name == name), None)
        if joint is None:
            raise ModelError(f"no sliding joint named {name!r}")
        force = self.multipliers(name)  # force on the body is +λ
        b, j = joint.beam, joint.sliding
        s = self.q[:, self.system.sliding_offset + j]
        tangent = np.asarray(_slope_history(self.system, b, jnp.asarray(self.q), jnp.asarray(s)))
        tangent = tangent / np.linalg.norm(tangent, axis=1, keepdims=True)
        normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
        return np.stack([np.sum(force * normal, axis=1), np.sum(force * tangent, axis=1)], axis=1)

    def joint_force(self, name: str) -> np.ndarray:
        """Force [N] a joint applies, in global (x, y), shape (N, 2): for a sliding joint
        on its body (+λ, as :meth:`sliding_reaction`); for a pin or clamp on the beam
        node or body point it holds (the support reaction); for a revolute or fixed
        joint and a prescribed point on its first point. From the multipliers: the
        joints' first two equations are r_a − r_b (− the target), whose constraint force
        −Φ_qᵀλ is −λ on point a and +λ on point b."""
        names = [c.name for c in self.system.constraints]
        c = self.system.constraints[self._index(tuple(names), name, "joint")]
        if not isinstance(c, (Coincident, Clamp, FixedJoint, PrescribedPoint, SlidingJoint)):
            raise ModelError(f"joint {name!r} ({type(c).__name__}) holds no point: no force output; "
                             "use its multipliers (reaction index)")
        lam = self.multipliers(name)[:, :2]
        return lam if isinstance(c, SlidingJoint) else -lam

    def joint_moment(self, name: str) -> np.ndarray:
        """Moment [N·m] (counter-clockwise positive) that a clamp, or a fixed joint of a
        beam node to a body, applies to the beam node it holds (the support moment of
        a clamp), shape (N,): from the joint's generalized force f on the node's slope
        r', M = r' × f (the virtual work of a rotation δr' = δθ ẑ × r')."""
        names = [c.name for c in self.system.constraints]
        k = self._index(tuple(names), name, "joint")
        c = self.system.constraints[k]
        holds_node = isinstance(c, Clamp) or (isinstance(c, FixedJoint) and isinstance(c.point, BeamNode))
        if not holds_node:
            raise ModelError(f"joint {name!r} ({type(c).__name__}) holds no beam node's slope: no moment "
                             "output (clamps and fixed joints of beam nodes have one)")
        return np.asarray(_moment_history(self.system, k, jnp.asarray(self.q), jnp.asarray(self.lam),
                                          jnp.asarray(self.t)))

    def force_element(self, name: str):
        """The force element called ``name`` of the system."""
        names = tuple(f.name for f in self.system.forces)
        return self.system.forces[self._index(names, name, "force element")]

    def member(self, name: str) -> np.ndarray:
        """Member force [N] (positive in tension) and engaged state (1: taut or closed,
        0: slack or open; linear spring-dampers are always 1) of a spring-damper,
        shape (N, 2). ``name`` may be a member of a set
        (:class:`~ancf_jax.forces.NodeSpringSet`), e.g. a catenary's dropper."""
        for f in self.system.forces:
            if isinstance(f, NodeSpringSet) and name in f.names:
                return self.members(f.name)[:, f.names.index(name)]
        f = self.force_element(name)
        if not isinstance(f, (SpringDamper, AbstractOneSidedSpringDamper)):
            raise ModelError(f"force element {name!r} is not a spring-damper")
        return np.asarray(_member_history(self.system, f, jnp.asarray(self.q), jnp.asarray(self.v)))

    def members(self, name: str) -> np.ndarray:
        """Member forces [N] and engaged states of every member of the spring-damper
        set ``name`` (:class:`~ancf_jax.forces.NodeSpringSet`), shape (N, m, 2)."""
        f = self.force_element(name)
        if not isinstance(f, NodeSpringSet):
            raise ModelError(f"force element {name!r} is not a spring-damper set")
        return np.asarray(_set_history(self.system, f, jnp.asarray(self.q), jnp.asarray(self.v)))

    def contact(self, name: str) -> np.ndarray:
        """Normal force F_n [N] (>= 0), gap g [m] (negative: penetration), engaged state
        (1: closed), contact arc length s* [m] on the beam and friction force F_t [N] on
        the point along the beam's unit tangent (0 without friction) of a unilateral
        contact named ``name`` (:class:`~ancf_jax.contact.UnilateralContact`), shape
        (N, 5)."""
        f = self.force_element(name)
        if not isinstance(f, UnilateralContact):
            raise ModelError(f"force element {name!r} is not a contact")
        return np.asarray(_contact_history(self.system, f, jnp.asarray(self.q), jnp.asarray(self.v)))

    def moving_load(self, name: str) -> np.ndarray:
        """Arc length s [m] and position x, y [m] of the beam point under a moving force
        named ``name``, and whether it is on the beam (1) (:class:`~ancf_jax.contact.MovingForce`),
        shape (N, 4): y is the deflection under the load."""
        f = self.force_element(name)
        if not isinstance(f, MovingForce):
            raise ModelError(f"force element {name!r} is not a moving force")
        return np.asarray(_load_history(self.system, f, jnp.asarray(self.q), jnp.asarray(self.t)))

    def friction(self, name: str) -> np.ndarray:
        """Friction force F [N] on the body along +s (its reaction acts on the beam) and
        the normal reaction N [N] of a sliding friction named ``name``, shape (N, 2)."""
        names = tuple(f.name for f in self.system.reaction_forces)
        f = self.system.reaction_forces[self._index(names, name, "friction")]
        return np.asarray(_friction_history(self.system, f, jnp.asarray(self.q), jnp.asarray(self.v),
                                            jnp.asarray(self.lam)))

    def drive_force(self, name: str) -> np.ndarray:
        """Tangential force [N] of a sliding drive named ``name`` on the body along +s
        (:meth:`~ancf_jax.model.Model.slider_drive`: for a prescribed arc length the
        reaction −λ_d/|r'(s)| of its constraint), shape (N,). For a moving mass driven
        along x (:meth:`~ancf_jax.model.Model.moving_mass`, drive ``"NAME.drive"``): the
        horizontal force [N] on the mass, −λ of its constraint."""
        drives = {f.name: f for f in self.system.forces if isinstance(f, AbstractSlidingDrive)}
        if name in drives:
            return np.asarray(_drive_history(self.system, drives[name], jnp.asarray(self.q),
                                             jnp.asarray(self.v), jnp.asarray(self.t)))
        joint = next((c for c in self.system.constraints if c.name == name
                      and isinstance(c, (PrescribedCoordinate, PathCoordinate))
                      and c.index >= self.system.sliding_offset), None)
        if joint is None and name.endswith(".drive") and name[:-len(".drive")] in self.system.body_names:
            # a moving mass driven along x (Model.moving_mass): the horizontal force on it
            body = self.system.constraints[self._index(tuple(c.name for c in self.system.constraints), name,
                                                       "joint")]
            if isinstance(body, (PrescribedCoordinate, PathCoordinate)):
                return -self.multipliers(name)[:, 0]
        if joint is None:
            known = list(drives) + [c.name for c in self.system.constraints
                                    if isinstance(c, (PrescribedCoordinate, PathCoordinate))
                                    and c.index >= self.system.sliding_offset]
            raise ModelError(f"no sliding drive named {name!r} (known: {', '.join(map(repr, known)) or 'none'})")
        j = joint.index - self.system.sliding_offset
        slider = next(c for c in self.system.constraints if isinstance(c, SlidingJoint) and c.sliding == j)
        s = self.q[:, joint.index]
        slope = np.asarray(_slope_history(self.system, slider.beam, jnp.asarray(self.q), jnp.asarray(s)))
        return -self.multipliers(name)[:, 0] / np.linalg.norm(slope, axis=1)

    # ------------------------------------------------------------------ stress
    def stress(self, beam: str, s: float, y: float | None = None, measure: str = "exact") -> np.ndarray:
        """Bending stress history [Pa] at arc length s on fibre y (Eq. 18), shape (N,)."""
        b = self._index(self.system.beam_names, beam, "beam")
        return np.asarray(_stress_history(self.system, b, jnp.asarray(self.q), _f(s), _f(y), measure))

    def axial_force(self, beam: str, s: float) -> np.ndarray:
        """Axial force history N = EA·ε [N] at arc length s (tension positive), shape (N,)."""
        b = self._index(self.system.beam_names, beam, "beam")
        return np.asarray(_axial_force_history(self.system, b, jnp.asarray(self.q), _f(s)))

    def element_stress(self, beam: str, element: int, xi: float, y: float | None = None,
                       measure: str = "exact") -> np.ndarray:
        """Stress history [Pa] in element ``element`` (0-based) at ξ = x/l, shape (N,)."""
        b = self._index(self.system.beam_names, beam, "beam")
        return np.asarray(_element_stress_history(self.system, b, jnp.asarray(self.q),
                                                  jnp.asarray(element), _f(xi), _f(y), measure))

    def stress_along(self, beam: str, points_per_element: int = 11, y: float | None = None,
                     measure: str = "exact") -> tuple[np.ndarray, np.ndarray]:
        """Stress along a beam over time: (s (E, P), sigma (N, E, P)) [m, Pa]; NaN on padding."""
        b = self._index(self.system.beam_names, beam, "beam")
        sig = np.asarray(_stress_along_history(self.system, b, jnp.asarray(self.q), points_per_element,
                                               _f(y), measure))
        s, _ = self.system.beams[b].stress_along(self.system.beams[b].mesh.reference_nodes,
                                                 points_per_element, y, measure)
        return np.asarray(s), sig

    # ------------------------------------------------------------------ diagnostics
    def energy(self) -> dict[str, np.ndarray]:
        """Energy histories [J]: kinetic, gravity, strain, springs, dissipated, external
        and constraint work, total = T + V + U + D − W_e − W_c and its drift
        ``balance_error`` = total − total(0)."""
        e = np.asarray(_energies(self.system, jnp.asarray(self.q), jnp.asarray(self.v),
                                 jnp.asarray(self.t)))
        out = dict(kinetic=e[:, 0], gravity=e[:, 1], strain=e[:, 2], springs=e[:, 3],
                   dissipated=self.work[:, 0], external=self.work[:, 1], constraint=self.work[:, 2])
        total = e.sum(axis=1) + self.work[:, 0] - self.work[:, 1] - self.work[:, 2]
        out["total"] = total
        out["balance_error"] = total - total[0]
        return out

    def energy_balance_error(self) -> float:
        """max |balance error| relative to the largest energy term of the run."""
        e = self.energy()
        scale = max(np.max(np.abs(e[k])) for k in ("kinetic", "gravity", "strain", "springs",
                                                   "dissipated", "external", "constraint"))
        scale = max(scale, 1e-300)
        return float(np.max(np.abs(e["balance_error"])) / scale)

    def constraint_violation(self) -> tuple[np.ndarray, np.ndarray]:
        """(max|Φ|, max|Φ̇|) at every output time."""
        viol = np.asarray(_violations(self.system, jnp.asarray(self.q), jnp.asarray(self.v),
                                      jnp.asarray(self.t)))
        return viol[:, 0], viol[:, 1]

    def summary(self) -> dict[str, Any]:
        """Diagnostics of the run as a JSON-ready dict; keys of dimensional scalars carry
        their unit (``dt_s``, ``t_end_s``, ``failure_time_s``, ``wall_time_s``);
        ``max_constraint_violation`` is in the units of the constraint equations (m for
        positions, - for slopes), ``energy_balance_error`` relative."""
        pos, vel = self.constraint_violation()
        return dict(solver=self.solver, dt_s=self.dt, t_end_s=float(self.t[-1]), outputs=len(self.t),
                    status=self.status, failure_time_s=self.failure_time,
                    wall_time_s=self.wall_time_s, compile_time_s=self.compile_time_s,
                    newton_iterations=int(self.iterations.sum()),
                    max_constraint_violation=float(pos.max()),
                    max_velocity_constraint_violation=float(vel.max()),
                    energy_balance_error=self.energy_balance_error(), **self.info)

    # ------------------------------------------------------------------ files
    def save_npz(self, path: str | Path, *, units: dict | None = None, **extra) -> None:
        """Full state histories (and any extra arrays) to a NumPy .npz file: ``t`` [s],
        ``q``, ``v``, ``acc`` with one column per :meth:`~ancf_jax.system.System.coordinate_labels`
        entry (units per s, per s² for v, acc), ``lam`` per ``constraint_labels``,
        ``work`` per ``work_labels``; and ``checkpoint_*`` (the run's
        :attr:`checkpoint`, read back by :func:`ancf_jax.simulation.load_checkpoint`).

        ``units`` maps each extra array's name to its SI unit (``"Pa"``, ``"m"``; ``"-"``:
        none; an extra without one is stored as ``"unspecified"``). The file's ``units``
        entry is the JSON text of {array name: unit} for every array in it:
        ``json.loads(str(np.load(path)["units"]))``; a unit that varies by column says
        where it is (``"per coordinate_labels"``)."""
        arrays = dict(t=self.t, q=self.q, v=self.v, acc=self.acc, lam=self.lam, work=self.work,
                      iterations=self.iterations,
                      coordinate_labels=np.array(self.system.coordinate_labels()),
                      work_labels=np.array(["dissipated [J]", "external [J]", "constraint [J]"]),
                      constraint_labels=np.array(self.system.constraint_labels()),
                      body_names=np.array(self.system.body_names),
                      beam_names=np.array(self.system.beam_names),
                      sliding_names=np.array(self.system.sliding_names), **self._checkpoint_arrays())
        if set(extra) & set(arrays):
            raise ModelError(f"save_npz: extra arrays may not be called {sorted(set(extra) & set(arrays))}")
        unit_map = dict(NPZ_UNITS)
        unit_map.update({k: "checkpoint: per coordinate_labels (q, v, acc), s (t)" for k in arrays
                         if k.startswith("checkpoint_")})
        unit_map.update({k: (units or {}).get(k, "unspecified") for k in extra})
        np.savez_compressed(path, **arrays, **extra, units=np.array(json.dumps(unit_map)))

    def _checkpoint_arrays(self) -> dict:
        if self.checkpoint is None:
            return {}
        c = self.checkpoint.carry
        # the solver memory (generalized-α's AcrossSteps factors) as its leaves, numbered
        memory = {f"checkpoint_memory_{i}": np.asarray(a) for i, a in enumerate(jax.tree.leaves(c.memory))}
        return {"checkpoint_solver": np.array(self.checkpoint.solver), **memory,
                **{f"checkpoint_{k}": np.asarray(getattr(c, k)) for k in type(c).__dataclass_fields__
                   if k != "memory"}}

    def save_summary(self, path: str | Path, **extra) -> dict:
        """Write :meth:`summary` (and any extra entries) as JSON; returns the dict."""
        data = {**self.summary(), **extra}
        Path(path).write_text(json.dumps(data, indent=2, default=float))
        return data
