"""The identification loss: a model's named output against measured samples.

For parameters p (physical units, see :mod:`.parameters`) the model is run with
:func:`ancf_jax.simulation.trajectory` on its fixed step h from t0 to the last sample
time (rounded up to the step), the named output (M1: ``tip_y``, the last node's y) is
evaluated at every step, and the simulation is interpolated linearly at the
measurement times (the simulation at the data, never the data at the simulation):

    e_i(p) = y_sim(t_i; p) − y_i,     r_i = sqrt(w_i / Σw) e_i,
    loss(p) = Σ r_i² = Σ w_i e_i² / Σ w_i           [m² for a displacement]

The loss is a pure JAX function of p: ``jax.grad``, ``jax.jvp`` and ``jax.vmap`` pass
through the whole simulation (the generalized-α Newton solve is differentiated by the
implicit function theorem).

Forward or reverse mode? Gauss–Newton needs the Jacobian ∂r/∂p (n_samples × n_params);
forward mode gives it in one pass with n_params tangents, reverse mode would need one
backward pass per sample (in one pass it gives only the gradient ∂loss/∂p). Measured on
model M1 (3 elements, 2 s, h = 1 ms, 2001 samples; CPU seconds, ``python
benchmarks/identification_gradients.py --timing-only --cpu-time``): one run 0.24 s;
residuals and the full 2-parameter Jacobian by forward mode 1.41 s (5.8 runs); value
and gradient by reverse mode 1.03 s (4.2 runs); the two gradients agree to 4e-15.
Forward mode is therefore the default for the few parameters of a fit; reverse mode
(:meth:`Problem.state_gradient`) is what the initial state (as many inputs as
coordinates, one scalar loss) needs.

Compiled once: the parameters, measurement times, values and weights are traced
arguments, so one compiled program serves every iteration, every noise seed and every
data set with the same number of samples (cached in-process by structure and shapes).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from ..failures import Failure
from ..integrators.base import AbstractIntegrator
from ..outputs import POSITION_KINDS, Output, output_value
from ..simulation import DEFAULT_SOLVER, compiled, make_solver, trajectory
from ..system import State, System
from . import parameters as P
from .data import DataError, Measurements

#: output kinds that are functions of the coordinates alone (fittable; their velocities
#: and accelerations too, ``Output.derivative``)
FITTABLE_KINDS = POSITION_KINDS
#: nuisance parameters of a measurement (Eq. M of :func:`measured`), in this order
NUISANCE = ("time_offset", "offset", "gain")
#: their values when they are not fitted (and their default initial values)
NUISANCE_DEFAULT = {"time_offset": 0.0, "offset": 0.0, "gain": 1.0}
#: default bound |τ| <= this on the fitted time offset [s]
MAX_TIME_OFFSET = 0.05


def output_unit(output: Output) -> str:
    """SI unit of a fittable output's values (:attr:`~ancf_jax.outputs.Output.unit`)."""
    return output.unit


def check_output(system: System, output: Output) -> None:
    """Raise ModelError if ``output`` cannot be fitted on ``system``."""
    if output.kind not in FITTABLE_KINDS:
        raise ModelError(f"output {output.name!r} is a {output.kind} output; fits use outputs that "
                         f"depend on the positions only ({', '.join(FITTABLE_KINDS)})")


def check_nuisance(nuisance) -> tuple:
    """Nuisance parameter names (a sequence or ``"a,b"``) in :data:`NUISANCE` order;
    ModelError for an unknown or repeated name."""
    if isinstance(nuisance, str):
        nuisance = [n.strip() for n in nuisance.split(",") if n.strip()]
    bad = [n for n in nuisance if n not in NUISANCE]
    if bad:
        raise ModelError(f"unknown nuisance parameter {bad[0]!r}; known: {', '.join(NUISANCE)}")
    if len(set(nuisance)) != len(nuisance):
        raise ModelError("nuisance: a parameter is given twice")
    return tuple(n for n in NUISANCE if n in nuisance)


