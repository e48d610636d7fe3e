"""Helpers shared by the dynamics tests: test models and a fixed-step runner whose
compiled code is reused across step sizes and parameter values.

:func:`ancf_jax.simulation.simulate` treats the step as a compile-time constant, so a
convergence study through it compiles once per step size. :func:`run_fixed` calls
:func:`ancf_jax.integrate.integrate_fixed` (the same time loop) with the step as traced
data, in chunks of a fixed number of steps: every step size and every system with the
same structure (only array values differ) reuses one compilation.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ancf_jax import mesh
from ancf_jax.integrate import NO_RETRIES, initial_loop, integrate_fixed
from ancf_jax.model import Model, body_point, node
from ancf_jax.section import Section

G = 9.81


# ---------------------------------------------------------------------------- runner
@eqx.filter_jit
def _init(system, state, solver):
    context = solver.prepare(system)
    return initial_loop(system, solver, state, context), context


@eqx.filter_jit
def _advance(system, solver, loop, context, h, steps, options):
    return integrate_fixed(system, solver, loop, context, h, n_intervals=steps, substeps=1,
                           options=options)


@dataclasses.dataclass
class Run:
    """Every step of a fixed-step run (NumPy arrays, leading axis: time)."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    acc: np.ndarray
    lam: np.ndarray
    work: np.ndarray
    crossings: np.ndarray
    status: int


