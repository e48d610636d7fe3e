# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 05 — Batching and gradients of your own model; benchmark figures
#
# What ancf_jax adds to the paper: whole simulations are JAX programs, so they
# 1. run in batches — many parameter sets or meshes in one compiled, vmapped program
#    (`simulate_batch`, or `jax.vmap` over the pure `trajectory`), and
# 2. differentiate — `jax.grad` of any functional of a trajectory. The generalized-α
#    Newton solves have a custom JVP, so the derivative is that of the converged
#    equations (implicit function theorem), not of the iterations.
#
# The example is model M1 (notebook 02); any model built with `ancf_jax.model.Model` or
# loaded from a scenario file works the same way. `ANCF_JAX_QUICK=1` shortens the runs.

# %%
import json
import os
import warnings
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image, Markdown, display

import ancf_jax  # noqa: F401  (turns on float64)
from ancf_jax.integrators.generalized_alpha import GeneralizedAlpha
from ancf_jax.models.m1 import m1_model
from ancf_jax.simulation import simulate_batch, trajectory

# ancf_jax.plotting selects the non-interactive Agg backend (for the command line);
# in Jupyter, switch back to inline figures:
# %matplotlib inline
warnings.filterwarnings("ignore", message="IProgress not found")  # tqdm without ipywidgets

QUICK = os.environ.get("ANCF_JAX_QUICK", "0") == "1"
N = 6                                   # elements
T_END = 0.1 if QUICK else 0.5           # [s]
DT = 1e-3                               # [s]

# %% [markdown]
# ## 1. `simulate_batch`: a parameter sweep in one program
#
# Systems that differ only in array data (parameter values, or meshes padded to a
# common size with `build(pad_to=...)`) batch. `simulate_batch` compiles once, runs the
# chunked time loop for all members together and returns one `Results` per member,
# with the same diagnostics and failure handling as `simulate`.

# %%
tip_masses = [0.01, 0.02, 0.04] if QUICK else list(np.linspace(0.005, 0.04, 8))
built = [m1_model(N, tip_mass=m).build() for m in tip_masses]
runs = simulate_batch([b[0] for b in built], [b[1] for b in built], t_end=T_END, dt=DT, progress=False)
print(f"{len(runs)} runs: compile {runs[0].compile_time_s:.1f} s, batch wall time "
      f"{runs[0].info['batch_wall_time_s']:.3f} s ({runs[0].wall_time_s * 1e3:.1f} ms per run)")

fig, ax = plt.subplots(figsize=(7, 3.5))
for m, r in zip(tip_masses, runs):
    ax.plot(r.t, 1e3 * r.node("beam", -1)[:, 1], label=f"{1e3 * m:.0f} g")
ax.set_xlabel("time [s]")
ax.set_ylabel("tip Y [mm]")
ax.legend(title="tip mass", fontsize=8, ncol=2)
ax.grid(alpha=0.3)
plt.show()

# %% [markdown]
# ## 2. The pure core: `trajectory` under `jax.vmap` and `jax.grad`
#
# `trajectory(system, state, solver, t_end=..., dt=...)` is a pure function: it returns
# the output rows (a `Segment`: t, q, v, λ, …) and the final loop state (with a
# `status`, 0 when ok). Make a parameter an input with `equinox.tree_at`, then compose
# JAX transformations freely. Here: the mean tip deflection over the run as a function
# of the Rayleigh coefficients p = (α, β) of Eq. 11,
#
# $$J(p) = \frac{1}{N_t}\sum_k y_{\mathrm{tip}}(t_k; p),$$
#
# with its gradient, for a batch of α values — `jax.vmap` of `jax.value_and_grad`,
# one compiled program. The batch holds α₀ ± δ as well, so the same call also gives a
# central finite difference to check the gradient against.

# %%
system, state = m1_model(N).build()
solver = GeneralizedAlpha()                         # rho_inf = 0.9, index 3
tip_y = system.beam_offset(0) + 4 * N + 1           # index of the tip node's y in q


def mean_tip_y(p):
    s = eqx.tree_at(lambda s: (s.beams[0].alpha, s.beams[0].beta), system, (p[0], p[1]))
    seg, loop = trajectory(s, state, solver, t_end=T_END, dt=DT)
    return jnp.mean(seg.q[:, tip_y]), (seg.q[:, tip_y], loop.status)


