"""The Exudyn cross-checks of ``tests/test_exudyn_crosscheck.py``, run in a separate
process (a spawned interpreter that imports Exudyn): Exudyn's native libraries never
load into the pytest workers that compile the rest of the suite's JAX programs (with
both in one process, XLA compilations later in that worker crashed at random:
segmentation faults and aborts in 2 of 3 full runs). Each function asserts and returns
None; the test module calls them through a process pool and re-raises what they raise.
"""

import numpy as np

import jax
import jax.numpy as jnp

from ancf_jax.element.strain_energy import strain_energy

import exudyn as exu

from benchmarks import exudyn_models as em


def _exudyn_element(q, ref, length, ea, ei, rho_a, mode, v=None, damping=None):
    """(elastic RHS, mass matrix) of one free Exudyn ANCFCable2D element at q (and
    velocities v, with ``damping`` = dict(axialDamping=, bendingDamping=))."""
    from exudyn.itemInterface import NodePoint2DSlope1, ObjectANCFCable2D
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    v = np.zeros(8) if v is None else v
    n0 = mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=list(ref[:4]), initialCoordinates=list(q[:4] - ref[:4]),
                                       initialVelocities=list(v[:4])))
    n1 = mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=list(ref[4:]), initialCoordinates=list(q[4:] - ref[4:]),
                                       initialVelocities=list(v[4:])))
    mbs.AddObject(ObjectANCFCable2D(nodeNumbers=[n0, n1], length=length, massPerLength=rho_a,
                                    axialStiffness=ea, bendingStiffness=ei, useReducedOrderIntegration=mode,
                                    **(damping or {})))
    mbs.Assemble()
    solver = exu.MainSolverStatic()
    ss = exu.SimulationSettings()
    ss.staticSolver.verboseMode = 0
    ss.solution.file.write = False
    ss.solution.sensors.active = False
    solver.InitializeSolver(mbs, ss)
    solver.ComputeODE2RHS(mbs)
    rhs = np.array(solver.GetSystemResidual())[:8]
    solver.ComputeMassMatrix(mbs)
    return rhs, np.array(solver.GetSystemMassMatrix())


def exudyn_quadrature_rules():
    """Exudyn's elastic force equals ancf_jax's −∂U/∂q with exudyn_formulation(mode) for
    every useReducedOrderIntegration mode (relative 1e-12; measured ~1e-15), and differs
    by > 1e-4 with any other mode's rules (so the rules are identified uniquely)."""
    length, ea, ei, rho_a = 0.3, 2.0e3, 0.7, 0.5
    rng = np.random.default_rng(0)
    ref = np.array([0.0, 0.0, 1.0, 0.0, length, 0.0, 1.0, 0.0])
    q = ref + 0.08 * rng.standard_normal(8)
    q[2:4], q[6:8] = [0.9, 0.35], [1.2, -0.4]  # stretched, sheared and bent

    def ancf_force(mode):
        f = em.exudyn_formulation(mode)
        return -np.asarray(jax.grad(strain_energy)(jnp.asarray(q), jnp.asarray(ref), length, ea, ei, f))

    for mode in em.EXUDYN_RULES:
        rhs, mass = _exudyn_element(q, ref, length, ea, ei, rho_a, mode)
        scale = np.max(np.abs(rhs))
        assert np.max(np.abs(ancf_force(mode) - rhs)) < 1e-12 * scale
        for other in em.EXUDYN_RULES:
            if other != mode:
                assert np.max(np.abs(ancf_force(other) - rhs)) > 1e-4 * scale
        # consistent mass matrix (exact in both codes)
        from ancf_jax.element.mass import mass_matrix
        m_ancf = np.asarray(mass_matrix(length, rho_a))
        assert np.max(np.abs(m_ancf - mass)) < 1e-14 * np.max(np.abs(mass))


