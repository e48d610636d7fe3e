"""Parameter sweeps (ancf_jax.sweep): designs, the local backend and its Zarr store with
statuses and resume, the command line, the Ray backend on a local cluster (worker killed
mid-sweep), sharding across host devices.

One module, so one xdist worker (--dist loadscope) holds the Ray cluster. Every sweep
here is M1 with 3 elements over 0.02 s in chunks of 2 members: one compiled program,
shared by the local runs, the Ray workers (persistent compilation cache) and the CLI.
"""

import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

xr = pytest.importorskip("xarray")
pytest.importorskip("zarr")

from ancf_jax.cli import main  # noqa: E402
from ancf_jax.sweep import SweepError, make_design, parse_param, run_sweep  # noqa: E402
from ancf_jax.sweep.design import Param  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BASE = ["beams.beam.elements=3", "solver.t_end=0.02", "solver.dt=2e-3", "outputs.dt=2e-3"]
PARAMS = ["beams.beam.alpha=0.01:0.2", "bodies.tip.mass=[0.01, 0.02, 0.03]"]
KW = dict(design="grid", levels=2, overrides=BASE, chunk_size=2, progress=False)


# ---------------------------------------------------------------------------- designs
def test_parse_param_forms():
    assert parse_param("beams.beam.alpha=0.01:0.1") == Param("beams.beam.alpha", 0.01, 0.1)
    assert parse_param("a.b=1e-3:1:log").log
    assert parse_param("beams.beam.elements=[2, 3]").values == (2, 3)
    assert parse_param('solver.name=["rk4", "generalized-alpha"]').values == ("rk4", "generalized-alpha")


@pytest.mark.parametrize("text,words", [
    ("beams.beam.alpha", "KEY=LOW:HIGH"),
    ("beams.beam.alpha=0.2:0.1", "LOW must be < HIGH"),
    ("beams.beam.alpha=0.1:0.1", "LOW must be < HIGH"),
    ("beams.beam.alpha=0:1:log", "LOW > 0"),
    ("beams.beam.alpha=a:b", "numbers"),
    ("beams.beam.alpha=[1, ", "TOML array"),
    ("beams.beam.alpha=[]", "empty"),
])
def test_parse_param_errors_name_the_key(text, words):
    with pytest.raises(SweepError, match=words) as e:
        parse_param(text)
    assert "--param" in str(e.value) and len(str(e.value).splitlines()) == 1


def test_designs():
    a, m = Param("a", 1.0, 2.0), Param("m", values=(1, 2, 3))
    grid = make_design([a, m], "grid", levels=3)
    assert len(grid["a"]) == 9 and sorted(set(grid["a"])) == [1.0, 1.5, 2.0] and set(grid["m"]) == {1, 2, 3}
    log = make_design([Param("a", 1e-3, 1e-1, log=True)], "grid", levels=3)["a"]
    assert np.allclose(log, [1e-3, 1e-2, 1e-1])
    lhs = np.asarray(make_design([a], "lhs", samples=10, seed=1)["a"])
    assert sorted(np.floor((lhs - 1.0) * 10).astype(int)) == list(range(10))  # one per stratum
    sob = make_design([a, Param("b", 0.0, 1.0)], "sobol", samples=16, seed=0)
    assert len(sob["a"]) == 16 and all(1.0 <= x <= 2.0 for x in sob["a"])
    assert make_design([a], "random", samples=5, seed=3) == make_design([a], "random", samples=5, seed=3)
    n = make_design([Param("beams.b.elements", 2, 9)], "lhs", samples=20)["beams.b.elements"]
    assert all(isinstance(x, int) and 2 <= x <= 9 for x in n)


@pytest.mark.parametrize("argv,option", [
    (["--param", "beams.beam.alpha=0.2:0.1"], "LOW must be < HIGH"),
    (["--param", "beams.beam.alpha=0:1:log"], "LOW > 0"),
    (["--param", "beams.beam.nope=1:2"], "beams.beam.nope"),
    (["--param", "beams.beam.alpha=-1:1"], "beams.beam.alpha"),
    (["--param", "bodies.tip.mass=1:2", "--design", "lhs"], "--samples"),
    (["--param", 'joints.clamp.type=["clamp", "fixed"]'], "joints.clamp.type"),
    (["--param", "bodies.tip.mass=1:2", "--address", "127.0.0.1:1"], "--address"),
])
def test_bad_sweeps_exit_2_with_one_line_before_compiling(argv, option, tmp_path, capsys):
    out = tmp_path / "s.zarr"
    code = main(["sweep", "m1", "--design", "grid", *argv, "--out", str(out)])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and option in err, err
    assert not out.exists()