# ---------------------------------------------------------------------------- problem
@dataclasses.dataclass(frozen=True)
class Layout:
    """Static description of a problem's compiled program (hashable).

    Attributes:
        params: the traced parameters; output: the fitted output.
        n_steps: steps simulated (one output row per step); h: step [s]; t0: start [s].
        nuisance: names of the measurement's nuisance parameters, a subset of
            :data:`NUISANCE` in that order; their values follow the physical
            parameters in the parameter vector p.
    """

    params: tuple
    output: Output
    n_steps: int
    h: float
    t0: float
    nuisance: tuple = ()

    @property
    def grid(self) -> np.ndarray:
        """Simulation output times [s], shape (n_steps + 1,)."""
        return self.t0 + self.h * np.arange(self.n_steps + 1)


def _with_params(system: System, state: State, params, p) -> tuple[System, State]:
    for k, par in enumerate(params):
        system, state = par.apply(system, state, p[k])
    return system, state


def simulate_output(system: System, state: State, solver, layout: Layout, p):
    """(output on the simulation grid (n_steps + 1,), run succeeded) for parameters p."""
    sys, state = _with_params(system, state, layout.params, p)
    seg, loop = trajectory(sys, state, solver, t_end=layout.n_steps * layout.h, dt=layout.h,
                           output_dt=layout.h)
    y = jax.vmap(lambda q, v, a: output_value(sys, layout.output, q, v, a))(seg.q, seg.v, seg.acc)
    return y, loop.status == Failure.OK


def measured(layout: Layout, p, t, y_grid):
    """The model of the measurement at the sample times t [s] (N,):

        m_i = g · y_sim(t_i + τ) + c            (Eq. M)

    with y_sim the output on the simulation grid interpolated linearly, τ the time
    offset [s] (the record's t = 0 is the simulation's t = τ: a trigger delay), c the
    sensor offset [output unit] and g the sensor gain [-]; each is present only when
    named in ``layout.nuisance`` (else τ = 0, c = 0, g = 1, and m_i = y_sim(t_i)).
    Model times before t0 take the initial value (the system at rest before release),
    times past the grid its last value. Differentiable in τ (the slope of the linear
    interpolant), c and g."""
    k = len(layout.params)
    nz = {n: p[k + i] for i, n in enumerate(layout.nuisance)}
    y_sim = jnp.interp(t + nz.get("time_offset", 0.0), jnp.asarray(layout.grid), y_grid)
    if "gain" in nz:
        y_sim = nz["gain"] * y_sim
    if "offset" in nz:
        y_sim = y_sim + nz["offset"]
    return y_sim


def residuals(system, state, solver, layout: Layout, p, t, y, w):
    """(r, (r, y_grid, ok)): weighted residuals r_i = sqrt(w_i/Σw)(m_i − y_i), with m_i
    the model of the measurement (:func:`measured`, Eq. M)."""
    y_grid, ok = simulate_output(system, state, solver, layout, p)
    r = jnp.sqrt(w / jnp.sum(w)) * (measured(layout, p, t, y_grid) - y)
    return r, (r, y_grid, ok)


def _evaluate_one(system, state, solver, layout, p, t, y, w):
    """Residuals, forward-mode Jacobian ∂r/∂p, output curve and success flag of one member."""
    jac, (r, y_grid, ok) = jax.jacfwd(
        lambda x: residuals(system, state, solver, layout, x, t, y, w), has_aux=True)(p)
    return r, jac, y_grid, ok


def _values_one(system, state, solver, layout, p, t, y, w):
    """Residuals, output curve and success flag of one member, without derivatives."""
    r, (_, y_grid, ok) = residuals(system, state, solver, layout, p, t, y, w)
    return r, y_grid, ok


