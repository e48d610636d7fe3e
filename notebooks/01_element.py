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
# # 01 — The planar ANCF element
#
# The element of Seo, Jung & Park (§2): eight absolute nodal coordinates, cubic
# Hermite shape functions (Eqs. 1–4), the consistent mass matrix (Eq. 6), the strain
# energy (Eq. 8) from which ancf_jax derives the elastic force (Eq. 9) and the tangent
# stiffness by automatic differentiation, and two closed-form checks: the
# large-deflection elastica and the natural frequencies of a clamped-free beam.
#
# Set `ANCF_JAX_QUICK=1` for a short run (fewer loads and meshes).

# %%
import os

import jax
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np

import ancf_jax  # noqa: F401  (turns on float64)
from ancf_jax import element, mesh
from ancf_jax.element.quadrature import gauss_legendre
from ancf_jax.modal import modal_analysis
from ancf_jax.model import Model, node
from ancf_jax.section import Section
from ancf_jax.statics import solve_static

QUICK = os.environ.get("ANCF_JAX_QUICK", "0") == "1"
print("quick mode" if QUICK else "full mode", "| JAX", jax.__version__, "on", jax.default_backend())

# %% [markdown]
# ## Shape functions (Eqs. 1–4)
#
# An element of reference length $l$ has the coordinates
# $e = [r_x(0), r_y(0), r_x'(0), r_y'(0), r_x(l), r_y(l), r_x'(l), r_y'(l)]$ and
# $r(x) = S(x)\,e$ with the cubic Hermite functions $S_1 \dots S_4$ (Eq. 2).

# %%
l = 0.5  # element length [m]
x = np.linspace(0.0, l, 101)
S = np.array([np.asarray(element.shape_functions(xx, l)) for xx in x])
fig, ax = plt.subplots(figsize=(6, 3.2))
for i in range(4):
    ax.plot(x / l, S[:, i], label=f"$S_{i + 1}$")
ax.set_xlabel("ξ = x / l")
ax.set_ylabel("S(x)  [–, m]")
ax.legend()
ax.grid(alpha=0.3)
ax.set_title("Hermite shape functions of Eq. 2")
plt.show()

# %% [markdown]
# The interpolation reproduces any rigid motion exactly: nodal coordinates of a
# straight element rotated by 30° and shifted interpolate a straight, unstretched line.

# %%
def straight_element(length, angle, origin=(0.0, 0.0)):
    c, s = np.cos(angle), np.sin(angle)
    p0 = np.asarray(origin, float)
    p1 = p0 + length * np.array([c, s])
    return jnp.array([*p0, c, s, *p1, c, s])


e_rot = straight_element(l, np.radians(30.0), (0.2, -0.1))
pts = np.array([np.asarray(element.position(e_rot, xx, l)) for xx in x])
expected = np.array([0.2, -0.1]) + np.outer(x, [np.cos(np.radians(30)), np.sin(np.radians(30))])
print("max |r(x) − exact line| =", np.abs(pts - expected).max(), "m")

# %% [markdown]
# ## Consistent mass matrix (Eq. 6)
#
# $M = \rho A \int_0^l S^T S\,dx$, implemented in closed form. Gauss–Legendre with 4
# points integrates the degree-6 integrand exactly, so the two must agree to round-off;
# a rigid translation carries the element mass $\rho A\,l$.

# %%
rho_a = 0.7  # ρA [kg/m]
M = np.asarray(element.mass_matrix(l, rho_a))
xg, wg = gauss_legendre(4)
M_quad = sum(w * l * rho_a * np.asarray(element.shape_matrix(xi * l, l)).T @ np.asarray(element.shape_matrix(xi * l, l))
             for xi, w in zip(xg, wg))
translation = np.array([1.0, 0, 0, 0, 1.0, 0, 0, 0])
print("max |M − quadrature| =", np.abs(M - M_quad).max())
print("translation mass", translation @ M @ translation, "kg  vs  ρA l =", rho_a * l, "kg")
print("eigenvalues of M > 0:", bool(np.all(np.linalg.eigvalsh(M) > 0)))