def test_shape_changing_key_is_refused():
    from ancf_jax.sweep import SweepDefinition, plan
    # a clamp of the direction only has fewer constraint equations than a full clamp
    d = SweepDefinition("m1", (Param("joints.clamp.mode", values=("full", "direction")),), design="grid",
                        overrides=tuple(BASE))
    with pytest.raises(SweepError, match="array shapes"):
        plan(d)


# ---------------------------------------------------------------------------- local backend
@pytest.fixture(scope="module")
def local_store(tmp_path_factory):
    """The grid sweep (6 members, 3 chunks), interrupted after its first chunk and
    resumed: (dataset, members of the first run, members of the resumed run)."""
    out = tmp_path_factory.mktemp("local") / "m1.zarr"
    first, second = [], []

    def stop(result):
        first.extend(result["members"])
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep("m1", PARAMS, out=out, on_chunk=stop, **KW)
    ds = run_sweep("m1", PARAMS, out=out, resume=True, on_chunk=lambda r: second.extend(r["members"]), **KW)
    return out, ds.load(), first, second


def test_store_layout(local_store):
    out, ds, _, _ = local_store
    assert ds.sizes["member"] == 6 and ds.sizes["time"] == 11
    assert np.allclose(ds["time"].values, np.linspace(0, 0.02, 11)) and ds["time"].attrs["units"] == "s"
    assert {"beams.beam.alpha", "bodies.tip.mass"} <= set(ds.coords)
    assert ds["tip_y"].dims == ("member", "time") and {"tip_x", "sigma_e1_mid"} <= set(ds.data_vars)
    assert ds["tip_y"].attrs["units"] == "m" and ds["sigma_e1_mid"].attrs["units"] == "Pa"
    assert list(ds["status"].values) == ["ok"] * 6
    definition = json.loads(ds.attrs["sweep"])
    assert definition["design"] == "grid" and [p["key"] for p in definition["params"]] == \
        ["beams.beam.alpha", "bodies.tip.mass"]
    again = xr.open_zarr(out)  # the contract: xarray.open_zarr
    assert np.array_equal(again["tip_y"].values, ds["tip_y"].values)


def test_resume_adds_only_the_missing_members(local_store):
    _, ds, first, second = local_store
    assert len(first) == 2 and sorted(first + second) == list(range(6)) and not set(first) & set(second)
    run = ds["run"].values
    assert all(run[m] == 0 for m in first) and all(run[m] == 1 for m in second)
    assert np.all(ds["stored"].values == 1)
    runs = json.loads(ds.attrs["runs"])
    assert [r["stored"] for r in runs] == [2, 4] and [r["completed"] for r in runs] == [False, True]


def test_store_equals_direct_simulate(local_store):
    from ancf_jax.outputs import evaluate
    from ancf_jax.scenario import load_scenario
    _, ds, _, _ = local_store
    for m in (0, 5):
        alpha = float(ds["beams.beam.alpha"][m])
        mass = float(ds["bodies.tip.mass"][m])
        sc = load_scenario("m1", BASE + [f"beams.beam.alpha={alpha!r}", f"bodies.tip.mass={mass!r}"])
        cols = evaluate(sc.simulate(progress=False), sc.outputs)
        for name in ("tip_x", "tip_y", "sigma_e1_mid"):
            np.testing.assert_allclose(ds[name].values[m], cols[name], rtol=1e-12,
                                       atol=1e-12 * np.max(np.abs(cols[name])))
    # the parameters matter (each member its own values)
    y = ds["tip_y"].isel(time=-1).values
    assert np.min(np.abs(np.diff(np.sort(y)))) > 1e-9


