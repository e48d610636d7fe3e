"""A validated scenario: the model, its initial state, run settings and outputs.

Obtained from :func:`~ancf_jax.scenario.load_scenario`; nothing is built until one of
:meth:`Scenario.model`, :meth:`Scenario.build`, :meth:`Scenario.simulate`,
:meth:`Scenario.equilibrium` or :meth:`Scenario.modal` is called.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Optional

import jax.numpy as jnp
import numpy as np

from ..integrate import RunOptions
from ..model import Model, build_in_equilibrium
from ..outputs import Output
from ..results import Results
from ..system import State, System
from . import schema as S
from .build import make_model, make_outputs, run_end
from .geometry import element_count


@dataclasses.dataclass(frozen=True)
class RunSettings:
    """How to run a scenario in time (the ``[solver]`` and ``[outputs]`` tables).

    Attributes:
        solver: solver name (one of :data:`ancf_jax.simulation.SOLVERS`).
        dt: step [s].
        t_end: end time [s].
        output_dt: sample interval [s] (None: every step).
        solver_options: options passed to the solver (only those given in the file).
        drift_tolerance: stop when max|Φ| exceeds this [m].
        locate_crossings: split steps at node crossings of sliding joints, slack/taut
            kinks of one-sided members and contacts, and friction reversals.
    """

    solver: str
    dt: float
    t_end: float
    output_dt: Optional[float]
    solver_options: dict
    drift_tolerance: float
    locate_crossings: bool

    def simulate_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`ancf_jax.simulation.simulate`: the solver instance
        (:func:`~ancf_jax.simulation.make_solver`) and the
        :class:`~ancf_jax.integrate.RunOptions` these settings describe."""
        from ..simulation import make_solver
        return dict(t_end=self.t_end, dt=self.dt, solver=make_solver(self.solver, **self.solver_options),
                    output_dt=self.output_dt, options=self.run_options())

    def run_options(self) -> RunOptions:
        """The :class:`~ancf_jax.integrate.RunOptions` of these settings (the others at
        their defaults)."""
        return RunOptions(drift_tolerance=self.drift_tolerance, locate_crossings=self.locate_crossings)