# %% [markdown]
# ## Strain energy, elastic force and stiffness by autodiff (Eqs. 8–9)
#
# One function, `element.strain_energy`, defines the element. The generalized elastic
# force is $-\partial U/\partial e$ and the tangent stiffness $\partial^2 U/\partial e^2$,
# both from `jax.grad` / `jax.hessian`; nothing is derived by hand. Checks:
#
# * a rigid rotation stores no energy;
# * the force agrees with central finite differences of the energy;
# * on a straight reference with the small-strain curvature (Eq. 17) the transverse
#   block of the Hessian is the classical Euler–Bernoulli beam stiffness
#   $\frac{EI}{l^3}\begin{bmatrix}12 & 6l & -12 & 6l\\ \cdot & 4l^2 & -6l & 2l^2\\
#   \cdot & \cdot & 12 & -6l\\ \cdot & \cdot & \cdot & 4l^2\end{bmatrix}$.

# %%
EA, EI = 1.5e5, 2.0  # [N], [N m²]
e_ref = straight_element(l, 0.0)
energy = jax.jit(lambda e, f: element.strain_energy(e, e_ref, l, EA, EI, f), static_argnums=1)
force = jax.jit(lambda e, f: -jax.grad(element.strain_energy)(e, e_ref, l, EA, EI, f), static_argnums=1)
hessian = jax.jit(lambda e, f: jax.hessian(element.strain_energy)(e, e_ref, l, EA, EI, f), static_argnums=1)
exact = element.Formulation()                      # Green–Lagrange strain, exact curvature (Eq. 16)
small = element.Formulation(curvature="small_strain")  # ½ EI r''·r'' (Eq. 17)

print("U(rigid rotation by 30° and shift) =", float(energy(e_rot, exact)), "J")

rng = np.random.default_rng(0)
e = e_ref + 0.02 * jnp.asarray(rng.standard_normal(8))
h = 1e-6
fd = np.array([-(energy(e.at[i].add(h), exact) - energy(e.at[i].add(-h), exact)) / (2 * h) for i in range(8)])
print("force: max relative |autodiff − FD| =", np.abs(np.asarray(force(e, exact)) - fd).max() / np.abs(fd).max())

K = np.asarray(hessian(e_ref, small))
ll = l
K_eb = EI / ll**3 * np.array([[12, 6 * ll, -12, 6 * ll], [6 * ll, 4 * ll**2, -6 * ll, 2 * ll**2],
                               [-12, -6 * ll, 12, -6 * ll], [6 * ll, 2 * ll**2, -6 * ll, 4 * ll**2]])
transverse = [1, 3, 5, 7]  # r_y(0), r_y'(0), r_y(l), r_y'(l)
print("transverse block vs Euler–Bernoulli: max relative difference",
      np.abs(K[np.ix_(transverse, transverse)] - K_eb).max() / np.abs(K_eb).max())
print("eigenvalues of K at the reference (3 rigid modes ≈ 0):",
      np.array2string(np.linalg.eigvalsh(K), precision=3, suppress_small=True))

# %% [markdown]
# ## Large deflection: the elastica
#
# A cantilever of length $L = 1$ m, $EI = 1$ N m² (nearly inextensible: $EA = 10^7$ N)
# under a dead tip load $P$. The closed-form reference is the inextensible elastica
# $\theta'' = k\cos\theta$, $\theta(0) = 0$, $\theta'(L) = 0$ with $k = PL^2/EI$, solved by
# shooting. The static solver (Newton with load stepping) runs every mesh padded to the
# largest one, so one compiled program serves every element count and load.

# %%
from scipy.integrate import solve_ivp
from scipy.optimize import brentq


def elastica_tip(k):
    """Tip (x/L, y/L) of the inextensible elastica with PL²/EI = k (shooting)."""
    def shoot(c, full=False):
        sol = solve_ivp(lambda s, y: [y[1], k * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])],
                        (0.0, 1.0), [0.0, c, 0.0, 0.0], rtol=1e-12, atol=1e-13)
        return sol.y[:, -1] if full else sol.y[1, -1]
    c = brentq(shoot, -k - 1.0, 0.0, xtol=1e-15)
    y = shoot(c, full=True)
    return np.array([y[2], y[3]])