def test_element_counts_and_spans_in_one_sweep(tmp_path):
    """Members of 2 and 3 elements (padded to 3: one vmapped program per span) over spans
    of 0.012 and 0.02 s (two groups of run settings, each in chunks of its own): the
    store's time is the union of the grids, a short member is NaN after its span, and
    every member equals a direct run of its own, unpadded, scenario."""
    from ancf_jax.outputs import evaluate
    from ancf_jax.scenario import load_scenario
    chunks = []
    ds = run_sweep("m1", ["beams.beam.elements=[2, 3]", "solver.t_end=[0.012, 0.02]"], out=tmp_path / "e.zarr",
                   design="grid", overrides=BASE, chunk_size=2, progress=False, on_chunk=chunks.append).load()
    n_el, t_end = ds["beams.beam.elements"].values, ds["solver.t_end"].values
    assert list(ds["status"].values) == ["ok"] * 4 and np.all(ds["stored"].values == 1)
    assert len(chunks) == 2
    for c in chunks:  # one span per chunk, both element counts in it
        assert len(set(t_end[c["members"]])) == 1 and set(n_el[c["members"]]) == {2, 3}
        assert len(c["times"]) == round(t_end[c["members"][0]] / 2e-3) + 1
    assert np.allclose(ds["time"].values, np.linspace(0, 0.02, 11))
    tips = {}
    for m in range(4):
        sc = load_scenario("m1", BASE + [f"beams.beam.elements={int(n_el[m])}", f"solver.t_end={float(t_end[m])!r}"])
        cols = evaluate(sc.simulate(progress=False), sc.outputs)
        rows = len(cols["t"])
        assert rows == round(t_end[m] / 2e-3) + 1
        for name in ("tip_x", "tip_y", "sigma_e1_mid"):
            np.testing.assert_allclose(ds[name].values[m, :rows], cols[name], rtol=1e-12,
                                       atol=1e-12 * np.max(np.abs(cols[name])))
            assert np.all(np.isnan(ds[name].values[m, rows:]))  # beyond the member's span
        tips[int(n_el[m]), float(t_end[m])] = cols["tip_y"]
    # the element count matters (a store that mixed the meshes up would fail above)
    assert np.max(np.abs(tips[2, 0.02] - tips[3, 0.02])) > 1e-7


def test_a_chunk_that_comes_back_twice_is_stored_once(tmp_path, monkeypatch):
    """As Ray may deliver a chunk again (a retry) or first as failed: a backend whose
    every chunk comes back as ``error`` (retries exhausted), then with its results, then
    again with other numbers. Each member is stored once, with the first results."""
    from ancf_jax.sweep import backends, store
    from ancf_jax.sweep.backends import LocalBackend, failed_chunk
    sent, writes = [], []

    class Retrying(LocalBackend):
        def run(self, tasks):
            for task in tasks:
                r = next(super().run([task]))
                sent.append(r)
                yield failed_chunk(task, "RayTaskError: the worker died")
                yield r
                yield dict(r, outputs={k: v + 1.0 for k, v in r["outputs"].items()}, status=["nan"] * len(r["status"]))

    real_write = store.write

    def spy(path, members, times, result, run):
        writes.append([(m, result["status"][result["members"].index(m)]) for m in members])
        real_write(path, members, times, result, run)

    monkeypatch.setattr(backends, "get_backend", lambda name, address=None: Retrying())
    monkeypatch.setattr(store, "write", spy)
    params = [PARAMS[0], "bodies.tip.mass=[0.01, 0.02]"]
    ds = run_sweep("m1", params, out=tmp_path / "twice.zarr", **KW).load()
    assert len(sent) == 2 and list(ds["status"].values) == ["ok"] * 4 and np.all(ds["stored"].values == 1)
    stored = sorted(m for w in writes for m, s in w if s != "error")
    assert stored == [0, 1, 2, 3]  # each member's results written once
    for r in sent:
        np.testing.assert_array_equal(ds["tip_y"].values[r["members"]], r["outputs"]["tip_y"])
    run = json.loads(ds.attrs["runs"])[0]
    assert run["stored"] == 4 and run["completed"]


