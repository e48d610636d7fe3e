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
    from ancf_jax.simulation import make_solver, simulate

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
                   solver=make_solver("generalized-alpha", newton_tol=1e-10, velocity_projection=False,
                                      refresh_every=1))
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


def curved_reference_element():
    """Exudyn's cable on a curved reference with non-unit slopes and an element length
    that is not its arc length: with strainIsRelativeToReference = 1 (and a natural
    strain and curvature, and strain-rate damping) its elastic and damping force equals
    ancf_jax's with ``metric="parameter"`` and ``StrainRateDamped(d, rest)`` laws, for
    every quadrature mode (relative 1e-12; measured 3e-16 to 9e-16). Negative control:
    the default ``metric="arc_length"`` (strains per unit reference arc length) differs
    by 8 % to 10 % of the force here (asserted > 1e-4); with strainIsRelativeToReference = 0 (stress-free: straight)
    the curved reference is loaded and equals ancf_jax on a straight unit-slope mesh
    of the element length with the curved state as the configuration."""
    from ancf_jax.element import laws
    from ancf_jax.element.strain_energy import dissipative_force
    from ancf_jax.interop.exudyn import cable_formulation
    length, ea, ei, rho_a, d_a, d_k, eps0, kappa0 = 0.3, 2.0e3, 0.7, 0.5, 30.0, 0.05, 0.01, 0.4
    rng = np.random.default_rng(5)
    ref = np.array([0.0, 0.0, 1.1, 0.2, 0.27, 0.09, 0.8, 0.5])  # curved, |r'| != 1, chord != length
    q = ref + 0.03 * rng.standard_normal(8)
    v = rng.standard_normal(8)
    straight = np.array([0.0, 0.0, 1.0, 0.0, length, 0.0, 1.0, 0.0])
    axial, bending = laws.StrainRateDamped(d_a, eps0), laws.StrainRateDamped(d_k, kappa0)
    import equinox as eqx

    @eqx.filter_jit
    def force(f, e_ref):
        x, xd, r = jnp.asarray(q), jnp.asarray(v), jnp.asarray(e_ref)
        return -(jax.grad(strain_energy)(x, r, length, ea, ei, f, axial, bending)
                 + dissipative_force(x, xd, r, length, ea, ei, f, axial, bending))

    cable = dict(axialDamping=d_a, bendingDamping=d_k, referenceAxialStrain=eps0, referenceCurvature=kappa0)
    for mode in em.EXUDYN_RULES:
        rhs, _ = _exudyn_element(q, ref, length, ea, ei, rho_a, mode, v, dict(cable, strainIsRelativeToReference=1.0))
        scale = np.max(np.abs(rhs))
        assert np.max(np.abs(np.asarray(force(cable_formulation(mode, "parameter"), ref)) - rhs)) < 1e-12 * scale
        assert np.max(np.abs(np.asarray(force(cable_formulation(mode), ref)) - rhs)) > 1e-4 * scale
        rhs0, _ = _exudyn_element(q, ref, length, ea, ei, rho_a, mode, v, cable)
        assert np.max(np.abs(np.asarray(force(cable_formulation(mode), straight)) - rhs0)) < 1e-12 * scale


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


def _bilinear_cantilever(law):
    """Written natively in Exudyn: a cable of 4 elements (L = 1 m, EI = 2 N·m²,
    ρA = 0.5 kg/m) clamped Exudyn-style (x, y, r'_y), a 0.1 kg MassPoint2D pinned at its
    tip, gravity, released with a uniform axial compression rate (v_x = −0.3 x/L m/s):
    the cable is compressed, rebounds into tension, and falls. ``law`` = (k_t, k_c): its
    axial force is an ``axialForceUserFunction``, N = k_t ε for ε ≥ 0 and k_c ε for
    ε < 0; None: Exudyn's linear cable with EA = k_t. Exudyn 1.13.6 evaluates the axial
    user function only where a ``bendingMomentUserFunction`` is set too (its cable
    source takes the user-function branch on the bending function alone), so the
    bending moment is given as one, Exudyn's linear M = EI (κ − κ₀). Returns (mbs,
    sensor of the tip mass's displacement)."""
    from exudyn.itemInterface import (CoordinateConstraint, LoadMassProportional, MarkerBodyMass,
                                      MarkerNodeCoordinate, MarkerNodePosition, MassPoint2D, NodePoint2D,
                                      NodePoint2DSlope1, NodePointGround, ObjectANCFCable2D, RevoluteJoint2D,
                                      SensorNode)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    _CONTAINERS.append(sc)
    k_t = law[0] if law else BILINEAR[0]
    uf = {}
    if law:
        def axial_force(mbs, t, item, x, eps, eps_t, eps_ref, ea, d_a, kappa, kappa_t, kappa_ref):
            g = eps - eps_ref
            return (law[0] if g >= 0.0 else law[1]) * g

        def bending_moment(mbs, t, item, x, kappa, kappa_t, kappa_ref, ei, d_k, eps, eps_t, eps_ref):
            return ei * (kappa - kappa_ref)

        uf = dict(axialForceUserFunction=axial_force, bendingMomentUserFunction=bending_moment)
    length, n, v0, g = 1.0, 4, 0.3, [0.0, -9.81, 0.0]
    nodes = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[i * length / n, 0.0, 1.0, 0.0],
                                           initialVelocities=[-v0 * i / n, 0.0, -v0 / length, 0.0]))
             for i in range(n + 1)]
    for i in range(n):
        cable = mbs.AddObject(ObjectANCFCable2D(nodeNumbers=nodes[i:i + 2], length=length / n, massPerLength=0.5,
                                                axialStiffness=k_t, bendingStiffness=2.0, **uf))
        mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=cable)), loadVector=g))
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    for c in (0, 1, 3):
        mbs.AddObject(CoordinateConstraint(markerNumbers=[
            ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=c))]))
    tip = mbs.AddNode(NodePoint2D(referenceCoordinates=[length, 0.0], initialVelocities=[-v0, 0.0]))
    bob = mbs.AddObject(MassPoint2D(nodeNumber=tip, mass=0.1))
    mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=bob)), loadVector=g))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[-1])),
                                                 mbs.AddMarker(MarkerNodePosition(nodeNumber=tip))]))
    sensor = mbs.AddSensor(SensorNode(nodeNumber=tip, outputVariableType=exu.OutputVariableType.Coordinates,
                                      storeInternal=True, writeToFile=False))
    mbs.Assemble()
    return mbs, sensor


