"""Beam meshes: node/element bookkeeping of a chain of planar ANCF elements.

A beam of ``n`` elements has ``n + 1`` nodes with 4 coordinates each
(r_x, r_y, ∂r_x/∂x, ∂r_y/∂x); element ``k`` joins nodes ``k`` and ``k + 1`` and the
beam is C¹ at the nodes. The element parameter is the arc length of the stress-free
reference configuration, and a point on the beam is addressed by one global reference
arc length s ∈ [0, L].

Padding. A mesh may be padded to ``n_max > n`` elements: the extra elements are
inactive (no mass, no stiffness, no load; their nodes get a dummy unit mass so the
system stays regular) and the extra nodes continue the last element straight. Meshes
of different element counts padded to the same ``n_max`` have identical array shapes
and run under one ``jax.vmap``.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .errors import ModelError
from .validation import check_count, check_finite, check_positive, check_vector


class BeamMesh(eqx.Module):
    """Reference geometry of one beam.

    Attributes:
        element_lengths: reference lengths of the ``n_max`` elements [m], shape (n_max,).
        reference_nodes: stress-free nodal coordinates, shape (n_max + 1, 4).
        n_elements: number of active elements (int array, so it can be batched).
    """

    element_lengths: jnp.ndarray
    reference_nodes: jnp.ndarray
    n_elements: jnp.ndarray

    @property
    def n_max(self) -> int:
        """Number of element slots (active + inactive); static."""
        return self.element_lengths.shape[-1]

    @property
    def n_nodes(self) -> int:
        """Number of node slots, ``n_max + 1``; static."""
        return self.n_max + 1

    @property
    def active(self):
        """Mask of active elements, shape (n_max,)."""
        return jnp.arange(self.n_max) < self.n_elements

    @property
    def active_nodes(self):
        """Mask of active nodes, shape (n_max + 1,)."""
        return jnp.arange(self.n_nodes) <= self.n_elements

    @property
    def node_arc_lengths(self):
        """Reference arc length of every node [m], shape (n_max + 1,)."""
        l = jnp.where(self.active, self.element_lengths, 0.0)
        return jnp.concatenate([jnp.zeros(1), jnp.cumsum(l)])

    @property
    def length(self):
        """Total reference length of the active elements [m]."""
        return jnp.sum(jnp.where(self.active, self.element_lengths, 0.0))

    def element_coordinates(self, nodes):
        """Gather element coordinate vectors from nodal coordinates.

        Args:
            nodes: shape (n_max + 1, 4).

        Returns:
            shape (n_max, 8): element k is [nodes[k], nodes[k + 1]].
        """
        return jnp.concatenate([nodes[:-1], nodes[1:]], axis=-1)

    @property
    def reference_elements(self):
        """Stress-free element coordinates, shape (n_max, 8)."""
        return self.element_coordinates(self.reference_nodes)

    def locate(self, s):
        """Element index and local coordinate of the global arc length s.

        The element is the active one whose span contains s (the last one at s = L);
        outside [0, L] the first or last element is extrapolated. Works inside ``jit``:
        the index is computed from s, so a point moving along the beam crosses nodes
        without re-tracing.

        Returns:
            (k, x): int element index and local reference arc length [m].
        """
        s_nodes = self.node_arc_lengths
        k = jnp.searchsorted(s_nodes, s, side="right") - 1
        k = jnp.clip(k, 0, self.n_elements - 1)
        return k, s - s_nodes[k]


def _finish(lengths: np.ndarray, nodes: np.ndarray, n_max: int | None) -> BeamMesh:
    n = lengths.shape[0]
    if n_max is None:
        n_max = n
    n_max = check_count("n_max (padded element count)", n_max, 1)
    if n_max < n:
        raise ModelError(f"n_max must be >= the element count {n}, got {n_max}")
    if n_max > n:
        t = nodes[-1, 2:] / np.linalg.norm(nodes[-1, 2:])
        l = lengths[-1]
        extra = np.array([[*(nodes[-1, :2] + (k + 1) * l * t), *t] for k in range(n_max - n)])
        nodes = np.concatenate([nodes, extra])
        lengths = np.concatenate([lengths, np.full(n_max - n, l)])
    return BeamMesh(jnp.asarray(lengths, float), jnp.asarray(nodes, float),
                    jnp.asarray(n, jnp.int32))


def straight(start, direction, length, n_elements, *, n_max=None) -> BeamMesh:
    """A straight beam from ``start`` along ``direction`` (normalized).

    Args:
        start: first node position [m], shape (2,).
        direction: direction vector, shape (2,), any non-zero length.
        length: beam length [m], > 0.
        n_elements: number of elements, >= 1.
        n_max: pad to this many element slots (default: no padding).
    """
    p0 = check_vector("start", start, 2)
    d = check_vector("direction", direction, 2)
    length = check_positive("length", length, "m")
    n = check_count("n_elements", n_elements, 1)
    nd = np.linalg.norm(d)
    if nd == 0.0:
        raise ModelError("direction must be a non-zero vector")
    t = d / nd
    s = np.linspace(0.0, length, n + 1)
    nodes = np.column_stack([p0[0] + s * t[0], p0[1] + s * t[1],
                             np.full(n + 1, t[0]), np.full(n + 1, t[1])])
    return _finish(np.full(n, length / n), nodes, n_max)


@jax.jit
def _hermite_arc_length(e, length):
    """Arc length of the cubic of element coordinates e (8,) with parameter length l."""
    from .element.quadrature import gauss_legendre
    from .element.shape_functions import slope
    x, w = gauss_legendre(8)
    r1 = jax.vmap(lambda xi: slope(e, xi * length, length))(jnp.asarray(x))
    return length * jnp.dot(jnp.asarray(w), jnp.sqrt(jnp.sum(r1 * r1, axis=1)))


#: the length l of a Hermite element through given points and unit slopes is the fixed
#: point l = (arc length of its cubic with parameter length l), found from the chord by
#: fixed-point iteration to this relative change (at most LENGTH_ITERATIONS steps)
LENGTH_TOLERANCE = 1e-14
LENGTH_ITERATIONS = 50


def element_length(arc_length, chord: float, where: str = "an element") -> float:
    """The fixed point l = ``arc_length(l)`` [m] from l = ``chord``
    (``scipy.optimize.fixed_point``, plain iteration, :data:`LENGTH_TOLERANCE`).

    Raises:
        ModelError: no convergence in :data:`LENGTH_ITERATIONS` steps (the slopes turn
            too far within the element; more points help).
    """
    from scipy.optimize import fixed_point
    try:
        return float(fixed_point(arc_length, chord, xtol=LENGTH_TOLERANCE, maxiter=LENGTH_ITERATIONS,
                                 method="iteration"))
    except RuntimeError:
        raise ModelError(f"the length of {where} did not converge in {LENGTH_ITERATIONS} fixed-point "
                         "iterations: its slopes turn too far within it (give more points)") from None


def through_points(points, slopes, *, n_max=None) -> BeamMesh:
    """A beam whose stress-free reference passes through given points with given slopes.

    Element k joins points k and k+1. Slopes are normalized to unit tangents and each
    element length is the arc length of the Hermite cubic through its end points
    (:func:`element_length`), so the element parameter is close to arc length. Use this
    for initially curved beams: the reference is stress-free.

    Args:
        points: node positions [m], shape (n + 1, 2), n >= 1.
        slopes: tangent directions at the nodes, shape (n + 1, 2), non-zero.
    """
    p = check_finite("points", points)
    t = check_finite("slopes", slopes)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 2:
        raise ModelError(f"points must have shape (n+1, 2) with n >= 1, got {p.shape}")
    if t.shape != p.shape:
        raise ModelError(f"slopes must have the shape of points {p.shape}, got {t.shape}")
    nt = np.linalg.norm(t, axis=1)
    if np.any(nt == 0.0):
        raise ModelError("slopes must be non-zero vectors")
    t = t / nt[:, None]
    lengths = []
    for k in range(p.shape[0] - 1):
        chord = np.linalg.norm(p[k + 1] - p[k])
        if chord == 0.0:
            raise ModelError(f"points {k} and {k + 1} coincide: element lengths must be > 0")
        # in coordinates local to the element's first point: the arc length does not
        # depend on where the element is, and far from the origin (a 600 m line) the
        # rounding of absolute positions (1e-13 of the chord) kept the fixed point
        # from meeting LENGTH_TOLERANCE
        e = jnp.asarray(np.concatenate([np.zeros(2), t[k], p[k + 1] - p[k], t[k + 1]]))
        lengths.append(element_length(lambda l: float(_hermite_arc_length(e, l)), chord, f"element {k}"))
    nodes = np.column_stack([p, t])
    return _finish(np.array(lengths), nodes, n_max)


def from_nodes(nodes, element_lengths, *, n_max=None) -> BeamMesh:
    """A beam of given stress-free nodal coordinates and element lengths, taken as they
    are (no fitting): element k joins nodes k and k + 1 and its parameter runs over
    [0, l_k], as Exudyn's ``ObjectANCFCable2D`` with ``length`` l_k.

    Args:
        nodes: reference nodal coordinates (r_x, r_y, r'_x, r'_y) [m, -], shape (n + 1, 4), n >= 1.
        element_lengths: l_k [m] > 0, shape (n,).
        n_max: pad to this many element slots (default: no padding).
    """
    x = check_finite("nodes", nodes)
    lengths = check_finite("element_lengths", element_lengths)
    if x.ndim != 2 or x.shape[1] != 4 or x.shape[0] < 2:
        raise ModelError(f"nodes must have shape (n+1, 4) with n >= 1, got {x.shape}")
    if lengths.shape != (x.shape[0] - 1,):
        raise ModelError(f"element_lengths must have shape ({x.shape[0] - 1},), got {lengths.shape}")
    if np.any(lengths <= 0.0):
        raise ModelError(f"element_lengths must be > 0 m, got {lengths.min()!r}")
    if np.any(np.linalg.norm(x[:, 2:], axis=1) == 0.0):
        raise ModelError("nodes must have non-zero slopes (columns 2 and 3)")
    return _finish(lengths.astype(float), x.astype(float), n_max)


def arc(center, radius, start_angle, end_angle, n_elements, *, n_max=None) -> BeamMesh:
    """A circular arc [m, rad], counter-clockwise if end_angle > start_angle."""
    c = check_vector("center", center, 2)
    r = check_positive("radius", radius, "m")
    n = check_count("n_elements", n_elements, 1)
    if start_angle == end_angle:
        raise ModelError("end_angle must differ from start_angle")
    phi = np.linspace(start_angle, end_angle, n + 1)
    sgn = np.sign(end_angle - start_angle)
    pts = np.column_stack([c[0] + r * np.cos(phi), c[1] + r * np.sin(phi)])
    tan = sgn * np.column_stack([-np.sin(phi), np.cos(phi)])
    return through_points(pts, tan, n_max=n_max)


def pad(mesh: BeamMesh, n_max: int) -> BeamMesh:
    """The same beam padded to ``n_max`` element slots (see module docstring)."""
    n = int(mesh.n_elements)
    lengths = np.asarray(mesh.element_lengths)[:n]
    nodes = np.asarray(mesh.reference_nodes)[: n + 1]
    return _finish(lengths, nodes, n_max)


def catenary_nodes(start, end, length, n_elements) -> np.ndarray:
    """Nodal coordinates of an inextensible catenary hanging (towards −y) between two
    points, with nodes at equal arc length and unit slopes, shape (n + 1, 4).

    A good initial guess for the static equilibrium of a slack cable whose stress-free
    reference is straight.

    Args:
        start: first end point [m], shape (2,).
        end: second end point [m], shape (2,), to the right of ``start`` (x₁ > x₀).
        length: cable length [m], longer than the chord.
        n_elements: number of elements.
    """
    p0 = check_vector("start", start, 2)
    p1 = check_vector("end", end, 2)
    length = check_positive("length", length, "m")
    n = check_count("n_elements", n_elements, 1)
    dx, dy = p1 - p0
    if dx <= 0.0:
        raise ModelError("catenary: end must lie to the right of start (x1 > x0)")
    if length <= np.hypot(dx, dy) * (1 + 1e-12):
        raise ModelError(f"catenary: length {length:g} m must exceed the chord {np.hypot(dx, dy):g} m")
    from scipy.optimize import brentq
    target = np.sqrt(length**2 - dy**2)
    # the parameter a: 2a sinh(dx/2a) = target (decreasing from ∞ to dx as a grows); in
    # u = dx/2a, r = target/dx: sinh(u)/u = r, which is <= r at u = acosh(r) (sinh u <= u
    # cosh u) and >= r at u = 2 acosh(r) + 2
    r = target / dx
    u_lo, u_hi = np.arccosh(r), 2.0 * np.arccosh(r) + 2.0
    a = brentq(lambda a: 2 * a * np.sinh(dx / (2 * a)) - target, dx / (2 * u_hi), dx / (2 * u_lo),
               xtol=1e-300, rtol=4 * np.finfo(float).eps)
    xc = 0.5 * (p0[0] + p1[0]) - a * np.arcsinh(dy / target)
    yc = p0[1] - a * np.cosh((p0[0] - xc) / a)
    s = np.linspace(0.0, length, n + 1)
    x = xc + a * np.arcsinh(s / a + np.sinh((p0[0] - xc) / a))
    y = yc + a * np.cosh((x - xc) / a)
    x[0], y[0], x[-1], y[-1] = p0[0], p0[1], p1[0], p1[1]
    slope = np.sinh((x - xc) / a)
    t = np.column_stack([np.ones_like(slope), slope]) / np.sqrt(1 + slope**2)[:, None]
    return np.column_stack([x, y, t])