def _m1_tip(integration_ancf, integration_exudyn, t_end):
    from benchmarks.compare_exudyn import ancf_run
    system, state = em.ancf_system("M1", 6, integration=integration_ancf)
    exu_system, exu_state = em.ancf_system("M1", 6, integration=integration_exudyn)
    model = em.build_exudyn(exu_system, exu_state, name="M1")
    r = em.run(model, t_end=t_end, dt=1e-3, output_dt=0.01, relative_tolerance=1e-8,
               absolute_tolerance=1e-12, modified_newton=False)
    a = ancf_run("M1", system, state, t_end=t_end, dt=1e-3, output_dt=0.01, newton_tol=1e-10,
                 velocity_projection=False)
    assert a["status"] == "ok" and r.status == "ok"
    np.testing.assert_allclose(a["t"], r.t, atol=1e-12)
    return np.max(np.linalg.norm(a["outputs"]["tip"] - r.outputs["tip"], axis=1)), r


def m1_matches_exudyn():
    """M1, 6 elements, 0.2 s, h = 1 ms, ρ∞ = 0.9, identical formulation: the tip positions
    agree to 1e-9 m (measured 8.8e-13 m: Newton tolerances only). The tip falls 0.17 m
    in that span, so 1e-9 m is ~6e-9 relative. Negative control: Exudyn with another
    quadrature rule (useReducedOrderIntegration=2) differs by 2.0e-4 m (measured)."""
    d, r = _m1_tip(0, 0, 0.2)
    assert np.ptp(r.outputs["tip"][:, 1]) > 0.1  # the beam really moved
    assert d < 1e-9
    d_other, _ = _m1_tip(0, 2, 0.2)
    assert d_other > 1e-6


def sliding_joint_term():
    """A body sliding along a pinned cable over two nodes: Exudyn as shipped differs from
    ancf_jax by the effect of the extra Δs S'ᵀλ term of its sliding joint (measured
    6.5e-4 m at h = 1 ms); with that term cancelled (cancel_sliding_term) the codes agree
    to 1e-8 m (measured 3.2e-10 m, Newton tolerances)."""
    from ancf_jax import mesh
    from ancf_jax.model import Model, node
    from ancf_jax.section import Section
    from ancf_jax.simulation import simulate

    m = Model(gravity=(0.0, -9.81))
    m.add_beam("cable", mesh.straight((0.0, 0.0), (1.0, 0.0), 1.0, 4),
               Section(2e9, 1e-5, 1e-11, 0.08), alpha=0.01, formulation=em.exudyn_formulation(0))
    m.pin("A", node("cable", 0))
    m.pin("B", node("cable", -1))
    m.add_body("slider", mass=0.5, inertia=1e-3, position=(0.3, 0.0), velocity=(1.5, 0.0))
    m.slider("s", "slider", "cable", 0.3, rate=1.5)
    system, state = m.build()

    def exudyn_point(cancel):
        model = em.build_exudyn(system, state, name="slider", cancel_sliding_term=cancel)
        r = em.run(model, t_end=0.3, dt=1e-3, output_dt=0.01, relative_tolerance=1e-8,
                   absolute_tolerance=1e-12, modified_newton=False)
        assert r.status == "ok"
        return r.histories.sliding_point[:, 0], r.histories.sliding[:, 0]

    res = simulate(system, state, t_end=0.3, dt=1e-3, output_dt=0.01, progress=False,
                   solver_options=dict(newton_tol=1e-10, velocity_projection=False, refresh_every=1))
    p_ancf = res.sliding_point("s")
    assert np.ptp(res.sliding("s")) > 0.3  # it slid over at least one node
    p_raw, _ = exudyn_point(False)
    p_fix, _ = exudyn_point(True)
    d_raw = np.max(np.linalg.norm(p_raw - p_ancf, axis=1))
    d_fix = np.max(np.linalg.norm(p_fix - p_ancf, axis=1))
    assert d_fix < 1e-8
    assert d_raw > 1e-5


