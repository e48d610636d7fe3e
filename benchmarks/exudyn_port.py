"""The side-by-side port of docs/exudyn.md, run: one model written natively in Exudyn and
in ancf_jax, and the difference of their tip trajectories.

    PYTHONPATH=. python -m benchmarks.exudyn_port

A damped cable (EA, EI, ρA, axial and bending strain-rate damping) clamped Exudyn-style
(x, y, r'_y) with a point mass pinned at its tip, under gravity; index-3 generalized-α
at ρ∞ = 0.9, h = 1 ms, 0.5 s. Exudyn runs in a child process (it is never imported
together with the JAX programs of the same process, see tests/exudyn_cases.py).
"""

from __future__ import annotations

import multiprocessing as mp

import numpy as np

L, N = 1.0, 8                      # length [m], elements
EA, EI, RHO_A = 1.0e6, 2.0, 0.5    # [N], [N m^2], [kg/m]
D_A, D_K = 2.0e3, 0.05             # axial [N s], bending [N m^2 s] strain-rate damping
M_TIP = 0.1                        # point mass [kg]
G = -9.81
T_END, H = 0.5, 1e-3


def exudyn_tip():
    """The model as an Exudyn user writes it; tip (x, y) every 10 ms."""
    import exudyn as exu
    from exudyn.itemInterface import (CoordinateConstraint, LoadMassProportional, MarkerBodyMass,
                                      MarkerNodeCoordinate, MarkerNodePosition, MassPoint2D, NodePoint2D,
                                      NodePoint2DSlope1, NodePointGround, ObjectANCFCable2D,
                                      RevoluteJoint2D, SensorNode)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    nodes = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[i * L / N, 0, 1, 0])) for i in range(N + 1)]
    for i in range(N):
        cable = mbs.AddObject(ObjectANCFCable2D(
            nodeNumbers=[nodes[i], nodes[i + 1]], length=L / N, massPerLength=RHO_A,
            axialStiffness=EA, bendingStiffness=EI, axialDamping=D_A, bendingDamping=D_K))
        mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=cable)),
                                         loadVector=[0, G, 0]))
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    for c in (0, 1, 3):  # Exudyn's clamp: x, y and r'_y of the first node
        mbs.AddObject(CoordinateConstraint(markerNumbers=[
            ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=c))]))
    tip = mbs.AddNode(NodePoint2D(referenceCoordinates=[L, 0]))
    bob = mbs.AddObject(MassPoint2D(nodeNumber=tip, mass=M_TIP))
    mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=bob)),
                                     loadVector=[0, G, 0]))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[-1])),
                                                 mbs.AddMarker(MarkerNodePosition(nodeNumber=tip))]))
    sensor = mbs.AddSensor(SensorNode(nodeNumber=tip, outputVariableType=exu.OutputVariableType.Position,
                                      storeInternal=True, writeToFile=False))
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.endTime, ti.numberOfSteps, ti.verboseMode = T_END, int(round(T_END / H)), 0
    ti.generalizedAlpha.spectralRadius = 0.9
    ti.generalizedAlpha.computeInitialAccelerations = True
    ti.newton.relativeTolerance, ti.newton.absoluteTolerance = 1e-8, 1e-12
    ti.newton.useModifiedNewton = False
    ss.solution.sensors.writePeriod = 0.01
    ss.solution.file.write = False
    ti.generalizedAlpha.useIndex2Constraints = False  # index 3, as ancf_jax
    ti.generalizedAlpha.useNewmark = False
    ti.adaptiveStep = False
    exu.SolveDynamic(mbs, ss)
    return np.asarray(mbs.GetSensorStoredData(sensor))[:, 1:3]


def ancf_model():
    """The same model in ancf_jax (a :class:`~ancf_jax.model.Model`)."""
    from ancf_jax import mesh
    from ancf_jax.element.laws import StrainRateDamped
    from ancf_jax.element.strain_energy import Formulation
    from ancf_jax.model import Model, body_point, node
    from ancf_jax.section import Section

    # Exudyn's cable: engineering strain, material curvature, Gauss 5 / Gauss 3 points
    exudyn_cable = Formulation(axial_strain="engineering", curvature="material",
                               axial_quadrature=("gauss", 5), bending_quadrature=("gauss", 3))
    m = Model(gravity=(0.0, G))
    m.add_beam("cable", mesh.straight((0, 0), (1, 0), L, N), Section.from_stiffness(EA, EI, RHO_A),
               formulation=exudyn_cable, axial_law=StrainRateDamped(D_A), bending_law=StrainRateDamped(D_K))
    m.clamp("support", "cable", 0, mode="exudyn")          # x, y, r'_y
    m.add_point_mass("bob", mass=M_TIP, position=(L, 0.0))
    m.revolute("pin", node("cable", -1), body_point("bob"))
    return m


def ancf_tip():
    """The model of :func:`ancf_model` run; tip (x, y) every 10 ms."""
    from ancf_jax.simulation import make_solver, simulate

    system, state = ancf_model().build()
    res = simulate(system, state, t_end=T_END, dt=H, output_dt=0.01, progress=False,
                   solver=make_solver("generalized-alpha", rho_inf=0.9, newton_tol=1e-10, refresh_every=1,
                                      velocity_projection=False))
    return res.body("bob")[:, :2]


def main():
    with mp.get_context("spawn").Pool(1) as pool:
        ref = pool.apply(exudyn_tip)
    tip = ancf_tip()
    d = np.max(np.linalg.norm(tip - ref, axis=1))
    print(f"tip falls {-ref[:, 1].min():.4f} m; max |ancf_jax - Exudyn| = {d:.3g} m over {len(ref)} outputs")
    return d


if __name__ == "__main__":
    main()
