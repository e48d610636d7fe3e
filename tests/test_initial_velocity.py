"""Initial velocities are projected onto the joints by the kinetic-energy projection
(issue 25): given velocities are kept as far as the joints allow, given sliding rates
exactly, unset body velocities follow the joints. Each result is checked against an
independent computation (closed form, or a null-space projection written here)."""

import contextlib
import warnings

import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg

from ancf_jax import ConstraintError, VelocityProjectionWarning, mesh
from ancf_jax.model import Model, body_point, node
from ancf_jax.scenario import load_scenario
from ancf_jax.section import Section

WIRE = Section.circle(4e-3, 200e9, mass_per_length=0.1)


def jacobian_and_rate(system, state):
    """Φ_q (m, n) and Φ_t (m,) at the state."""
    return (np.asarray(system.constraint_jacobian(state.q, state.t)),
            np.asarray(system.constraint_time_derivative(state.q, state.t)))


def null_space_projection(system, state, v_given, given=None, keep=()):
    """The projection by the null-space method, written independently of ancf_jax:
    over the non-padding coordinates but those in ``keep`` (kept as given), every
    feasible v is v_p + N z (N a null-space basis of Φ_q); z first minimizes the kinetic
    energy of the change of the given velocities (``given`` (n,) bool, default all),
    then, among those minimizers, the kinetic energy of the velocities not given
    (two least-squares problems in z, solved with Cholesky factors of the mass)."""
    jac, phit = jacobian_and_rate(system, state)
    n_all = jac.shape[1]
    free = ~np.asarray(system.inactive_mask())
    free[list(keep)] = False
    given = np.ones(n_all, bool) if given is None else np.asarray(given, bool)
    mass = np.asarray(system.mass_matrix())
    a = jac[:, free]
    base = np.array(v_given, float)
    particular = np.linalg.pinv(a) @ -(jac @ base + phit)
    n = scipy.linalg.null_space(a)
    g, u = given[free], ~given[free]
    lg = np.linalg.cholesky(mass[np.ix_(free, free)][np.ix_(g, g)]).T
    # stage 1: min |Lg (particular + N z)_g|  (the change of the given velocities)
    a1, b1 = lg @ n[g], lg @ particular[g]
    z0 = np.linalg.lstsq(a1, -b1, rcond=None)[0]
    ny = scipy.linalg.null_space(a1) if a1.size else np.eye(n.shape[1])
    if u.any() and ny.size:
        # stage 2: min |Lu (particular + N (z0 + Ny y))_u|, the unset velocities
        lu = np.linalg.cholesky(mass[np.ix_(free, free)][np.ix_(u, u)]).T
        y = np.linalg.lstsq(lu @ n[u] @ ny, -lu @ (particular[u] + n[u] @ z0), rcond=None)[0]
        z0 = z0 + ny @ y
    out = base.copy()
    out[free] += particular + n @ z0
    return out