#: (k_t, k_c) [N] of the bilinear axial law of :func:`bilinear_law_matches_exudyn`
BILINEAR = (1.0e4, 2.5e3)


def bilinear_law_matches_exudyn():
    """A nonlinear material law against Exudyn: :func:`_bilinear_cantilever` with its
    bilinear axialForceUserFunction (k_t = 4 k_c) and the same model in ancf_jax with
    ``axial_law=Bilinear(k_t, k_c)``, 0.1 s of index-3 generalized-α at h = 1 ms,
    ρ∞ = 0.9, full Newton (Exudyn's Jacobian of a cable with user functions is by
    numerical differences): the axial strain near the clamp passes through compression
    and tension (measured −4.1e-3 to 1.9e-3; asserted beyond ∓1e-4), and the tip
    positions agree to 1e-9 m, the tolerance of the other dynamic cross-checks at these
    settings (measured 4.7e-12 m). Negative control: Exudyn's linear cable (EA = k_t)
    differs from ancf_jax's bilinear one by > 1e-6 m."""
    from ancf_jax import mesh
    from ancf_jax.element.laws import Bilinear
    from ancf_jax.model import Model, body_point, node
    from ancf_jax.section import Section
    from ancf_jax.simulation import make_solver, simulate

    m = Model(gravity=(0.0, -9.81))
    x = np.linspace(0.0, 1.0, 5)
    m.add_beam("cable", mesh.straight((0.0, 0.0), (1.0, 0.0), 1.0, 4), Section.from_stiffness(BILINEAR[0], 2.0, 0.5),
               formulation=em.exudyn_formulation(0), axial_law=Bilinear(*BILINEAR),
               initial_velocities=np.column_stack([-0.3 * x, 0 * x, -0.3 + 0 * x, 0 * x]))
    m.clamp("support", "cable", 0, mode="exudyn")
    m.add_point_mass("bob", mass=0.1, position=(1.0, 0.0), velocity=(-0.3, 0.0))
    m.revolute("pin", node("cable", -1), body_point("bob"))
    system, state = m.build(assemble=False)  # the released state is consistent
    res = simulate(system, state, t_end=0.1, dt=1e-3, output_dt=0.01, progress=False,
                   solver=make_solver("generalized-alpha", **_ANCF_OPTIONS))
    assert res.status == "ok"
    tip = res.body("bob")[:, :2] - np.array([1.0, 0.0])
    beam = system.beams[0]
    strain = np.array([float(beam.axial_strain(system.beam_nodes(q, 0), 0.05)) for q in np.asarray(res.q)])
    assert strain.min() < -1e-4 and strain.max() > 1e-4, (strain.min(), strain.max())

    def exudyn_tip(law):
        mbs, sensor = _bilinear_cantilever(law)
        exu.SolveDynamic(mbs, simulation_settings(0.1))
        return np.asarray(mbs.GetSensorStoredData(sensor))[:, 1:3]

    bilinear, linear = exudyn_tip(BILINEAR), exudyn_tip(None)
    assert len(bilinear) == len(tip) and np.ptp(bilinear[:, 1]) > 1e-3
    d, d_linear = (np.max(np.linalg.norm(tip - e, axis=1)) for e in (bilinear, linear))
    print(f"bilinear law: {d:.3g} m; against Exudyn's linear cable {d_linear:.3g} m; clamp strain "
          f"{strain.min():.3g} .. {strain.max():.3g}")
    assert d < 1e-9 and d_linear > 1e-6


_CONTAINERS = []


def _exudyn_mechanism(extra=None, box=True, mode=0):
    """A planar Exudyn model with the items :func:`ancf_jax.interop.exudyn.from_exudyn`
    translates: a damped 6-element cable chain (useReducedOrderIntegration = ``mode``)
    clamped by three CoordinateConstraints (x, y, r'_y), a MassPoint2D pinned at its tip
    (RevoluteJoint2D), gravity as LoadMassProportional; ``extra(mbs, nodes, cables)``
    adds items before the box; with ``box``, the cable is also naturally curved
    (referenceCurvature), a RigidBody2D hangs from a point inside an element by a
    SpringDamper, pushed by a LoadForceVector and turned by a LoadTorqueVector under its
    own LoadMassProportional (not gravity), and a rigid arm pinned to the ground at a
    body point (RevoluteJoint2D to ObjectGround) is tied to a cable node by a second
    SpringDamper. Returns (mbs, sensors)."""
    from exudyn.itemInterface import (CoordinateConstraint, LoadForceVector, LoadMassProportional, LoadTorqueVector,
                                      MarkerBodyMass, MarkerBodyPosition, MarkerBodyRigid, MarkerNodeCoordinate,
                                      MarkerNodePosition, MassPoint2D, NodePoint2D, NodePoint2DSlope1,
                                      NodePointGround, NodeRigidBody2D, ObjectANCFCable2D, ObjectGround,
                                      RevoluteJoint2D, RigidBody2D, SensorNode, SpringDamper)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    _CONTAINERS.append(sc)  # keep the container alive with its system
    length, n, g = 1.2, 6, [0.0, -9.81, 0.0]
    nodes = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[i * length / n, 0.1, 1, 0])) for i in range(n + 1)]
    cables = []
    for i in range(n):
        cables.append(mbs.AddObject(ObjectANCFCable2D(
            name="cable" if i == 0 else "", nodeNumbers=[nodes[i], nodes[i + 1]], length=length / n,
            massPerLength=0.4, axialStiffness=5e5,
            bendingStiffness=1.5, axialDamping=500.0, bendingDamping=0.01, referenceCurvature=0.2 if box else 0.0,
            useReducedOrderIntegration=mode)))
        mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=cables[-1])),
                                         loadVector=g))
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    for c in (0, 1, 3):
        mbs.AddObject(CoordinateConstraint(markerNumbers=[
            ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=c))]))
    tip = mbs.AddNode(NodePoint2D(referenceCoordinates=[length, 0.1]))
    bob = mbs.AddObject(MassPoint2D(name="bob", nodeNumber=tip, mass=0.05))
    mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=bob)), loadVector=g))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[-1])),
                                                 mbs.AddMarker(MarkerNodePosition(nodeNumber=tip))]))
    if extra is not None:
        extra(mbs, nodes, cables)
    if not box:
        mbs.Assemble()
        return mbs, tip
    box_node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.5, -0.2, 0.1]))
    box = mbs.AddObject(RigidBody2D(name="box", nodeNumber=box_node, mass=0.2, inertia=2e-3))
    mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=box)),
                                     loadVector=[0.5, -9.81, 0.0]))
    hook = mbs.AddMarker(MarkerBodyPosition(bodyNumber=box, localPosition=[0.05, 0.02, 0.0]))
    on_cable = mbs.AddMarker(MarkerBodyPosition(bodyNumber=cables[2], localPosition=[0.1, 0.0, 0.0]))
    mbs.AddObject(SpringDamper(markerNumbers=[on_cable, hook], stiffness=300.0, damping=0.5, referenceLength=0.25))
    mbs.AddLoad(LoadForceVector(markerNumber=hook, loadVector=[0.3, 0.0, 0.0]))
    mbs.AddLoad(LoadTorqueVector(markerNumber=mbs.AddMarker(MarkerBodyRigid(bodyNumber=box)), loadVector=[0, 0, 0.02]))
    arm_node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.2, -0.3, 0.3]))
    arm = mbs.AddObject(RigidBody2D(name="arm", nodeNumber=arm_node, mass=0.1, inertia=1e-3))
    mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=arm)), loadVector=g))
    hinge = [0.2 - 0.1 * np.cos(0.3), -0.3 - 0.1 * np.sin(0.3), 0.0]
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[
        mbs.AddMarker(MarkerBodyPosition(bodyNumber=mbs.AddObject(ObjectGround()), localPosition=hinge)),
        mbs.AddMarker(MarkerBodyPosition(bodyNumber=arm, localPosition=[-0.1, 0.0, 0.0]))]))
    arm_end = mbs.AddMarker(MarkerBodyPosition(bodyNumber=arm, localPosition=[0.1, 0.0, 0.0]))
    tie_length = float(np.hypot(0.2 + 0.1 * np.cos(0.3) - 2 * length / n, -0.3 + 0.1 * np.sin(0.3) - 0.1))
    mbs.AddObject(SpringDamper(markerNumbers=[arm_end, mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[2]))],
                               stiffness=200.0, damping=0.2, referenceLength=tie_length))
    sensors = [mbs.AddSensor(SensorNode(nodeNumber=nd, outputVariableType=exu.OutputVariableType.Coordinates,
                                        storeInternal=True, writeToFile=False)) for nd in (tip, box_node)]
    mbs.Assemble()
    return mbs, sensors


