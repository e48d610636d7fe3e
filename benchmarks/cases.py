"""Models, runs and error measures shared by the benchmark sections.

Both codes get their model from one parameter source: the ancf_jax model builders with
Exudyn's cable formulation (:func:`benchmarks.exudyn_models.exudyn_formulation`, rule 0),
translated to Exudyn by :func:`benchmarks.exudyn_models.build_exudyn`. M2's initial
state (a static solve of ~20 s) is cached on disk (``results/cache/*.npz``, not in git).

Runs write an output at every step (``output_dt = dt``): one compiled ancf_jax program
then serves every step size (the step is traced), and results of different steps are
compared on the common grid of :data:`GRID` seconds.
"""

from __future__ import annotations

import dataclasses
import os
import time

import numpy as np

from .common import RESULTS

#: comparison grid [s]: every step size used divides it
GRID = 0.01
#: accuracy tolerances of the equal-accuracy comparison (the issue's contract)
TOLERANCE = dict(M1=2e-4, M2=2e-3, H1=1e-3)
#: what the error measures
ERROR_MEASURE = dict(M1="max over t of |tip Y − reference| [m]",
                     M2="max over t of |point 1 − reference| [m]",
                     H1="max over t of |tip − reference| [m]")
NO_EXUDYN_ENV = "ANCF_BENCH_NO_EXUDYN"
CACHE = RESULTS / "cache"


def exudyn_available() -> bool:
    """Exudyn installed and not disabled by ``ANCF_BENCH_NO_EXUDYN=1`` (found without
    importing it, so asking does not load its native libraries into this process)."""
    if os.environ.get(NO_EXUDYN_ENV, "") not in ("", "0"):
        return False
    import importlib.util
    return importlib.util.find_spec("exudyn") is not None


def section_options(doc: str, argv, quick, exudyn) -> tuple[bool, bool]:
    """(quick, exudyn) of a benchmark section's ``main``: keyword arguments (from
    ``benchmarks.run``) win over the command line (``--quick``); Exudyn is used when
    installed unless ``exudyn=False``."""
    import argparse
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv or [])
    quick = args.quick if quick is None else quick
    return quick, (exudyn_available() if exudyn is None else exudyn)


def exudyn_missing_reason() -> str:
    if os.environ.get(NO_EXUDYN_ENV, "") not in ("", "0"):
        return f"Exudyn disabled ({NO_EXUDYN_ENV}=1)"
    return "Exudyn not installed (pip install 'ancf_jax[bench]')"


# ------------------------------------------------------------------ models
def formulation():
    from .exudyn_models import exudyn_formulation
    return exudyn_formulation(0)


def m1(n: int = 6, **overrides):
    """(system, state) of M1 with Exudyn's formulation."""
    from ancf_jax.models.m1 import m1_model
    return m1_model(n, formulation=formulation(), **overrides).build()


def m2(n: int = 24, *, pad_to: int | None = None, s0: float | None = None):
    """(released system, equilibrium state) of M2 with Exudyn's formulation; the static
    solution is cached in results/cache."""
    import jax.numpy as jnp

    from ancf_jax.models.m2 import M2, m2_initial, m2_model
    from ancf_jax.system import State
    s0 = M2["s0"] if s0 is None else float(s0)
    key = f"m2_n{n}_pad{pad_to or n}_s{s0:.6f}_rule1.npz"
    path = CACHE / key
    over = {} if s0 == M2["s0"] else dict(s0=s0)
    if path.exists():
        q = np.load(path)["q"]
        system, _ = m2_model(n, formulation=formulation(), hold=False, **over).build(
            pad_to=pad_to, hold=False, assemble=False)
        return system, State(jnp.asarray(q), jnp.zeros_like(jnp.asarray(q)), jnp.zeros(()))
    from ancf_jax.errors import StaticsError
    for load_steps in (20, 40):
        # m2_initial's 10 load steps stall at 8e-7 (tolerance 1e-9) for 12 elements with
        # Exudyn's formulation, or converge to another equilibrium: at s0 = 0.6215 m
        # (12 elements) one 2 m away with 87 kN joint reactions instead of 38 N, after a
        # change of rounding (2026-12-05); 20 and 40 steps reach the stable one
        try:
            system, state, _ = m2_initial(n, formulation=formulation(), pad_to=pad_to,
                                          load_steps=load_steps, **over)
            break
        except StaticsError:
            if load_steps == 40:
                raise
    CACHE.mkdir(parents=True, exist_ok=True)
    np.savez(path, q=np.asarray(state.q))
    return system, state


def h1(n: int = 16):
    """(system, state) of the flexible pendulum H1 with Exudyn's formulation."""
    from .exudyn_models import ancf_system
    return ancf_system("H1", n)


def model(name: str, n: int):
    return dict(M1=m1, M2=m2, H1=h1)[name](n)


