"""Parameter sweeps: designs over dotted scenario keys, vmapped chunks run locally or
on Ray, results in one incrementally written xarray/Zarr store that resumes, Sobol and
gradient sensitivities, VTK output.

Needs the ``sweep`` extra (``pip install 'ancf_jax[sweep]'``: xarray, zarr, meshio,
ray, SALib); they are imported only when used. Example::

    from ancf_jax.sweep import run_sweep
    ds = run_sweep("m1", ["beams.beam.alpha=0.01:0.1", "bodies.tip.mass=[0.01, 0.02]"],
                   design="grid", levels=3, out="m1.zarr",
                   overrides=["solver.t_end=0.1"])
    ds["tip_y"].sel(time=0.1)

The layer imports :mod:`ancf_jax.simulation` and :mod:`ancf_jax.scenario`, never the
reverse.
"""

from .design import DESIGNS, Param, SweepError, make_design, parse_param
from .runner import ChunkTask, Plan, SweepDefinition, plan, run_chunk, run_sweep

__all__ = ["DESIGNS", "Param", "SweepError", "make_design", "parse_param", "ChunkTask", "Plan",
           "SweepDefinition", "plan", "run_chunk", "run_sweep"]
