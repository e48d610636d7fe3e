"""Sensitivity of scalar outputs: variance-based (Sobol, with SALib) over a sweep, and
local (gradients through the run) at chosen points.

Sobol: run the sweep with the ``saltelli`` design (``N (d + 2)`` members for ``d``
ranges and ``samples = N``; first-order and total indices, no second order), then
reduce each member's output history to a scalar (:data:`REDUCTIONS`: its maximum,
minimum, maximum magnitude or final value) and estimate S1 and ST with Saltelli's and
Jansen's estimators (``SALib.analyze.sobol``), with bootstrap confidence intervals.

Local: :func:`local_sensitivities` differentiates the same scalar with respect to the
swept keys (any scalar key of the scenario that
:mod:`ancf_jax.identification.parameters` accepts: the named kinds are traced leaves of
the built system, other keys are probed by rebuilding) at each of several points,
by forward mode (``jax.jacfwd``) through the whole run, vmapped over the points: one
compiled program, no rebuild.
"""

from __future__ import annotations

import json

import numpy as np

from ._deps import need
from .design import SweepError

REDUCTIONS = ("max", "min", "maxabs", "final")


def _problem(d: int) -> dict:
    return {"num_vars": d, "names": [f"x{i}" for i in range(d)], "bounds": [[0.0, 1.0]] * d}


def saltelli_unit(d: int, n: int, seed: int = 0) -> np.ndarray:
    """Saltelli's design in the unit cube, shape (n (d + 2), d) (SALib's Sobol sampler)."""
    need("SALib", "SALib")
    from SALib.sample import sobol as sample
    return sample.sample(_problem(d), n, calc_second_order=False, scramble=True, seed=seed)


def scalar(ds, output: str, reduce: str = "max") -> np.ndarray:
    """One number per member: ``reduce`` of ``output`` over time (NaN-aware)."""
    if output not in ds.data_vars or ds[output].dims != ("member", "time"):
        raise SweepError(f"output {output!r}: not an output of the store (accepted: "
                         f"{', '.join(k for k in ds.data_vars if ds[k].dims == ('member', 'time'))})")
    y = np.asarray(ds[output].values, float)
    if reduce == "max":
        return np.nanmax(y, axis=1)
    if reduce == "min":
        return np.nanmin(y, axis=1)
    if reduce == "maxabs":
        return np.nanmax(np.abs(y), axis=1)
    if reduce == "final":
        return y[:, -1]
    raise SweepError(f"reduce: must be one of {', '.join(REDUCTIONS)}, got {reduce!r}")


def _reduce(y, reduce: str):
    """``reduce`` of a traced output history y (n,) (as :func:`scalar`)."""
    import jax.numpy as jnp
    return {"max": jnp.max, "min": jnp.min, "maxabs": lambda a: jnp.max(jnp.abs(a)),
            "final": lambda a: a[-1]}[reduce](y)