def strain_rate_damping_element():
    """Exudyn's cable damping (axialDamping d_A, bendingDamping d_K: δW = ∫ d γ̇ δγ dx)
    equals the StrainRateDamped laws' force (ancf_jax.element.strain_energy.
    dissipative_force) on a stretched, sheared and bent element moving at random
    velocities, for every quadrature mode: relative 1e-12 of the damping force
    (measured ~1e-15). Negative control: without the rate terms the forces differ by
    the whole damping force."""
    from ancf_jax.element import laws
    from ancf_jax.element.strain_energy import dissipative_force
    length, ea, ei, rho_a, d_a, d_k = 0.3, 2.0e3, 0.7, 0.5, 30.0, 0.05
    rng = np.random.default_rng(1)
    ref = np.array([0.0, 0.0, 1.0, 0.0, length, 0.0, 1.0, 0.0])
    q = ref + 0.08 * rng.standard_normal(8)
    q[2:4], q[6:8] = [0.9, 0.35], [1.2, -0.4]
    v = rng.standard_normal(8)
    import equinox as eqx
    axial, bending = laws.StrainRateDamped(d_a), laws.StrainRateDamped(d_k)
    force = eqx.filter_jit(lambda f, la, lk: -dissipative_force(jnp.asarray(q), jnp.asarray(v), jnp.asarray(ref),
                                                                length, ea, ei, f, la, lk))
    for mode in em.EXUDYN_RULES:
        f = em.exudyn_formulation(mode)
        elastic = -np.asarray(jax.grad(strain_energy)(jnp.asarray(q), jnp.asarray(ref), length, ea, ei, f))
        damp = np.asarray(force(f, axial, bending))
        rhs0, _ = _exudyn_element(q, ref, length, ea, ei, rho_a, mode, v)
        rhs, _ = _exudyn_element(q, ref, length, ea, ei, rho_a, mode, v,
                                 dict(axialDamping=d_a, bendingDamping=d_k))
        assert np.max(np.abs(rhs0 - elastic)) < 1e-12 * np.max(np.abs(rhs0))
        exudyn_damping = rhs - rhs0
        assert np.max(np.abs(exudyn_damping)) > 1e-3 * np.max(np.abs(rhs0))  # the terms matter
        assert np.max(np.abs(damp - exudyn_damping)) < 1e-12 * np.max(np.abs(exudyn_damping))
        for law_a, law_k in (((axial, None), (None, bending)) if mode == 0 else ()):  # each part alone
            part = np.asarray(force(f, law_a, law_k))
            one, _ = _exudyn_element(q, ref, length, ea, ei, rho_a, mode, v,
                                     dict(axialDamping=d_a if law_a else 0.0, bendingDamping=d_k if law_k else 0.0))
            assert np.max(np.abs(part - (one - rhs0))) < 1e-12 * np.max(np.abs(exudyn_damping))


def strain_rate_damping_dynamics():
    """A cantilever (Exudyn clamp: x, y, r'_y) falling under gravity with axial and
    bending strain-rate damping, 4 elements, 0.1 s at h = 1 ms, ρ∞ = 0.9, identical
    formulation: the tip positions agree to 1e-9 m (measured 7.9e-16 m). Negative
    control: Exudyn without the damping differs from ancf_jax with it by > 1e-6 m."""
    from benchmarks.compare_exudyn import ancf_run
    from ancf_jax import mesh
    from ancf_jax.element import laws
    from ancf_jax.model import Model
    from ancf_jax.section import Section

    def system(damped):
        m = Model(gravity=(0.0, -9.81))
        kw = dict(axial_law=laws.StrainRateDamped(2.0e3), bending_law=laws.StrainRateDamped(0.05)) if damped else {}
        m.add_beam("beam", mesh.straight((0.0, 0.0), (1.0, 0.0), 1.0, 4),
                   Section.from_stiffness(1.0e6, 2.0, 0.5), formulation=em.exudyn_formulation(0), **kw)
        m.clamp("support", "beam", 0, mode="exudyn")
        return m.build(assemble=False)  # the reference at rest is consistent

    def exudyn_tip(damped):
        model = em.build_exudyn(*system(damped), name="M1")
        r = em.run(model, t_end=0.1, dt=1e-3, output_dt=0.01, relative_tolerance=1e-8,
                   absolute_tolerance=1e-12, modified_newton=False)
        assert r.status == "ok"
        return r.outputs["tip"]

    a = ancf_run("M1", *system(True), t_end=0.1, dt=1e-3, output_dt=0.01, newton_tol=1e-10,
                 velocity_projection=False, refresh_every=1)
    assert a["status"] == "ok"
    tip = exudyn_tip(True)
    assert np.ptp(tip[:, 1]) > 1e-3  # it moved
    assert np.max(np.linalg.norm(a["outputs"]["tip"] - tip, axis=1)) < 1e-9
    assert np.max(np.linalg.norm(a["outputs"]["tip"] - exudyn_tip(False), axis=1)) > 1e-6
