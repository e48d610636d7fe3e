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
# # 02 — Paper example 1 (model M1): cantilever with a tip body
#
# §3.3 of Seo, Jung & Park (Table 1, Figs. 4–8): a 0.402 m steel wire (d = 1 mm,
# E = 200 GPa, 0.0025 kg) clamped at one end with a 0.02 kg body fixed to the other,
# released straight from rest under gravity, Rayleigh α = 0.02. The model is
# `ancf_jax.models.m1` (parameters in `M1`); `ancf-jax run m1` writes the same figures
# from the command line.
#
# Every element count runs in ONE jit-compiled, vmapped program (`simulate_batch`,
# meshes padded to the largest count). `ANCF_JAX_QUICK=1` shortens the run.

# %%
import os
import tempfile
import warnings

import matplotlib.pyplot as plt
import numpy as np

import ancf_jax  # noqa: F401  (turns on float64)
from ancf_jax import plotting
from ancf_jax.models.m1 import M1, OUTPUTS, RUN, STRESS_ELEMENT, STRESS_FIBRE, STRESS_XI, m1_model
from ancf_jax.outputs import evaluate
from ancf_jax.reports import report_m1
from ancf_jax.simulation import simulate_batch

# ancf_jax.plotting selects the non-interactive Agg backend (for the command line);
# in Jupyter, switch back to inline figures:
# %matplotlib inline
warnings.filterwarnings("ignore", message="IProgress not found")  # tqdm without ipywidgets

QUICK = os.environ.get("ANCF_JAX_QUICK", "0") == "1"
T_END = 0.4 if QUICK else RUN["t_end"]      # the paper: 2 s
COUNTS = (3, 6) if QUICK else (3, 6, 12, 24)  # the paper: 6 elements
DT, OUTPUT_DT = RUN["dt"], 2e-3
print({k: M1[k] for k in ("length", "youngs_modulus", "beam_mass", "tip_mass", "tip_inertia", "alpha")})

# %% [markdown]
# ## Run every mesh in one batch
#
# `m1_model(n).build(pad_to=N)` gives systems of identical structure; `simulate_batch`
# compiles once and integrates them together with generalized-α (index 3, h = 1 ms).

# %%
built = [m1_model(n).build(pad_to=max(COUNTS)) for n in COUNTS]
runs = simulate_batch([b[0] for b in built], [b[1] for b in built], t_end=T_END, dt=DT,
                      output_dt=OUTPUT_DT, progress=False)
runs = dict(zip(COUNTS, runs))
r6 = runs[6]
print(f"compile {r6.compile_time_s:.1f} s, batch of {len(COUNTS)} runs {r6.info['batch_wall_time_s']:.2f} s, "
      f"{r6.info['steps']} steps each")
for n, r in runs.items():
    s = r.summary()
    print(f"{n:2d} elements: status {r.status}, max|Φ| = {s['max_constraint_violation']:.1e} m, "
          f"energy balance error {s['energy_balance_error']:.1e}")

# %% [markdown]
# The report helper writes the CSV, NPZ and `summary.json` of `ancf-jax run m1`
# (here into a temporary directory) and returns the summary:

# %%
out_dir = tempfile.mkdtemp(prefix="ancf_m1_")
summary = report_m1(r6, out_dir, figures=False)
for key in ("tip_y_min_m", "tip_y_min_time_s", "tip_y_final_m", "max_abs_sigma_e1_mid_Pa",
            "max_abs_sigma_e1_mid_small_strain_Pa", "max_abs_stress_along_beam_Pa"):
    print(f"{key:36s} {summary[key]: .6g}")

# %% [markdown]
# ## Fig. 5 — large deformation

# %%
times = np.linspace(0.0, float(r6.t[-1]), 9)
plotting.deformed_shapes(r6, "beam", times, bodies=("tip",), title="M1 large deformation (Fig. 5), 6 elements")
plt.show()

# %% [markdown]
# ## Fig. 6 — tip displacement, and convergence in the number of elements

# %%
cols = {n: evaluate(r, OUTPUTS) for n, r in runs.items()}
plotting.time_history(r6.t, {f"{n} elements": 1e3 * cols[n]["tip_y"] for n in COUNTS},
                      ylabel="Y-displacement of the tip [mm]", title="M1 tip displacement (Fig. 6)")
plt.show()

# %% [markdown]
# Differences to the finest mesh: tip Y over the run, and the bending stress at a fixed
# material point, $s = L/12$ (the midpoint of element E1 of the paper's 6 elements).
# The step study (and 24 elements at four steps) is `python -m benchmarks.m1_convergence`.

# %%
ref = max(COUNTS)
s_fixed = M1["length"] / 12
sig_fixed = {n: r.stress("beam", s_fixed, STRESS_FIBRE, "exact") for n, r in runs.items()}
print(f"reference: {ref} elements")
for n in COUNTS[:-1]:
    d_tip = np.max(np.abs(cols[n]["tip_y"] - cols[ref]["tip_y"]))
    d_sig = np.max(np.abs(sig_fixed[n] - sig_fixed[ref]))
    print(f"{n:2d} elements: max |Δ tip y| = {1e3 * d_tip:.3f} mm, max |Δ σ(L/12)| = {d_sig / 1e6:.2f} MPa")

# %% [markdown]
# ## Fig. 7 — dynamic stress at the midpoint of E1, exact vs approximate curvature
#
# $\sigma = -E\,y\,\kappa$ on the fibre $y = +0.5$ mm with the exact curvature (Eq. 16)
# and the small-strain approximation $|r''|$ (Eq. 17). The wire hardly stretches
# ($\varepsilon \sim 10^{-4}$), so the two agree closely here; for a sagging cable
# (notebook 03) the exact formula matters.

# %%
sig_exact = cols[6]["sigma_e1_mid"]
sig_approx = r6.element_stress("beam", STRESS_ELEMENT, STRESS_XI, STRESS_FIBRE, "small_strain")
plotting.time_history(r6.t, {"exact curvature (Eq. 16)": 1e-6 * sig_exact,
                             "approximate curvature (Eq. 17)": 1e-6 * sig_approx},
                      ylabel="σ at E1 midpoint, y = +0.5 mm [MPa]", title="M1 dynamic stress (Fig. 7)",
                      styles={"approximate curvature (Eq. 17)": dict(ls="--")})
plt.show()
rel = np.max(np.abs(sig_approx - sig_exact)) / np.max(np.abs(sig_exact))
print(f"max |σ_approx − σ_exact| / max |σ_exact| = {rel:.2e}")

# %% [markdown]
# ## Fig. 8 — stress along the beam over time

# %%
s_along, sigma_along = r6.stress_along("beam", 11)
plotting.stress_map(r6.t, s_along, sigma_along, title="M1 stress along the beam (Fig. 8), exact curvature")
plt.show()
i_max = np.unravel_index(np.nanargmax(np.abs(sigma_along)), sigma_along.shape)
print(f"max |σ| = {np.nanmax(np.abs(sigma_along)) / 1e6:.1f} MPa at t = {r6.t[i_max[0]]:.3f} s, "
      f"s = {s_along[i_max[1:]]:.4f} m")
