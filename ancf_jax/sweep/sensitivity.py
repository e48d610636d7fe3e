"""Variance-based (Sobol) sensitivity of scalar outputs of a sweep, with SALib.

Run the sweep with the ``saltelli`` design (``N (d + 2)`` members for ``d`` ranges and
``samples = N``; first-order and total indices, no second order), then reduce each
member's output history to a scalar (:data:`REDUCTIONS`: its maximum, minimum, maximum
magnitude or final value) and estimate S1 and ST with Saltelli's and Jansen's
estimators (``SALib.analyze.sobol``), with bootstrap confidence intervals.
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
