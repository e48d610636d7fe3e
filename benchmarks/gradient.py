"""Value and gradient of the damping-identification loss w.r.t. (α, β) on M1.

Loss: mean over the output times of (tip Y(α, β) − y_meas)², where y_meas is the tip
Y of M1 with the paper's α = 0.02, β = 0 (synthetic "measurement", same grid) and the
loss is evaluated at (α, β) = (0.03, 1e-6). The run is ancf_jax's pure ``trajectory``
(generalized-α, index 3, Newton solve differentiated by the implicit function theorem)
with the equal-accuracy step of M1 from ``results/single_run.json`` (else 1 ms).

Timed (compiled with ``jax.jit(...).lower().compile()``, compile time reported
separately; medians over ``reps`` rounds that run every program once, interleaved):
one forward evaluation of the loss; value and gradient by ``jax.value_and_grad``
(reverse mode); value and gradient by forward mode (one ``jax.jvp`` per parameter in
one ``vmap``, as ``ancf_jax.identification``'s Gauss–Newton fit differentiates with
``jax.jacfwd``: the cheaper mode for a few parameters); the gradient by central finite
differences (4 forward evaluations, relative step 1e-4), also used to check the AD
gradient.
Exudyn: one forward run of the same case at its equal-accuracy settings; it has no
gradients (finite differences only) and no stiffness-proportional β for the cable.

Equal accuracy for gradients too: the tangent solves of the implicit-function-theorem
derivative factor, by default, the exact Jacobian of the step residual (here, where the
iteration's Newton matrix leaves out the rate term of a β set after the build, the
matrix with it: ``GeneralizedAlpha.tangent_system``), unrefined: the row "exact". The
value and gradient are also timed with the iteration's own matrix and ``REFINEMENTS``
steps of iterative refinement; the reference gradient is the most refined one, and the
ratio at equal accuracy is that of the fastest setting whose gradient is within
``GRADIENT_TOLERANCE`` (relative, per component) of it.

    python -m benchmarks.gradient [--quick]
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from . import cases as C
from .batch import chosen_settings
from .common import write

FULL = dict(t_end=2.0, reps=7)
QUICK = dict(t_end=0.2, reps=2)
THETA0 = (0.03, 1e-6)
TRUTH = (0.02, 0.0)
FD_REL_STEP = 1e-4
#: iterative-refinement steps of the tangent solves timed (the last is the reference)
REFINEMENTS = (0, 1, 2, 4, 8)
#: the sweep's label of the default: the exact tangent matrix, unrefined
EXACT = "exact"
#: relative accuracy of each gradient component required at "equal accuracy": far below
#: what a fit needs (its standard errors are percent-level) and below the agreement
#: with central differences (their truncation and rounding errors)
GRADIENT_TOLERANCE = 1e-6


def identification_loss_available() -> bool:
    try:
        import ancf_jax.identification  # noqa: F401
    except ImportError:
        return False
    return True


def make_loss(system, state, solver, t_end, dt):
    """(loss(theta, y_meas), tip(theta)) over ``trajectory``; theta = (α, β)."""
    import equinox as eqx
    import jax.numpy as jnp

    from ancf_jax.simulation import trajectory
    n = int(system.beams[0].mesh.n_elements)
    tip_index = system.beam_offset(0) + 4 * n + 1
    # β enters after the build (as a traced parameter): the Newton matrix leaves its
    # β-rate term out (Beam.rate_stiffness off: the fastest forward run), so the tangent
    # solves factor the matrix with it (GeneralizedAlpha.tangent_system) or refine

    def tip(theta):
        s = eqx.tree_at(lambda s: (s.beams[0].alpha, s.beams[0].beta), system, (theta[0], theta[1]))
        seg, _ = trajectory(s, state, solver, t_end=t_end, dt=dt, output_dt=None)
        return seg.q[:, tip_index]

    def loss(theta, y_meas):
        return jnp.mean((tip(theta) - y_meas) ** 2)

    return loss, tip


def forward_mode(loss):
    """(value, gradient) of ``loss(theta, y)`` by forward mode: one JVP per component
    of theta, vmapped over the unit tangents (the primal run is shared)."""
    import jax
    import jax.numpy as jnp

    def value_and_grad(theta, y):
        vals, ders = jax.vmap(lambda e: jax.jvp(lambda th: loss(th, y), (theta,), (e,)))(
            jnp.eye(theta.size, dtype=theta.dtype))
        return vals[0], ders

    return value_and_grad


def _status(system, state, solver, t_end, dt, theta):
    import equinox as eqx

    from ancf_jax.simulation import trajectory
    s = eqx.tree_at(lambda s: (s.beams[0].alpha, s.beams[0].beta), system, (theta[0], theta[1]))
    _, loop = trajectory(s, state, solver, t_end=t_end, dt=dt, output_dt=None)
    return loop.status


def _timed(fn, *args, reps):
    out, times = None, []
    for _ in range(reps):
        t0 = time.perf_counter()
        out = fn(*args)
        import jax
        jax.block_until_ready(out)
        times.append(time.perf_counter() - t0)
    return out, times


def main(argv=None, *, quick=None, exudyn=None):
    import equinox as eqx
    import jax
    import jax.numpy as jnp

    from ancf_jax.simulation import make_solver
    quick, exudyn = C.section_options(__doc__, argv, quick, exudyn)
    plan = QUICK if quick else FULL
    settings = chosen_settings(quick)
    a = settings["ancf_jax"]
    system, state = C.m1(6)
    solver = make_solver("generalized-alpha", **a["options"])
    theta0 = jnp.asarray(THETA0)
    # ``trajectory`` has no step retries (reverse mode needs max_halvings = 0), unlike
    # ``simulate``: a Newton failure freezes the state for the rest of the run (and the
    # loss and its gradient become meaningless). Halve the step until both the truth
    # and theta0 run through.
    dt, tried = a["dt"], []
    while True:
        loss, tip = make_loss(system, state, solver, plan["t_end"], dt)
        status_of = jax.jit(lambda th, dt=dt: _status(system, state, solver, plan["t_end"], dt, th))
        status = [int(status_of(jnp.asarray(th))) for th in (TRUTH, THETA0)]  # one compilation
        tried.append(dict(dt=dt, status=status))
        print(f"gradient: trajectory at dt={dt:g}: status {status} (0 = ok)", flush=True)
        if all(s == 0 for s in status) or dt < 1e-5:
            break
        dt /= 2
    y_meas = jax.jit(tip)(jnp.asarray(TRUTH))

    t0 = time.perf_counter()
    fwd = jax.jit(loss).lower(theta0, y_meas).compile()
    compile_fwd = time.perf_counter() - t0
    t0 = time.perf_counter()
    vg = jax.jit(jax.value_and_grad(loss)).lower(theta0, y_meas).compile()
    compile_vg = time.perf_counter() - t0
    t0 = time.perf_counter()
    vg_fwd = jax.jit(forward_mode(loss)).lower(theta0, y_meas).compile()
    compile_vg_fwd = time.perf_counter() - t0
    print(f"gradient: compile forward {compile_fwd:.1f} s, value_and_grad {compile_vg:.1f} s, "
          f"forward mode {compile_vg_fwd:.1f} s", flush=True)
    late_beta = eqx.tree_at(lambda s: s.beams[0].beta, system, jnp.asarray(THETA0[1]))
    default_refinement = (EXACT if solver.tangent_system(late_beta) is not None
                          else solver.tangent_refinement(late_beta))
    variants = {default_refinement: (vg, compile_vg)}
    for r in REFINEMENTS:
        if r not in variants:
            loss_r, _ = make_loss(system, state, dataclasses.replace(solver, refinement=r), plan["t_end"], dt)
            t0 = time.perf_counter()
            variants[r] = (jax.jit(jax.value_and_grad(loss_r)).lower(theta0, y_meas).compile(),
                           time.perf_counter() - t0)
    # central finite differences (4 forward evaluations)
    steps = FD_REL_STEP * np.abs(np.asarray(THETA0))

    def fd():
        g = []
        for i in range(2):
            e = np.zeros(2)
            e[i] = steps[i]
            g.append((fwd(theta0 + e, y_meas) - fwd(theta0 - e, y_meas)) / (2 * steps[i]))
        return jnp.stack(g)

    # interleaved repetitions: a drift in the machine's speed affects every program alike
    t_fwd, t_fd, t_var, got, t_fm = [], [], {r: [] for r in variants}, {}, []
    for _ in range(plan["reps"]):
        value, t = _timed(fwd, theta0, y_meas, reps=1)
        t_fwd += t
        (_, grad_fm), t = _timed(vg_fwd, theta0, y_meas, reps=1)
        t_fm += t
        for r, (prog, _) in variants.items():
            got[r], t = _timed(prog, theta0, y_meas, reps=1)
            t_var[r] += t
        g_fd, t = _timed(fd, reps=1)
        t_fd += t
    value2, grad = got[default_refinement]
    t_vg = t_var[default_refinement]
    grad, g_fd = np.asarray(grad), np.asarray(g_fd)
    rel = np.abs(grad - g_fd) / np.maximum(np.abs(g_fd), 1e-300)
    out = dict(section="gradient", quick=quick, exudyn=exudyn, t_end=plan["t_end"], dt=dt, dt_tried=tried,
               trajectory_ok=all(s == 0 for s in tried[-1]["status"]),
               solver_options=a["options"], settings_source=a["source"], theta0=THETA0, truth=TRUTH,
               loss="mean over output times of (tip Y - y_meas)^2, own loss in benchmarks/gradient.py",
               identification_module_available=identification_loss_available(),
               value=float(value), value_from_value_and_grad=float(value2), gradient=grad.tolist(),
               gradient_fd=g_fd.tolist(), fd_relative_step=FD_REL_STEP, gradient_rel_difference=rel.tolist(),
               compile_forward_s=compile_fwd, compile_value_and_grad_s=compile_vg,
               forward_s=t_fwd, value_and_grad_s=t_vg, finite_differences_s=t_fd,
               median_forward_s=C.median(t_fwd), median_value_and_grad_s=C.median(t_vg),
               median_finite_differences_s=C.median(t_fd),
               ratio_value_and_grad_to_forward=C.median(t_vg) / C.median(t_fwd),
               ratio_fd_to_forward=C.median(t_fd) / C.median(t_fwd),
               compile_forward_mode_s=compile_vg_fwd, forward_mode_s=t_fm,
               median_forward_mode_s=C.median(t_fm),
               ratio_forward_mode_to_forward=C.median(t_fm) / C.median(t_fwd),
               forward_mode_rel_difference_to_reverse=float(np.max(
                   np.abs(np.asarray(grad_fm) - grad) / np.maximum(np.abs(grad), 1e-300))),
               command="python -m benchmarks.run" + (" --quick" if quick else "") + " --only gradient")
    print(f"gradient: forward {out['median_forward_s']:.3f} s, value+grad {out['median_value_and_grad_s']:.3f} s "
          f"(x{out['ratio_value_and_grad_to_forward']:.2f}), forward mode {out['median_forward_mode_s']:.3f} s "
          f"(x{out['ratio_forward_mode_to_forward']:.2f}), FD {out['median_finite_differences_s']:.3f} s; "
          f"AD vs FD rel. difference {rel.max():.1e}", flush=True)
    out.update(refinement_sweep({r: (got[r][1], t_var[r], variants[r][1]) for r in variants},
                                default_refinement, out["median_forward_s"]))
    if exudyn:
        e = settings["exudyn"]
        sys_a = C.m1(6, alpha=THETA0[0])
        runs = [C.run_exudyn("M1", *sys_a, t_end=plan["t_end"], dt=e["dt"], options=e["options"])
                for _ in range(plan["reps"])]
        out["exudyn_forward"] = dict(median_run_s=C.median([r.run_s for r in runs]),
                                     median_setup_s=C.median([r.setup_s for r in runs]),
                                     dt=e["dt"], options=e["options"],
                                     note="no gradients; beta (stiffness-proportional) not available")
    else:
        out["exudyn_missing"] = C.exudyn_missing_reason()
    return write("gradient", out)


def refinement_sweep(measured, default, forward_s):
    """Rows of the refinement sweep from ``measured[r] = (gradient, times, compile_s)``;
    the fastest setting within ``GRADIENT_TOLERANCE`` of the most refined gradient gives
    the equal-accuracy ratio."""
    rows = []
    for r in sorted(measured, key=lambda r: (r != EXACT, r if r != EXACT else 0)):
        g, times, comp = measured[r]
        rows.append(dict(refinement=r, default=r == default, gradient=np.asarray(g).tolist(),
                         compile_s=comp, median_value_and_grad_s=C.median(times),
                         ratio_to_forward=C.median(times) / forward_s))
    ref = np.asarray(rows[-1]["gradient"])
    for row in rows:
        row["rel_difference_to_reference"] = float(np.max(np.abs(np.asarray(row["gradient"]) - ref)
                                                          / np.maximum(np.abs(ref), 1e-300)))
        print(f"gradient: refinement {row['refinement']}: value+grad {row['median_value_and_grad_s']:.3f} s "
              f"(x{row['ratio_to_forward']:.2f}), relative difference to refinement {REFINEMENTS[-1]}: "
              f"{row['rel_difference_to_reference']:.1e}", flush=True)
    within = [row for row in rows[:-1] if row["rel_difference_to_reference"] <= GRADIENT_TOLERANCE]
    chosen = min(within, key=lambda row: row["median_value_and_grad_s"]) if within else None
    return dict(refinement_sweep=rows, gradient_tolerance=GRADIENT_TOLERANCE,
                chosen_refinement=None if chosen is None else chosen["refinement"],
                ratio_at_equal_accuracy=None if chosen is None else chosen["ratio_to_forward"])


if __name__ == "__main__":
    import sys
    print(main(sys.argv[1:]))
