"""The assembled multibody system: coordinates, mass, forces, constraints, energy.

System coordinates (paper Eqs. 14 and 21)::

    q = [ x₁ y₁ θ₁ … x_nb y_nb θ_nb | nodes of beam 1 | … | nodes of beam nB | s₁ … s_ns ]

rigid-body coordinates first, then the ANCF coordinates of every beam (4 per node,
n_max + 1 node slots per beam), then the sliding coordinates. The mass matrix is block
diagonal: diag(m, m, J) per body, the consistent beam mass (block tridiagonal), and
zero for the sliding coordinates, which carry neither mass nor force.

The equations of motion are M q̈ + Φ_qᵀ λ = Q(q, q̇, t), Φ(q, t) = 0. Here Q holds the
elastic forces (−∂U/∂q, Eq. 9), gravity, applied loads and the damping forces
(Rayleigh C = αM + βK per beam, Eq. 11, with β K q̇ evaluated as one Jacobian-vector
product of the elastic force). Φ_q and γ (Eq. 12) come from automatic differentiation
of the joint residuals.

Like beams (one structure and array shapes: the wires of a catenary) are evaluated
together, stacked and vectorized (:meth:`System.map_beams`): their element code is
traced and compiled once per group, not once per beam.

A :class:`System` is an ``equinox.Module``: ``jit``, ``vmap`` and ``grad`` pass through
it. Everything a batch may vary (lengths, masses, α, β, node indices) is array data;
the structure (counts, offsets, names) is static.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _products
from ._control import traced_once
from .beam import Beam
from .bodies import RigidBodies
from .linalg import AbstractChainLayout, BlockTridiagonal, SequentialChain


def _stack(*xs):
    return jnp.stack(xs)


class State(eqx.Module):
    """Positions q, velocities v = q̇ and time t of a system."""

    q: jnp.ndarray
    v: jnp.ndarray
    t: jnp.ndarray


class System(eqx.Module):
    """An assembled planar multibody system with ANCF beams.

    Attributes:
        bodies: masses and inertias of the rigid bodies.
        beams: the beams, in coordinate order.
        constraints: the joints (Φ(q, t) = 0).
        forces: force elements added by the user.
        gravity: acceleration of gravity [m/s²], shape (2,).
        n_sliding: number of sliding coordinates (static).
        reaction_forces: forces that depend on the multipliers λ (friction,
            :class:`~ancf_jax.forces.AbstractReactionForce`); empty: none, and nothing
            of them is traced.
        body_names, beam_names, sliding_names: names for messages and outputs (static).
        gravity_off: names of the bodies and beams that gravity does not act on (static;
            empty: on all).
        layout: order of the beam coordinates in the solvers' block-tridiagonal chain
            (:class:`~ancf_jax.linalg.SequentialChain`: beam after beam;
            :class:`~ancf_jax.linalg.InterleavedChain`: node i of every beam in one
            block, for beams along a common track).
        banded_forces: indices in ``forces`` of the force elements whose coordinates
            lie in two neighbouring chain blocks (static, found by
            :meth:`ancf_jax.model.Model.build`): their Newton matrix enters the chain
            instead of the border.
    """

    bodies: RigidBodies
    beams: tuple
    constraints: tuple
    forces: tuple
    gravity: jnp.ndarray
    n_sliding: int = eqx.field(static=True, default=0)
    body_names: tuple = eqx.field(static=True, default=())
    beam_names: tuple = eqx.field(static=True, default=())
    sliding_names: tuple = eqx.field(static=True, default=())
    gravity_off: tuple = eqx.field(static=True, default=())
    reaction_forces: tuple = ()
    layout: AbstractChainLayout = eqx.field(static=True, default=SequentialChain())
    banded_forces: tuple = eqx.field(static=True, default=())

    # ------------------------------------------------------------------ layout
    @property
    def n_bodies(self) -> int:
        return self.bodies.count

    def body_offset(self, k: int) -> int:
        """Index in q of the x coordinate of body k (its pose is q[o:o + 3] = x, y, θ)."""
        return 3 * k

    def beam_offset(self, b: int) -> int:
        """Index in q of the first coordinate of beam b (4 per node, padding included)."""
        return 3 * self.n_bodies + sum(beam.n_coordinates for beam in self.beams[:b])

    @property
    def chain_size(self) -> int:
        """Number of beam coordinates (the block-tridiagonal part)."""
        return sum(beam.n_coordinates for beam in self.beams)

    @property
    def sliding_offset(self) -> int:
        return 3 * self.n_bodies + self.chain_size

    @property
    def n_coordinates(self) -> int:
        return self.sliding_offset + self.n_sliding

    @property
    def n_constraints(self) -> int:
        return sum(c.size for c in self.constraints)

    def border_indices(self) -> np.ndarray:
        """Indices of the coordinates outside the beam chain (bodies, sliding)."""
        return np.concatenate([np.arange(3 * self.n_bodies),
                               np.arange(self.sliding_offset, self.n_coordinates)]).astype(int)

    def chain_slice(self) -> slice:
        """Slice of q holding all beam coordinates (the block-tridiagonal part)."""
        return slice(3 * self.n_bodies, self.sliding_offset)

    def chain_indices(self) -> np.ndarray:
        """Indices in q of the beam coordinates in chain order (:attr:`layout`)."""
        if not self.beams:
            return np.zeros(0, int)
        order = self.layout.order(tuple(b.n_coordinates for b in self.beams))
        return (3 * self.n_bodies + order).astype(int)

    def chain_selector(self):
        """:meth:`chain_slice` where the chain order is that of q (a slice, not a
        gather, in the compiled program), else :meth:`chain_indices`."""
        return self.chain_slice() if isinstance(self.layout, SequentialChain) else self.chain_indices()

    def coordinate_labels(self) -> tuple[str, ...]:
        """One label per coordinate of q, in order, with its SI unit: ``body:NAME.x [m]``
        (x, y [m], theta [rad]), ``beam:NAME.node[i].x [m]`` (x, y [m], slope_x,
        slope_y [-]; padding nodes included), ``sliding:NAME.s [m]``. Velocities and
        accelerations have the same labels per s and per s²."""
        labels = [f"body:{name}.{c}" for name in self.body_names
                  for c in ("x [m]", "y [m]", "theta [rad]")]
        for name, beam in zip(self.beam_names, self.beams):
            labels += [f"beam:{name}.node[{i}].{c}" for i in range(beam.n_coordinates // 4)
                       for c in ("x [m]", "y [m]", "slope_x [-]", "slope_y [-]")]
        labels += [f"sliding:{name}.s [m]" for name in self.sliding_names]
        return tuple(labels)

    def constraint_labels(self) -> tuple[str, ...]:
        """One label per constraint equation, ``joint[i]``, in the order of λ."""
        return tuple(lbl for c in self.constraints for lbl in c.equation_labels())

    def constraint_owner(self) -> tuple[str, ...]:
        """Name of the joint each constraint equation belongs to."""
        return tuple(c.name for c in self.constraints for _ in range(c.size))

    def inactive_mask(self):
        """True for coordinates of inactive (padding) beam nodes, shape (n,)."""
        parts = [jnp.zeros(3 * self.n_bodies, bool)]
        parts += [jnp.repeat(~b.mesh.active_nodes, 4) for b in self.beams]
        parts += [jnp.zeros(self.n_sliding, bool)]
        return jnp.concatenate(parts)

    # ------------------------------------------------------------------ views of q
    def body_pose(self, q, k: int):
        """(x, y, θ) of body k, shape (3,)."""
        o = self.body_offset(k)
        return q[o:o + 3]

    def beam_nodes(self, q, b: int):
        """Nodal coordinates of beam b, shape (n_max + 1, 4)."""
        o = self.beam_offset(b)
        return jnp.reshape(q[o:o + self.beams[b].n_coordinates], (-1, 4))

    def sliding(self, q, j: int):
        """Sliding coordinate j [m] (reference arc length along its beam)."""
        return q[self.sliding_offset + j]

    def pack(self, body_poses, beam_nodes, sliding):
        """Build q from per-part arrays: body_poses (nb, 3), a list of (n_nodes, 4), (ns,)."""
        parts = [jnp.reshape(jnp.asarray(body_poses, float), (-1,))]
        parts += [jnp.reshape(jnp.asarray(n, float), (-1,)) for n in beam_nodes]
        parts += [jnp.reshape(jnp.asarray(sliding, float), (-1,))]
        return jnp.concatenate(parts)

    # ------------------------------------------------------------------ inertia
    def with_rate_stiffness(self, on=True) -> "System":
        """The system with every beam's static :attr:`~ancf_jax.beam.Beam.rate_stiffness`
        set to ``on`` (a bool, or one per beam)."""
        flags = [on] * len(self.beams) if isinstance(on, bool) else list(on)
        beams = tuple(b.with_rate_stiffness(f) for b, f in zip(self.beams, flags))
        return eqx.tree_at(lambda s: s.beams, self, beams) if self.beams else self

    def beam_mass(self) -> BlockTridiagonal:
        """Mass matrix of the beam chain in chain order (:meth:`chain_indices`; block
        tridiagonal, dummy unit mass on padding)."""
        return self.layout.assemble([b.mass() for b in self.beams])

    def border_mass_diagonal(self):
        """Diagonal mass of the border coordinates (bodies: m, m, J; sliding: 0)."""
        return jnp.concatenate([self.bodies.mass_diagonal(), jnp.zeros(self.n_sliding)])

    def mass_matrix(self):
        """Dense system mass matrix M (Eq. 14/21), shape (n, n)."""
        n = self.n_coordinates
        m = jnp.zeros((n, n))
        nb3 = 3 * self.n_bodies
        m = m.at[:nb3, :nb3].set(jnp.diag(self.bodies.mass_diagonal()))
        if self.beams:
            c = self.chain_indices()
            m = m.at[np.ix_(c, c)].set(self.beam_mass().to_dense())
        return m

    def mass_times(self, v):
        """M v without forming M, shape (n,)."""
        out = jnp.zeros_like(v)
        nb3 = 3 * self.n_bodies
        out = out.at[:nb3].set(self.bodies.mass_diagonal() * v[:nb3])
        if self.beams:
            c = self.chain_selector()
            out = out.at[c].set(self.beam_mass().matvec(v[c]))
        return out

    # ------------------------------------------------------------------ energies
    def kinetic_energy(self, v):
        """T = ½ vᵀ M v [J]."""
        return 0.5 * jnp.dot(v, self.mass_times(v))

    def strain_energy(self, q):
        """Σ U of all beams [J] (Eq. 8)."""
        return sum(self.map_beams(lambda b, nodes: b.strain_energy(nodes),
                                  [self.beam_nodes(q, i) for i in range(len(self.beams))]), jnp.zeros(()))

    def gravity_load(self):
        """Generalized gravity force (constant), shape (n,); zero on the items named in
        :attr:`gravity_off`."""
        if self.gravity_off:
            return self._gravity_load_on_some()
        parts = [jnp.reshape(self.bodies.mass[:, None] * jnp.array([1.0, 1.0, 0.0])[None, :]
                             * jnp.concatenate([self.gravity, jnp.zeros(1)])[None, :], (-1,))]
        parts += [jnp.reshape(b.gravity_load(self.gravity), (-1,)) for b in self.beams]
        parts += [jnp.zeros(self.n_sliding)]
        return jnp.concatenate(parts)

    def _gravity_load_on_some(self):
        """:meth:`gravity_load` with gravity off on the items of :attr:`gravity_off`."""
        on = np.array([n not in self.gravity_off for n in self.body_names], float)
        body = (self.bodies.mass * jnp.asarray(on))[:, None] * jnp.concatenate(
            [self.gravity, jnp.zeros(1)])[None, :]
        parts = [jnp.reshape(body, (-1,))]
        parts += [jnp.reshape(b.gravity_load(self.gravity), (-1,)) if name not in self.gravity_off
                  else jnp.zeros(b.n_coordinates) for b, name in zip(self.beams, self.beam_names)]
        parts += [jnp.zeros(self.n_sliding)]
        return jnp.concatenate(parts)

    def gravity_potential(self, q):
        """Potential of gravity −F_gᵀ q [J] (exact: the consistent load is constant)."""
        return -jnp.dot(self.gravity_load(), q)

    def force_potential(self, q, t):
        """Potential of the conservative parts of the force elements [J]."""
        return sum((f.potential(self, q, t) for f in self.forces), jnp.zeros(()))

    def potential_energy(self, q, t=0.0, load_factor=1.0):
        """Total potential: strain + load_factor·gravity + force elements [J]."""
        return (self.strain_energy(q) + load_factor * self.gravity_potential(q)
                + self.force_potential(q, t))

    # ------------------------------------------------------------------ forces
    def conservative_force(self, q, t=0.0, load_factor=1.0):
        """−∂V/∂q of the total potential (elastic Eq. 9, gravity, springs), shape (n,)."""
        return -jax.grad(self.potential_energy)(q, t, load_factor)

    def beam_groups(self) -> tuple[tuple[int, ...], ...]:
        """The beams in groups of like beams (static): equal structure (element, laws,
        formulation, static settings) and equal array shapes, e.g. the two wires of a
        catenary padded to one node count. :meth:`map_beams` evaluates a group in one
        vectorized evaluation, so its element code is traced and compiled once. A beam
        with leaves that are not arrays (a Python float) is a group of its own."""
        groups: dict = {}
        for i, b in enumerate(self.beams):
            leaves, treedef = jax.tree.flatten(b)
            if not all(isinstance(x, (jax.Array, np.ndarray)) for x in leaves):
                groups[("alone", i)] = [i]
                continue
            key = (treedef, tuple((x.shape, np.dtype(x.dtype)) for x in leaves))
            groups.setdefault(key, []).append(i)
        return tuple(tuple(g) for g in groups.values())

    def map_beams(self, fn, *per_beam):
        """``[fn(beam_b, *(a[b] for a in per_beam)) for every beam b]``, with the beams of a
        group of like beams (:meth:`beam_groups`) stacked and ``fn`` vectorized over
        them (``jax.vmap``): one traced evaluation per group. ``per_beam``: sequences
        of one array (or pytree) per beam, of equal shapes within a group (the beams'
        nodes, velocities); ``fn`` returns a pytree of arrays."""
        out = [None] * len(self.beams)
        for group in self.beam_groups():
            if len(group) == 1:
                b = group[0]
                out[b] = fn(self.beams[b], *(a[b] for a in per_beam))
                continue
            beams = jax.tree.map(_stack, *(self.beams[b] for b in group))
            args = [jax.tree.map(_stack, *(a[b] for b in group)) for a in per_beam]
            with _products.batch(len(group)):
                res = jax.vmap(fn)(beams, *args)
            for k, b in enumerate(group):
                out[b] = jax.tree.map(lambda x: x[k], res)
        return out

    @traced_once
    def _beam_forces(self, q, v):
        """Elastic forces −∂U/∂q and Rayleigh forces −(αM + βK)v of all beams, in one
        linearization of the elastic force per beam: ``jax.jvp`` of −∂U/∂e along the
        nodal velocities returns the force (primal) and −K v (tangent) together; plus the
        rate parts of material laws (:meth:`ancf_jax.beam.Beam.dissipative_force`). Like
        beams are evaluated together (:meth:`map_beams`)."""
        def one(b, nodes, vel):
            f, minus_kv = jax.jvp(b.elastic_force, (nodes,), (vel,))
            m_v = b.mass().add_diagonal(-jnp.repeat(
                jnp.where(b.mesh.active_nodes, 0.0, 1.0), 4)).matvec(jnp.reshape(vel, (-1,)))
            d = -b.alpha * m_v + b.beta * jnp.reshape(minus_kv, (-1,))
            if b.has_rate_law:  # rate parts of material laws (a dissipation)
                d = d + jnp.reshape(b.dissipative_force(nodes, vel), (-1,))
            return jnp.reshape(f, (-1,)), d

        parts = self.map_beams(one, [self.beam_nodes(q, i) for i in range(len(self.beams))],
                               [self.beam_nodes(v, i) for i in range(len(self.beams))])
        elastic = jnp.zeros_like(q)
        damping = jnp.zeros_like(q)
        for i, (f, d) in enumerate(parts):
            o = self.beam_offset(i)
            sl = slice(o, o + self.beams[i].n_coordinates)
            damping = damping.at[sl].add(d)
            elastic = elastic.at[sl].add(f)
        return elastic, damping

    def damping_force(self, q, v):
        """Rayleigh damping −(αM + βK) v per beam (Eq. 11) plus dampers, shape (n,).

        β K v is one Jacobian-vector product of the elastic force at the current q
        (K is the current tangent stiffness); no matrix is assembled.
        """
        # the elastic force is dropped (XLA removes it): one traced body serves this and
        # generalized_force (traced_once), the forces come from one JVP either way
        _, out = self._beam_forces(q, v)
        for f in self.forces:
            out = out + f.dissipative_force(self, q, v)
        return out

    def applied_force(self, q, v, t, load_factor=1.0):
        """Prescribed loads of the force elements, scaled by load_factor, shape (n,)."""
        out = jnp.zeros_like(q)
        for f in self.forces:
            out = out + f.applied_force(self, q, v, t)
        return load_factor * out

    def generalized_force(self, q, v, t, load_factor=1.0):
        """Q(q, v, t): all forces on the coordinates (right-hand side of Eq. 14), shape (n,).

        Elastic and Rayleigh forces come from one JVP of the elastic force per beam
        (see :meth:`_beam_forces`); gravity is the constant consistent load.
        """
        elastic, damping = self._beam_forces(q, v)
        out = elastic + damping + load_factor * self.gravity_load()
        for f in self.forces:
            out = out + f.generalized_force(self, q, v, t, load_factor)
        return out

    def reaction_force(self, q, v, t, lam):
        """Σ Q_r(q, v, t, λ) of the reaction-dependent forces (friction), shape (n,)."""
        out = jnp.zeros_like(q)
        for f in self.reaction_forces:
            out = out + f.generalized_force(self, q, v, t, lam)
        return out

    def constraint_offset(self, k: int) -> int:
        """Index in λ of the first equation of constraint k."""
        return sum(c.size for c in self.constraints[:k])

    # ------------------------------------------------------------------ constraints
    @traced_once
    def constraint(self, q, t=0.0):
        """Φ(q, t), shape (m,)."""
        if not self.constraints:
            return jnp.zeros((0,), q.dtype)
        return jnp.concatenate([c.residual(self, q, t) for c in self.constraints])

    @traced_once
    def constraint_jacobian(self, q, t=0.0):
        """Φ_q(q, t) = ∂Φ/∂q by reverse-mode autodiff (m VJPs), shape (m, n)."""
        if not self.constraints:
            return jnp.zeros((0, q.shape[0]), q.dtype)
        return jax.jacrev(self.constraint)(q, t)

    def constraint_velocity(self, q, v, t=0.0):
        """Φ̇ = Φ_q v + Φ_t, shape (m,) (one JVP)."""
        return jax.jvp(lambda qq, tt: self.constraint(qq, tt), (q, jnp.asarray(t, q.dtype)),
                       (v, jnp.ones((), q.dtype)))[1]

    def constraint_time_derivative(self, q, t=0.0):
        """Φ_t, shape (m,)."""
        return jax.jvp(lambda tt: self.constraint(q, tt), (jnp.asarray(t, q.dtype),),
                       (jnp.ones((), q.dtype),))[1]

    def constraint_rhs(self, q, v, t=0.0):
        """γ of Eq. 12: Φ_q q̈ = γ = −(Φ_q v)_q v − 2 Φ_qt v − Φ_tt, shape (m,).

        Computed as minus the second derivative of τ ↦ Φ(q + τ v, t + τ) at τ = 0 by
        nested JVPs.
        """
        tt = jnp.asarray(t, q.dtype)

        def phi_dot(tau):
            return jax.jvp(lambda a: self.constraint(q + a * v, tt + a), (tau,),
                           (jnp.ones((), q.dtype),))[1]

        return -jax.jvp(phi_dot, (jnp.zeros((), q.dtype),), (jnp.ones((), q.dtype),))[1]