def _static_settings():
    """Exudyn's SolveStatic: 10 equal load steps, full Newton to tight tolerances."""
    ss = exu.SimulationSettings()
    ss.solution.file.write = False
    ss.staticSolver.verboseMode = 0
    ss.staticSolver.numberOfLoadSteps = 10
    ss.staticSolver.adaptiveStep = False
    ss.staticSolver.newton.relativeTolerance = 1e-10
    ss.staticSolver.newton.absoluteTolerance = 1e-14
    ss.staticSolver.newton.useModifiedNewton = False
    ss.staticSolver.newton.maxIterations = 50
    return ss


def _dynamic_settings():
    """0.2 s of index-3 generalized-α, h = 1 ms, ρ∞ = 0.9, full Newton, outputs every 10 ms."""
    return simulation_settings(0.2)


_ANCF_OPTIONS = dict(rho_inf=0.9, newton_tol=1e-10, refresh_every=1, velocity_projection=False)
_RESULTS = {}


def _mechanism_results():
    """from_exudyn of :func:`_exudyn_mechanism` and ancf_jax's statics (10 load steps)
    and 0.2 s dynamics of it, computed once per process (the to_exudyn case compares
    against the same results)."""
    if not _RESULTS:
        from ancf_jax.interop.exudyn import from_exudyn
        from ancf_jax.simulation import make_solver, simulate
        from ancf_jax.statics import solve_static
        mbs, sensors = _exudyn_mechanism()
        model = from_exudyn(mbs)
        system, state = model.build()
        res = simulate(system, state, t_end=0.2, dt=1e-3, output_dt=0.01, progress=False,
                       solver=make_solver("generalized-alpha", **_ANCF_OPTIONS))
        assert res.status == "ok"
        sol = solve_static(system, state, load_steps=10, tolerance=1e-12)
        _RESULTS.update(mbs=mbs, sensors=sensors, model=model, system=system, state=state, res=res, sol=sol)
    return _RESULTS


def from_exudyn_dynamics():
    """from_exudyn of the mechanism of :func:`_exudyn_mechanism` and Exudyn's own run,
    0.2 s at h = 1 ms, ρ∞ = 0.9, index 3, full Newton: the point mass and the rigid box
    (x, y, θ) agree to 1e-9 (m, rad) (measured 6.5e-11 and 1.6e-10); the statics of the
    same mechanism agree to 1e-9 (measured 9.0e-11 and 3.8e-11). Without the hinged arm
    they agree to ~1e-13: the arm is a soft mode (a 0.1 m lever on a 200 N/m spring)
    that turns round-off in the equilibrium equations into 1e-10 differences (both
    codes' solutions leave residuals of 3e-10 to 6e-10 N in ancf_jax's equations,
    4e-11 to 8e-11 of the largest load; tighter Newton tolerances change nothing).
    Untranslatable items raise, naming the item."""
    from ancf_jax.errors import ModelError
    from ancf_jax.interop.exudyn import from_exudyn

    r = _mechanism_results()
    mbs, sensors, model, system, res = r["mbs"], r["sensors"], r["model"], r["system"], r["res"]
    assert tuple(model.gravity) == (0.0, 0.0)  # the box carries its own load: per-item loads
    exu.SolveDynamic(mbs, _dynamic_settings())
    ref_tip, ref_box = (np.asarray(mbs.GetSensorStoredData(s))[:, 1:] for s in sensors)
    tip = res.body("bob")[:, :2] - np.array([1.2, 0.1])       # Exudyn's node coordinates are displacements
    box = res.body("box") - np.array([0.5, -0.2, 0.1])
    assert len(ref_tip) == len(tip)
    assert np.ptp(ref_tip[:, 1]) > 1e-2 and np.ptp(ref_box[:, 2]) > 1e-3  # it moved and turned
    print(f"from_exudyn: point mass {np.max(np.abs(tip - ref_tip)):.3g} m, rigid body "
          f"{np.max(np.abs(box - ref_box)):.3g} (m, rad)")
    assert np.max(np.abs(tip - ref_tip)) < 1e-9
    assert np.max(np.abs(box - ref_box)) < 1e-9

    # statics of the same mechanism: Exudyn's SolveStatic and ancf_jax's solve_static,
    # 10 equal load steps from the reference, full Newton in both
    mbs_s, sensors_s = _exudyn_mechanism()
    exu.SolveStatic(mbs_s, _static_settings())
    static_tip, static_box = (np.asarray(mbs_s.GetSensorValues(s)) for s in sensors_s)
    q = np.asarray(r["sol"].state.q)
    o_bob, o_box = (system.body_offset(system.body_names.index(b)) for b in ("bob", "box"))
    d_tip = np.max(np.abs(q[o_bob:o_bob + 2] - np.array([1.2, 0.1]) - static_tip))
    d_box = np.max(np.abs(q[o_box:o_box + 3] - np.array([0.5, -0.2, 0.1]) - static_box))
    print(f"from_exudyn statics: point mass {d_tip:.3g} m, rigid body {d_box:.3g} (m, rad); "
          f"tip sags {-static_tip[1]:.3g} m")
    assert -static_tip[1] > 1e-2 and d_tip < 1e-9 and d_box < 1e-9

    def cartesian(mbs, nodes, cables):
        from exudyn.itemInterface import CartesianSpringDamper, MarkerNodePosition
        mbs.AddObject(CartesianSpringDamper(name="xy_spring", markerNumbers=[
            mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[1])), mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[2]))]))

    mbs2, _ = _exudyn_mechanism(cartesian)
    try:
        from_exudyn(mbs2)
    except ModelError as err:
        assert "'xy_spring'" in str(err) and "not translated" in str(err) and "\n" not in str(err)
    else:
        raise AssertionError("an untranslatable item was accepted")