def test_default_chunk_size_fits_the_memory_budget():
    """Without --chunk-size a chunk holds as many members as keep at most CHUNK_BYTES of
    histories (what simulate_batch counts against max_output_bytes), at most
    MAX_CHUNK, split so that every worker gets a chunk."""
    from ancf_jax.simulation import run_size
    from ancf_jax.sweep import SweepDefinition, plan
    from ancf_jax.sweep.runner import CHUNK_BYTES, MAX_CHUNK
    params = tuple(parse_param(p) for p in PARAMS)

    def size(t_end, **kw):
        d = SweepDefinition("m1", params, design="grid", levels=2, overrides=(*BASE, f"solver.t_end={t_end}"))
        return plan(d, **kw)

    assert size(0.02).chunk_size == 6 and size(0.02, workers=2).chunk_size == 3
    assert size(0.02, workers=2, multiple=2).chunk_size == 4  # a multiple of the devices
    # 1,600 s keep 800,001 rows per member of 19 coordinates (4 nodes of 4, the tip
    # body's 3) and 7 multipliers: 0.44 GB a member, 2 members fit in 1 GiB
    p = size(1600.0)
    one = run_size(800_000, 1, 19, 7)[1]
    assert p.chunk_size == CHUNK_BYTES // one == 2 and 2 * one <= CHUNK_BYTES < 3 * one
    assert [len(c.members) for c in p.chunks] == [2, 2, 2]
    assert MAX_CHUNK == 256


def test_failing_members_are_stored_with_their_failure(tmp_path):
    """A Newton limit of 1 iteration fails every member (one compiled program: members
    of other settings would each compile their own): the sweep still completes and
    stores each failure's reason, message and time (the ok members are those of the
    local store above)."""
    out = tmp_path / "f.zarr"
    ds = run_sweep("m1", ["solver.generalized_alpha.max_iterations=[1]", "beams.beam.alpha=[0.01, 0.2]"],
                   out=out, design="grid", overrides=BASE, chunk_size=2, progress=False).load()
    assert list(ds["status"].values) == ["newton"] * 2, list(ds["status"].values)
    assert np.all(np.isfinite(ds["failure_time"].values)) and np.all(ds["stored"].values == 1)
    assert all("Newton" in m for m in ds["message"].values)


def test_cli_sweep_interrupted_then_resumed(tmp_path, capsys, monkeypatch):
    """Ctrl-C in the time loop of the second chunk (simulate_batch returns its members
    as ``interrupted``, as on a real Ctrl-C with on_failure="return"): the command
    stops with one line saying how many members are stored and that --resume runs the
    rest, which it does."""
    import ancf_jax.simulation as simulation
    from ancf_jax.failures import Failure
    out = tmp_path / "cli.zarr"
    argv = ["sweep", "m1", "--param", PARAMS[0], "--param", PARAMS[1], "--design", "grid", "--levels", "2",
            "--chunk-size", "2", "--no-progress", "--out", str(out)]
    for s in BASE:
        argv += ["--set", s]
    real, calls = simulation.simulate_batch, []

    def ctrl_c_in_the_second(*args, **kw):
        results = real(*args, **kw)
        calls.append(len(results))
        if len(calls) == 2:
            for r in results:
                r.status = Failure.INTERRUPTED.reason
        return results

    with monkeypatch.context() as mp:
        mp.setattr(simulation, "simulate_batch", ctrl_c_in_the_second)
        assert main(argv) == 130
    err = capsys.readouterr().err.strip()
    assert len(calls) == 2 and len(err.splitlines()) == 1, err
    assert "interrupted (Ctrl-C): 2 of 6 members stored" in err and "--resume" in err, err
    assert main(argv) == 2 and "--resume" in capsys.readouterr().err  # the store exists
    nc = tmp_path / "cli.nc"
    assert main(argv + ["--resume", "--netcdf", str(nc)]) == 0
    assert "6 members (6 ok)" in capsys.readouterr().out
    ds = xr.open_zarr(out)
    assert list(ds["run"].values).count(0) == 2 and list(ds["run"].values).count(1) == 4
    assert np.array_equal(xr.open_dataset(nc)["tip_y"].values, ds["tip_y"].values)
    wrong = argv + ["--resume", "--seed", "3"]
    assert main(wrong) == 2 and "different sweep" in capsys.readouterr().err