def run_fixed(system, state, solver, h, t_end, *, chunk=50, options=NO_RETRIES):
    """Run ``t_end / h`` steps (a multiple of ``chunk``) of size h; returns a :class:`Run`
    with the initial state and every step."""
    n = int(round(t_end / h))
    assert abs(n * h - t_end) < 1e-9 * t_end and n % chunk == 0, (t_end, h, chunk)
    loop, context = _init(system, state, solver)
    c = loop.carry
    rows = dict(t=[np.asarray(c.t)[None]], q=[np.asarray(c.q)[None]], v=[np.asarray(c.v)[None]],
                acc=[np.asarray(c.acc)[None]], lam=[np.asarray(c.lam)[None]],
                work=[np.asarray(c.work)[None]], crossings=[np.zeros(1, int)])
    for _ in range(n // chunk):
        loop, seg = _advance(system, solver, loop, context, jnp.asarray(h, float), chunk, options)
        for k in rows:
            rows[k].append(np.asarray(getattr(seg, k)))
    return Run(**{k: np.concatenate(v) for k, v in rows.items()}, status=int(loop.status))


def observed_orders(errors):
    """log2 of successive error ratios for steps halved each time."""
    e = np.asarray(errors, float)
    return np.log2(e[:-1] / e[1:])


# ---------------------------------------------------------------------------- models
def h1_model(n_elements=4, *, alpha=0.0, beta=0.0, youngs_modulus=0.7e6):
    """H1 (docs/models.md): very flexible pendulum, 1.2 m, pinned at the origin, gravity only."""
    m = Model(gravity=(0.0, -G))
    area = 0.0018
    section = Section(youngs_modulus, area, 1.215e-8, 5540.0 * area)
    m.add_beam("beam", mesh.straight((0.0, 0.0), (1.0, 0.0), 1.2, n_elements), section,
               alpha=alpha, beta=beta)
    m.pin("pin", node("beam", 0))
    return m


# ---------------------------------------------------------------------------- tracks
STEEL = Section(2.1e11, 1e-4, 1e-9, 0.785)  # a 1 cm² steel bar


def hermite_point(nodes, lengths, s, order=0, element=None):
    """r, r' or r'' (``order``) of the cubic Hermite beam ``nodes`` (n + 1, 4) with
    element ``lengths`` at arc length s, in NumPy (independent of the package's code);
    ``element`` forces the element (to evaluate either side of a node)."""
    nodes, lengths = np.asarray(nodes, float), np.asarray(lengths, float)
    s_nodes = np.concatenate([[0.0], np.cumsum(lengths)])
    k = (int(np.clip(np.searchsorted(s_nodes, s, side="right") - 1, 0, len(lengths) - 1))
         if element is None else element)
    l, xi = lengths[k], (s - s_nodes[k]) / lengths[k]
    n = np.array([[1, 0, -3, 2], [0, 1, -2, 1], [0, 0, 3, -2], [0, 0, -1, 1]], float)
    c = np.polynomial.polynomial.polyder(n, m=order, axis=1) if order else n
    basis = c @ xi ** np.arange(c.shape[1]) * np.array([1.0, l, 1.0, l]) / l**order
    e = np.concatenate([nodes[k], nodes[k + 1]]).reshape(4, 2)
    return basis @ e


def track_model(track, s0, *, nodes=None, clamp_nodes="all", mass=1.0, inertia=0.1, rate=0.0,
                section=STEEL, gravity=(0.0, -G)):
    """A body sliding without friction on beam "track" (its centre on the centre line,
    sliding coordinate "slider", initially at s0 with rate ṡ₀).

    ``nodes`` (n + 1, 4): initial nodal coordinates of the track (default: the mesh's
    reference). ``clamp_nodes="all"`` clamps every node where it starts (the track is
    then exactly the Hermite curve of ``nodes``); ``"ends"`` clamps only the two end
    nodes (a flexible track)."""
    m = Model(gravity=gravity)
    n = int(track.n_elements)
    nodes = np.asarray(track.reference_nodes)[: n + 1] if nodes is None else np.asarray(nodes, float)
    m.add_beam("track", track, section, initial_nodes=nodes)
    lengths = np.asarray(track.element_lengths)[:n]
    m.add_body("slider_body", mass=mass, inertia=inertia, position=hermite_point(nodes, lengths, s0),
               velocity=rate * hermite_point(nodes, lengths, s0, 1))
    for i in (range(n + 1) if clamp_nodes == "all" else (0, n)):
        m.clamp(f"clamp{i}", "track", i)
    m.slider("slider", "slider_body", "track", s0, rate=rate)
    return m


def curve_motion(nodes, lengths, s0, rate0, t_eval, gravity=(0.0, -G)):
    """Reference motion of a particle sliding without friction on the fixed Hermite
    curve of ``nodes``/``lengths`` under gravity: the Lagrange equation
    |r'|² s̈ + (r'·r'') ṡ² = g·r', integrated element by element by SciPy's DOP853
    (tolerance 1e-13) with the node crossings as events, so the jump of r'' at the
    nodes is resolved exactly. Returns (s, ṡ) at ``t_eval``, shape (len(t_eval), 2),
    and the crossing times."""
    from scipy.integrate import solve_ivp

    lengths = np.asarray(lengths, float)
    s_nodes = np.concatenate([[0.0], np.cumsum(lengths)])
    g = np.asarray(gravity, float)
    t_eval = np.asarray(t_eval, float)
    out = np.full((len(t_eval), 2), np.nan)
    t0, y0 = float(t_eval[0]), np.array([s0, rate0], float)
    k = int(np.clip(np.searchsorted(s_nodes, s0, side="right") - 1, 0, len(lengths) - 1))
    crossings = []
    while True:
        def f(t, y, k=k):
            r1 = hermite_point(nodes, lengths, y[0], 1, element=k)
            r2 = hermite_point(nodes, lengths, y[0], 2, element=k)
            return [y[1], (g @ r1 - (r1 @ r2) * y[1] ** 2) / (r1 @ r1)]

        def lower(t, y, k=k):
            return y[0] - s_nodes[k]

        def upper(t, y, k=k):
            return y[0] - s_nodes[k + 1]

        lower.terminal, lower.direction = True, -1
        upper.terminal, upper.direction = True, 1
        sol = solve_ivp(f, (t0, t_eval[-1]), y0, method="DOP853", rtol=1e-13, atol=1e-14,
                        events=(lower, upper), dense_output=True)
        inside = (t_eval >= t0) & (t_eval <= sol.t[-1])
        if inside.any():
            out[inside] = sol.sol(t_eval[inside]).T
        if sol.status != 1:
            return out, np.array(crossings)
        t0, y0 = sol.t[-1], sol.y[:, -1].copy()
        up = sol.t_events[1].size > 0
        y0[0] = s_nodes[k + 1] if up else s_nodes[k]
        crossings.append(t0)
        k = k + 1 if up else k - 1
        if not 0 <= k < len(lengths):
            return out, np.array(crossings)


def pendulum_model(theta0, *, mass=1.0, inertia=0.01, arm=0.5):
    """Rigid pendulum: body "bob" (centre of mass ``arm`` below the hinge when θ = 0)
    pinned to the ground at the origin by its point (0, arm), released at rest at
    angle θ₀ [rad] from the vertical; its body angle is the pendulum angle."""
    m = Model(gravity=(0.0, -G))
    m.add_body("bob", mass=mass, inertia=inertia,
               position=(arm * np.sin(theta0), -arm * np.cos(theta0)), angle=theta0)
    m.pin("hinge", body_point("bob", (0.0, arm)), location=(0.0, 0.0))
    return m


def uneven_arc(n_elements=8, radius=1.0, half_angle=1.2):
    """Clamped-track geometry with curvature jumps: nodes on a circle of ``radius``
    centred at (0, radius), spanning ±``half_angle`` about the bottom, with element
    angles alternating 1:2, and unit tangents. Each Hermite element's curvature varies
    with its length, so κ jumps at every interior node (uniform elements, as from
    :func:`ancf_jax.mesh.arc`, have no jump by symmetry)."""
    steps = np.tile([1.0, 2.0], n_elements // 2 + 1)[:n_elements]
    steps *= 2.0 * half_angle / steps.sum()
    phi = -np.pi / 2 - half_angle + np.concatenate([[0.0], np.cumsum(steps)])
    points = np.column_stack([radius * np.cos(phi), radius + radius * np.sin(phi)])
    return mesh.through_points(points, np.column_stack([-np.sin(phi), np.cos(phi)]))


class LazyRuns(dict):
    """{key: run}, each run made by ``make(key)`` when a test first asks for it: a
    module fixture holding a study's runs, of which the default suite uses a few."""

    def __init__(self, make):
        super().__init__()
        self.make = make

    def __missing__(self, key):
        self[key] = run = self.make(key)
        return run