def _pendulum_cable(mode, shift, sensors):
    """``extra`` of :func:`_exudyn_mechanism`: a second cable (2 elements, 0.5 m,
    useReducedOrderIntegration = ``mode``) pinned at its first node by two
    CoordinateConstraints with offsets, the x one with the ground as marker 1
    (−q_x − offset = 0), the y one with the ground as marker 0 and factor1 = 2
    (2 q_y − offset = 0); it starts rigidly displaced by ``shift`` (dx, dy) from its
    reference, where the constraints hold it, and swings down under gravity. Appends
    sensors of the mechanism cable's tip and of this cable's tip to ``sensors``."""
    from exudyn.itemInterface import (CoordinateConstraint, LoadMassProportional, MarkerBodyMass,
                                      MarkerNodeCoordinate, NodePoint2DSlope1, NodePointGround, ObjectANCFCable2D,
                                      SensorNode)

    def add(mbs, nodes, cables):
        dx, dy = shift
        pendulum = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[0.25 * i, -0.4, 1.0, 0.0],
                                                  initialCoordinates=[dx, dy, 0.0, 0.0])) for i in range(3)]
        for i in range(2):
            cable = mbs.AddObject(ObjectANCFCable2D(
                name="pendulum" if i == 0 else "", nodeNumbers=pendulum[i:i + 2], length=0.25, massPerLength=0.3,
                axialStiffness=1e5, bendingStiffness=0.5, useReducedOrderIntegration=mode))
            mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=cable)),
                                             loadVector=[0.0, -9.81, 0.0]))
        ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
        x, y = (mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=pendulum[0], coordinate=c)) for c in (0, 1))
        mbs.AddObject(CoordinateConstraint(markerNumbers=[x, ground], offset=-dx))
        mbs.AddObject(CoordinateConstraint(markerNumbers=[ground, y], factor1=2.0, offset=2.0 * dy))
        sensors.extend(mbs.AddSensor(SensorNode(nodeNumber=nd, outputVariableType=exu.OutputVariableType.Coordinates,
                                                storeInternal=True, writeToFile=False))
                       for nd in (nodes[-1], pendulum[-1]))
    return add


def from_exudyn_formulations_and_offsets():
    """The importer's options end to end: the small mechanism (the damped cable with its
    tip mass, ``box=False``) with useReducedOrderIntegration = 1 and a second cable with
    useReducedOrderIntegration = 2 pinned by coordinate constraints with offsets and
    factor1 on either marker side (:func:`_pendulum_cable`), imported and run by both
    codes, 0.1 s at h = 1 ms, ρ∞ = 0.9, index 3, full Newton: both cables' tip
    coordinates agree to 1e-9 (m, -), as the other dynamic cross-checks (measured
    7.8e-16 on the mechanism's cable, 6.3e-14 on the pendulum); the imported pin holds the pendulum at its shifted start (|Φ| < 1e-14).
    Negative control: Exudyn with the two cables' modes swapped differs by > 1e-6 on
    each cable."""
    from ancf_jax.interop.exudyn import cable_formulation, from_exudyn
    from ancf_jax.simulation import make_solver, simulate
    shift = (0.01, -0.02)

    def exudyn_model(modes):
        sensors = []
        mbs, _ = _exudyn_mechanism(_pendulum_cable(modes[1], shift, sensors), box=False, mode=modes[0])
        return mbs, sensors

    mbs, _ = exudyn_model((1, 2))
    system, state = from_exudyn(mbs).build(assemble=False)
    assert [b.formulation for b in system.beams] == [cable_formulation(1), cable_formulation(2)]
    assert float(np.max(np.abs(np.asarray(system.constraint(state.q))))) < 1e-14
    res = simulate(system, state, t_end=0.1, dt=1e-3, output_dt=0.01, progress=False,
                   solver=make_solver("generalized-alpha", **_ANCF_OPTIONS))
    assert res.status == "ok"
    ancf = [np.asarray(res.node(b, -1)) for b in ("cable", "pendulum")]
    refs = [np.array([1.2, 0.1, 1.0, 0.0]), np.array([0.5, -0.4, 1.0, 0.0])]
    assert np.ptp(ancf[1][:, 1]) > 1e-2 and np.ptp(ancf[0][:, 1]) > 1e-3  # both moved

    def differences(modes):
        mbs, sensors = exudyn_model(modes)
        exu.SolveDynamic(mbs, simulation_settings(0.1))
        return [np.max(np.abs(np.asarray(mbs.GetSensorStoredData(k))[:, 1:] + r - a))
                for k, r, a in zip(sensors, refs, ancf)]

    d, d_swapped = differences((1, 2)), differences((2, 1))
    print("modes 1 and 2, offsets: " + ", ".join(f"{x:.3g}" for x in d) + "; modes swapped "
          + ", ".join(f"{x:.3g}" for x in d_swapped))
    assert max(d) < 1e-9 and min(d_swapped) > 1e-6


