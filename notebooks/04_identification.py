# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.7
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 04 — Identifying the damping α, β from measured tip displacement
#
# The design card: "gradients enable damping parameter identification from experimental
# data". Here the "measurements" are synthetic: model M1 (the paper's cantilever with a
# tip body) simulated with α = 0.02 1/s, β = 0, sampled and, in the second part, with
# 1 mm of Gaussian noise added. The fit is Levenberg–Marquardt on log-parameters, with
# the Jacobian of the simulated tip displacement at the sample times computed exactly by
# forward-mode autodiff through the whole simulation (`docs/identification.md`).
#
# The same from the command line:
#
#     ancf-jax synth m1 --alpha 0.02 --beta 0 --noise 1e-3 --rate 1000 --seed 1 --out data.csv
#     ancf-jax fit m1 --data data.csv --params alpha,beta --out results/m1-fit
#
# `ANCF_JAX_QUICK=1` shortens the span and coarsens the mesh (to the problem of
# `tests/test_identification.py`).

# %%
import os
import warnings

import matplotlib.pyplot as plt
import numpy as np

import ancf_jax  # noqa: F401  (turns on float64)
from ancf_jax.identification import Problem, fit, fit_batch, synthesize

# %matplotlib inline
warnings.filterwarnings("ignore", message="IProgress not found")  # tqdm without ipywidgets

QUICK = os.environ.get("ANCF_JAX_QUICK", "0") == "1"
ELEMENTS = 3 if QUICK else 6
T_END = 1.0 if QUICK else 2.0       # [s]
DT = 2e-3                            # [s] solver step (also the output grid)
RATE = 500.0                         # [Hz] sample rate of the "measurements"
NOISE = 1e-4 if QUICK else 1e-3      # [m] (the short quick span needs less noise to say much)
TRUE = {"alpha": 0.02, "beta": 0.0}

# %% [markdown]
# ## 1. The problem: model, free parameters, fitted output
#
# `Problem.from_scenario` takes any shipped model or scenario file and one of its named
# outputs (M1: `tip_y`, the Y coordinate of the last node). The simulation is
# interpolated at the measurement times, never the other way round.

# %%
problem = Problem.from_scenario("m1", ("alpha", "beta"), elements=ELEMENTS, t_end=T_END, dt=DT)
# program="jacobian": simulate with the fit's compiled program (compiled here once,
# reused by every fit of one member below) instead of compiling a second, value-only one
clean, _ = synthesize(problem, TRUE, noise=0.0, rate=RATE, program="jacobian")
noisy, _ = synthesize(problem, TRUE, noise=NOISE, rate=RATE, seed=1, program="jacobian")
print(f"{len(clean.t)} samples in [{clean.t[0]:g}, {clean.t[-1]:g}] s")

fig, ax = plt.subplots(figsize=(7, 3))
ax.plot(noisy.t, noisy.y, ".", ms=2, label=f"noisy (σ = {NOISE * 1e3:g} mm)")
ax.plot(clean.t, clean.y, "-", lw=1, label="noise-free")
ax.set_xlabel("t [s]"); ax.set_ylabel("tip y [m]"); ax.legend()
plt.show()

# %% [markdown]
# ## 2. Noise-free data: α is recovered from any reasonable start
#
# Four initial guesses of α between 0.005 and 0.08 run as **one vmapped fit**
# (`fit_batch`); β is held at zero here (`free=("alpha",)`).

# %%
starts = [{"alpha": a, "beta": 0.0} for a in (0.005, 0.01, 0.04, 0.08)]
runs = fit_batch(problem, [clean], starts, free=("alpha",))
for s, r in zip(starts, runs):
    a = r.value("alpha")
    print(f"start α = {s['alpha']:<6g} -> α = {a:.10f}  (relative error {abs(a / 0.02 - 1):.1e}, "
          f"{r.iterations} iterations)")
assert all(abs(r.value("alpha") / 0.02 - 1) < 1e-4 for r in runs)

# %% [markdown]
# ## 3. Noisy data: estimates with standard errors, and whether β is determined
#
# (1 mm of noise on the full 2 s span; 0.1 mm in quick mode, whose 1 s span alone
# determines α only marginally against 1 mm.)
#
# With both α and β free, the report gives Gauss–Newton standard errors and the
# correlation at the optimum. A parameter the data cannot determine (here β: the tip
# motion of M1 is dominated by its first mode, and α and β both damp it) is reported as
# not identifiable, with its reason, instead of as a number.

# %%
result = fit(problem, noisy, {"alpha": 0.01, "beta": 1e-5})
print(result.summary())
for name in ("alpha", "beta"):
    print(f"{name}: identifiable = {result.identifiable(name)} — {result.identifiability(name)}")

# %%
result.figure()
plt.show()

# %% [markdown]
# ## 4. Are the standard errors right? Scatter over noise seeds
#
# Several noise realisations fitted as one vmapped batch: the spread of the α estimates
# should match the reported standard error. (`benchmarks/identification_study.py` does
# this with 20 seeds on the full span.)

# %%
seeds = range(4 if QUICK else 12)
sets = [synthesize(problem, TRUE, noise=NOISE, rate=RATE, seed=s)[0] for s in seeds]
batch = fit_batch(problem, sets, [{"alpha": 0.01, "beta": 0.0}], free=("alpha",))
k = batch[0].names.index("alpha")
alpha = np.array([r.estimates[k] for r in batch])   # raw estimates (value() is None if undetermined)
se = np.array([r.stderr[k] for r in batch])
print(f"α estimates: mean {alpha.mean():.5f}, scatter {alpha.std(ddof=1):.5f}; "
      f"mean reported standard error {se.mean():.5f}")
print("within 3 standard errors of the true value:", np.mean(np.abs(alpha - 0.02) < 3 * se))

# %% [markdown]
# ## 5. A measured record
#
# These data were made by the fitted model itself. A measured record also carries the
# model's discretization error, an unknown trigger time, a sensor offset and gain, and
# noise that may not be white. For such a record:
#
# ```python
# problem = Problem.from_scenario("m1", ("alpha", "beta"), nuisance=("time_offset", "offset", "gain"))
# result = fit(problem, record, {"alpha": 0.01, "beta": 0.0},
#              free=("alpha", "time_offset", "offset", "gain"), noise=2e-4, discretization=True)
# ```
#
# fits the delay and the sensor's offset and gain as nuisance parameters, tests the
# residuals for whiteness and against the stated noise (the summary above already has
# the `residuals white: Ljung–Box p = …` line), and refines the step and the mesh while
# refining them would move an estimate by more than 0.3 standard errors;
# `ancf_jax.identification.bootstrap` and `profile` check the standard errors without
# linearising. The workflow and the coverage measured on foreign data are in
# `docs/identification.md` ("A measured record, end to end"); notebook 06 fits such a
# record made by Exudyn.
