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
# # 03 — Paper example 2 (model M2): bodies sliding on a catenary cable
#
# §4.3 of Seo, Jung & Park (Table 2, Figs. 11–13), in the project's interpretation
# (`docs/models.md`): a 4.02 m steel cable (d = 3 mm, 0.148 kg) pinned at A = (0, 0) and
# B = (3.8, 0); a trolley RB1 whose centre slides on the cable without friction
# (sliding joint, Eqs. 19–21) and a cabin RB2 hanging 0.5 m below it on a revolute
# joint; α = 0.01 on the cable. The initial state is the static equilibrium with the
# trolley held at s₀ = 0.6 m; the hold is released at t = 0.
#
# The paper's conclusion (Fig. 13) is that the trajectory of the sliding point depends
# on the mesh: the element counts run here in ONE vmapped program (`simulate_batch`).
# `ANCF_JAX_QUICK=1` shortens the run and uses coarser meshes.

# %%
import os
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation
from IPython.display import HTML, display

import ancf_jax  # noqa: F401  (turns on float64)
from ancf_jax import plotting
from ancf_jax.models.m2 import M2, OUTPUTS, RUN, m2_initial
from ancf_jax.outputs import evaluate
from ancf_jax.reports import report_m2
from ancf_jax.simulation import make_solver, simulate_batch

# ancf_jax.plotting selects the non-interactive Agg backend (for the command line);
# in Jupyter, switch back to inline figures:
# %matplotlib inline
warnings.filterwarnings("ignore", message="IProgress not found")  # tqdm without ipywidgets

QUICK = os.environ.get("ANCF_JAX_QUICK", "0") == "1"
T_END = 0.6 if QUICK else RUN["t_end"]        # docs/models.md: 3 s
COUNTS = (8, 12) if QUICK else (12, 18, 24)   # the paper's Fig. 13 meshes
print({k: M2[k] for k in ("length", "span", "cable_mass", "trolley_mass", "cabin_mass", "hanger", "s0", "alpha")})
print("solver:", RUN["solver"], RUN["solver_options"], "dt =", RUN["dt"], "s")

# %% [markdown]
# ## Initial equilibrium and the batched run
#
# `m2_initial(n, pad_to=N)` solves the held static equilibrium (Newton with load
# stepping), checks that it is stable (no negative-stiffness mode), releases the hold
# and pads the cable to N element slots so that all meshes share one compiled program.

# %%
built = [m2_initial(n, pad_to=max(COUNTS)) for n in COUNTS]
results = simulate_batch([b[0] for b in built], [b[1] for b in built], t_end=T_END, dt=RUN["dt"],
                         output_dt=RUN["output_dt"], solver=make_solver(RUN["solver"], **RUN["solver_options"]),
                         progress=False)
runs = dict(zip(COUNTS, results))
ref = max(COUNTS)
rn = runs[ref]
print(f"compile {rn.compile_time_s:.1f} s, batch of {len(COUNTS)} runs {rn.info['batch_wall_time_s']:.2f} s")
for n, r in runs.items():
    s = r.summary()
    print(f"{n:2d} elements: {r.status}, max|Φ| = {s['max_constraint_violation']:.1e} m, "
          f"Newton iterations {s['newton_iterations']}, energy balance error {s['energy_balance_error']:.1e}")

# %% [markdown]
# `report_m2` (what `ancf-jax run m2` calls) computes the summary, including the
# distances between the point-1 trajectories of the meshes:

# %%
out_dir = Path("results") / "notebook_m2"
summary = report_m2(runs, out_dir, figures=False)
for pair, d in summary["point1_distances"].items():
    print(f"point 1, {pair.replace('_vs_', ' vs ')} elements: max distance {1e3 * d['max_m']:.1f} mm, "
          f"up to 1.3 s {1e3 * d['max_before_1_3s_m']:.1f} mm")

# %% [markdown]
# ## Fig. 12 — cable and bodies

# %%
plotting.deformed_shapes(rn, "cable", np.linspace(0.0, float(rn.t[-1]), 7), bodies=("trolley", "cabin"),
                         title=f"M2: cable and bodies, {ref} elements (Fig. 12)")
plt.show()

# %% [markdown]
# ## Fig. 13 — trajectory of point 1 (the sliding point on the cable) for each mesh

# %%
cols = {n: evaluate(r, OUTPUTS) for n, r in runs.items()}
plotting.trajectories({f"{n} elements": (cols[n]["point1_x"], cols[n]["point1_y"]) for n in COUNTS},
                      title="M2: trajectory of point 1 (Fig. 13)")