def from_exudyn_eigenvalues():
    """The damped cable with its tip mass (the mechanism without the hanging box),
    imported: the ten lowest ω² of ancf_jax's modal analysis (constraints eliminated by
    the null space of Φ_q) equal Exudyn's ComputeODE2Eigenvalues (constraints by the
    null-space projection) about the reference configuration to 1e-9 relative, every
    mode (measured 2.0e-10 on the lowest, 1.5e-10 on the second, 1.0e-11 on the fourth,
    2e-14 to 2e-12 on modes 5-10). The bound a dense eigen-solution guarantees is
    absolute, ~ε·max ω² = 3e-7 1/s² (the axial modes reach 1.3e9 1/s²), 2e-8 of the
    lowest ω²; both codes stay two orders below it here."""
    from ancf_jax.interop.exudyn import from_exudyn
    from ancf_jax.modal import modal_analysis
    mbs, _ = _exudyn_mechanism(box=False)
    system, state = from_exudyn(mbs).build()
    w = np.asarray(modal_analysis(system, state.q).angular_frequencies)[:10]
    ss = exu.SimulationSettings()
    values, _ = mbs.ComputeODE2Eigenvalues(simulationSettings=ss, useSparseSolver=False, numberOfEigenvalues=0,
                                           ignoreAlgebraicEquations=False, convert2Frequencies=False,
                                           useAbsoluteValues=False)
    values = np.sort(np.asarray(values))
    ref = values[:10]
    print("eigenvalues rel. difference", np.abs(w**2 - ref) / ref, "max omega^2", values[-1])
    # 1e-9 relative, or the absolute floor a dense eigen-solution guarantees (4 ε max ω²,
    # 2e-8 of the lowest ω²; another BLAS may round there), whichever is larger
    np.testing.assert_allclose(w**2, ref, rtol=1e-9, atol=4 * np.finfo(float).eps * values[-1])


def explicit_solvers_match_exudyn():
    """ancf_jax's explicit Euler and RK4 against Exudyn's ``ExplicitEuler`` and
    ``RK44`` on a free 4-element cable (EA = 1e4 N, EI = 2 N·m², ρA = 0.5 kg/m) spinning
    at 10 rad/s about its middle under gravity, 0.05 s at h = 10 µs (5,000 steps), the
    same initial state: tip positions agree to 1e-12 m (measured 8.5e-15 m Euler,
    1.7e-15 m RK4). Negative control: explicit Euler against Exudyn's RK44 differs by
    the first-order error, > 1e-6 m. (Exudyn's explicit solvers are for systems
    without constraints, or with constraints of coordinates to the ground; with the
    Exudyn clamp they gave a tip 1.3e-3 m from both codes' generalized-α runs, which
    agree to 5e-12 m: not compared here.)"""
    import equinox as eqx
    from ancf_jax import mesh
    from ancf_jax.model import Model
    from ancf_jax.section import Section
    from ancf_jax.simulation import make_solver, simulate

    m = Model(gravity=(0.0, -9.81))
    m.add_beam("beam", mesh.straight((0.0, 0.0), (1.0, 0.0), 1.0, 4),
               Section.from_stiffness(1.0e4, 2.0, 0.5), formulation=em.exudyn_formulation(0))
    system, state = m.build(assemble=False)
    q, w = np.asarray(state.q).reshape(-1, 4), 10.0
    v = np.stack([-w * q[:, 1], w * (q[:, 0] - 0.5), -w * q[:, 3], w * q[:, 2]], 1).ravel()
    state = eqx.tree_at(lambda s: s.v, state, jnp.asarray(v))
    kw = dict(t_end=0.05, dt=1e-5, output_dt=0.01)

    def exudyn_tip(kind):
        r = em.run(em.build_exudyn(system, state, name="M1"), solver_type=kind, **kw)
        assert r.status == "ok"
        return r.outputs["tip"]

    exudyn = {kind: exudyn_tip(kind) for kind in ("ExplicitEuler", "RK44")}
    for name, kind in (("explicit-euler", "ExplicitEuler"), ("rk4", "RK44")):
        res = simulate(system, state, solver=name, progress=False, **kw)
        assert res.status == "ok"
        tip = np.asarray(res.node("beam", -1))[:, :2]
        assert np.ptp(tip[:, 1]) > 0.1  # it moved
        assert np.max(np.linalg.norm(tip - exudyn[kind], axis=1)) < 1e-12, name
        if name == "explicit-euler":
            assert np.max(np.linalg.norm(tip - exudyn["RK44"], axis=1)) > 1e-6


# ----------------------------------------------------------------------------- rigid bodies only
def _slider_crank(rod_inertia=0.02):
    """A slider-crank of rigid bodies only, written natively in Exudyn: a crank
    (RigidBody2D, 0.2 m) pinned to an ObjectGround point (RevoluteJoint2D), a rod
    (0.5 m) pinned to the crank's end and to the slider's centre, a slider whose y and
    angle are held by CoordinateConstraints on its NodeRigidBody2D with offsets (y by
    factor1 = 2 with the ground as marker 0, the angle with the ground as marker 1),
    the slider's node starting away from its reference by the constrained
    displacements; gravity on every body (LoadMassProportional) and a torque of
    0.8 N·m on the crank (LoadTorqueVector). Returns (mbs, sensors of the three nodes'
    coordinates, their reference coordinates)."""
    from exudyn.itemInterface import (CoordinateConstraint, LoadMassProportional, LoadTorqueVector, MarkerBodyMass,
                                      MarkerBodyPosition, MarkerBodyRigid, MarkerNodeCoordinate, NodePointGround,
                                      NodeRigidBody2D, ObjectGround, RevoluteJoint2D, RigidBody2D, SensorNode)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    _CONTAINERS.append(sc)
    g = [0.0, -9.81, 0.0]
    crank_angle, crank, rod, slider_y, dy, d_theta = 0.5, 0.2, 0.5, -0.05, 0.03, 0.2
    a = crank * np.array([np.cos(crank_angle), np.sin(crank_angle)])
    b = np.array([a[0] + np.sqrt(rod**2 - (a[1] - slider_y) ** 2), slider_y])
    rod_angle = float(np.arctan2(*(b - a)[::-1]))
    refs = [[*(a / 2), crank_angle], [*((a + b) / 2), rod_angle], [b[0], slider_y - dy, -d_theta]]
    initial = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, dy, d_theta]]
    nodes, bodies = [], []
    for name, ref, q0, mass, inertia in zip(("crank", "rod", "slider"), refs, initial, (0.5, 1.0, 2.0),
                                            (2e-3, rod_inertia, 5e-3)):
        nodes.append(mbs.AddNode(NodeRigidBody2D(referenceCoordinates=ref, initialCoordinates=q0)))
        bodies.append(mbs.AddObject(RigidBody2D(name=name, nodeNumber=nodes[-1], mass=mass, inertia=inertia)))
        mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=bodies[-1])),
                                         loadVector=g))

    def at(body, x):
        return mbs.AddMarker(MarkerBodyPosition(bodyNumber=body, localPosition=[x, 0.0, 0.0]))

    ground = mbs.AddObject(ObjectGround(referencePosition=[0.0, 0.0, 0.0]))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[at(ground, 0.0), at(bodies[0], -crank / 2)]))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[at(bodies[0], crank / 2), at(bodies[1], -rod / 2)]))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[at(bodies[1], rod / 2), at(bodies[2], 0.0)]))
    fixed = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    y, theta = (mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[2], coordinate=c)) for c in (1, 2))
    mbs.AddObject(CoordinateConstraint(markerNumbers=[fixed, y], factor1=2.0, offset=2.0 * dy))  # 2 q_y - offset = 0
    mbs.AddObject(CoordinateConstraint(markerNumbers=[theta, fixed], offset=-d_theta))  # -q_theta - offset = 0
    mbs.AddLoad(LoadTorqueVector(markerNumber=mbs.AddMarker(MarkerBodyRigid(bodyNumber=bodies[0])),
                                 loadVector=[0.0, 0.0, 0.8]))
    sensors = [mbs.AddSensor(SensorNode(nodeNumber=nd, outputVariableType=exu.OutputVariableType.Coordinates,
                                        storeInternal=True, writeToFile=False)) for nd in nodes]
    mbs.Assemble()
    return mbs, sensors, np.array(refs)