# ---------------------------------------------------------------------------- Ray, devices
@pytest.fixture(scope="module")
def spawned(tmp_path_factory, request):
    """One spawned interpreter with two XLA host devices (tests/sweep_ray_case.py): the
    local backend sharded across both devices, then the sweep on a Ray cluster started
    by ``ray start --head`` (2 CPUs on this machine), reached by its address, with one
    worker killed mid-chunk where the Ray test is selected (both are validation
    studies, ``-m study``: the cluster and its workers' compilations take ~80 s, the
    spawned interpreter ~25 s). Ray never loads
    into this pytest worker. Returns {case: (store path, what the case returned)}."""
    import importlib.util
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor
    tmp = tmp_path_factory.mktemp("spawned")
    old = os.environ.get("XLA_FLAGS")
    # for the child only, with the suite's own flags (tests/conftest.py)
    os.environ["XLA_FLAGS"] = f"{old or ''} --xla_force_host_platform_device_count=2".strip()
    try:
        pool = ProcessPoolExecutor(max_workers=1, mp_context=mp.get_context("spawn"))
        shard = pool.submit(_case, "sweep_sharded_across_two_host_devices", PARAMS, str(tmp / "two.zarr"), KW)
        shard.result()  # the child has started and read its environment
    finally:
        if old is None:
            os.environ.pop("XLA_FLAGS")
        else:
            os.environ["XLA_FLAGS"] = old
    with pool:
        out = {"shard": (tmp / "two.zarr", shard.result())}
        ray_selected = any(item.name == "test_ray_equals_local_with_a_worker_killed" for item in request.session.items)
        if ray_selected and importlib.util.find_spec("ray") is not None:  # found, not imported (docstring)
            # chunks of one member: six chunks on two workers, so that workers run several
            out["ray"] = (tmp / "ray.zarr", pool.submit(_case, "sweep_on_ray_killing_a_worker", PARAMS,
                                                        str(tmp / "ray.zarr"), dict(KW, chunk_size=1),
                                                        str(ROOT)).result())
    assert "ray" not in sys.modules  # the pytest worker stayed free of Ray
    return out


def _case(name, *args):
    """In the spawned child: a case of tests/sweep_ray_case.py."""
    import tests.sweep_ray_case as cases
    return getattr(cases, name)(*args)


@pytest.mark.study
def test_ray_equals_local_with_a_worker_killed(spawned, local_store):
    """On a running cluster reached by its address (``--address``), every member comes
    back exactly once and equals the local backend (chunks of 2 there, of 1 here). A
    worker compiles the chunk program once: every later chunk it runs reports 0 s of
    compilation (the in-process cache of ancf_jax.simulation.compiled), and every
    worker had the driver's persistent compilation cache."""
    import jax
    if "ray" not in spawned:
        pytest.skip("ray is not installed (it is in the test extra)")
    _, local, _, _ = local_store
    out, (seen, killed, address, chunks) = spawned["ray"]
    by_pid = {}
    for pid, compile_s, cache in chunks:
        by_pid.setdefault(pid, []).append(compile_s)
        assert cache == jax.config.jax_compilation_cache_dir and cache, (cache, chunks)
    assert max(map(len, by_pid.values())) >= 2, chunks  # six chunks, two CPUs: a worker ran several
    assert all(c == 0.0 for runs in by_pid.values() for c in runs[1:]), chunks
    assert any(runs[0] > 0.0 for runs in by_pid.values()), chunks  # compile_s measures compilation
    assert address.rsplit(":", 1)[1].isdigit()
    assert killed, "no chunk was running when the first one finished"
    assert sorted(seen) == list(range(6))  # every member came back exactly once
    ds = xr.open_zarr(out).load()
    assert np.all(ds["stored"].values == 1) and np.all(ds["run"].values == 0)
    assert list(ds["status"].values) == ["ok"] * 6
    for name in ("tip_x", "tip_y", "sigma_e1_mid"):
        np.testing.assert_allclose(ds[name].values, local[name].values, rtol=1e-12, atol=1e-15)
    run = json.loads(ds.attrs["runs"])[0]
    assert run["backend"] == "ray" and run["cpus"] == 2.0


