"""What the figures show (issue 25: figures that show their point): the difference
panels of Figs. 7 and 13 and the linked, labelled bodies of Fig. 12, checked on the
figure objects drawn from synthetic arrays (no simulation, nothing compiled)."""

import matplotlib.pyplot as plt
import numpy as np
import pytest

from ancf_jax import mesh, plotting
from ancf_jax.model import Model
from ancf_jax.results import Results
from ancf_jax.section import Section


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def test_time_history_difference_panel_shows_a_minus_b():
    """Fig. 7: the two curvature measures differ by far less than the curves' scale, so
    a panel below draws exact − approximate."""
    t = np.linspace(0.0, 1.0, 50)
    a, b = np.sin(6 * t), np.sin(6 * t) + 1e-3 * t
    fig = plotting.time_history(t, {"exact": a, "approximate": b}, ylabel="stress [MPa]",
                                difference=("exact", "approximate"))
    top, low = fig.axes
    assert [len(top.lines), len(low.lines)] == [2, 1]
    np.testing.assert_allclose(low.lines[0].get_ydata(), a - b)
    assert low.get_title() == "exact − approximate"
    assert low.get_ylabel() == "difference [MPa]" and low.get_xlabel() == "time [s]"
    assert len(plotting.time_history(t, {"exact": a}, ylabel="x").axes) == 1  # no panel unless asked


def test_trajectories_panel_shows_the_distance_from_the_reference():
    """Fig. 13: each mesh's distance [mm] from the finest one over time."""
    t = np.linspace(0.0, 1.0, 40)
    ref = (np.cos(t), np.sin(t))
    curves = {"12 elements": (np.cos(t) + 3e-3, np.sin(t) + 4e-3), "18 elements": (np.cos(t), np.sin(t) + 1e-3),
              "24 elements": ref}
    fig = plotting.trajectories(curves, t=t, reference="24 elements")
    top, low = fig.axes
    assert len(top.lines) == 3
    assert [ln.get_label() for ln in low.lines] == ["12 elements", "18 elements"]
    np.testing.assert_allclose(low.lines[0].get_ydata(), 5.0)  # hypot(3, 4) mm
    np.testing.assert_allclose(low.lines[1].get_ydata(), 1.0)
    np.testing.assert_allclose(low.lines[0].get_xdata(), t)
    assert low.get_ylabel() == "distance from 24 elements [mm]"


def test_deformed_shapes_link_and_label_the_bodies():
    """Fig. 12: trolley and cabin drawn joined by a line and labelled by name (they were
    two unlinked, unlabelled squares)."""
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("cable", mesh.straight((0, 0), (1, 0), 1.0, 2), Section(1e6, 1e-4, 1e-10, 0.1))
    m.add_body("trolley", mass=1.0, inertia=0.1, position=(0.5, 0.0))
    m.add_body("cabin", mass=1.0, inertia=0.1, position=(0.5, -0.5))
    system, state = m.build()
    q = np.repeat(np.asarray(state.q)[None], 3, axis=0)
    q[:, 4] -= np.array([0.0, 0.1, 0.2])  # the cabin moves down: y of body 1
    z = np.zeros_like(q)
    res = Results(system=system, t=np.array([0.0, 0.5, 1.0]), q=q, v=z, acc=z, lam=np.zeros((3, 0)),
                  work=np.zeros((3, 3)), iterations=np.zeros(3, int))
    fig = plotting.deformed_shapes(res, "cable", [0.0, 1.0], bodies=("trolley", "cabin"),
                                   links=(("trolley", "cabin"),))
    ax = fig.axes[0]
    links = [ln for ln in ax.lines if ln.get_linestyle() == ":"]
    assert len(links) == 2  # one per time
    np.testing.assert_allclose(links[0].get_xdata(), [0.5, 0.5])
    np.testing.assert_allclose(links[0].get_ydata(), [0.0, -0.5])
    np.testing.assert_allclose(links[1].get_ydata(), [0.0, -0.7])
    assert sorted(txt.get_text() for txt in ax.texts) == ["cabin", "trolley"]  # labelled once
