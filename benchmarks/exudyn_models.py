"""The reference models M1, M2 and H1 built in Exudyn, from the ancf_jax models.

One parameter source: every Exudyn model here is *translated* from an assembled ancf_jax
:class:`~ancf_jax.system.System` and its initial :class:`~ancf_jax.system.State`
(:func:`build_exudyn`), so lengths, sections, masses, damping, gravity, joint locations
and the initial state are the numbers ancf_jax simulates; nothing is retyped. The
ancf_jax systems come from the model builders (:func:`ancf_jax.models.m1_model`,
:func:`ancf_jax.models.m2.m2_initial`, :func:`h1_model` below) with the formulation
that matches Exudyn's cable element (:func:`exudyn_formulation`).

The translation is the package's :func:`ancf_jax.interop.exudyn.to_exudyn` (its
docstring has the mapping); :func:`build_exudyn` wraps it for :func:`run`.

Exudyn's cable uses the axial strain |r'| − 1 and the material curvature
(r' × r'')/|r'|², with Gauss rules chosen by ``useReducedOrderIntegration``
(:data:`EXUDYN_RULES`, measured against Exudyn's residual in the tests). The ancf_jax
side of any comparison must use :func:`exudyn_formulation` with the same mode.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

import ancf_jax  # noqa: F401  (float64)
from ancf_jax import mesh as _mesh
from ancf_jax.element.quadrature import rule as _rule
from ancf_jax.interop import exudyn as _interop
from ancf_jax.interop.exudyn import CABLE_RULES, hermite as _hermite, integration_mode, sliding_term  # noqa: F401
from ancf_jax.element.strain_energy import Formulation
from ancf_jax.errors import ModelError
from ancf_jax.model import Model, node
from ancf_jax.section import Section
from ancf_jax.simulation import time_grid

# Exudyn (optional, the ``bench`` extra) is imported on first use by require_exudyn(),
# never at import: the ancf_jax side of this module (formulations, twin systems) runs in
# processes that compile JAX programs, where Exudyn's native libraries must not load
# (tests/exudyn_cases.py says why)
exu = None
eii = None

MODELS = ("M1", "M2", "H1")

#: Gauss rules of Exudyn's ObjectANCFCable2D per ``useReducedOrderIntegration`` mode:
#: (axial rule, bending rule) as ancf_jax (kind, points). Determined by matching
#: Exudyn 1.13.6's elastic force of a randomly deformed element to 1e-15 (relative)
#: (``tests/test_exudyn_crosscheck.py::test_exudyn_quadrature_rules``); the source
#: comments call them "A9-B5", "A7-B3" and "A4-B3" (polynomial orders).
EXUDYN_RULES = CABLE_RULES  # 0 is Exudyn's default

#: H1, the very flexible pendulum (docs/models.md), SI. No ancf_jax builder exists yet, so
#: the parameters live here (the lead may move them to ``ancf_jax.models``).
H1 = dict(length=1.2, n_elements=8, area=0.0018, second_moment=1.215e-8, density=5540.0,
          youngs_modulus=0.7e6, gravity=9.81)


def require_exudyn():
    """Import Exudyn (module globals ``exu``, ``eii``); raise ImportError with a helpful
    message when it is not installed."""
    global exu, eii
    if exu is None:
        try:
            import exudyn
            from exudyn import itemInterface
        except ImportError as err:
            raise ImportError("exudyn is not installed (pip install 'ancf_jax[bench]' or "
                              "pip install exudyn)") from err
        exu, eii = exudyn, itemInterface


# ------------------------------------------------------------------ ancf_jax side
def exudyn_formulation(integration: int = 0) -> Formulation:
    """The ancf_jax formulation equal to Exudyn's ANCFCable2D with
    ``useReducedOrderIntegration=integration``: |r'| − 1, material curvature and
    Exudyn's Gauss rules (:data:`EXUDYN_RULES`); the package's
    :func:`ancf_jax.interop.exudyn.cable_formulation`."""
    if integration not in EXUDYN_RULES:
        raise ModelError(f"integration must be one of {sorted(EXUDYN_RULES)}, got {integration!r}")
    return _interop.cable_formulation(integration)


def h1_model(n_elements: int | None = None, *, formulation: Formulation | None = None,
             **overrides) -> Model:
    """H1: a straight beam pinned at the origin, released from rest under gravity
    (no damping); parameters :data:`H1`."""
    unknown = set(overrides) - set(H1)
    if unknown:
        raise ModelError(f"unknown H1 parameter(s) {sorted(unknown)}; known: {sorted(H1)}")
    p = {**H1, **overrides}
    if n_elements is not None:
        p["n_elements"] = n_elements
    m = Model(gravity=(0.0, -p["gravity"]))
    section = Section(p["youngs_modulus"], p["area"], p["second_moment"], p["density"] * p["area"])
    m.add_beam("beam", _mesh.straight((0.0, 0.0), (1.0, 0.0), p["length"], p["n_elements"]),
               section, formulation=formulation)
    m.pin("pin", node("beam", 0))
    return m


def ancf_system(model: str, n_elements: int, *, integration: int = 0, **overrides):
    """(system, initial state) of an ancf_jax reference model with Exudyn's formulation.

    ``model`` is "M1", "M2" (released at the static equilibrium with the trolley held at
    s₀, from :func:`ancf_jax.models.m2.m2_initial`; this solve takes ~20 s) or "H1".
    """
    form = exudyn_formulation(integration)
    if model == "M1":
        from ancf_jax.models.m1 import m1_model
        return m1_model(n_elements, formulation=form, **overrides).build()
    if model == "M2":
        from ancf_jax.models.m2 import m2_initial
        system, state, _ = m2_initial(n_elements, formulation=form, **overrides)
        return system, state
    if model == "H1":
        return h1_model(n_elements, formulation=form, **overrides).build()
    raise ModelError(f"model must be one of {MODELS}, got {model!r}")


# ------------------------------------------------------------------ Exudyn side
@dataclasses.dataclass
class ExudynModel(_interop.ExudynSystem):
    """An Exudyn system translated from an ancf_jax system
    (:class:`ancf_jax.interop.exudyn.ExudynSystem`) with what :func:`run` keeps.

    Attributes:
        name: model name ("M1", "M2", "H1" or free text).
        setup_time_s: wall time of the translation, Assemble and mass matrix.
        used: whether it has been run (Exudyn sensors accumulate: one run each).
    """

    name: str = ""
    setup_time_s: float = 0.0
    used: bool = False


def build_exudyn(system, state, *, name: str = "", integration: int | None = None,
                 cancel_sliding_term: bool = False) -> ExudynModel:
    """Translate an assembled ancf_jax system and its initial state into Exudyn with
    the package's :func:`ancf_jax.interop.exudyn.to_exudyn` (sensors on), wrapped for
    :func:`run`.

    Args:
        integration: override the cable's ``useReducedOrderIntegration`` (default: the
            mode equal to each beam's formulation; a formulation without an Exudyn
            equivalent raises :class:`ModelError`).
        cancel_sliding_term: cancel the extra term Exudyn 1.13's ``ObjectJointSliding2D``
            puts into the cable equations (:func:`sliding_term`); only for cross-checks
            (a Python user function called at every residual evaluation).
    """
    require_exudyn()
    t_start = time.perf_counter()
    x = _interop.to_exudyn(system, state, integration=integration, sensors=True,
                           cancel_sliding=cancel_sliding_term)
    return ExudynModel(**{f.name: getattr(x, f.name) for f in dataclasses.fields(x)}, name=name,
                       setup_time_s=time.perf_counter() - t_start)


def build_m1(n_elements: int = 6, *, integration: int = 0, initial=None, **overrides) -> ExudynModel:
    """M1 in Exudyn (parameters: :data:`ancf_jax.models.m1.M1` with ``overrides``).

    ``initial``: an ancf_jax ``(system, state)`` to translate (default: built here).
    """
    system, state = initial or ancf_system("M1", n_elements, integration=integration, **overrides)
    return build_exudyn(system, state, name="M1")


def build_m2(n_elements: int = 24, *, integration: int = 0, initial=None,
             cancel_sliding_term: bool = False, **overrides) -> ExudynModel:
    """M2 in Exudyn, released from ancf_jax's static equilibrium with the trolley held
    at s₀ (:func:`ancf_jax.models.m2.m2_initial`; pass ``initial=(system, state)`` to
    reuse one, since that solve takes ~20 s). ``cancel_sliding_term``: see
    :func:`build_exudyn`."""
    system, state = initial or ancf_system("M2", n_elements, integration=integration, **overrides)
    return build_exudyn(system, state, name="M2", cancel_sliding_term=cancel_sliding_term)


def build_h1(n_elements: int = 8, *, integration: int = 0, initial=None, **overrides) -> ExudynModel:
    """H1 (very flexible pendulum, :data:`H1`) in Exudyn."""
    system, state = initial or ancf_system("H1", n_elements, integration=integration, **overrides)
    return build_exudyn(system, state, name="H1")


# ------------------------------------------------------------------ histories and outputs
@dataclasses.dataclass
class Histories:
    """State histories on an output grid, the same for both codes.

    Attributes:
        t: output times (N,).
        nodes, velocities: per beam, (N, n + 1, 4) total nodal coordinates / velocities.
        bodies, body_velocities: (N, nb, 3) poses (x, y, θ) and their rates.
        sliding: (N, ns) sliding coordinates [m]; sliding_point: (N, ns, 2) point 1
            (Exudyn: the joint's body point; ancf_jax: the beam point at s).
    """

    t: np.ndarray
    nodes: list
    velocities: list
    bodies: np.ndarray
    body_velocities: np.ndarray
    sliding: np.ndarray
    sliding_point: np.ndarray


def ancf_histories(results) -> Histories:
    """:class:`Histories` of an ancf_jax :class:`~ancf_jax.results.Results`."""
    system = results.system
    nodes = [results.nodes(name) for name in system.beam_names]
    vel = [np.stack([np.asarray(system.beam_nodes(v, b)) for v in results.v])
           for b in range(len(system.beams))]
    nb = system.n_bodies
    bodies = np.stack([results.body(nm) for nm in system.body_names], axis=1) if nb else np.zeros((len(results.t), 0, 3))
    bvel = results.v[:, : 3 * nb].reshape(len(results.t), nb, 3)
    s = np.stack([results.sliding(nm) for nm in system.sliding_names], axis=1) if system.n_sliding else np.zeros((len(results.t), 0))
    sp = (np.stack([results.sliding_point(nm) for nm in system.sliding_names], axis=1)
          if system.n_sliding else np.zeros((len(results.t), 0, 2)))
    return Histories(np.asarray(results.t), nodes, vel, bodies, bvel, s, sp)


def _element_rules(mode: int):
    (ka, na), (kb, nb) = EXUDYN_RULES[mode]
    return _rule(ka, na), _rule(kb, nb)


def _map(shape, e):
    """r = Σ S_i e_i for element coordinates e (..., 8) → (..., P, 2)."""
    pos = e[..., None, 0:2] * shape[:, 0:1] + e[..., None, 2:4] * shape[:, 1:2]
    return pos + e[..., None, 4:6] * shape[:, 2:3] + e[..., None, 6:8] * shape[:, 3:4]


def cable_energies(system, hist: Histories, modes) -> dict:
    """Energies [J] of a history, computed in NumPy with Exudyn's element definitions
    (|r'| − 1, material curvature, Exudyn's Gauss rules): the same function for both
    codes, independent of ancf_jax's JAX energy. Returns kinetic, gravity, strain and
    total, each (N,)."""
    g = np.asarray(system.gravity, float)
    n_t = len(hist.t)
    kin, pot, strain = np.zeros(n_t), np.zeros(n_t), np.zeros(n_t)
    xg, wg = _rule("gauss", 4)  # exact for the mass integrals (degree 6)
    for b, beam in enumerate(system.beams):
        (xa, wa), (xb, wb) = _element_rules(modes[b])
        sec = beam.section
        ea = float(sec.youngs_modulus) * float(sec.area)
        ei = float(sec.youngs_modulus) * float(sec.second_moment)
        rho_a = float(sec.mass_per_length)
        nodes, vel = hist.nodes[b], hist.velocities[b]
        for i, length in enumerate(np.asarray(beam.mesh.element_lengths, float)[: int(beam.mesh.n_elements)]):
            e = np.concatenate([nodes[:, i], nodes[:, i + 1]], axis=-1)
            ev = np.concatenate([vel[:, i], vel[:, i + 1]], axis=-1)
            s, _, _ = _hermite(xg, length)
            r, v = _map(s, e), _map(s, ev)
            kin += 0.5 * rho_a * length * np.einsum("p,tp->t", wg, np.sum(v * v, axis=-1))
            pot -= rho_a * length * np.einsum("p,tp->t", wg, r @ g)
            _, s1, _ = _hermite(xa, length)
            rx = _map(s1, e)
            eps = np.linalg.norm(rx, axis=-1) - 1.0
            strain += 0.5 * ea * length * np.einsum("p,tp->t", wa, eps**2)
            _, s1, s2 = _hermite(xb, length)
            rx, rxx = _map(s1, e), _map(s2, e)
            kappa = (rx[..., 0] * rxx[..., 1] - rx[..., 1] * rxx[..., 0]) / np.sum(rx * rx, axis=-1)
            strain += 0.5 * ei * length * np.einsum("p,tp->t", wb, kappa**2)
    for k in range(system.n_bodies):
        m, jz = float(system.bodies.mass[k]), float(system.bodies.inertia[k])
        bv = hist.body_velocities[:, k]
        kin += 0.5 * m * np.sum(bv[:, :2] ** 2, axis=-1) + 0.5 * jz * bv[:, 2] ** 2
        pot -= m * hist.bodies[:, k, :2] @ g
    return dict(kinetic=kin, gravity=pot, strain=strain, total=kin + pot + strain)


def model_outputs(name: str, system, hist: Histories, modes=None) -> dict:
    """The compared outputs of a reference model from its :class:`Histories`.

    M1: ``tip`` (N, 2) position of the last node, ``nodes`` (N, n + 1, 4).
    M2: ``s`` (N,), ``point1`` (N, 2) sliding point, ``cabin`` (N, 2) cabin centre.
    H1: ``tip`` (N, 2), ``energy`` (N,) total energy (:func:`cable_energies`).
    """
    if name == "M1":
        return dict(tip=hist.nodes[0][:, -1, :2], nodes=hist.nodes[0])
    if name == "M2":
        return dict(s=hist.sliding[:, 0], point1=hist.sliding_point[:, 0],
                    cabin=hist.bodies[:, system.body_names.index("cabin"), :2])
    if name == "H1":
        if modes is None:
            modes = [integration_mode(b.formulation) for b in system.beams]
        return dict(tip=hist.nodes[0][:, -1, :2], energy=cable_energies(system, hist, modes)["total"])
    raise ModelError(f"model must be one of {MODELS}, got {name!r}")


# ------------------------------------------------------------------ run
@dataclasses.dataclass
class ExudynRun:
    """Result of :func:`run`.

    Attributes:
        name: model name; t: output times (N,); outputs: :func:`model_outputs`.
        histories: the full :class:`Histories`.
        wall_time_s: SolveDynamic wall time [s]; setup_time_s: translation, Assemble and
            mass matrix [s].
        steps: time steps taken; newton_iterations: total Newton iterations;
        jacobians: Jacobian evaluations (= factorizations).
        status: "ok" or "failed"; failure_time: time of the failed step [s] or None;
        message: Exudyn's error; settings: what was used.
    """

    name: str
    t: np.ndarray
    outputs: dict
    histories: Histories
    wall_time_s: float
    setup_time_s: float
    steps: int
    newton_iterations: int
    jacobians: int
    status: str
    failure_time: float | None
    message: str
    settings: dict


LINEAR_SOLVERS = _interop.LINEAR_SOLVERS


def simulation_settings(**kwargs):
    """Exudyn SimulationSettings for a fixed-step index-3 generalized-α run
    (:func:`ancf_jax.interop.exudyn.simulation_settings`, same arguments)."""
    require_exudyn()
    return _interop.simulation_settings(**kwargs)


def run(model: ExudynModel, *, t_end: float, dt: float, output_dt: float | None = None,
        rho_inf: float = 0.9, relative_tolerance: float = 1e-8, absolute_tolerance: float = 1e-10,
        modified_newton: bool = True, max_iterations: int = 25, linear_solver: str = "EXUdense",
        discontinuous_tolerance: float = 1e-12, threads: int = 1, on_failure: str = "raise",
        verbose: int = 0, solver_type: str = "GeneralizedAlpha") -> ExudynRun:
    """Integrate an :class:`ExudynModel` with Exudyn's generalized-α (index 3), or the
    explicit solver named by ``solver_type`` (an ``exudyn.DynamicSolverType``, e.g.
    ``"ExplicitEuler"``, ``"RK44"``: constraints to the ground eliminated, Exudyn's
    default for explicit solvers; the Newton settings then do not apply).

    The step and output grid are those of :func:`ancf_jax.simulation.time_grid` for the
    same ``t_end``, ``dt``, ``output_dt`` (identical steps in both codes). A model runs
    once (Exudyn sensors accumulate); build a new one for another run.

    Newton: Exudyn stops when the residual norm falls below ``relative_tolerance``
    times the step's initial residual (or below ``absolute_tolerance``);
    ``modified_newton`` keeps the Jacobian across iterations and steps (Exudyn's
    default for time integration); ``False`` is full Newton.

    Args:
        on_failure: "raise" (RuntimeError) or "return" (histories up to the last
            output time before the failure, ``status="failed"``).
    """
    require_exudyn()
    if on_failure not in ("raise", "return"):
        raise ModelError(f"on_failure must be 'raise' or 'return', got {on_failure!r}")
    if model.used:
        raise ModelError("this Exudyn model has already been run; build a new one")
    model.used = True
    n_int, sub, h, out_dt = time_grid(t_end, dt, output_dt)
    n_steps = n_int * sub
    settings = dict(t_end=float(t_end), h=h, output_dt=out_dt, steps=n_steps, rho_inf=rho_inf,
                    relative_tolerance=relative_tolerance, absolute_tolerance=absolute_tolerance,
                    modified_newton=modified_newton, max_iterations=max_iterations,
                    linear_solver=linear_solver, discontinuous_tolerance=discontinuous_tolerance,
                    threads=threads, integration=model.integration, solver_type=solver_type)
    ss = simulation_settings(t_end=n_steps * h, h=h, n_steps=n_steps, output_dt=out_dt,
                             rho_inf=rho_inf, relative_tolerance=relative_tolerance,
                             absolute_tolerance=absolute_tolerance, modified_newton=modified_newton,
                             max_iterations=max_iterations, linear_solver=linear_solver,
                             discontinuous_tolerance=discontinuous_tolerance, threads=threads,
                             verbose=verbose)
    mbs = model.mbs
    status, message = "ok", ""
    t0 = time.perf_counter()
    try:
        ok = mbs.SolveDynamic(ss, solverType=getattr(exu.DynamicSolverType, solver_type),
                              storeSolver=True, showHints=bool(verbose))
        if not ok:
            status, message = "failed", "SolveDynamic returned False"
    except Exception as err:  # exudyn raises SolverError on failure
        status, message = "failed", str(err)
    wall = time.perf_counter() - t0
    solver = mbs.sys.get("dynamicSolver")
    it = solver.it if solver is not None else None
    failure_time = float(it.currentTime) if (status != "ok" and it is not None) else None
    if status != "ok" and on_failure == "raise":
        raise RuntimeError(f"Exudyn {model.name}: {message} (t = {failure_time})")

    t_grid = np.arange(n_int + 1) * out_dt
    s = model.sensors
    all_sensors = [k for group in s.values() for item in group
                   for k in (item if isinstance(item, list) else [item])]
    n_t = int(np.asarray(mbs.GetSensorStoredData(all_sensors[0])).shape[0])
    if status != "ok" and failure_time is not None:
        # keep the output times before the failed step
        n_t = min(n_t, int(np.floor(failure_time / out_dt - 1e-9)) + 1)
    n_t = max(1, min(n_t, n_int + 1))

    def stored(sensor):
        data = np.asarray(mbs.GetSensorStoredData(sensor))[:n_t]
        if data.shape[0] != n_t or np.max(np.abs(data[:, 0] - t_grid[:n_t])) > 1e-9 * max(1.0, t_end):
            raise RuntimeError(f"Exudyn sensor times do not match the output grid "
                               f"({data.shape[0]} rows for {n_t} output times)")
        return data[:, 1:]

    nodes = [np.stack([stored(k) for k in ks], axis=1) + ref[None]
             for ks, ref in zip(s["beam_q"], model.beam_reference)]
    vel = [np.stack([stored(k) for k in ks], axis=1) for ks in s["beam_v"]]
    nb = len(model.body_nodes)
    bodies = (np.stack([stored(k) for k in s["body_q"]], axis=1) + model.body_reference[None]
              if nb else np.zeros((n_t, 0, 3)))
    bvel = np.stack([stored(k) for k in s["body_v"]], axis=1) if nb else np.zeros((n_t, 0, 3))
    sl = (np.stack([stored(k)[:, 0] for k in s["sliding_s"]], axis=1) if model.sliders
          else np.zeros((n_t, 0)))
    sp = (np.stack([stored(k)[:, :2] for k in s["sliding_p"]], axis=1) if model.sliders
          else np.zeros((n_t, 0, 2)))
    hist = Histories(t_grid[:n_t], nodes, vel, bodies, bvel, sl, sp)
    outputs = model_outputs(model.name, model.system, hist, model.integration) if model.name in MODELS else {}
    return ExudynRun(name=model.name, t=t_grid[:n_t], outputs=outputs, histories=hist,
                     wall_time_s=wall, setup_time_s=model.setup_time_s,
                     steps=n_steps if status == "ok" else int(round((failure_time or 0.0) / h)) - 1,
                     newton_iterations=int(it.newtonStepsCount) if it is not None else -1,
                     jacobians=int(it.newtonJacobiCount) if it is not None else -1,
                     status=status, failure_time=failure_time, message=message, settings=settings)
