"""Exudyn parity (issue 22): sections from EA, EI, ρA; coordinate constraints and the
Exudyn-style clamp; point masses and per-item loads; CSV precision; material laws.

Each feature is checked against a closed form or against the equivalent model written
the existing way; the Exudyn cross-checks of the laws are in tests/exudyn_cases.py
(run in a spawned interpreter by tests/test_exudyn_crosscheck.py).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ancf_jax import mesh
from ancf_jax.beam import Beam
from ancf_jax.errors import ModelError
from ancf_jax.section import Section

E, A, I, RHO_A = 2.0e11, 1.0e-4, 1.0e-9, 0.785


def _deformed(beam, seed=0):
    ref = np.asarray(beam.mesh.reference_nodes)
    return jnp.asarray(ref + 0.01 * np.random.default_rng(seed).standard_normal(ref.shape))


# ----------------------------------------------------------------------------- 1. sections
def test_section_from_stiffness_is_the_same_beam():
    """EA, EI, ρA without E: the element sees exactly E·A and E·I (bitwise equal forces);
    with E given as well the stiffnesses agree to round-off, and stresses agree."""
    m = mesh.straight((0, 0), (1, 0), 1.0, 3)
    by_modulus = Beam(m, Section(E, A, I, RHO_A))
    by_stiffness = Beam(m, Section.from_stiffness(E * A, E * I, RHO_A))
    with_e = Beam(m, Section.from_stiffness(E * A, E * I, RHO_A, youngs_modulus=E))
    nodes = _deformed(by_modulus)
    force = eqx.filter_jit(lambda b, n: b.elastic_force(n))
    f0 = np.asarray(force(by_modulus, nodes))
    assert np.array_equal(np.asarray(force(by_stiffness, nodes)), f0)
    assert float(by_stiffness.section.mass_per_length) == float(by_modulus.section.mass_per_length)
    np.testing.assert_allclose(np.asarray(force(with_e, nodes)), f0, rtol=1e-15, atol=1e-15 * abs(f0).max())
    assert float(by_stiffness.section.fibre_distance) == float(by_modulus.section.fibre_distance)
    s0 = float(by_modulus.stress(nodes, 0.3))
    assert float(with_e.stress(nodes, 0.3)) == pytest.approx(s0, rel=1e-14)
    with pytest.raises(ModelError, match="needs Young's modulus.*youngs_modulus"):
        by_stiffness.stress(nodes, 0.3)
    # an explicit outer-fibre distance c is the default fibre of the stresses: σ = −E c κ
    # is linear in the fibre, so σ(c) = σ(c₀)·c/c₀, and equals σ at y = c given explicitly
    c = 3.0 * float(with_e.section.fibre_distance)
    with_c = Beam(m, Section.from_stiffness(E * A, E * I, RHO_A, youngs_modulus=E, fibre_distance=c))
    assert float(with_c.section.fibre_distance) == c
    assert float(with_c.stress(nodes, 0.3)) == pytest.approx(3.0 * s0, rel=1e-14)
    assert float(with_c.stress(nodes, 0.3)) == float(with_e.stress(nodes, 0.3, y=c))


@pytest.mark.parametrize("bad, match", [
    (dict(axial_stiffness=0.0), r"axial_stiffness \(EA\)"),
    (dict(bending_stiffness=-1.0), r"bending_stiffness \(EI\)"),
    (dict(youngs_modulus=0.0), r"youngs_modulus \(E\)"),
    (dict(fibre_distance=-0.01), r"fibre_distance must be a finite number > 0"),
])
def test_section_from_stiffness_rejects_bad_input(bad, match):
    args = dict(axial_stiffness=E * A, bending_stiffness=E * I, mass_per_length=RHO_A) | bad
    with pytest.raises(ModelError, match=match):
        Section.from_stiffness(**args)


SCENARIO = '''
gravity = [0.0, -9.81]
[beams.arm]
geometry = {{ type = "straight", length = 1.0 }}
elements = 3
section = {{ {section}, mass_per_length = 0.785 }}
[joints.clamp]
type = "clamp"
beam = "arm"
[solver]
t_end = 0.01
'''


def test_scenario_section_given_both_ways_is_identical(tmp_path):
    from ancf_jax.scenario import load_scenario
    sections = {"modulus": f"E = {E!r}, A = {A!r}, I = {I!r}",
                "stiffness": f"EA = {E * A!r}, EI = {E * I!r}"}
    beams = {}
    for key, text in sections.items():
        path = tmp_path / f"{key}.toml"
        path.write_text(SCENARIO.format(section=text))
        beams[key] = load_scenario(str(path)).model()._beams["arm"].section
    a, b = beams["modulus"], beams["stiffness"]
    assert float(a.axial_stiffness) == float(b.axial_stiffness)
    assert float(a.bending_stiffness) == float(b.bending_stiffness)
    assert float(a.mass_per_length) == float(b.mass_per_length)
    assert not b.modulus_known


# ----------------------------------------------------------------------------- 2. coordinate constraints
EA_C, EI_C, L_C = 1.0e8, 1.0e2, 1.0


def _cantilever(clamp):
    from ancf_jax.model import Model, node
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), L_C, 2), Section.from_stiffness(EA_C, EI_C, 0.1))
    clamp(m, node)
    return m


def test_exudyn_clamp_cantilever_matches_beam_theory():
    """The Exudyn clamp (x, y, r'_y held: 3 equations of rank 3), written as three
    coordinate constraints, under a small tip load: δ = P L³ / 3EI. Cubic elements hold
    the linear solution exactly; the rest is the geometric nonlinearity, O((δ/L)²) ≈
    1e-10 at δ/L = 1e-5, and the statics tolerance."""
    from ancf_jax.model import _JACOBIAN
    from ancf_jax.statics import solve_static

    delta = 1e-5 * L_C
    p = 3.0 * EI_C * delta / L_C**3

    def clamp(m, node):
        m.coordinate("x0", node("beam", 0), "x")
        m.coordinate("y0", node("beam", 0), "y", value=0.0)
        m.coordinate("slope0", node("beam", 0), "slope_y")
        m.point_force("load", node("beam", -1), (0.0, -p))

    system, state = _cantilever(clamp).build()
    assert system.n_constraints == 3
    assert np.linalg.matrix_rank(np.asarray(_JACOBIAN(system, state.q, jnp.zeros(())))) == 3
    sol = solve_static(system, state, load_steps=1, tolerance=1e-12)
    nodes = np.asarray(system.beam_nodes(sol.state.q, 0))
    assert nodes[-1, 1] == pytest.approx(-delta, rel=1e-8)
    assert abs(nodes[0, 1]) < 1e-20 and abs(nodes[0, 3]) < 1e-20

    # the named clamp option is the same three equations
    named, _ = _cantilever(lambda m, node: m.clamp("support", "beam", 0, mode="exudyn")).build(assemble=False)
    q = jnp.asarray(np.random.default_rng(1).standard_normal(system.n_coordinates))
    np.testing.assert_array_equal(np.asarray(named.constraint(q)), np.asarray(system.constraint(q)))


def test_coordinate_constraint_follows_a_time_function():
    """A coordinate given by a function of time: Φ = q[i] − f(t) (beam node and body)."""
    from ancf_jax.model import body_point

    def clamp(m, node):
        m.add_body("b", mass=1.0, inertia=1.0, position=(0.0, 1.0))
        m.coordinate("tip", node("beam", -1), "slope_x", function=lambda t: 1.0 + 0.1 * t)
        m.coordinate("turn", body_point("b"), "theta", function=lambda t: 2.0 * t)

    system, state = _cantilever(clamp).build(assemble=False)
    q = jnp.asarray(np.random.default_rng(2).standard_normal(system.n_coordinates))
    phi = np.asarray(system.constraint(q, 0.5))
    tip = system.beam_offset(0) + 4 * 2 + 2
    np.testing.assert_array_equal(phi, [float(q[tip]) - 1.05, float(q[2]) - 1.0])


@pytest.mark.parametrize("call, match", [
    (lambda m, node: m.coordinate("c", node("beam", 0), "theta"), "component of coordinate constraint 'c'"),
    (lambda m, node: m.coordinate("c", node("beam", 0), "x", value=1.0, function=lambda t: t),
     "give value or function, not both"),
    (lambda m, node: m.clamp("c", "beam", 0, mode="exuydn"), "mode of clamp 'c'"),
])
def test_coordinate_constraint_errors(call, match):
    with pytest.raises(ModelError, match=match):
        _cantilever(call)


# ----------------------------------------------------------------------------- 3. point masses, per-item loads
G = (0.0, -9.81)


def _tip_mass(point_mass, *, gravity_on_items=True):
    """A cantilever (Exudyn clamp) with a mass pinned at its tip: a point mass, or a
    rigid body of any inertia joined at its centre (which then never turns)."""
    from ancf_jax.model import Model, body_point, node
    m = Model(gravity=G)
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), L_C, 2), Section.from_stiffness(EA_C, EI_C, 0.1),
               gravity=gravity_on_items)
    m.clamp("support", "beam", 0, mode="exudyn")
    if point_mass:
        m.add_point_mass("mass", mass=0.3, position=(L_C, 0.0), gravity=gravity_on_items)
    else:
        m.add_body("mass", mass=0.3, inertia=0.7, position=(L_C, 0.0))
    m.revolute("pin", node("beam", -1), body_point("mass"))
    if not gravity_on_items:
        m.mass_proportional_load("g_beam", "beam", G)
        m.mass_proportional_load("g_mass", "mass", G)
    return m


def test_point_mass_moves_as_a_body_whose_rotation_has_no_inertia():
    """Index-1 accelerations at t = 0: a point mass at a cantilever's tip and a rigid body
    joined at its centre (θ̈ = 0: nothing turns it) give the same beam and mass
    accelerations (to round-off); the point mass's rotation constraint carries no force.
    Gravity switched off on every item and replaced by mass-proportional loads of g on
    each gives the same generalized force and accelerations."""
    from ancf_jax import dae
    acc = eqx.filter_jit(lambda s, st: dae.accelerations(s, st.q, st.v, st.t))
    # the initial states are consistent (at rest, on the joints): no assembly needed
    body_sys, body_state = _tip_mass(False).build(assemble=False)
    point_sys, point_state = _tip_mass(True).build(assemble=False)
    loads_sys, loads_state = _tip_mass(True, gravity_on_items=False).build(assemble=False)
    assert point_sys.constraint_labels()[-1] == "mass.rotation[0]"
    assert point_sys.n_constraints == body_sys.n_constraints + 1
    a_body, lam_body = acc(body_sys, body_state)
    a_point, lam_point = acc(point_sys, point_state)
    scale = float(jnp.max(jnp.abs(a_body)))
    np.testing.assert_allclose(np.asarray(a_point[3:]), np.asarray(a_body[3:]), rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(np.asarray(a_point[:2]), np.asarray(a_body[:2]), rtol=0, atol=1e-12 * scale)
    assert float(a_body[2]) == pytest.approx(0.0, abs=1e-12 * scale)
    assert abs(float(lam_point[-1])) < 1e-12 * float(jnp.max(jnp.abs(lam_point)))
    np.testing.assert_allclose(np.asarray(lam_point[:-1]), np.asarray(lam_body), rtol=1e-12)

    # gravity per item: off everywhere, replaced by mass-proportional loads
    assert loads_sys.gravity_off == ("mass", "beam")
    assert float(jnp.max(jnp.abs(loads_sys.gravity_load()))) == 0.0
    q, v = point_state.q, point_state.v
    force = eqx.filter_jit(lambda s: s.gravity_load() + s.applied_force(q, v, 0.0))
    np.testing.assert_allclose(np.asarray(force(loads_sys)), np.asarray(force(point_sys)), rtol=0, atol=1e-14)
    a_loads, _ = acc(loads_sys, loads_state)
    np.testing.assert_allclose(np.asarray(a_loads), np.asarray(a_point), rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize("add, match", [
    (lambda m, P: m.fixed("f", P.node("beam", -1), body="pm"), "joint 'f' needs a rotation .*point mass"),
    (lambda m, P: m.torque("t", "pm", 1.0), "force 't' needs a rotation .*point mass"),
    (lambda m, P: m.revolute("r", P.node("beam", -1), P.body_point("pm", (0.1, 0.0))),
     "needs a body point away from the centre"),
    (lambda m, P: m.prescribe_body("p", "pm", "theta", lambda t: t), "needs a rotation"),
    (lambda m, P: m.mass_proportional_load("g", "nothing", (0.0, 1.0)), "no beam or body"),
    (lambda m, P: m.add_point_mass("pm2", mass=0.0), "mass of point mass 'pm2'"),
])
def test_point_mass_refuses_what_needs_a_rotation(add, match):
    import ancf_jax.model as P
    m = P.Model()
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), 1.0, 2), Section.from_stiffness(EA_C, EI_C, 0.1))
    m.add_point_mass("pm", mass=1.0, position=(1.0, 0.0))
    with pytest.raises(ModelError, match=match):
        add(m, P)
        m.build(assemble=False)


PORTED = '''
gravity = [0.0, -9.81]
[beams.cable]
geometry = { type = "straight", length = 1.0 }
elements = 2
section = { EA = 1e8, EI = 100.0, mass_per_length = 0.1 }
gravity = false
axial_law = { type = "strain_rate_damped", damping = 2.0, rest = 0.001 }
bending_law = { type = "tabulated", table = [[-1.0, -100.0], [0.0, 0.0], [1.0, 100.0]] }
[bodies.bob]
mass = 0.3
position = [1.0, 0.0]
point_mass = true
[joints.clamp]
type = "clamp"
beam = "cable"
mode = "exudyn"
[joints.pin]
type = "revolute"
a = { beam = "cable", node = -1 }
b = { body = "bob" }
[joints.lift]
type = "coordinate"
point = { beam = "cable", node = 1 }
component = "y"
function = "0.01 * t"
[loads.g_cable]
type = "mass_proportional"
item = "cable"
acceleration = [0.0, -9.81]
[solver]
t_end = 0.01
'''


def test_scenario_with_the_exudyn_items(tmp_path):
    """A scenario using every new key builds to the system the Python API builds."""
    from ancf_jax.forces import BeamMassLoad
    from ancf_jax.joints import Clamp, FixedCoordinate, PrescribedCoordinate
    from ancf_jax.scenario import load_scenario
    path = tmp_path / "ported.toml"
    path.write_text(PORTED)
    system, state = load_scenario(str(path)).model().build(assemble=False)
    assert system.gravity_off == ("cable",)
    kinds = [type(c) for c in system.constraints]
    assert kinds[0] is Clamp and system.constraints[0].mode == "exudyn"
    assert kinds[2] is PrescribedCoordinate and kinds[3] is FixedCoordinate
    assert system.constraint_labels()[-1] == "bob.rotation[0]"
    assert float(system.bodies.inertia[0]) == 0.0
    assert isinstance(system.forces[0], BeamMassLoad)
    beam = system.beams[0]
    assert isinstance(beam.axial_law, laws.StrainRateDamped) and float(beam.axial_law.damping) == 2.0
    assert float(beam.axial_law.rest) == 0.001
    assert isinstance(beam.bending_law, laws.Tabulated) and beam.has_rate_law
    phi = np.asarray(system.constraint(state.q, 2.0))
    assert phi[5] == pytest.approx(-0.02, rel=1e-15)  # node 1 starts at y = 0, f(2) = 0.02


def test_docs_scenario_file_is_the_python_port(tmp_path):
    """The scenario file of docs/exudyn.md ("One model, side by side") builds the system
    and initial state of the page's Python port (benchmarks/exudyn_port.py, whose run
    against Exudyn is the page's measured figure) exactly, and its solver table gives
    the port's step, span, output interval and ρ∞ (no run: compiling the port costs
    ~9 s; ``python -m benchmarks.exudyn_port`` runs both codes)."""
    import re
    from pathlib import Path
    from ancf_jax.scenario import load_scenario
    from benchmarks import exudyn_port as port
    page = (Path(__file__).resolve().parents[1] / "docs" / "exudyn.md").read_text(encoding="utf-8")
    block = re.search(r"### scenario file\s+```toml\n(.*?)```", page, re.S).group(1)
    (tmp_path / "port.toml").write_text(block)
    scenario = load_scenario(str(tmp_path / "port.toml"))
    system, state = scenario.model().build(assemble=False)
    ported, ported_state = port.ancf_model().build(assemble=False)
    assert bool(eqx.tree_equal(system, ported)) and bool(eqx.tree_equal(state, ported_state))
    kw = scenario.solver.simulate_kwargs()
    assert (kw["t_end"], kw["dt"], kw["output_dt"], float(kw["solver"].rho_inf)) == (port.T_END, port.H, 0.01, 0.9)
    different = load_scenario(str(tmp_path / "port.toml"), overrides=["beams.cable.elements=7"])
    assert not bool(eqx.tree_equal(different.model().build(assemble=False)[0], ported))  # the check can fail


# ----------------------------------------------------------------------------- 4. CSV precision
def test_csv_round_trips_doubles_by_default(tmp_path):
    """Default: every value reads back to the same double; ``precision`` digits otherwise."""
    import csv
    from ancf_jax.outputs import write_csv
    values = np.array([0.1 + 0.2, -1.0 / 3.0, 6.02214076e23, 5e-324, 0.0, np.pi * 1e-9])
    cols = {"t": np.arange(values.size, dtype=float), "v": values}
    write_csv(tmp_path / "full.csv", cols)
    write_csv(tmp_path / "short.csv", cols, precision=10)
    with open(tmp_path / "full.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["t", "v"]
    assert np.array_equal(np.array([float(r[1]) for r in rows[1:]]), values)
    with open(tmp_path / "short.csv") as f:
        short = np.array([float(r[1]) for r in list(csv.reader(f))[1:]])
    np.testing.assert_allclose(short, values, rtol=5e-10)
    assert not np.array_equal(short, values)
    with pytest.raises(ModelError, match="precision of CSV output must be an integer 1..17"):
        write_csv(tmp_path / "bad.csv", cols, precision=0)


# ----------------------------------------------------------------------------- 5. material laws
from ancf_jax.element import laws  # noqa: E402
from ancf_jax.element.strain_energy import Formulation  # noqa: E402

ENGINEERING = Formulation(axial_strain="engineering", curvature="material")


def test_bilinear_bar_under_axial_load_matches_the_closed_form():
    """A clamped bar with a bilinear axial law (k_t = 4 k_c) under an axial tip load ±P:
    the engineering strain is uniform, ε = P/k_t in tension and −P/k_c in compression,
    so the tip moves by L·ε (exact for the cubic element; statics to 1e-12)."""
    import equinox as eqx
    from ancf_jax.model import Model, node
    from ancf_jax.statics import solve_static
    k_t, k_c, p = 4.0e6, 1.0e6, 2.0e3
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("bar", mesh.straight((0, 0), (1, 0), L_C, 2), Section.from_stiffness(EA_C, EI_C, 0.1),
               formulation=ENGINEERING, axial_law=laws.Bilinear(k_t, k_c))
    m.clamp("support", "bar", 0, mode="exudyn")  # the axial stretch at the clamp is free
    m.point_force("load", node("bar", -1), (p, 0.0))
    system, state = m.build()
    for sign, k in ((1.0, k_t), (-1.0, k_c)):
        loaded = eqx.tree_at(lambda s: s.forces[0].force, system, jnp.array([sign * p, 0.0]))
        sol = solve_static(loaded, state, load_steps=2, tolerance=1e-12)
        tip = np.asarray(loaded.beam_nodes(sol.state.q, 0))[-1]
        assert tip[0] - L_C == pytest.approx(sign * p / k * L_C, rel=1e-10)
        assert abs(tip[1]) < 1e-14
        n = float(loaded.beams[0].axial_force(loaded.beam_nodes(sol.state.q, 0), 0.4))
        assert n == pytest.approx(sign * p, rel=1e-10)


def test_tabulated_law_energy_is_the_exact_integral_of_the_table():
    """W(γ) = ∫₀^γ N for the piecewise-linear table (against scipy's quad), W'(γ) = N,
    extended linearly outside the table; a table without the stress-free state is refused."""
    from scipy.integrate import quad
    strains = np.array([-0.02, -0.005, 0.0, 0.01, 0.03])
    forces = np.array([-5.0e3, -2.0e3, 0.0, 6.0e3, 1.0e4])
    law = laws.Tabulated(strains, forces)

    def n_of(g):
        if g < strains[0]:
            return forces[0] + (g - strains[0]) * (forces[1] - forces[0]) / (strains[1] - strains[0])
        if g > strains[-1]:
            return forces[-1] + (g - strains[-1]) * (forces[-1] - forces[-2]) / (strains[-1] - strains[-2])
        return np.interp(g, strains, forces)

    grid = np.array([-0.03, -0.02, -0.011, 0.0, 0.004, 0.02, 0.05])
    w = np.asarray(eqx.filter_jit(lambda lw, g: lw.energy(g, 1.0))(law, jnp.asarray(grid)))
    n = np.asarray(eqx.filter_jit(lambda lw, g: jax.vmap(jax.grad(lw.energy), (0, None))(g, 1.0))(
        law, jnp.asarray(grid)))
    for g, wi, ni in zip(grid, w, n):
        pts = [s for s in strains if min(0, g) < s < max(0, g)]
        assert wi == pytest.approx(quad(n_of, 0.0, g, points=pts or None)[0], rel=1e-12, abs=1e-15)
        assert ni == pytest.approx(n_of(g), rel=1e-12, abs=1e-12)
    with pytest.raises(ModelError, match="force at zero strain must be 0"):
        laws.Tabulated([-0.01, 0.01], [0.0, 1.0])
    with pytest.raises(ModelError, match="increase with the strain"):
        laws.Tabulated([-0.01, 0.0, 0.01], [1.0, 0.0, -1.0])


def _damped_beam(d_axial=3.0, d_bending=0.02, n=2):
    return Beam(mesh.straight((0, 0), (1, 0), L_C, n), Section.from_stiffness(EA_C, EI_C, 0.1),
                formulation=ENGINEERING, axial_law=laws.StrainRateDamped(d_axial),
                bending_law=laws.StrainRateDamped(d_bending))


def test_strain_rate_damping_dissipates_d_eps_dot_squared():
    """Rate terms are a dissipation: under a uniform stretching rate ε̇ of a straight bar
    (ṙ = ε̇ x, ṙ' = ε̇ e_x) the dissipated power −v·Q_d is d_A ε̇² L; under a uniform
    curvature rate κ̇ of the straight beam (ṙ_y = κ̇ x²/2, ṙ'_y = κ̇ x) it is d_K κ̇² L.
    The strain energy does not depend on the rates."""
    beam = _damped_beam()
    nodes = beam.mesh.reference_nodes
    x = np.asarray(nodes)[:, 0]
    power = jax.jit(lambda b, v: -jnp.sum(v * b.dissipative_force(nodes, v)))
    rate = 0.7
    stretch = jnp.asarray(np.stack([rate * x, 0 * x, rate + 0 * x, 0 * x], axis=1))
    bend = jnp.asarray(np.stack([0 * x, rate * x**2 / 2, 0 * x, rate * x], axis=1))
    assert float(power(beam, stretch)) == pytest.approx(3.0 * rate**2 * L_C, rel=1e-13)
    assert float(power(beam, bend)) == pytest.approx(0.02 * rate**2 * L_C, rel=1e-13)
    plain = Beam(beam.mesh, beam.section, formulation=ENGINEERING)
    deformed = _deformed(beam)
    assert float(beam.strain_energy(deformed)) == float(plain.strain_energy(deformed))


def _assert_tangent_is_the_derivative_of_the_forces(beam, seed):
    """element_tangent of a one-element beam with rate laws equals central differences
    of the element's resisting force ∂U/∂e + f_d(e, ė) along (δe, c_v δe) (relative 1e-7)."""
    from ancf_jax.element.strain_energy import dissipative_force, strain_energy
    nodes = _deformed(beam, seed)
    vel = jnp.asarray(np.random.default_rng(seed + 1).standard_normal(nodes.shape))
    c_v = 40.0
    k = np.asarray(eqx.filter_jit(lambda b: b.element_tangent(nodes, vel, c_v))(beam))[0]
    e, ed = jnp.ravel(nodes), jnp.ravel(vel)
    er, l = beam.mesh.reference_elements[0], beam.mesh.element_lengths[0]
    ea, ei = beam.section.axial_stiffness, beam.section.bending_stiffness
    f = beam.formulation

    @eqx.filter_jit
    def force(x, xd):
        return (jax.grad(strain_energy)(x, er, l, ea, ei, f, beam.axial_law, beam.bending_law)
                + dissipative_force(x, xd, er, l, ea, ei, f, beam.axial_law, beam.bending_law))

    h = 1e-6
    fd = np.stack([(np.asarray(force(e + h * d, ed + c_v * h * d)) - np.asarray(force(e - h * d, ed - c_v * h * d)))
                   / (2 * h) for d in np.eye(8)], axis=1)
    np.testing.assert_allclose(k, fd, rtol=0, atol=1e-7 * np.abs(k).max())


def test_rate_law_newton_matrix_is_the_derivative_of_the_forces():
    """The strain-rate damped laws: element_tangent against central differences."""
    _assert_tangent_is_the_derivative_of_the_forces(_damped_beam(n=1), 3)


def test_user_law_of_the_linear_energy_is_the_default_law():
    """``UserLaw(½ k γ²)`` on both parts is the default (no law): elastic force and
    element stiffness equal to round-off (that the user's function is what is used is
    shown by the closed form of the next test)."""
    m = mesh.straight((0, 0), (1, 0), 1.0, 2)
    section = Section.from_stiffness(EA_C, EI_C, 0.1)
    linear = laws.UserLaw(lambda g, k: 0.5 * k * g**2)
    default = Beam(m, section)
    user = Beam(m, section, axial_law=linear, bending_law=linear)
    nodes = _deformed(default, 11)
    terms = eqx.filter_jit(lambda b: (b.elastic_force(nodes), b.element_tangent(nodes, jnp.zeros_like(nodes), 0.0)))
    f0, k0 = (np.asarray(x) for x in terms(default))
    f1, k1 = (np.asarray(x) for x in terms(user))
    assert not user.has_rate_law
    np.testing.assert_allclose(f1, f0, rtol=0, atol=1e-14 * np.abs(f0).max())
    np.testing.assert_allclose(k1, k0, rtol=0, atol=1e-14 * np.abs(k0).max())


def _hardening_user_law():
    """W = ½ k γ² (1 + c γ²) and N_d = d γ̇ (1 + b γ²): a nonlinear elastic part and a
    rate part that depends on the strain too."""
    c, d, b = 2.0e3, 5.0, 4.0e2
    law = laws.UserLaw(lambda g, k: 0.5 * k * g**2 * (1.0 + c * g**2),
                       lambda g, gd, k: d * gd * (1.0 + b * g**2))
    return law, (c, d, b)


def test_user_law_with_a_rate_term_forces_and_newton_matrix():
    """A nonlinear UserLaw with a rate term on the axial part: under a uniform stretch ε
    of a straight bar (r' = (1 + ε, 0)) the elastic force at the free end is
    N = W'(ε) = k ε (1 + 2 c ε²) (a bar of one element: the force at node 1 is N e_x)
    and the power dissipated under a uniform stretching rate ε̇ is N_d(ε, ε̇) ε̇ L
    (closed forms); on a randomly deformed and moving element the elastic force equals
    central differences of the strain energy and element_tangent equals central
    differences of the resisting force ∂U/∂e + f_d (relative 1e-7)."""
    law, (c, d, b) = _hardening_user_law()
    beam = Beam(mesh.straight((0, 0), (1, 0), L_C, 1), Section.from_stiffness(EA_C, EI_C, 0.1),
                formulation=ENGINEERING, axial_law=law)
    assert beam.has_rate_law
    x = np.asarray(beam.mesh.reference_nodes)[:, 0]
    eps, rate = 3e-3, 0.7
    stretched = jnp.asarray(np.stack([(1 + eps) * x, 0 * x, 1 + eps + 0 * x, 0 * x], axis=1))
    moving = jnp.asarray(np.stack([rate * x, 0 * x, rate + 0 * x, 0 * x], axis=1))
    force, power = eqx.filter_jit(lambda bm, n, v: (bm.elastic_force(n), -jnp.sum(v * bm.dissipative_force(n, v))))(
        beam, stretched, moving)
    n_closed = EA_C * eps * (1.0 + 2.0 * c * eps**2)
    assert -float(force[1, 0]) == pytest.approx(n_closed, rel=1e-12)  # elastic_force is −∂U/∂q
    assert float(power) == pytest.approx(d * rate * (1.0 + b * eps**2) * rate * L_C, rel=1e-12)

    nodes = _deformed(beam, 5)
    f = np.asarray(eqx.filter_jit(lambda bm: bm.elastic_force(nodes))(beam)).ravel()
    energy = eqx.filter_jit(lambda bm, n: bm.strain_energy(n))
    h = 1e-6
    fd = np.array([(float(energy(beam, nodes + h * dn)) - float(energy(beam, nodes - h * dn))) / (2 * h)
                   for dn in np.eye(8).reshape(8, 2, 4)])
    np.testing.assert_allclose(f, -fd, rtol=0, atol=1e-7 * np.abs(f).max())  # elastic_force is −∂U/∂q
    _assert_tangent_is_the_derivative_of_the_forces(beam, 5)


# ----------------------------------------------------------------------------- 6. metric, meshes of given nodes
def test_parameter_metric_is_the_arc_length_metric_on_straight_unit_references():
    """``metric="parameter"`` (Exudyn's strainIsRelativeToReference = 1) measures strains
    per unit element parameter; on a straight reference with unit slopes that is the
    arc length, so both metrics give the same elastic force (to round-off); on a curved
    reference with non-unit slopes they differ (the Exudyn cross-check
    ``test_curved_reference_element_matches_exudyn`` pins the parameter one to Exudyn)."""
    straight = mesh.from_nodes(np.asarray(mesh.straight((0, 0), (1, 0), 1.0, 2).reference_nodes), [0.5, 0.5])
    curved = mesh.from_nodes([[0, 0, 1.1, 0.2], [0.45, 0.1, 0.9, 0.4], [0.8, 0.4, 0.6, 0.9]], [0.47, 0.5])
    force = eqx.filter_jit(lambda b, n: b.elastic_force(n))
    for m, same in ((straight, True), (curved, False)):
        beams = [Beam(m, Section.from_stiffness(EA_C, EI_C, 0.1), formulation=Formulation(
            axial_strain="engineering", curvature="material", metric=metric)) for metric in ("arc_length", "parameter")]
        nodes = _deformed(beams[0], 7)
        f = [np.asarray(force(b, nodes)) for b in beams]
        gap = np.max(np.abs(f[0] - f[1])) / np.max(np.abs(f[0]))
        assert (gap < 1e-14) if same else (gap > 1e-3), gap
    with pytest.raises(ModelError, match="metric must be one of"):
        Formulation(metric="reference")


@pytest.mark.parametrize("nodes, lengths, match", [
    (np.zeros((3, 3)), [1.0, 1.0], r"nodes must have shape \(n\+1, 4\)"),
    ([[0, 0, 1, 0], [1, 0, 1, 0]], [1.0, 1.0], r"element_lengths must have shape \(1,\)"),
    ([[0, 0, 1, 0], [1, 0, 1, 0]], [0.0], "element_lengths must be > 0"),
    ([[0, 0, 0, 0], [1, 0, 1, 0]], [1.0], "non-zero slopes"),
])
def test_mesh_from_nodes_rejects_bad_input(nodes, lengths, match):
    with pytest.raises(ModelError, match=match):
        mesh.from_nodes(nodes, lengths)