def _batched(fn):
    """``fn`` over a leading batch axis of (p, t, y, w). A single member runs the
    unbatched program: under ``vmap`` the solver's while loops and conditionals become
    selects (every member iterates until the last has converged, and the iteration
    matrix is refactored whenever any member asks for it). Measured on M1 (3 elements,
    500 steps, forward-mode Jacobian): one member alone 0.70 s, a batch of four 2.3 s
    (0.58 s per member)."""
    single = eqx.filter_jit(fn)
    many = eqx.filter_jit(lambda system, state, solver, layout, p, t, y, w: jax.vmap(
        lambda pp, tt, yy, ww: fn(system, state, solver, layout, pp, tt, yy, ww))(p, t, y, w))
    return single, many


def _loss_reverse(system, state, solver, layout, p, t, y, w):
    """(loss, ∂loss/∂p) by reverse mode, for one member (benchmarks, comparison)."""
    def loss(pp):
        r, (_, _, ok) = residuals(system, state, solver, layout, pp, t, y, w)
        return jnp.sum(r * r), ok
    (val, ok), g = jax.value_and_grad(loss, has_aux=True)(p)
    return val, g, ok


def _state_gradient(system, state, solver, layout, p, t, y, w):
    """(loss, ∂loss/∂q0, ∂loss/∂v0, ok) by reverse mode."""
    def loss(q0, v0):
        r, (_, _, ok) = residuals(system, State(q0, v0, state.t), solver, layout, p, t, y, w)
        return jnp.sum(r * r), ok
    (val, ok), (gq, gv) = jax.value_and_grad(loss, argnums=(0, 1), has_aux=True)(state.q, state.v)
    return val, gq, gv, ok


_evaluate_jit = _batched(_evaluate_one)
_values_jit = _batched(_values_one)
_reverse_jit = eqx.filter_jit(_loss_reverse)
_state_jit = eqx.filter_jit(_state_gradient)


def stack_data(datasets: Sequence[Measurements], n: Optional[int] = None):
    """(t, y, w) arrays of shape (B, n): shorter data sets are padded with zero-weight
    copies of their last sample, so data sets of any lengths share one program."""
    n = max(len(d) for d in datasets) if n is None else n
    t = np.zeros((len(datasets), n))
    y = np.zeros_like(t)
    w = np.zeros_like(t)
    for i, d in enumerate(datasets):
        k = len(d)
        t[i, :k], y[i, :k], w[i, :k] = d.t, d.y, d.w
        t[i, k:], y[i, k:] = d.t[-1], d.y[-1]
    return t, y, w


_BUILT: dict = {}


def _build(sc):
    """(system, state) of a scenario, cached in-process by file, modification time and
    overrides (building M1 costs seconds of eager JAX; systems are immutable)."""
    try:
        key = (str(sc.path), sc.path.stat().st_mtime_ns, tuple(sc.overrides))
    except (OSError, TypeError, AttributeError):
        return sc.build()
    if key not in _BUILT:
        _BUILT[key] = sc.build()
    return _BUILT[key]