LOADS = (1.0, 10.0) if QUICK else (0.5, 1.0, 2.0, 5.0, 10.0)
COUNTS = (2, 4) if QUICK else (2, 4, 8, 16)
N_MAX = max(COUNTS)


def cantilever(n, k):
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), 1.0, n), Section(1e7, 1.0, 1e-7, 1.0))
    m.clamp("support", "beam", 0)
    m.point_force("load", node("beam", -1), (0.0, -k))
    return m.build(pad_to=N_MAX)


tips, shapes = {}, {}
for n in COUNTS:
    for k in LOADS:
        system, state = cantilever(n, k)
        sol = solve_static(system, state, load_steps=5)
        nodes = np.asarray(system.beam_nodes(sol.state.q, 0))[: n + 1]
        tips[n, k] = nodes[-1, :2]
        shapes[n, k] = (system, sol.state.q)

rows = []
for k in LOADS:
    ref = elastica_tip(k)
    errs = [np.linalg.norm(tips[n, k] - ref) / np.linalg.norm(ref - [1, 0]) for n in COUNTS]
    rows.append(errs)
    print(f"PL²/EI = {k:4g}: tip (x, y)/L = ({ref[0]:.5f}, {ref[1]:.5f});  relative error "
          + ", ".join(f"{n} el. {err:.1e}" for n, err in zip(COUNTS, errs)))
rates = np.log2(np.array(rows)[:, :-1] / np.array(rows)[:, 1:])
print("observed order between the two finest meshes:", np.round(rates[:, -1], 2))

# %%
fig, ax = plt.subplots(figsize=(6, 4))
n = N_MAX
for k in LOADS:
    system, q = shapes[n, k]
    b = system.beams[0]
    s = np.linspace(0.0, 1.0, 80)
    nodes = jnp.asarray(system.beam_nodes(q, 0))
    xy = np.asarray(jax.vmap(lambda ss: b.position(nodes, ss))(jnp.asarray(s)))
    ax.plot(xy[:, 0], xy[:, 1], label=f"PL²/EI = {k:g}")
    ax.plot(*elastica_tip(k), "k+", ms=10)
ax.set_aspect("equal")
ax.set_xlabel("X [m]")
ax.set_ylabel("Y [m]")
ax.grid(alpha=0.3)
ax.legend(fontsize=8)
ax.set_title(f"Elastica, {n} elements (+: closed-form tip)")
plt.show()

# %% [markdown]
# ## Natural frequencies of a clamped-free beam
#
# Modal analysis about the straight configuration (joints eliminated by a null-space
# basis of $\Phi_q$) against the Euler–Bernoulli roots of $1 + \cos\beta L\cosh\beta L = 0$,
# $\omega = (\beta L)^2 \sqrt{EI/(\rho A L^4)}$. Consistent-mass elements bound the
# frequencies from above.

# %%
def clamped_free_roots(count):
    f = lambda x: 1.0 + np.cos(x) * np.cosh(x)  # noqa: E731
    grid = np.linspace(0.5, (count + 1) * np.pi, 4000)
    v = f(grid)
    return np.array([brentq(f, grid[i], grid[i + 1], xtol=1e-14)
                     for i in range(len(grid) - 1) if v[i] * v[i + 1] < 0][:count])


ei, rho, L = 1.0, 1.0, 1.0
exact_w = clamped_free_roots(4) ** 2 * np.sqrt(ei / (rho * L**4))
for n in ((3, 6) if QUICK else (3, 6, 12)):
    m = Model(gravity=(0.0, 0.0))
    m.add_beam("beam", mesh.straight((0, 0), (1, 0), L, n), Section(1e7, 1.0, ei / 1e7, rho))
    m.clamp("support", "beam", 0)
    system, state = m.build()
    w = modal_analysis(system, state.q, n_modes=4).angular_frequencies
    print(f"{n:2d} elements: ω / ω_exact − 1 =", np.array2string(w / exact_w - 1, precision=2))
print("βL of the closed form:", np.round(clamped_free_roots(4), 5))