def from_exudyn_rigid_mechanism():
    """from_exudyn of :func:`_slider_crank` (rigid bodies only: revolute joints to an
    ObjectGround point and between bodies, coordinate constraints on a body's node
    with offset and factor1 on either side, gravity, a torque) and Exudyn's own run,
    0.5 s at h = 1 ms, ρ∞ = 0.9, index 3, full Newton (the crank turns 1.40 rad, the
    slider travels 0.086 m): every body coordinate agrees to 1e-9 (m, rad), as in the
    other dynamic cross-checks (measured 3.6e-10 on the crank angle: Exudyn's Newton
    tolerance, relative 1e-8; 6.3e-11 at 1e-10). The importer's constraint values are Exudyn's: the imported
    initial state satisfies them (|Φ| < 1e-14) with the slider 0.03 m and 0.2 rad away
    from its node's reference. Negative control: Exudyn with the rod's inertia 1 %
    larger differs by > 1e-6."""
    from ancf_jax.interop.exudyn import from_exudyn
    from ancf_jax.simulation import make_solver, simulate

    mbs, _, refs = _slider_crank()
    system, state = from_exudyn(mbs).build(assemble=False)
    assert not system.beams and system.n_constraints == 8
    assert float(np.max(np.abs(np.asarray(system.constraint(state.q))))) < 1e-14
    res = simulate(system, state, t_end=0.5, dt=1e-3, output_dt=0.01, progress=False,
                   solver=make_solver("generalized-alpha", **_ANCF_OPTIONS))
    assert res.status == "ok"
    ancf = np.stack([res.body(b) for b in ("crank", "rod", "slider")], axis=1) - refs
    assert np.ptp(ancf[:, 0, 2]) > 1.0  # the crank turned

    def exudyn_run(**kw):
        mbs, sensors, _ = _slider_crank(**kw)
        exu.SolveDynamic(mbs, simulation_settings(0.5))
        return np.stack([np.asarray(mbs.GetSensorStoredData(k))[:, 1:] for k in sensors], axis=1)

    d = np.max(np.abs(exudyn_run() - ancf))
    d_control = np.max(np.abs(exudyn_run(rod_inertia=0.0202) - ancf))
    print(f"rigid slider-crank: {d:.3g}; rod inertia +1 %: {d_control:.3g}")
    assert d < 1e-9 and d_control > 1e-6


# ----------------------------------------------------------------------------- to_exudyn
def to_exudyn_matches_ancf_jax():
    """to_exudyn of the imported mechanism of :func:`_mechanism_results` (an ancf_jax
    model: cable with strain-rate damping and a natural curvature, coordinate
    constraints, point mass, rigid bodies, revolute joints to a beam node and to the
    ground, spring-dampers at a point inside an element and at a node, point force,
    torque, per-item mass-proportional loads), solved by Exudyn, against ancf_jax's own
    solutions of that model: statics (10 load steps, full Newton in both) and 0.2 s of
    index-3 generalized-α (h = 1 ms, ρ∞ = 0.9, full Newton, no velocity projection):
    every coordinate agrees to 1e-9 (m, rad, -) (measured 2.4e-10 statics, 7.8e-10
    dynamics, the largest on the arm's angle: the soft mode of
    :func:`from_exudyn_dynamics`; displacements up to 1.3 m). Untranslatable items raise
    a one-line ModelError naming the item."""
    from ancf_jax.errors import ModelError
    from ancf_jax.interop.exudyn import to_exudyn

    r = _mechanism_results()
    system, state = r["system"], r["state"]
    x = to_exudyn(system, state, sensors=False)
    exu.SolveStatic(x.mbs, _static_settings())
    q = np.asarray(r["sol"].state.q)
    d_static = np.max(np.abs(q - x.coordinates()))
    sag = np.max(np.abs(q - np.asarray(state.q)))

    x = to_exudyn(system, state)
    exu.SolveDynamic(x.mbs, _dynamic_settings())
    t, q_exudyn = x.history()
    res = r["res"]
    np.testing.assert_allclose(t, np.asarray(res.t), atol=1e-12)
    d_dynamic = np.max(np.abs(np.asarray(res.q) - q_exudyn))
    moved = np.max(np.abs(np.asarray(res.q) - np.asarray(state.q)))
    print(f"to_exudyn: statics {d_static:.3g} (largest displacement {sag:.3g}); dynamics {d_dynamic:.3g} "
          f"(largest motion {moved:.3g})")
    assert sag > 0.1 and moved > 0.05
    assert d_static < 1e-9 and d_dynamic < 1e-9

    # what Exudyn has no item for is named, on one line
    from ancf_jax import mesh
    from ancf_jax.element.laws import Bilinear
    from ancf_jax.model import Model, body_point, node
    from ancf_jax.section import Section

    def bilinear(m):
        m.add_beam("rope", mesh.straight((0.0, 1.0), (1.0, 0.0), 1.0, 2), Section.from_stiffness(1e4, 1.0, 0.1),
                   formulation=em.exudyn_formulation(0), axial_law=Bilinear(1e4, 1e2))

    def refused(name, *source):
        try:
            to_exudyn(*source)
        except ModelError as err:
            assert name in str(err) and "not translated to Exudyn" in str(err) and "\n" not in str(err), str(err)
        else:
            raise AssertionError(f"{name} was translated")

    tiny = Model()
    bilinear(tiny)
    refused("'rope'", tiny)  # a Model is built by to_exudyn
    from ancf_jax.interop.exudyn import from_exudyn
    for extra, name in (
            (lambda m: m.spring_damper("rope", node("cable", 1), body_point("arm"), stiffness=1.0, acts="tension"),
             "'rope'"),
            (lambda m: m.point_force("gust", node("cable", 1), (1.0, 0.0), time_function=lambda t: t), "'gust'"),
            (lambda m: m.prescribe_body("drive", "arm", "theta", lambda t: 0.3 + t), "'drive'")):
        model = from_exudyn(_exudyn_mechanism()[0])
        extra(model)
        refused(name, *model.build(assemble=False))