plt.show()

# %% [markdown]
# ## Node crossings
#
# The sliding coordinate s is one global arc length over the whole cable; the element
# that holds the trolley follows from s inside the compiled step, so crossing a node
# needs no event handling (the paper's Fig. 10 algorithm). Because ANCF is C¹, s and
# its rate are continuous at a crossing; the curvature is not, so the normal reaction
# jumps there. Dotted lines: nodes of the finest mesh.

# %%
fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True)
for n, r in runs.items():
    ax1.plot(r.t, cols[n]["s"], label=f"{n} elements")
    ax2.plot(r.t, r.sliding_reaction("slider")[:, 0], label=f"{n} elements")
    s_nodes = np.asarray(r.system.beams[0].mesh.node_arc_lengths)[: n + 1]
    s_hist = cols[n]["s"]
    crossings = [(s_node, r.t[i + 1]) for s_node in s_nodes
                 for i in np.nonzero(np.diff(np.sign(s_hist - s_node)) != 0)[0]]
    print(f"{n:2d} elements: {len(crossings)} node crossings; s from {s_hist.min():.3f} to {s_hist.max():.3f} m; "
          "first at " + (", ".join(f"t = {t:.2f} s (node s = {sn:.3f} m)" for sn, t in sorted(crossings, key=lambda c: c[1])[:3]) or "—"))
s_nodes = np.asarray(rn.system.beams[0].mesh.node_arc_lengths)[: ref + 1]
lo, hi = min(c["s"].min() for c in cols.values()), max(c["s"].max() for c in cols.values())
for sn in s_nodes[(s_nodes >= lo - 0.2) & (s_nodes <= hi + 0.2)]:
    ax1.axhline(sn, color="k", lw=0.5, ls=":")
ax1.set_ylabel("s [m]")
ax1.legend()
ax1.grid(alpha=0.3)
ax2.set_ylabel("normal reaction on RB1 [N]")
ax2.set_xlabel("time [s]")
ax2.grid(alpha=0.3)
ax1.set_title("M2: sliding coordinate and sliding-joint reaction")
plt.show()

# %% [markdown]
# ## Stress in the cable (exact curvature, Eq. 16)

# %%
s_along, sigma_along = rn.stress_along("cable", 11)
plotting.stress_map(rn.t, s_along, sigma_along, title=f"M2: bending stress along the cable, {ref} elements")
plt.show()

# %% [markdown]
# ## Animation
#
# A matplotlib `FuncAnimation` shown inline as JavaScript HTML. In full mode the GIF is
# also written with `plotting.animate` (what `ancf-jax run m2 --animate` does).

# %%
stride = max(1, len(rn.t) // (12 if QUICK else 60))
rows = list(range(0, len(rn.t), stride))
fig, ax = plt.subplots(figsize=(6, 4))
curves = [plotting.beam_curve(rn, "cable", i, 6) for i in rows]
bodies = {b: rn.body(b) for b in ("trolley", "cabin")}
allx = np.concatenate([c[0] for c in curves] + [p[:, 0] for p in bodies.values()])
ally = np.concatenate([c[1] for c in curves] + [p[:, 1] for p in bodies.values()])
ax.set_xlim(allx.min() - 0.1, allx.max() + 0.1)
ax.set_ylim(ally.min() - 0.1, ally.max() + 0.1)
ax.set_aspect("equal")
ax.grid(alpha=0.3)
(line,) = ax.plot([], [], "b-", lw=2)
(hanger,) = ax.plot([], [], "k-", lw=1)
(marks,) = ax.plot([], [], "s", color="tab:red", ms=8)
label = ax.text(0.02, 0.92, "", transform=ax.transAxes)
ax.set_title(f"M2, {ref} elements")


def update(k):
    i = rows[k]
    line.set_data(*curves[k])
    p, c = bodies["trolley"][i], bodies["cabin"][i]
    hanger.set_data([p[0], c[0]], [p[1], c[1]])
    marks.set_data([p[0], c[0]], [p[1], c[1]])
    label.set_text(f"t = {rn.t[i]:.2f} s")
    return line, hanger, marks, label


anim = animation.FuncAnimation(fig, update, frames=len(rows), interval=100, blit=True)
display(HTML(anim.to_jshtml()))
plt.close(fig)
if not QUICK:
    gif = plotting.animate(rn, "cable", out_dir / f"m2_n{ref}.gif", bodies=("trolley", "cabin"),
                           links=(("trolley", "cabin"),), title=f"M2, {ref} elements")
    print("written", gif)