batched = eqx.filter_jit(jax.vmap(jax.value_and_grad(mean_tip_y, has_aux=True)))

alpha0, beta0, delta = 0.02, 1e-5, 2e-4
alphas = jnp.array([alpha0 - delta, alpha0, alpha0 + delta, 5.0, 20.0, 50.0])
params = jnp.stack([alphas, jnp.full_like(alphas, beta0)], axis=1)
(values, (histories, status)), grads = batched(params)
print("status of the members (0 = ok):", np.asarray(status))
for p, v, g in zip(np.asarray(params), np.asarray(values), np.asarray(grads)):
    print(f"α = {p[0]:6.4f} 1/s: J = {1e3 * v:9.5f} mm,  ∂J/∂α = {1e3 * g[0]: .5e} mm·s,  ∂J/∂β = {1e3 * g[1]: .5e} mm/s")
fd = (values[2] - values[0]) / (2 * delta)
print(f"central difference ∂J/∂α = {1e3 * float(fd): .5e} mm·s; relative difference to jax.grad "
      f"{abs(float(fd) - float(grads[1, 0])) / abs(float(grads[1, 0])):.1e}")

# %%
t = np.linspace(0.0, T_END, histories.shape[1])
fig, ax = plt.subplots(figsize=(7, 3.5))
for a, h in zip(np.asarray(alphas)[[1, 3, 4, 5]], np.asarray(histories)[[1, 3, 4, 5]]):
    ax.plot(t, 1e3 * h, label=f"α = {a:g} 1/s")
ax.set_xlabel("time [s]")
ax.set_ylabel("tip Y [mm]")
ax.legend(fontsize=8)
ax.grid(alpha=0.3)
ax.set_title("vmapped trajectories (from the same call as the gradients)")
plt.show()

# %% [markdown]
# Notes for your own models:
#
# * Keep shapes fixed: `t_end`, `dt`, `output_dt` are Python floats (they fix array
#   shapes); element counts differ only through padding (`build(pad_to=...)`).
# * Reverse-mode `jax.grad` needs the run without step-halving retries (the default of
#   `trajectory`: `RunOptions(max_halvings=0)`); check `loop.status` — a failed member
#   freezes its state.
# * `simulate`/`simulate_batch` compile once per model structure and reuse the program
#   in-process for runs of other lengths, and of other steps as long as the number of
#   steps per output interval stays the same (it is part of the compiled loop).
# * Parameter identification (fitting α, β, E, … to measured data) builds on this: see
#   the identification notebook when it is added.

# %% [markdown]
# ## 3. Benchmark figures
#
# `python -m benchmarks.run` measures run times, batches, gradients, compile times and
# scaling (against Exudyn where installed) into `benchmarks/results/*.json`;
# `python -m benchmarks.report` renders `benchmarks/RESULTS.md` and the figures from
# those files only. This cell shows whatever is there.

# %%
def repository_root():
    """The checkout holding benchmarks/: above the working directory or the package."""
    for start in (Path.cwd(), Path(ancf_jax.__file__).resolve().parent):
        for d in (start, *start.parents):
            if (d / "benchmarks").is_dir() and (d / "ancf_jax").is_dir():
                return d
    return None


root = repository_root()
results_dir = None if root is None else root / "benchmarks" / "results"
found = sorted(results_dir.glob("*.json")) if results_dir is not None and results_dir.is_dir() else []
if not found:
    print("No benchmark results found. Produce them with (from the repository root):\n"
          "    python -m benchmarks.run            # add --quick for a short run\n"
          "    python -m benchmarks.report")
for path in found:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        print(f"{path.name}: unreadable ({err})")
        continue
    if not isinstance(data, dict):
        print(path.name)
        continue
    stamp = data.get("stamp", data) if isinstance(data.get("stamp", data), dict) else {}
    print(f"{path.name:32s} {str(stamp.get('date', '?')):20s} quick={data.get('quick', '?')!s:5s} "
          f"jax {stamp.get('jax', '?')} on {stamp.get('machine', '?')}  ({data.get('command', '')})")
for png in (sorted(results_dir.glob("*.png")) if found else []):
    print(png.name)
    display(Image(filename=str(png)))
report = None if root is None else root / "benchmarks" / "RESULTS.md"
if report is not None and report.exists():
    display(Markdown(report.read_text()))