# ----------------------------------------------------------------------------- sliding joint, curved cables
def _curved_sliding_mechanism(cancel, speed=0.0):
    """Two curved cables written natively in Exudyn: a bowl made by Exudyn's own
    GenerateCircularArcANCFCable2D (a pre-curved cable: referenceCurvature 1/R, strain
    measured from the straight state, strainIsRelativeToReference = 0; pinned at both
    ends) with a MassPoint2D sliding along it (JointSliding2D over all its elements,
    released at ``speed`` [m/s] along the track), and a hook whose stress-free
    reference is a curve with non-unit slopes and unequal element lengths
    (strainIsRelativeToReference = 1, axial damping), clamped at its first node by four
    CoordinateConstraints; gravity. ``cancel``: cancel Exudyn's extra sliding-joint
    term. Returns (mbs, sensors: bead, hook tip, sliding coordinate).

    Released at speed, Exudyn's initial accelerations leave out the velocity terms of
    the joint's acceleration equation (its sliding coordinate has no rate): at 1 m/s
    its bead starts at the at-rest acceleration (-2.485, -12.236) m/s², ancf_jax's
    consistent one is (-2.351, -12.105), and s differs by 1.0e-8 m after 0.3 s
    (measured; at rest both start equal to all digits). The test releases at rest."""
    from exudyn.beams import GenerateCircularArcANCFCable2D
    from exudyn.itemInterface import (CoordinateConstraint, LoadMassProportional, MarkerBodyCable2DCoordinates,
                                      MarkerBodyMass, MarkerBodyPosition, MarkerNodeCoordinate, MassPoint2D,
                                      NodeGenericData, NodePoint2D, NodePoint2DSlope1, NodePointGround,
                                      ObjectANCFCable2D, ObjectJointSliding2D, SensorNode, SensorObject)
    from ancf_jax.interop.exudyn import cancel_sliding_term, hermite
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    _CONTAINERS.append(sc)
    g = [0.0, -9.81, 0.0]
    template = ObjectANCFCable2D(massPerLength=0.3, axialStiffness=2e5, bendingStiffness=5.0,
                                 bendingDamping=0.01)
    track_nodes, track, _, _, _ = GenerateCircularArcANCFCable2D(
        mbs, positionOfNode0=[0.0, 0.0, 0.0], radius=1.0, startAngle=-np.pi / 3, arcAngle=2 * np.pi / 3,
        numberOfElements=6, cableTemplate=template, massProportionalLoad=g, fixedConstraintsNode0=[1, 1, 0, 0],
        fixedConstraintsNode1=[1, 1, 0, 0])
    # the bead on the track's centre line at s0, moving along it
    length = float(mbs.GetObject(track[0])["length"])
    s0 = 0.25
    e0 = np.concatenate([np.asarray(mbs.GetNode(n)["referenceCoordinates"], float) for n in track_nodes[:2]])
    s, s1, _ = hermite(s0 / length, length)
    r0 = np.array([s[0] @ e0[0::2], s[0] @ e0[1::2]])
    t0 = np.array([s1[0] @ e0[0::2], s1[0] @ e0[1::2]])
    bead_node = mbs.AddNode(NodePoint2D(referenceCoordinates=list(r0),
                                        initialVelocities=list(speed * t0 / np.linalg.norm(t0))))
    bead = mbs.AddObject(MassPoint2D(name="bead", nodeNumber=bead_node, mass=0.2))
    mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=bead)), loadVector=g))
    markers = [mbs.AddMarker(MarkerBodyCable2DCoordinates(bodyNumber=e)) for e in track]
    data = mbs.AddNode(NodeGenericData(initialCoordinates=[0.0, s0], numberOfDataCoordinates=2))
    joint = mbs.AddObject(ObjectJointSliding2D(
        name="slide", markerNumbers=[mbs.AddMarker(MarkerBodyPosition(bodyNumber=bead, localPosition=[0, 0, 0])),
                                     markers[0]],
        slidingMarkerNumbers=markers, slidingMarkerOffsets=[i * length for i in range(len(track))], nodeNumber=data))
    if cancel:
        cancel_sliding_term(mbs, [joint])

    # the hook: a stress-free curved reference, non-unit slopes, unequal elements
    x = np.array([0.0, 0.25, 0.45, 0.7, 1.0])
    ref = np.column_stack([2.5 + x, 0.5 + 0.3 * x**2, np.ones_like(x), 0.6 * x])
    hook_nodes = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=list(r))) for r in ref]
    for i in range(len(x) - 1):
        cable = mbs.AddObject(ObjectANCFCable2D(
            name="hook" if i == 0 else "", nodeNumbers=hook_nodes[i:i + 2],
            length=1.01 * float(np.linalg.norm(ref[i + 1, :2] - ref[i, :2])), massPerLength=0.2,
            axialStiffness=1e5, bendingStiffness=0.5, axialDamping=50.0, strainIsRelativeToReference=1.0))
        mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=cable)), loadVector=g))
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    for c in range(4):
        mbs.AddObject(CoordinateConstraint(markerNumbers=[
            ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=hook_nodes[0], coordinate=c))]))
    ovt = exu.OutputVariableType
    sensors = [mbs.AddSensor(SensorNode(nodeNumber=n, outputVariableType=ovt.Coordinates, storeInternal=True,
                                        writeToFile=False)) for n in (bead_node, hook_nodes[-1])]
    sensors.append(mbs.AddSensor(SensorObject(objectNumber=joint, outputVariableType=ovt.SlidingCoordinate,
                                              storeInternal=True, writeToFile=False)))
    mbs.Assemble()
    return mbs, sensors


