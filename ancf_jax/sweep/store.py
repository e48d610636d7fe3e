"""The results store of a sweep: one xarray Dataset in a Zarr directory, written
incrementally (one region write per finished chunk) so that an interrupted sweep
resumes where it stopped.

Layout (``xarray.open_zarr(path)``):

* dimensions ``member`` (every member of the design) and ``time`` (output times [s],
  the union of the members' grids);
* one coordinate per swept key (``beams.beam.alpha``), over ``member``;
* one variable per named output of the scenario (``tip_y``), over (``member``,
  ``time``), NaN where a member has no value (after a failure, outside its span);
* ``status`` (``"ok"``, the failure's reason such as ``"newton"``, ``"invalid"`` for a
  member whose scenario is rejected, ``"error"`` for a chunk that raised; ``""``: not
  run yet), ``message``, ``failure_time`` [s];
* ``stored`` (1 once the member's results are in the store) and ``run`` (which run of
  the sweep wrote them: 0 the first, 1 the first ``--resume``, ...);
* attributes ``sweep`` (the definition, JSON) and ``runs`` (metadata of each run,
  JSON).

Only the driver process writes; members are written by index, and a member already
stored is never written again (a chunk that Ray ran twice is stored once).
"""

from __future__ import annotations

import datetime
import json
from pathlib import Path

import numpy as np

from ._deps import need
from .design import SweepError

STATUS_WIDTH = 32
MESSAGE_WIDTH = 240


def _xr():
    need("zarr")
    return need("xarray")


def _runs(ds) -> list:
    return json.loads(ds.attrs.get("runs", "[]"))


def create(path, definition: dict, values: dict[str, list], times: np.ndarray, outputs: list[str],
           chunk: int, units: dict[str, str] | None = None) -> None:
    """A new store for ``len(values[k])`` members; nothing computed yet (no chunk of
    NaNs is written to disk). ``units``: SI unit of each output (its ``units``
    attribute)."""
    xr = _xr()
    n = len(next(iter(values.values())))
    t = len(times)
    coords = {"member": np.arange(n), "time": np.asarray(times, float)}
    for key, v in values.items():
        if any(isinstance(x, (list, tuple, str, dict)) for x in v):  # vectors, names: their TOML text
            from .design import override
            arr = np.asarray([override("v", x)[2:] for x in v], dtype="<U64")
        else:
            arr = np.asarray(v)
        coords[key] = ("member", arr)
    data = {name: (("member", "time"), np.broadcast_to(np.nan, (n, t))) for name in outputs}
    data.update(status=("member", np.full(n, "", f"<U{STATUS_WIDTH}")),
                message=("member", np.full(n, "", f"<U{MESSAGE_WIDTH}")),
                failure_time=("member", np.full(n, np.nan)),
                stored=("member", np.zeros(n, np.int8)),
                run=("member", np.full(n, -1, np.int16)))
    ds = xr.Dataset(data, coords=coords,
                    attrs=dict(sweep=json.dumps(definition), runs="[]",
                               created=datetime.datetime.now(datetime.timezone.utc).isoformat()))
    ds["time"].attrs["units"] = "s"
    ds["failure_time"].attrs["units"] = "s"
    for name in outputs:
        if units and name in units:
            ds[name].attrs["units"] = units[name]
    c = max(1, min(int(chunk), n))
    enc = {name: {"chunks": (c, t)} for name in outputs}
    enc.update({k: {"chunks": (c,)} for k in ("status", "message", "failure_time", "stored", "run")})
    ds.to_zarr(str(path), mode="w-", encoding=enc, zarr_format=2)


def definition(path) -> dict:
    """The sweep definition a store was created with."""
    ds = _xr().open_zarr(str(path))
    return json.loads(ds.attrs["sweep"])


def stored(path) -> np.ndarray:
    """Boolean mask of the members already in the store."""
    ds = _xr().open_zarr(str(path))
    return np.asarray(ds["stored"].values) == 1


def next_run(path) -> int:
    """Index of the next run (0 for a new store)."""
    return len(_runs(_xr().open_zarr(str(path))))


def write(path, members, times: np.ndarray, result: dict, run: int) -> None:
    """Store the results of ``members`` (sorted member indices) from a chunk result
    (:func:`ancf_jax.sweep.runner.run_chunk`): each contiguous run of indices is one
    region write."""
    xr = _xr()
    members = np.asarray(members, int)
    pos = {m: i for i, m in enumerate(result["members"])}
    rows = np.asarray([pos[m] for m in members])
    # the chunk's time grid inside the store's time coordinate
    tcols = np.searchsorted(times, np.asarray(result["times"]) - 1e-12 * max(1.0, float(times[-1])))
    n_t = len(times)
    start = 0
    while start < len(members):
        stop = start + 1
        while stop < len(members) and members[stop] == members[stop - 1] + 1:
            stop += 1
        sel = rows[start:stop]
        data = {}
        for name, arr in result["outputs"].items():
            block = np.full((len(sel), n_t), np.nan)
            block[:, tcols] = np.asarray(arr)[sel]
            data[name] = (("member", "time"), block)
        data.update(
            status=("member", np.asarray([result["status"][i][:STATUS_WIDTH] for i in sel], f"<U{STATUS_WIDTH}")),
            message=("member", np.asarray([result["message"][i][:MESSAGE_WIDTH] for i in sel],
                                          f"<U{MESSAGE_WIDTH}")),
            failure_time=("member", np.asarray([result["failure_time"][i] for i in sel], float)),
            stored=("member", np.asarray([0 if result["status"][i] == "error" else 1 for i in sel], np.int8)),
            run=("member", np.full(len(sel), run, np.int16)))
        xr.Dataset(data).to_zarr(str(path), region={"member": slice(int(members[start]), int(members[stop - 1]) + 1)})
        start = stop


def add_run(path, meta: dict) -> None:
    """Append the metadata of a finished (or interrupted) run to the ``runs`` attribute."""
    zarr = need("zarr")
    group = zarr.open_group(str(path), mode="r+")
    runs = json.loads(group.attrs.get("runs", "[]"))
    runs.append(meta)
    group.attrs["runs"] = json.dumps(runs)
    zarr.consolidate_metadata(str(path))


def open_store(path):
    """The store as an xarray Dataset (lazy; ``xarray.open_zarr``)."""
    return _xr().open_zarr(str(path))


def to_netcdf(path, target) -> Path:
    """Export a store to one NetCDF file (loads it into memory)."""
    ds = open_store(path).load()
    ds.to_netcdf(str(target))
    return Path(target)


def check_new(path) -> None:
    if Path(path).exists():
        raise SweepError(f"--out {path}: already exists (accepted: a new path, or --resume to complete it)")
