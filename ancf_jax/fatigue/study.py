"""Damage as a differentiable function of model parameters, and vmapped studies.

:func:`damage_function` composes the pure run (:func:`ancf_jax.simulation.trajectory`),
the surface-fibre stresses at the assessed points (:func:`~.analysis.fibre_stresses`)
and Dirlik's spectral damage (:func:`~.spectral.dirlik_damage`) into one JAX function
p ↦ D(p) of the parameters p (Rayleigh α, β, Young's modulus E, body masses; the names
of :func:`ancf_jax.identification.parameters.resolve`), so ``jax.jacfwd``/``jax.grad``
give ∂D/∂p through the whole simulated run (implicit differentiation of every Newton
solve) and ``jax.vmap`` gives a study over many parameter values in one compiled
program. :func:`study` does both in one call.

Damage here is Dirlik's estimate from the stress PSD of the record at t ≥ ``t_start``,
the differentiable one; rainflow counting (:func:`~.analysis.analyse`) is not a smooth
function of the parameters. Spectral methods assume a stationary Gaussian stress: on a
single transient pass they are an estimate whose difference to rainflow should be
checked on one member (``analyse(results, settings)`` with ``method="rainflow"``).

Forward mode is the natural derivative here (a handful of parameters, many damage
outputs): one jvp per parameter, no stored trajectory.
"""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path
from typing import Callable, Optional, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ModelError
from ..integrate import NO_RETRIES, RunOptions
from ..integrators.base import AbstractIntegrator
from ..simulation import DEFAULT_SOLVER, make_solver, time_grid, trajectory
from ..system import State, System
from .analysis import FatigueSettings, assessed_points, dirlik_fibres, fibre_stresses

#: a setter (system, state, p) -> (system, state) for parameters that are not named
Setter = Callable[[System, State, jnp.ndarray], tuple]