@contextlib.contextmanager
def no_projection_warning():
    """A VelocityProjectionWarning inside the block is an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", VelocityProjectionWarning)
        yield


# ----------------------------------------------------------------------------- closed form
@pytest.mark.parametrize("mass, inertia, d", [(2.0, 0.3, 0.5), (100.0, 1.0, 0.05), (0.1, 2e-3, 1.5)])
def test_pinned_body_keeps_its_angular_momentum_about_the_pin(mass, inertia, d):
    v = 1.2
    m = Model(gravity=(0.0, 0.0))
    m.add_body("b", mass=mass, inertia=inertia, position=(1.0 + d, 2.0), velocity=(0.0, v),
               angular_velocity=0.0)
    m.pin("pin", body_point("b", (-d, 0.0)))
    with pytest.warns(VelocityProjectionWarning, match="body 'b'"):
        _, state = m.build()
    omega = mass * d * v / (inertia + mass * d * d)
    np.testing.assert_allclose(np.asarray(state.v), [0.0, omega * d, omega], rtol=1e-12, atol=1e-14)


# ----------------------------------------------------------------------------- beam model
@pytest.fixture(scope="module")
def cantilever():
    """A clamped 1 m wire (3 elements, padded to 5 slots) with a 0.05 kg tip body
    given a velocity and angular velocity the clamp does not allow as they are."""
    m = Model(gravity=(0.0, -9.81))
    m.add_beam("arm", mesh.straight((0, 0), (1, 0), 1.0, 3), WIRE)
    m.add_body("tip", mass=0.05, inertia=2e-5, position=(1.0, 0.0), velocity=(0.3, -0.8),
               angular_velocity=2.0)
    m.clamp("root", "arm", node=0)
    m.fixed("weld", node("arm", -1), body="tip")
    with pytest.warns(VelocityProjectionWarning):
        system, state = m.build(pad_to=5)
    given = np.zeros(system.n_coordinates)
    given[:3] = (0.3, -0.8, 2.0)
    return system, state, given


def test_projection_is_feasible_and_optimal(cantilever):
    system, state, given = cantilever
    v = np.asarray(state.v)
    jac, phit = jacobian_and_rate(system, state)
    assert np.max(np.abs(jac @ v + phit)) < 1e-10
    inactive = np.asarray(system.inactive_mask())
    assert inactive.any() and np.all(v[inactive] == 0.0)
    # KKT: M (v − v_given) on the free coordinates lies in the range of Φ_qᵀ
    free = ~inactive
    g = (np.asarray(system.mass_matrix()) @ (v - given))[free]
    lam = np.linalg.lstsq(jac[:, free].T, g, rcond=None)[0]
    assert np.linalg.norm(jac[:, free].T @ lam - g) < 1e-10 * np.linalg.norm(g)
    np.testing.assert_allclose(v, null_space_projection(system, state, given), rtol=0, atol=1e-10)


# ----------------------------------------------------------------------------- hoist load
def test_hoist_load_keeps_its_speed():
    """A 100 kg load on a clamped 2 m hanging wire, given 0.3 m/s downward: the load
    carries almost all the kinetic energy, so it keeps almost all its speed (the old
    minimum-norm correction halved it)."""
    m = Model(gravity=(0.0, -9.81))
    m.add_beam("rope", mesh.straight((0, 0), (0, -1), 2.0, 4), WIRE)
    m.add_body("load", mass=100.0, inertia=2.0, position=(0.0, -2.0), velocity=(0.0, -0.3))
    m.clamp("top", "rope", node=0)
    m.fixed("hook", node("rope", -1), body="load")
    with pytest.warns(VelocityProjectionWarning, match="body 'load'"):
        system, state = m.build()
    v = np.asarray(state.v)
    given = np.zeros(v.size)
    given[1] = -0.3
    mask = np.ones(v.size, bool)
    mask[2] = False  # the load's angular velocity was not given
    np.testing.assert_allclose(v, null_space_projection(system, state, given, mask), rtol=0, atol=1e-10)
    assert abs(v[1] + 0.3) < 1e-3 and abs(v[1] + 0.15) > 0.1
    jac, phit = jacobian_and_rate(system, state)
    assert np.max(np.abs(jac @ v + phit)) < 1e-10


# ----------------------------------------------------------------------------- trolley
def trolley_model(hold=False):
    """A 5 m wire from (0, 0) to (4, 3), clamped at the start and pinned at the end,
    with a 2 kg trolley at s = 2.5 m given rate −4 m/s and no velocity."""
    m = Model(gravity=(0.0, -9.81))
    m.add_beam("cable", mesh.straight((0, 0), (4, 3), 5.0, 4), WIRE)
    m.add_body("trolley", mass=2.0, inertia=0.05, position=(2.0, 1.5))
    m.clamp("A", "cable", node=0)
    m.pin("B", node("cable", -1))
    m.slider("slide", "trolley", "cable", 2.5, rate=-4.0, hold=hold)
    return m


def test_trolley_given_a_rate_moves_along_the_cable_at_rest():
    with no_projection_warning():
        system, state = trolley_model().build()
    v = np.asarray(state.v)
    s = system.sliding_offset
    assert v[s] == -4.0
    given = np.zeros(v.size)
    given[s] = -4.0
    mask = np.ones(v.size, bool)
    mask[:3] = False  # the trolley's velocities were not given
    np.testing.assert_allclose(v, null_space_projection(system, state, given, mask, keep=[s]),
                               rtol=0, atol=1e-10)
    # closed form: the cable stays at rest, the trolley moves along it at r'(s)·ṡ (|r'| = 1:
    # the straight wire is unstretched)
    np.testing.assert_allclose(v[:2], -4.0 * np.array([0.8, 0.6]), rtol=1e-12)
    assert abs(v[2]) < 1e-12  # nothing sets the trolley's angular velocity
    assert np.max(np.abs(v[system.chain_slice()])) < 1e-12
    jac, phit = jacobian_and_rate(system, state)
    assert np.max(np.abs(jac @ v + phit)) < 1e-10


def test_held_trolley_given_a_rate_is_an_error():
    with pytest.raises(ConstraintError, match="slide.hold"):
        trolley_model(hold=True).build()


# ----------------------------------------------------------------------------- static mode
def test_static_mode_starts_with_the_given_rate():
    """The shipped M2 (initial.mode = "static": equilibrium with the trolley held, then
    released) given a trolley rate starts with exactly that ṡ, the cable at rest and the
    trolley, whose velocity is not given, moving along the cable with it. (The statics
    program is that of the shipped M2, which other tests compile: the persistent
    compilation cache shares it.)"""
    with no_projection_warning():  # only the joints set what was not given
        system, state = load_scenario("m2", ["joints.slider.rate=0.7"]).build()
    v = np.asarray(state.v)
    assert v[system.sliding_offset] == 0.7
    jac, phit = jacobian_and_rate(system, state)
    assert np.max(np.abs(jac @ v + phit)) < 1e-10
    assert np.max(np.abs(v[system.chain_slice()])) < 1e-12  # the cable stays at rest
    assert abs(np.linalg.norm(v[:2]) - 0.7) < 1e-3  # |r'| = 1 + axial strain


def test_no_warning_when_only_the_joints_set_velocities():
    """A beam at rest (the default) whose clamped end is prescribed to move at t = 0: the
    joints set the velocities, no given velocity was non-zero, so there is no warning."""
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("rope", mesh.straight((0, 0), (1, 0), 1.0, 3), Section.circle(1e-3, 2e11, mass_per_length=0.01))
    m.prescribe_point("drive", node("rope", 0), lambda t: jnp.array([0.5 * t, 0.0]))
    with no_projection_warning():
        system, state = m.build()
    assert abs(float(state.v[system.beam_offset(0)]) - 0.5) < 1e-9