def local_sensitivities(model, keys, points, output: str, reduce: str = "max", *,
                        overrides=(), t_end: float | None = None) -> dict:
    """Gradients of ``reduce(output)`` with respect to scenario keys at several points.

    Args:
        model: a shipped scenario name or a scenario file.
        keys: dotted scalar keys of the scenario (any that
            :mod:`ancf_jax.identification.parameters` accepts: ``beams.NAME.alpha``,
            ``bodies.NAME.mass``, ``beams.NAME.section.I``, ``gravity[1]``, ...).
        points: values of the keys, shape (m, len(keys)) (e.g. the members of a sweep,
            or the centre of its box).
        output: a named output of the scenario (a position, stress, or their
            derivatives: what :mod:`ancf_jax.identification` can fit).
        reduce: one of :data:`REDUCTIONS`.
        overrides: ``--set`` items applied to the scenario first.
        t_end: simulated span [s] (default the scenario's).

    Returns:
        ``values`` (m,), ``gradients`` {key: (m,)} [output unit / key unit] and
        ``normalized`` {key: (m,)}: (∂y/∂p)·p/y, the relative change of the output per
        relative change of the key (comparable across keys of different units).
    """
    import jax
    import jax.numpy as jnp

    from ..errors import ModelError
    from ..identification.problem import Problem, simulate_output
    from ..identification.data import Measurements
    if reduce not in REDUCTIONS:
        raise SweepError(f"reduce: must be one of {', '.join(REDUCTIONS)}, got {reduce!r}")
    keys = list(keys)
    points = np.atleast_2d(np.asarray(points, float))
    if points.shape[1] != len(keys) or not np.all(np.isfinite(points)):
        raise SweepError(f"points: finite values of shape (m, {len(keys)}) (one column per key), "
                         f"got shape {points.shape}")
    try:
        problem = Problem.from_scenario(model, keys, output, overrides=overrides, t_end=t_end)
    except ModelError as e:
        raise SweepError(str(e)) from None
    grid = problem.t0 + problem.dt * np.arange(int(round((problem.t_end - problem.t0) / problem.dt)) + 1)
    layout = problem.layout([Measurements.from_arrays(grid, np.zeros_like(grid))])

    def value(p):
        """(y, y): the reduced output twice, so that ``jacfwd(..., has_aux=True)``
        returns its value from the same traced run as its derivatives (one run in
        the compiled program, not a separate primal one)."""
        y, ok = simulate_output(problem.system, problem.state, problem.solver, layout, p)
        y = jnp.where(ok, _reduce(y, reduce), jnp.nan)
        return y, y

    f = jax.jit(jax.vmap(jax.jacfwd(value, has_aux=True)))
    jac, vals = (np.asarray(a) for a in f(jnp.asarray(points)))
    grads = {k: jac[:, i] for i, k in enumerate(keys)}
    return dict(values=vals, gradients=grads,
                normalized={k: grads[k] * points[:, i] / vals for i, k in enumerate(keys)})


def sobol_indices(ds, output: str, reduce: str = "max", *, seed: int = 0) -> dict[str, dict[str, float]]:
    """First-order and total Sobol indices of ``reduce(output)`` for each swept key,
    from a store of a ``saltelli`` sweep (every member ``ok``).

    Returns:
        {key: {"S1", "S1_conf", "ST", "ST_conf"}}.
    """
    need("SALib", "SALib")
    from SALib.analyze import sobol as analyze
    definition = json.loads(ds.attrs["sweep"])
    if definition["design"] != "saltelli":
        raise SweepError(f"sobol_indices: the store holds a {definition['design']} design "
                         f"(accepted: a sweep with --design saltelli)")
    bad = int(np.sum(np.asarray(ds["status"].values) != "ok"))
    if bad:
        raise SweepError(f"sobol_indices: {bad} member(s) are not ok (complete the sweep with --resume)")
    keys = [p["key"] for p in definition["params"]]
    y = scalar(ds, output, reduce)
    res = analyze.analyze(_problem(len(keys)), y, calc_second_order=False, seed=seed)
    return {k: {"S1": float(res["S1"][i]), "S1_conf": float(res["S1_conf"][i]), "ST": float(res["ST"][i]),
                "ST_conf": float(res["ST_conf"][i])} for i, k in enumerate(keys)}


def sobol_figure(indices: dict, path, title: str = "") -> None:
    """Bar chart of S1 and ST with their confidence intervals."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    keys = list(indices)
    x = np.arange(len(keys))
    fig, ax = plt.subplots(figsize=(1.6 + 1.4 * len(keys), 3.2))
    for off, k, label in ((-0.18, "S1", "first order S1"), (0.18, "ST", "total ST")):
        ax.bar(x + off, [indices[n][k] for n in keys], 0.36, yerr=[indices[n][k + "_conf"] for n in keys],
               capsize=3, label=label)
    ax.set_xticks(x, keys, rotation=15)
    ax.set_ylabel("Sobol index")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