@dataclasses.dataclass
class StudyResult:
    """Damage of every member of a study.

    Attributes:
        names: parameter names, (k,).
        values: parameter values of the members, shape (B, k).
        beam: beam name of each assessed point, (P,).
        s: reference arc length of each point [m], (P,).
        damage: Dirlik damage per run of each point (larger fibre), shape (B, P).
        jacobian: ∂damage/∂p, shape (B, P, k) (None without derivatives).
        status: failure code of each member's run (0 ok, :class:`~ancf_jax.failures.Failure`).
    """

    names: tuple
    values: np.ndarray
    beam: np.ndarray
    s: np.ndarray
    damage: np.ndarray
    jacobian: Optional[np.ndarray]
    status: np.ndarray

    @property
    def max_damage(self) -> np.ndarray:
        """Largest damage of each member, shape (B,)."""
        return self.damage.max(axis=1)

    @property
    def hot_spot(self) -> list[dict]:
        """Per member: beam and arc length ``s_m`` [m] of its most damaged point."""
        i = np.argmax(self.damage, axis=1)
        return [dict(beam=str(self.beam[k]), s_m=float(self.s[k])) for k in i]

    def max_damage_gradient(self) -> np.ndarray:
        """∂(damage at each member's hot spot)/∂p, shape (B, k)."""
        if self.jacobian is None:
            raise ModelError("the study was run without derivatives (derivatives=True)")
        i = np.argmax(self.damage, axis=1)
        return self.jacobian[np.arange(len(i)), i]

    def write(self, out) -> dict:
        """Write ``study.csv`` (one row per member: the parameters, ``max_damage``,
        ``hot_beam``, ``hot_s``, ``d_max_damage_d_<name>`` per parameter when derived,
        ``status``) and ``study.json`` (the same, with damage along the points and
        units) into the directory ``out``; returns the JSON data."""
        from ..failures import Failure
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        grad = None if self.jacobian is None else self.max_damage_gradient()
        header = list(self.names) + ["max_damage", "hot_beam", "hot_s"]
        if grad is not None:
            header += [f"d_max_damage_d_{n}" for n in self.names]
        header.append("status")
        statuses = [Failure(int(c)).reason for c in self.status]
        with open(out / "study.csv", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(header)
            for b, (v, d, hs) in enumerate(zip(self.values, self.max_damage, self.hot_spot)):
                row = [repr(float(x)) for x in v] + [repr(float(d)), hs["beam"], repr(hs["s_m"])]
                if grad is not None:
                    row += [repr(float(g)) for g in grad[b]]
                w.writerow(row + [statuses[b]])
        data = dict(parameters=list(self.names), values=self.values.tolist(), method="dirlik",
                    points=dict(beam=self.beam.tolist(), s_m=self.s.tolist()),
                    damage=self.damage.tolist(), max_damage=self.max_damage.tolist(),
                    hot_spot=self.hot_spot, status=statuses,
                    units=dict(s_m="m", damage="- (per run)", max_damage="- (per run)",
                               values="SI (alpha 1/s, beta s, E Pa, mass kg)",
                               d_max_damage_d_parameters="per unit of each parameter (SI)"))
        if grad is not None:
            data["d_max_damage_d_parameters"] = grad.tolist()
        (out / "study.json").write_text(json.dumps(data, indent=2))
        return data


def damage_function(system: System, state: State, parameters, settings: FatigueSettings, *,
                    t_end: float, dt: float, output_dt: float | None = None, solver=DEFAULT_SOLVER,
                    setter: Setter | None = None, options: RunOptions = NO_RETRIES):
    """The damage of the assessed points as a pure function of parameters.

    Args:
        system: the model.
        state: its initial state.
        parameters: names (``"alpha"``, ``"beta.cable"``, ``"E"``, ``"mass.tip"``, ...;
            :func:`ancf_jax.identification.parameters.resolve`), or, with ``setter``, a
            sequence of labels for the entries of p.
        settings: the fatigue settings (points, S–N curve, correction, fibre, ``t_start``,
            ``nperseg``); ``method`` is ignored (Dirlik).
        t_end: end time [s] (a Python float, as ``dt`` and ``output_dt``: they fix shapes).
        dt: time step [s].
        output_dt: output interval [s], the sampling interval of the stress (default dt).
        solver: a fixed-step solver, by name or instance.
        setter: ``(system, state, p) -> (system, state)`` for other parameters (e.g. a
            trolley's initial speed); replaces the named ones.
        options: run options (drift tolerance, crossing location; no step retries:
            ``max_halvings`` must be 0, a failed step freezes the member).

    Returns:
        (f, names, beam, s): ``f(p)`` with p of shape (k,) returns ``(damage (P,), status)``
        (``f(p, system, state)`` for another model of the same structure); ``beam`` and
        ``s`` [m] name the P points.

    Raises:
        ModelError: unknown parameters, no points, fewer than 3 samples after ``t_start``.
    """
    from ..identification.parameters import resolve

    if isinstance(solver, str):
        solver = make_solver(solver)
    if options.max_halvings:
        raise ModelError("damage_function runs without step retries (RunOptions.max_halvings = 0)")
    names = tuple(parameters.split(",")) if isinstance(parameters, str) else tuple(parameters)
    if setter is None:
        params = resolve(system, names)
        names = tuple(p.name for p in params)

        def setter(sys, st, p):
            for k, par in enumerate(params):
                sys = par.set(sys, p[k])
            return sys, st
    if not names:
        raise ModelError("damage_function needs at least one parameter")
    n_int, _, _, out_dt = time_grid(t_end, dt, output_dt)
    times = float(state.t) + out_dt * np.arange(n_int + 1)
    rows = np.flatnonzero(times >= settings.t_start - 1e-12)
    if rows.size < 3:
        raise ModelError(f"fatigue: fewer than 3 output rows at t >= t_start = {settings.t_start:g} s")
    points = assessed_points(system, settings)
    beam = np.array([system.beam_names[b] for b, (_, _, s, _) in points.items() for _ in s])
    s = np.concatenate([s for (_, _, s, _) in points.values()])

    def f(p, sys0=system, st0=state):
        # the model enters as arguments where the caller passes them (study does: the
        # compiled program then does not hold it as constants and is shared between
        # models of one structure, also through the persistent cache)
        sys, st = setter(sys0, st0, jnp.asarray(p, float))
        seg, loop = trajectory(sys, st, solver, t_end=t_end, dt=dt, output_dt=output_dt, options=options)
        sigma = fibre_stresses(sys, seg.q[rows], points, settings)
        return jnp.max(dirlik_fibres(sigma, out_dt, settings), axis=1), loop.status

    return f, names, beam, s


def study(system: System, state: State, parameters, values, settings: FatigueSettings, *,
          t_end: float, dt: float, output_dt: float | None = None, solver=DEFAULT_SOLVER,
          derivatives: bool = True, setter: Setter | None = None,
          options: RunOptions = NO_RETRIES) -> StudyResult:
    """Damage along the beams for many parameter values, in one vmapped program (and
    with ∂damage/∂p by forward mode in the same pass when ``derivatives``).

    ``values``: shape (B, k) (or (B,) for one parameter). Other arguments as
    :func:`damage_function`. A member whose run fails has a non-zero ``status`` and its
    damage is that of its frozen state (check ``status``).
    """
    if isinstance(solver, str):
        solver = make_solver(solver)
    if not derivatives and isinstance(solver, AbstractIntegrator):
        solver = solver.forward_only()  # no implicit-derivative tracing: a smaller program
    f, names, beam, s = damage_function(system, state, parameters, settings, t_end=t_end, dt=dt,
                                        output_dt=output_dt, solver=solver, setter=setter, options=options)
    values = np.asarray(values, float)
    if values.ndim == 1:
        values = values[:, None]
    if values.ndim != 2 or values.shape[1] != len(names) or values.shape[0] < 1:
        raise ModelError(f"values must have shape (members, {len(names)}) for parameters {list(names)}, "
                         f"got {np.shape(values)}")
    if not np.all(np.isfinite(values)):
        raise ModelError("values must be finite")
    if derivatives:
        def member(p, sys, st):
            def g(x):
                d, status = f(x, sys, st)
                return d, (d, status)
            jac, (d, status) = jax.jacfwd(g, has_aux=True)(p)
            return d, jac, status
    else:
        def member(p, sys, st):
            d, status = f(p, sys, st)
            return d, None, status
    d, jac, status = eqx.filter_jit(eqx.filter_vmap(member, in_axes=(0, None, None)))(jnp.asarray(values),
                                                                                 system, state)
    return StudyResult(names, values, beam, s, np.asarray(d), None if jac is None else np.asarray(jac),
                       np.asarray(status))
