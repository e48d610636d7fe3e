"""Meshes: straight beams, beams through points (curved references), padding, lookup."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax import ModelError, mesh


def test_straight_mesh_nodes_and_lengths():
    m = mesh.straight((1.0, 2.0), (3.0, 4.0), 5.0, 5)
    nodes = np.asarray(m.reference_nodes)
    np.testing.assert_allclose(nodes[:, :2], [[1 + 0.6 * s, 2 + 0.8 * s] for s in range(6)], atol=1e-14)
    np.testing.assert_allclose(nodes[:, 2:], [[0.6, 0.8]] * 6)
    np.testing.assert_allclose(m.element_lengths, 1.0)
    assert int(m.n_elements) == 5 and m.n_max == 5 and float(m.length) == pytest.approx(5.0)


def test_arc_mesh_element_lengths_are_arc_lengths():
    """Element lengths are arc lengths of the Hermite cubics, which approach the circle
    at O(Δφ⁴)."""
    r, phi = 2.0, np.pi / 2
    errs = []
    for n in (6, 12):
        m = mesh.arc((0.0, 0.0), r, 0.0, phi, n)
        errs.append(np.max(np.abs(np.asarray(m.element_lengths) / (r * phi / n) - 1)))
    assert errs[1] < 1e-6
    assert 14 < errs[0] / errs[1] < 18


def test_padding_keeps_active_geometry():
    m = mesh.straight((0, 0), (1, 0), 2.0, 4)
    p = mesh.pad(m, 9)
    assert p.n_max == 9 and int(p.n_elements) == 4
    np.testing.assert_allclose(p.reference_nodes[:5], m.reference_nodes)
    np.testing.assert_allclose(p.node_arc_lengths[:5], m.node_arc_lengths)
    np.testing.assert_allclose(p.node_arc_lengths[5:], 2.0)  # inactive: zero length
    assert float(p.length) == pytest.approx(2.0)
    np.testing.assert_array_equal(p.active, [True] * 4 + [False] * 5)


def test_locate_crosses_nodes_without_retracing():
    m = mesh.straight((0, 0), (1, 0), 3.0, 3, n_max=5)
    traces = []

    @jax.jit
    def f(s):
        traces.append(1)
        return m.locate(s)

    for s, (k, x) in [(0.0, (0, 0.0)), (0.5, (0, 0.5)), (1.0, (1, 0.0)), (2.999, (2, 0.999)),
                      (3.0, (2, 1.0)), (3.2, (2, 1.2)), (-0.1, (0, -0.1))]:
        kk, xx = f(jnp.asarray(s))
        assert int(kk) == k and float(xx) == pytest.approx(x)
    assert len(traces) == 1


def test_through_points_requires_matching_shapes():
    with pytest.raises(ModelError, match="slopes"):
        mesh.through_points([[0, 0], [1, 0]], [[1, 0]])
    with pytest.raises(ModelError, match="coincide"):
        mesh.through_points([[0, 0], [0, 0]], [[1, 0], [1, 0]])


def test_catenary_nodes_length_and_ends():
    nodes = mesh.catenary_nodes((0, 0), (3.8, 0), 4.02, 40)
    seg = np.hypot(*np.diff(nodes[:, :2], axis=0).T)
    assert seg.sum() == pytest.approx(4.02, rel=1e-4)
    np.testing.assert_allclose(seg, 4.02 / 40, rtol=2e-3)
    np.testing.assert_allclose(nodes[[0, -1], :2], [[0, 0], [3.8, 0]])
    np.testing.assert_allclose(np.hypot(nodes[:, 2], nodes[:, 3]), 1.0)
    assert nodes[20, 1] < -0.5


def test_through_points_far_from_the_origin():
    """Element lengths do not depend on where the points are: a straight 0.5 m element
    is its chord, and a quarter circle of radius 1 keeps its length (one Hermite
    cubic's, 0.9 % short of π/2) to 1e-14 relative, at the origin and 10 km away
    (there the absolute positions' rounding, 1e-13 of the chord, had stopped the fixed
    point of the length from converging: the shipped 600 m catenary failed to build)."""
    arc = np.linspace(0.0, np.pi / 2, 2)
    circle = np.column_stack([np.cos(arc), np.sin(arc)])
    tangents = np.column_stack([-np.sin(arc), np.cos(arc)])
    lengths = []
    for x0 in (0.0, 358.25, 1e4):
        straight = mesh.through_points([[x0, 0.0], [x0 + 0.5, 0.0]], [[1.0, 0.0], [1.0, 0.0]])
        assert float(straight.element_lengths[0]) == pytest.approx(0.5, rel=1e-14)
        lengths.append(float(mesh.through_points(circle + [x0, 0.0], tangents).element_lengths[0]))
    assert lengths[0] == pytest.approx(np.pi / 2, rel=1e-2)
    np.testing.assert_allclose(lengths, lengths[0], rtol=1e-14)