@pytest.mark.study
def test_local_backend_shards_across_host_devices(spawned, local_store):
    """Two CPU host devices: each chunk is one program sharded across both; the numbers
    equal the one-device store."""
    _, local, _, _ = local_store
    out, devices = spawned["shard"]
    assert len(devices) == 2
    ds = xr.open_zarr(out)
    assert json.loads(ds.attrs["runs"])[0]["devices"] == ["cpu:0", "cpu:1"]
    for name in ("tip_x", "tip_y", "sigma_e1_mid"):
        np.testing.assert_allclose(ds[name].values, local[name].values, rtol=1e-12, atol=1e-15)


# ---------------------------------------------------------------------------- VTK
def test_run_vtk_reads_back(tmp_path, capsys):
    meshio = pytest.importorskip("meshio")
    import xml.etree.ElementTree as ET
    from ancf_jax.scenario import load_scenario
    out = tmp_path / "run"
    assert main(["run", "m1", "--elements", "3", "--t-end", "0.02", "--dt", "2e-3", "--output-dt", "2e-3",
                 "--no-figures", "--no-progress", "--vtk", "--out", str(out)]) == 0
    capsys.readouterr()
    pvd = ET.parse(out / "vtk" / "m1.pvd").getroot()
    sets = pvd.findall("./Collection/DataSet")
    assert [float(d.get("timestep")) for d in sets] == pytest.approx(np.linspace(0, 0.02, 11))
    r = load_scenario("m1", BASE).simulate(progress=False)
    last = meshio.read(out / "vtk" / sets[-1].get("file"))
    beam = last.point_data["beam"] == 0
    assert {"stress", "curvature", "axial_force"} <= set(last.point_data)
    np.testing.assert_allclose(last.points[~beam][0, :2], r.body("tip")[-1, :2], rtol=1e-12)
    np.testing.assert_allclose(last.points[beam][0, :2], [0.0, 0.0], atol=1e-12)  # the clamp
    np.testing.assert_allclose(last.point_data["stress"][beam][0], r.stress("beam", 0.0)[-1], rtol=1e-9)
    np.testing.assert_allclose(last.point_data["axial_force"][beam][2], r.axial_force("beam", 0.402 / 3 * 0.5)[-1],
                               rtol=1e-9, atol=1e-9)
    # curvature: σ = E y (κ − κ₀) on the outer fibre of the straight (κ₀ = 0) wire
    np.testing.assert_allclose(last.point_data["stress"][beam],
                               -200e9 * 0.5e-3 * last.point_data["curvature"][beam], rtol=1e-6)
    assert len(last.cells_dict["line"]) == 3 * 4 and len(last.cells_dict["vertex"]) == 1


# ---------------------------------------------------------------------------- sensitivity
def test_sobol_indices_of_an_additive_function(tmp_path):
    """SALib's estimators on the Saltelli design of make_design: y = x1 + 0.1 x2 over
    [0, 1]² has S1 = ST = 1/1.01 and 0.01/1.01 (no simulation needed)."""
    pytest.importorskip("SALib")
    from ancf_jax.sweep.sensitivity import sobol_figure, sobol_indices
    v = make_design([Param("a", 0.0, 1.0), Param("b", 0.0, 1.0)], "saltelli", samples=256, seed=1)
    assert len(v["a"]) == 256 * 4
    y = np.asarray(v["a"]) + 0.1 * np.asarray(v["b"])
    ds = xr.Dataset({"y": (("member", "time"), y[:, None]), "status": ("member", np.full(len(y), "ok"))},
                    attrs={"sweep": json.dumps({"design": "saltelli", "params": [{"key": "a"}, {"key": "b"}]})})
    s = sobol_indices(ds, "y", "final")
    assert s["a"]["S1"] == pytest.approx(1 / 1.01, abs=0.03) and s["a"]["ST"] == pytest.approx(1 / 1.01, abs=0.03)
    assert s["b"]["ST"] == pytest.approx(0.01 / 1.01, abs=0.01)
    sobol_figure(s, tmp_path / "sobol.png")
    assert (tmp_path / "sobol.png").stat().st_size > 0