def from_exudyn_sliding_and_curved():
    """from_exudyn of :func:`_curved_sliding_mechanism` (a JointSliding2D, a pre-curved
    cable of Exudyn's arc generator, a cable with strainIsRelativeToReference = 1) and
    Exudyn's own runs, 0.3 s at h = 1 ms, ρ∞ = 0.9, index 3, full Newton (the bead slides
    0.30 m from rest, over node 1): with Exudyn's extra sliding-joint term cancelled the
    bead, the hook's tip and the sliding coordinate agree to 1e-9 m (measured 2.0e-10 m
    on the bead, 2.3e-10 m on s, 1.1e-14 m on the hook); Exudyn as shipped differs by
    the effect of that term (measured 8.7e-6 m on the bead, 1.9e-6 m on s: its O(h)
    error)."""
    from ancf_jax.interop.exudyn import from_exudyn
    from ancf_jax.simulation import make_solver, simulate

    from ancf_jax.errors import ModelError
    mbs, _ = _curved_sliding_mechanism(cancel=False)
    model = from_exudyn(mbs)
    system, state = model.build()
    refused, _ = _curved_sliding_mechanism(cancel=False)
    refused.SetObjectParameter(refused.GetObjectNumber("slide"), "useClassicalFormulation", False)
    try:
        from_exudyn(refused)
    except ModelError as err:
        assert "'slide'" in str(err) and "classical formulation only" in str(err), str(err)
    else:
        raise AssertionError("the local formulation of the sliding joint was accepted")
    assert system.beams[1].formulation.metric == "parameter"
    assert float(system.beams[0].bending_law.rest) == 1.0
    res = simulate(system, state, t_end=0.3, dt=1e-3, output_dt=0.01, progress=False,
                   solver=make_solver("generalized-alpha", **_ANCF_OPTIONS))
    assert res.status == "ok"
    ancf = (res.body("bead")[:, :2], np.asarray(res.node("hook", -1))[:, :2], res.sliding("slide"))
    assert ancf[2][0] < 0.349 < ancf[2][-1]  # it slid over node 1 (s = 0.349 m)
    assert np.ptp(ancf[1][:, 1]) > 1e-3  # the hook moved
    diffs = {}
    for cancel in (True, False):
        mbs, sensors = _curved_sliding_mechanism(cancel)
        ss = simulation_settings(0.3)
        exu.SolveDynamic(mbs, ss)
        bead, tip, s = (np.asarray(mbs.GetSensorStoredData(k))[:, 1:] for k in sensors)
        bead = bead + np.asarray(mbs.GetNode(mbs.GetObject(mbs.GetObjectNumber("bead"))["nodeNumber"])
                                 ["referenceCoordinates"], float)
        tip = tip[:, :2] + np.asarray(mbs.GetNode(int(sensors_node(mbs, sensors[1])))["referenceCoordinates"],
                                      float)[:2]
        diffs[cancel] = (np.max(np.abs(bead - ancf[0])), np.max(np.abs(tip - ancf[1])),
                         np.max(np.abs(s[:, 0] - ancf[2])))
    print("sliding and curved (bead, hook tip, s): cancelled " + ", ".join(f"{d:.3g}" for d in diffs[True])
          + "; as shipped " + ", ".join(f"{d:.3g}" for d in diffs[False]))
    assert max(diffs[True]) < 1e-9
    assert diffs[False][2] > 1e-7


def simulation_settings(t_end):
    """Exudyn's index-3 generalized-α as ancf_jax's (ρ∞ = 0.9, h = 1 ms, outputs every
    10 ms, full Newton to tight tolerances) over ``t_end`` [s]."""
    from ancf_jax.interop.exudyn import simulation_settings as settings
    return settings(t_end=t_end, h=1e-3, n_steps=int(round(t_end / 1e-3)), output_dt=0.01, relative_tolerance=1e-8,
                    absolute_tolerance=1e-12, modified_newton=False, max_iterations=50)


def sensors_node(mbs, sensor):
    return mbs.GetSensor(sensor)["nodeNumber"]


# ----------------------------------------------------------------------------- index 2
def index2_matches_exudyn():
    """Velocity-level constraints: ancf_jax's generalized-α at ρ∞ = 1 with ``index=2``
    against Exudyn's Newmark (β = ¼, γ = ½) with useIndex2Constraints, on the rigid
    pendulum swinging ±143° (to_exudyn: RigidBody2D, RevoluteJoint2D to the ground at a
    body point), 0.5 s at h = 1 ms, full Newton: every coordinate agrees to 1e-9
    (measured 1.7e-11). Negative control: Exudyn at index 3 differs from ancf_jax at
    index 2 by the O(h²) difference of the two methods (> 1e-6)."""
    from ancf_jax.interop.exudyn import to_exudyn
    from ancf_jax.integrate import RunOptions
    from ancf_jax.simulation import make_solver, simulate
    from tests.dynamics import pendulum_model
    system, state = pendulum_model(2.5).build()
    res = simulate(system, state, t_end=0.5, dt=1e-3, output_dt=0.01, progress=False,
                   options=RunOptions(drift_tolerance=1.0),
                   solver=make_solver("generalized-alpha", rho_inf=1.0, index=2, newton_tol=1e-12, refresh_every=1,
                                      velocity_projection=False))
    assert res.status == "ok"
    diffs = {}
    for index in (2, 3):
        _, q = to_exudyn(system, state).solve_dynamic(t_end=0.5, h=1e-3, output_dt=0.01, rho_inf=1.0,
                                                      relative_tolerance=1e-8, absolute_tolerance=1e-12,
                                                      modified_newton=False, max_iterations=50, index=index)
        diffs[index] = np.max(np.abs(q - np.asarray(res.q)))
    print(f"index 2: {diffs[2]:.3g}; against Exudyn at index 3: {diffs[3]:.3g}")
    assert np.ptp(np.asarray(res.q)[:, 2]) > 1.0  # it swung
    assert diffs[2] < 1e-9 and diffs[3] > 1e-6
    from ancf_jax.errors import ModelError
    try:  # solve_dynamic refuses a span that is not a whole number of steps, before solving
        to_exudyn(system, state).solve_dynamic(t_end=0.5, h=3e-3)
    except ModelError as e:
        assert "t_end = 0.5 s must be a positive whole number of steps" in str(e)
    else:
        raise AssertionError("t_end = 0.5 s with h = 3 ms was accepted")