class Problem:
    """A model, the parameters to identify, and the output they are fitted to.

    Attributes:
        system, state: the built model and its initial state.
        params: the identifiable parameters (:class:`~.parameters.Parameter`).
        output: the fitted named output.
        solver: a fixed-step solver instance; dt: its step h [s].
        t0, t_end: the simulated span [s] (data must lie inside it).
        name: label for reports (scenario name).
    """

    def __init__(self, system: System, state: State, params=("alpha", "beta"), output: Output | None = None,
                 *, dt: float, t_end: float, solver=DEFAULT_SOLVER, solver_options: dict | None = None,
                 name: str = "", nuisance: Sequence[str] = (), max_time_offset: float = MAX_TIME_OFFSET,
                 scenario=None):
        from ..validation import check_positive
        self.system, self.state = system, state
        if isinstance(params, (tuple, list)) and params and all(isinstance(q, P.Parameter) for q in params):
            self.params = tuple(params)  # resolved already (a refined copy)
        else:
            self.params = P.resolve(system, params, state=state, scenario=scenario)
        #: the nuisance parameters of the measurement (:func:`measured`), in NUISANCE order
        self.nuisance = check_nuisance(nuisance)
        self.max_time_offset = check_positive("max_time_offset", max_time_offset, "s")
        #: how the problem was built from a scenario (for :meth:`refined`); None otherwise
        self.recipe = None
        if output is None:
            if len(system.beam_names) != 1:
                raise ModelError("give the output to fit (the system has several beams)")
            output = Output("tip_y", "node", system.beam_names[0], "y", node=-1)
        check_output(system, output)
        self.output = output
        if isinstance(solver, str):
            solver = make_solver(solver, **(solver_options or {}))
        if not isinstance(solver, AbstractIntegrator):
            raise ModelError(f"identification needs a fixed-step solver (generalized-alpha or rk4), "
                             f"got {getattr(solver, 'name', type(solver).__name__)}")
        self.solver = solver
        self.dt = check_positive("dt", dt, "s")
        self.t0 = float(state.t)
        self.t_end = self.t0 + check_positive("t_end", t_end, "s")
        self.name = name
        self.compile_time_s = 0.0

    @classmethod
    def from_scenario(cls, source="m1", params=("alpha", "beta"), output: str | None = "tip_y", *,
                      overrides: Sequence[str] = (), elements: int | None = None,
                      t_end: float | None = None, dt: float | None = None,
                      solver_options: dict | None = None, nuisance: Sequence[str] = (),
                      max_time_offset: float = MAX_TIME_OFFSET) -> "Problem":
        """A problem on a shipped scenario (``"m1"``) or scenario file.

        Args:
            params: names of the identifiable parameters (:mod:`.parameters`).
            output: name of one of the scenario's output columns (default ``tip_y``;
                None: the scenario's only output).
            overrides: ``--set`` items (``"solver.dt=2e-3"``).
            elements: element count of the (single) beam.
            t_end: simulated span [s] (default: the scenario's ``solver.t_end``).
            dt: solver step [s] (default: the scenario's ``solver.dt``; also sets
                ``outputs.dt``, which must not be shorter).
            solver_options: solver options on top of the scenario's.
            nuisance: nuisance parameters of the measurement to fit with the physical
                ones (any of ``time_offset``, ``offset``, ``gain``; :func:`measured`).
            max_time_offset: bound |τ| on a fitted time offset [s]; the simulation runs
                this much past the last sample.
        """
        from ..scenario import load_scenario
        check_nuisance(nuisance)  # before anything is built
        extra = list(overrides)
        if dt is not None:
            from ..validation import check_positive
            dt = check_positive("dt", dt, "s")
            extra += [f"solver.dt={dt!r}", f"outputs.dt={dt!r}"]
        sc = load_scenario(source, extra)
        if elements is not None:
            if len(sc.beam_elements) != 1:
                raise ModelError(f"elements: the scenario has {len(sc.beam_elements)} beams; "
                                 "use beams.NAME.elements=N")
            sc = load_scenario(source, extra + [f"beams.{next(iter(sc.beam_elements))}.elements={int(elements)}"])
        outs = {o.name: o for o in sc.outputs}
        if output is None:
            if len(outs) != 1:
                raise ModelError(f"scenario {sc.name!r} has {len(outs)} outputs "
                                 f"({', '.join(outs) or 'none'}); name the one to fit")
            output = next(iter(outs))
        if output not in outs:
            raise ModelError(f"scenario {sc.name!r} has no output named {output!r} "
                             f"(outputs: {', '.join(outs) or 'none'})")
        run = sc.solver
        system, state = _build(sc)
        resolved = P.resolve(system, params, state=state, scenario=sc)
        if sc.initial_mode == "static" and any(p.kind in ("E", "mass") for p in resolved):
            raise ModelError(f"scenario {sc.name!r} starts from a static equilibrium, which depends on "
                             "E and the masses; only alpha and beta can be identified on it")
        problem = cls(system, state, resolved, outs[output], dt=run.dt,
                      t_end=run.t_end if t_end is None else t_end, solver=run.solver,
                      solver_options={**run.solver_options, **(solver_options or {})}, name=sc.name,
                      nuisance=nuisance, max_time_offset=max_time_offset)
        problem.recipe = dict(source=source, params=tuple(params) if not isinstance(params, str) else params,
                              output=output, overrides=tuple(overrides), solver_options=solver_options,
                              elements=dict(sc.beam_elements), t_end=run.t_end if t_end is None else t_end)
        return problem

    # ------------------------------------------------------------------ discretization
    @property
    def elements(self) -> Optional[int]:
        """Element count of the (single) beam of a scenario-built problem, else None."""
        if self.recipe is None or len(self.recipe["elements"]) != 1:
            return None
        return int(next(iter(self.recipe["elements"].values())))

    def refined(self, *, step: int = 1, mesh: int = 1) -> "Problem":
        """The same problem with the step divided by ``step`` and (scenario-built
        problems with one beam) the element count multiplied by ``mesh``."""
        if mesh == 1:
            new = Problem(self.system, self.state, self.params, self.output,
                          dt=self.dt / step, t_end=self.t_end - self.t0, solver=self.solver, name=self.name,
                          nuisance=self.nuisance, max_time_offset=self.max_time_offset)
            new.recipe = self.recipe
            return new
        if self.elements is None:
            raise ModelError("the mesh of this problem cannot be refined (it was not built from a "
                             "scenario with one beam)")
        return self._rebuilt(elements=self.elements * mesh, dt=self.dt / step)

    def _rebuilt(self, *, elements, dt, overrides: tuple = ()) -> "Problem":
        """This problem rebuilt from its scenario with another mesh, step and further overrides."""
        rc = self.recipe
        return Problem.from_scenario(rc["source"], rc["params"], rc["output"], overrides=rc["overrides"] + overrides,
                                     elements=elements, t_end=rc["t_end"], dt=dt,
                                     solver_options=rc["solver_options"], nuisance=self.nuisance,
                                     max_time_offset=self.max_time_offset)

    def reformulated(self, formulations: dict) -> "Problem":
        """The same problem (step, mesh, parameters, output) with the beams' strain
        measures replaced: ``formulations`` maps a beam name to {Formulation field:
        value} (scenario-built problems only)."""
        if self.recipe is None:
            raise ModelError("the strain measures of this problem cannot be changed (it was not built from a "
                             "scenario)")
        import json
        extra = tuple(f"beams.{b}.formulation.{k}={json.dumps(v)}" for b, f in formulations.items()
                      for k, v in f.items())
        return self._rebuilt(elements=self.elements, dt=self.dt, overrides=extra)

    # ------------------------------------------------------------------ parameters
    @property
    def names(self) -> tuple[str, ...]:
        """Names of all entries of the parameter vector: physical, then nuisance."""
        return tuple(p.name for p in self.params) + self.nuisance

    @property
    def units(self) -> tuple[str, ...]:
        unit = {"time_offset": "s", "offset": output_unit(self.output), "gain": "-"}
        return tuple(p.unit for p in self.params) + tuple(unit[n] for n in self.nuisance)

    @property
    def n_physical(self) -> int:
        """Number of physical parameters (the first entries of p)."""
        return len(self.params)

    @property
    def log_scaled(self) -> np.ndarray:
        """Which entries of p are fitted on log p (bool, (len(names),)): the positive
        physical parameters (every named kind; a scenario key whose value is > 0); the
        others (a scenario key at a value <= 0, the nuisance parameters) on p itself."""
        return np.array([p.positive for p in self.params] + [False] * len(self.nuisance))

    def values(self) -> np.ndarray:
        """The parameters' values in the built system (physical units), then the
        nuisance parameters' neutral values (τ = 0, c = 0, g = 1)."""
        return np.array([float(p.get(self.system)) for p in self.params]
                        + [NUISANCE_DEFAULT[n] for n in self.nuisance])

    def vector(self, values: dict | Sequence[float] | None = None) -> np.ndarray:
        """Physical parameter vector from a dict name → value (missing names keep the
        system's values) or a sequence in :attr:`names` order."""
        p = self.values()
        if values is None:
            return p
        if isinstance(values, dict):
            unknown = set(values) - set(self.names)
            if unknown:
                raise ModelError(f"unknown parameter(s) {sorted(unknown)}; this problem has "
                                 f"{', '.join(self.names)}")
            for k, n in enumerate(self.names):
                if n in values:
                    p[k] = float(values[n])
        else:
            arr = np.asarray(values, float).reshape(-1)
            if arr.shape != p.shape:
                raise ModelError(f"expected {len(p)} parameter values ({', '.join(self.names)}), got {arr.size}")
            p = arr.copy()
        for n, x in zip(self.names, p):
            if n in ("time_offset", "offset"):
                if not math.isfinite(x):
                    raise ModelError(f"parameter {n} must be a finite number, got {x!r}")
                if n == "time_offset" and abs(x) > self.max_time_offset:
                    raise ModelError(f"parameter time_offset must be within ±{self.max_time_offset:g} s "
                                     f"(max_time_offset), got {x!r}")
            elif n == "gain":
                if not math.isfinite(x) or x <= 0:
                    raise ModelError(f"parameter gain must be a finite number > 0, got {x!r}")
            elif not math.isfinite(x):
                raise ModelError(f"parameter {n} must be a finite number, got {x!r}")
            elif x < 0 and self.params[self.names.index(n)].positive:
                raise ModelError(f"parameter {n} must be a finite number >= 0, got {x!r}")
        return p

    # ------------------------------------------------------------------ data
    def prepare(self, data: Measurements, window: tuple | None = None) -> Measurements:
        """Data restricted to the time window and checked against the simulated span."""
        if not isinstance(data, Measurements):
            raise DataError("data must be Measurements (identification.read_csv or Measurements.from_arrays)")
        if window is not None:
            data = data.window(*window)
        elif int(np.sum(data.w > 0)) < 10:
            data = data.window(None, None)
        data.check_span(self.t0, self.t_end)
        return data

    def layout(self, datasets: Sequence[Measurements]) -> Layout:
        """The simulation needed by these data sets: up to the last sample, on the step."""
        t_last = max(float(d.t[-1]) for d in datasets)
        if "time_offset" in self.nuisance:  # the model at t + τ, |τ| <= max_time_offset
            t_last += self.max_time_offset
        n = max(1, int(math.ceil((t_last - self.t0) / self.dt - 1e-9)))
        return Layout(self.params, self.output, n, self.dt, self.t0, self.nuisance)

    def _args(self, layout, p, t, y, w):
        return (self.system, self.state, self.solver, layout, jnp.asarray(p, float), jnp.asarray(t),
                jnp.asarray(y), jnp.asarray(w))

    def _run(self, fn, args):
        exe, c = compiled(fn, *args)
        self.compile_time_s += c
        return exe(*args), c

    def _batch(self, fns, p, datasets):
        """Run a (single, batched) pair on members (rows of p × data sets, broadcast)."""
        layout = self.layout(datasets)
        t, y, w = stack_data(datasets)
        p = np.atleast_2d(np.asarray(p, float))
        b = max(len(p), len(t))
        if len(p) not in (1, b) or len(t) not in (1, b):
            raise ModelError(f"{len(p)} parameter vectors and {len(t)} data sets do not broadcast")
        if b == 1:
            out, c = self._run(fns[0], self._args(layout, p[0], t[0], y[0], w[0]))
            out = tuple(np.array(a)[None] for a in out)
        else:
            p = np.broadcast_to(p, (b, p.shape[1]))
            t, y, w = (np.broadcast_to(a, (b, a.shape[1])) for a in (t, y, w))
            out, c = self._run(fns[1], self._args(layout, p, t, y, w))
            out = tuple(np.array(a) for a in out)
        return out, layout, c

    # ------------------------------------------------------------------ evaluations
    def evaluate(self, p, datasets: Sequence[Measurements]):
        """Batched forward-mode evaluation: for members i (rows of p, or data sets)

        Returns:
            (r (B, N), J = ∂r/∂p (B, N, n_params), y on the grid (B, n_steps + 1),
            ok (B,), layout, seconds spent compiling now).
        """
        (r, jac, yg, ok), layout, c = self._batch(_evaluate_jit, p, datasets)
        return r, jac, yg, ok, layout, c

    def curves(self, p, datasets: Sequence[Measurements], program: str = "auto"):
        """(grid times, output on the grid (B, n_steps + 1), ok (B,)).

        ``program``: ``"values"`` compiles a program without derivatives (about half the
        compile time of the Jacobian program, a third of its run time); ``"jacobian"``
        reuses the fit's program (no new compilation when a fit of the same shapes runs
        or ran in this process); ``"auto"``: the Jacobian program if it is compiled
        already, else the values program.
        """
        if program not in ("auto", "values", "jacobian"):
            raise ModelError(f"program must be 'auto', 'values' or 'jacobian', got {program!r}")
        if program == "auto":
            program = "jacobian" if self._jacobian_ready(p, datasets) else "values"
        if program == "jacobian":
            _, _, yg, ok, layout, _ = self.evaluate(p, datasets)
        else:
            (_, yg, ok), layout, _ = self._batch(_values_jit, p, datasets)
        return layout.grid, yg, ok

    def _jacobian_ready(self, p, datasets) -> bool:
        """Whether the Jacobian program for these shapes is compiled in this process."""
        from ..simulation import is_compiled
        p = np.atleast_2d(np.asarray(p, float))
        t, y, w = stack_data(datasets)
        b = max(len(p), len(t))
        layout = self.layout(datasets)
        if b == 1:
            args = self._args(layout, p[0], t[0], y[0], w[0])
            fn = _evaluate_jit[0]
        else:
            args = self._args(layout, np.broadcast_to(p, (b, p.shape[1])), *(np.broadcast_to(a, (b, a.shape[1]))
                                                                            for a in (t, y, w)))
            fn = _evaluate_jit[1]
        return is_compiled(fn, *args)

    def loss_and_gradient(self, p, data: Measurements):
        """(loss [m²], ∂loss/∂p) by forward mode (Jacobian of the residuals)."""
        r, jac, _, ok, _, _ = self.evaluate(np.asarray(p, float)[None], [data])
        return float(r[0] @ r[0]), 2.0 * jac[0].T @ r[0], bool(ok[0])

    def loss_and_gradient_reverse(self, p, data: Measurements):
        """(loss [m²], ∂loss/∂p) by reverse mode (for comparison and benchmarks)."""
        layout = self.layout([data])
        t, y, w = stack_data([data])
        (val, g, ok), _ = self._run(_reverse_jit, self._args(layout, p, t[0], y[0], w[0]))
        return float(val), np.asarray(g), bool(ok)

    def state_gradient(self, p, data: Measurements):
        """(loss, ∂loss/∂q0, ∂loss/∂v0) by reverse mode: the initial state has as many
        entries as the model has coordinates, so reverse mode (one backward pass) is the
        right choice there."""
        layout = self.layout([data])
        t, y, w = stack_data([data])
        (val, gq, gv, ok), _ = self._run(_state_jit, self._args(layout, p, t[0], y[0], w[0]))
        return float(val), np.asarray(gq), np.asarray(gv)

    def loss_function(self, data: Measurements):
        """The loss as a pure JAX function of θ = log p (log-parametrised, so every
        parameter stays positive): ``f(theta) -> loss`` [m²]; jit/grad/jvp/vmap it."""
        layout = self.layout([data])
        t, y, w = (jnp.asarray(a[0]) for a in stack_data([data]))

        if not self.log_scaled.all():
            raise ModelError("loss_function works on log p of positive physical parameters; this problem "
                             "has nuisance parameters or a parameter at a value <= 0 (use evaluate)")

        def f(theta):
            r, _ = residuals(self.system, self.state, self.solver, layout, jnp.exp(theta), t, y, w)
            return jnp.sum(r * r)
        return f