# ------------------------------------------------------------------ outputs and errors
def ancf_output(name: str, res) -> np.ndarray:
    """The compared output of an ancf_jax Results: M1 tip Y (N,), M2 point 1 (N, 2),
    H1 tip (N, 2)."""
    system = res.system
    if name == "M1":
        n = int(system.beams[0].mesh.n_elements)
        return np.asarray(res.nodes("beam")[:, n, 1])
    if name == "M2":
        return np.asarray(res.sliding_point(system.sliding_names[0]))
    n = int(system.beams[0].mesh.n_elements)
    return np.asarray(res.nodes(system.beam_names[0])[:, n, :2])


def exudyn_output(name: str, run) -> np.ndarray:
    if name == "M1":
        return np.asarray(run.outputs["tip"][:, 1])
    if name == "M2":
        return np.asarray(run.outputs["point1"])
    return np.asarray(run.outputs["tip"])


def on_grid(t: np.ndarray, y: np.ndarray, grid: float = GRID):
    """Rows of (t, y) at multiples of ``grid`` (the steps divide it)."""
    t = np.asarray(t)
    k = np.round(t / grid)
    keep = np.abs(t - k * grid) < 1e-9
    return k[keep].astype(int), np.asarray(y)[keep]


def error(name: str, t, y, t_ref, y_ref) -> float:
    """Maximum over the common grid times of |y − y_ref| (Euclidean for points); inf if
    the run ended early."""
    k, a = on_grid(t, y)
    kr, b = on_grid(t_ref, y_ref)
    if len(k) < len(kr):
        return float("inf")
    index = {int(v): i for i, v in enumerate(k)}
    a = a[[index[int(v)] for v in kr]]
    d = a - b
    d = np.linalg.norm(d, axis=-1) if d.ndim == 2 else np.abs(d)
    return float(np.max(d))


# ------------------------------------------------------------------ runs
@dataclasses.dataclass
class Run:
    """One timed run of either code."""

    code: str
    t: np.ndarray
    y: np.ndarray
    run_s: float
    setup_s: float      # ancf_jax: compile time of this call (0 when cached); Exudyn: build
    status: str
    steps: int
    iterations: int


def chosen_settings(name: str, code: str = "ancf_jax") -> tuple[float, dict]:
    """(h [s], flat solver options) that results/single_run.json chose for ``code`` on
    model ``name`` (ancf_jax's through :func:`ancf_options`)."""
    import json
    d = json.loads((RESULTS / "single_run.json").read_text())
    chosen = next(r for r in d["rows"] if r["model"] == name)[code]["chosen"]
    return chosen["dt"], ancf_options(chosen["options"]) if code == "ancf_jax" else dict(chosen["options"])


def ancf_options(options: dict) -> dict:
    """ancf_jax's solver options as simulate takes them now: results written before
    the solver-core rewrite (issue 16) say ``dense = true`` for ``linear_solver = "dense"``."""
    options = dict(options)
    if options.pop("dense", False):
        options["linear_solver"] = "dense"
    return options


def ancf_settings(name: str) -> dict:
    """ancf_jax's own solver options per model (M2: the shipped run settings, since the
    default Newton settings fail on M2, EXUDYN.md finding 1)."""
    from ancf_jax.models.m2 import RUN as M2RUN
    return dict(M2RUN["solver_options"]) if name == "M2" else {}


def run_ancf(name, system, state, *, t_end, dt, solver="generalized-alpha", options=None,
             output_dt=None) -> Run:
    from ancf_jax.simulation import make_solver, simulate
    res = simulate(system, state, t_end=t_end, dt=dt, output_dt=dt if output_dt is None else output_dt,
                   solver=make_solver(solver, **(options or {})), on_failure="return", progress=False)
    return Run("ancf_jax", np.asarray(res.t), ancf_output(name, res), res.wall_time_s,
               res.compile_time_s, res.status, int(res.info.get("steps", 0)), int(np.sum(res.iterations)))


#: Exudyn's fastest solver choice (EXUDYN.md): modified Newton, sparse LU
EXUDYN_FAST = dict(modified_newton=True, linear_solver="EigenSparse", max_iterations=25)


def run_exudyn(name, system, state, *, t_end, dt, options=None, output_dt=None) -> Run:
    from . import exudyn_models as em
    t0 = time.perf_counter()
    mdl = em.build_exudyn(system, state, name=name)
    setup = time.perf_counter() - t0
    opts = {**EXUDYN_FAST, **(options or {})}
    r = em.run(mdl, t_end=t_end, dt=dt, output_dt=dt if output_dt is None else output_dt,
               on_failure="return", **opts)
    return Run("exudyn", np.asarray(r.t), exudyn_output(name, r), r.wall_time_s, setup, r.status,
               int(r.steps), int(r.newton_iterations))


def median(xs):
    return float(np.median(np.asarray(xs, float))) if len(xs) else float("nan")


def interleaved(functions: dict, reps: int) -> dict:
    """Call each function ``reps`` times, interleaved (a, b, a, b, …); returns the list
    of return values per name."""
    out = {k: [] for k in functions}
    for _ in range(reps):
        for k, f in functions.items():
            out[k].append(f())
    return out