class Scenario:
    """A validated scenario file (see module docstring).

    Attributes:
        spec: the validated tables (:class:`~.schema.ScenarioSpec`).
        path: the scenario file.
        name: ``name`` of the file, else the file name without suffix.
        description: free text of the file.
        overrides: the ``--set`` items applied.
        beam_lengths: reference length L [m] of each beam.
        beam_elements: element count of each beam.
    """

    def __init__(self, spec: S.ScenarioSpec, *, path: Path, overrides=(), lengths=None, elements=None):
        self.spec = spec
        self.path = Path(path)
        self.name = spec.name or self.path.stem
        self.description = spec.description.strip()
        self.overrides = tuple(overrides)
        self.beam_lengths = dict(lengths or {})
        self.beam_elements = dict(elements or {n: element_count(b) for n, b in spec.beams.items()})

    def __repr__(self):
        return f"Scenario({self.name!r}, path={str(self.path)!r})"

    # ------------------------------------------------------------------ settings
    @property
    def solver(self) -> RunSettings:
        """Run settings of ``[solver]`` and ``outputs.dt``."""
        s = self.spec.solver
        table = getattr(s, S.SOLVER_TABLES[s.name])
        options = {k: v for k, v in table.model_dump().items() if v is not None}
        # a pantograph run ends one span past the evaluated ones (solver.t_end: at most)
        return RunSettings(s.name, s.dt, run_end(self.spec), self.spec.outputs.dt, options, s.drift_tolerance,
                           s.locate_crossings)

    @property
    def outputs(self) -> list[Output]:
        """The named output columns (CSV header after ``t``), in file order."""
        return make_outputs(self.spec)

    @property
    def initial_mode(self) -> str:
        """``"given"`` or ``"static"``."""
        return self.spec.initial.mode

    @property
    def statics(self) -> S.StaticsSpec:
        """Static solver settings (load_steps, tolerance)."""
        return self.spec.statics

    @property
    def modal_settings(self) -> S.ModalSpec:
        """Modal analysis settings (modes, about)."""
        return self.spec.modal

    # ------------------------------------------------------------------ building
    def model(self) -> Model:
        """A fresh :class:`~ancf_jax.model.Model` of the scenario."""
        return make_model(self.spec, str(self.path))

    def build(self, *, pad_to=None) -> tuple[System, State]:
        """``(system, initial state)``; ``pad_to`` pads beams (see
        :meth:`ancf_jax.model.Model.build`) so that systems batch under ``vmap``.

        ``initial.mode = "given"``: the state as written, assembled onto the joints.
        ``"static"``: the static equilibrium under the loads at t = 0 with every sliding
        joint held at its s₀ (:func:`~ancf_jax.model.build_in_equilibrium`), with the given
        velocities and rates (default at rest) projected onto the joints of the returned
        system, which keeps the holds of joints with ``hold = true`` only. With a
        catenary: its static equilibrium at t = 0 by the structured Newton solve
        (:func:`~ancf_jax.models.catenary.moving_equilibrium`).
        """
        model = self.model()
        if self.spec.catenary is not None:
            # structured statics from the design state; beams at rest, bodies as driven
            from ..models.catenary import moving_equilibrium
            system, guess = model.build(pad_to=pad_to, assemble=False)
            state, _ = moving_equilibrium(system, guess, load_steps=self.statics.load_steps)
            return system, state
        if self.initial_mode == "given":
            return model.build(pad_to=pad_to)
        system, state, _ = build_in_equilibrium(model, load_steps=self.statics.load_steps,
                                                tolerance=self.statics.tolerance, pad_to=pad_to,
                                                hold=None)
        return system, state

    def simulate(self, **overrides) -> Results:
        """Build and run with the file's settings (keyword arguments of
        :func:`~ancf_jax.simulation.simulate` override them)."""
        from ..simulation import simulate
        system, state = self.build()
        return simulate(system, state, **{**self.solver.simulate_kwargs(), **overrides})

    def equilibrium(self):
        """Static equilibrium under the loads at t = ``statics.time``, every sliding
        joint held.

        Returns:
            (held system, :class:`~ancf_jax.statics.StaticSolution`).
        """
        from ..statics import solve_static
        held, guess = self.model().build(hold=True)
        guess = State(guess.q, guess.v, jnp.asarray(self.statics.time, float))
        sol = solve_static(held, guess, load_steps=self.statics.load_steps,
                           tolerance=self.statics.tolerance)
        return held, sol

    def static_results(self) -> Results:
        """The static equilibrium as a one-row :class:`~ancf_jax.results.Results`,
        so that :func:`ancf_jax.outputs.evaluate` gives the output columns; reactions are
        the equilibrium multipliers."""
        held, sol = self.equilibrium()
        q = np.asarray(sol.state.q)[None]
        return Results(system=held, t=np.asarray(sol.state.t, float).reshape(1), q=q, v=np.zeros_like(q), acc=np.zeros_like(q),
                       lam=np.asarray(sol.multipliers)[None], work=np.zeros((1, 3)),
                       iterations=np.array([int(np.sum(sol.iterations))]), solver="static",
                       info=dict(load_steps=int(len(sol.load_factors))))

    def modal(self, n_modes: int | None = None):
        """Natural frequencies and modes (``[modal]``: about the initial state, or about
        the static equilibrium with the stress stiffness).

        Returns:
            (system, configuration q, :class:`~ancf_jax.modal.ModalResult`).
        """
        from ..modal import degrees_of_freedom, modal_analysis
        n = self.modal_settings.modes if n_modes is None else n_modes
        if self.modal_settings.about == "equilibrium":
            system, sol = self.equilibrium()
            q, lam = sol.state.q, sol.multipliers
        else:
            system, state = self.build()
            q, lam = state.q, None
        n = min(n, degrees_of_freedom(system))
        return system, jnp.asarray(q), modal_analysis(system, q, lam, n_modes=n)

    # ------------------------------------------------------------------ text
    def summary(self) -> str:
        """One paragraph saying what was validated (for ``ancf-jax check``)."""
        sp = self.spec

        def plural(n, word, words=None):
            return f"{n} {word if n == 1 else (words or word + 's')}"

        beams = [f"{n} ({type(b.geometry).__name__.lower().replace('throughpoints', 'through points')}, "
                 f"L = {self.beam_lengths.get(n, float('nan')):g} m, {self.beam_elements[n]} elements)"
                 for n, b in sp.beams.items()]
        bodies = [f"{n} ({b.mass:g} kg)" for n, b in sp.bodies.items()]
        joints = [f"{n} ({j.type})" for n, j in sp.joints.items()]
        loads = [f"{n} ({f.type})" for n, f in sp.loads.items()]
        moving = [f"{n} ({m.mass:g} kg on {m.beam})" for n, m in sp.moving_masses.items()]
        chains = [f"{n} ({plural(len(c.heights), 'mass', 'masses')})" for n, c in sp.chains.items()]
        s = self.solver
        sliders = any(j.type == "sliding" for j in sp.joints.values())
        parts = [f"{self.path}: valid scenario '{self.name}'"
                 + (f" ({', '.join(self.overrides)})" if self.overrides else "") + ".",
                 f"{plural(len(beams), 'beam')}{': ' + ', '.join(beams) if beams else ''};",
                 f"{plural(len(bodies), 'body', 'bodies')}{': ' + ', '.join(bodies) if bodies else ''};",
                 f"{plural(len(joints), 'joint')}{': ' + ', '.join(joints) if joints else ''};",
                 f"{plural(len(loads), 'load')}{': ' + ', '.join(loads) if loads else ''};",
                 *([f"{plural(len(moving), 'moving mass', 'moving masses')}: {', '.join(moving)};"] if moving else []),
                 *([f"{plural(len(chains), 'chain')}: {', '.join(chains)};"] if chains else []),
                 f"gravity ({sp.gravity[0]:g}, {sp.gravity[1]:g}) m/s².",
                 "Initial state: " + ("as given" if self.initial_mode == "given" else
                                      "static equilibrium under the loads at t = 0"
                                      + (", sliding joints held" if sliders else "")) + ".",
                 f"Solver {s.solver}, dt = {s.dt:g} s, t_end = {s.t_end:g} s"
                 + (f", options {s.solver_options}" if s.solver_options else "")
                 + f"; outputs every {s.output_dt if s.output_dt is not None else s.dt:g} s: "
                 + (", ".join(o.name for o in self.outputs) or "none") + "."]
        return " ".join(parts)
