"""Beam geometry of a scenario: host-side lengths for checks, and the meshes.

:func:`reference_length` and :func:`element_count` use NumPy only, so that arc lengths
named in a scenario can be checked against the beam before anything is compiled;
:func:`make_mesh` builds the :class:`~ancf_jax.mesh.BeamMesh`.
"""

from __future__ import annotations

import math

import numpy as np

from .. import mesh as _mesh
from ..element.shape_functions import HERMITE
from .schema import Arc, BeamSpec, Straight, ThroughPoints

_XI, _W = np.polynomial.legendre.leggauss(8)
_XI, _W = 0.5 * (_XI + 1.0), 0.5 * _W
# ξ-derivatives of the Hermite polynomials at the Gauss points, shape (8, 4)
_DN = np.stack([np.polynomial.polynomial.polyval(_XI, np.polynomial.polynomial.polyder(c))
                for c in HERMITE], axis=1)


def hermite_length(p0, t0, p1, t1) -> float:
    """Arc length [m] of the cubic Hermite element through p0, p1 with unit tangents
    t0, t1 whose parameter length equals its arc length (the fixed point of
    :func:`ancf_jax.mesh.element_length`, as :func:`ancf_jax.mesh.through_points`)."""
    p0, t0, p1, t1 = (np.asarray(a, float) for a in (p0, t0, p1, t1))

    def arc_length(length):
        d = (_DN[:, 0:1] * p0 + length * _DN[:, 1:2] * t0 + _DN[:, 2:3] * p1
             + length * _DN[:, 3:4] * t1)
        return float(np.dot(_W, np.linalg.norm(d, axis=1)))

    return _mesh.element_length(arc_length, float(np.linalg.norm(p1 - p0)))


def unit_slopes(slopes) -> np.ndarray:
    """Slope vectors, shape (k, 2), normalized to unit length."""
    t = np.asarray(slopes, float)
    return t / np.linalg.norm(t, axis=1, keepdims=True)


def arc_nodes(arc: Arc, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Node positions and unit tangents of an arc of n elements (as :func:`ancf_jax.mesh.arc`)."""
    phi = np.linspace(arc.start_angle, arc.end_angle, n + 1)
    sgn = np.sign(arc.end_angle - arc.start_angle)
    points = np.column_stack([arc.center[0] + arc.radius * np.cos(phi), arc.center[1] + arc.radius * np.sin(phi)])
    return points, sgn * np.column_stack([-np.sin(phi), np.cos(phi)])


def reference_length(geometry, n_elements: int) -> float:
    """Total stress-free length L [m] of the beam's mesh (host only): the given length
    of a straight beam, else the sum of the Hermite element lengths (for an arc a
    little shorter than r·|Δφ|)."""
    if isinstance(geometry, Straight):
        return float(geometry.length)
    if isinstance(geometry, Arc):
        p, t = arc_nodes(geometry, n_elements)
    else:
        p, t = np.asarray(geometry.points, float), unit_slopes(geometry.slopes)
    return float(sum(hermite_length(p[k], t[k], p[k + 1], t[k + 1]) for k in range(len(p) - 1)))


def element_count(beam: BeamSpec) -> int:
    """Number of elements of a beam (points: one per interval unless given)."""
    if isinstance(beam.geometry, ThroughPoints) and beam.elements is None:
        return len(beam.geometry.points) - 1
    return 1 if beam.elements is None else int(beam.elements)


def make_mesh(beam: BeamSpec) -> _mesh.BeamMesh:
    """The beam's reference mesh."""
    g, n = beam.geometry, element_count(beam)
    if isinstance(g, Straight):
        return _mesh.straight(g.start, g.direction, g.length, n)
    if isinstance(g, Arc):
        return _mesh.arc(g.center, g.radius, g.start_angle, g.end_angle, n)
    return _mesh.through_points(g.points, g.slopes)


def first_node(beam: BeamSpec) -> tuple[float, float]:
    """Position of the first node of the reference geometry [m]."""
    g = beam.geometry
    if isinstance(g, Straight):
        return g.start
    if isinstance(g, Arc):
        return (g.center[0] + g.radius * math.cos(g.start_angle),
                g.center[1] + g.radius * math.sin(g.start_angle))
    return g.points[0]


def initial_node_positions(beam: BeamSpec, n_elements: int, length: float) -> np.ndarray:
    """Node positions [m] of the beam's initial shape, shape (k, 2), host only: every
    node of the reference geometry or of given nodes; for a catenary only its two ends
    (its x is monotonic between them)."""
    ini, g = beam.initial, beam.geometry
    if ini.shape == "nodes" and ini.nodes is not None:
        return np.asarray(ini.nodes, float)[:, :2]
    if ini.shape == "catenary" and ini.end is not None:
        start = ini.start if ini.start is not None else first_node(beam)
        return np.array([start, ini.end], float)
    if isinstance(g, Straight):
        d = np.asarray(g.direction, float) / np.linalg.norm(g.direction)
        return np.asarray(g.start, float) + np.linspace(0.0, length, n_elements + 1)[:, None] * d
    if isinstance(g, Arc):
        return arc_nodes(g, n_elements)[0]
    return np.asarray(g.points, float)
