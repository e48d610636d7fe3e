"""Pantograph–catenary at full scale (issue 21): statistics, convergence, cost.

1. ``scaling``: cost per step of the shipped model's structure at 2, 4 and 10 spans
   (480, 960 and 2,400 elements at 0.5 m), 200 steps each after compilation: the
   exponent of a power-law fit and the marginal cost per element, and the compile
   times (statics, time stepping).
2. ``convergence``: the reduced catenary of tests/test_catenary.py (3 spans of 10 m,
   span 2 evaluated) under joint refinement of element length and step (1, 0.5,
   0.25 m against 0.125 m; steps 1 ms × element length / 1 m), and the step alone at
   the shipped 0.5 m (1, 2, 4 ms) against the same reference.
   ``tolerance``: the Newton tolerance at the shipped mesh and step (0.5 m, 2 ms):
   the contact force's and the statistics' changes from 1e-10 m, Newton iterations.
3. ``full``: the shipped scenario (10 spans, 2,400 elements) at 250 and 300 km/h, its
   statistics against the EN 50318:2002 ranges, wall time and real-time factor.
   ``full_steps``: the shipped scenario at 250 km/h at 0.5, 1 and 2 ms.
4. ``batch``: the reduced catenary at 8 speeds (150–350 km/h) in one vmapped run
   against 8 single runs (same program and step count).
5. ``reuse``: the 2-span model of ``scaling`` with the Newton matrix factored at every
   step (default) and carried across steps (``AcrossSteps``, issues 17 and 21), 200
   steps each, interleaved, best of 5: cost per step, Newton iterations and
   factorizations per step, and the difference of the two runs.
6. At the shipped settings (the scenario's ``[solver]``: 2 ms, factors carried up to
   16 steps, tolerance 1e-7 m): ``scaling_shipped``, the cost per step of ``scaling``
   (about 4 minutes); ``full_mesh``, the shipped scenario at 250 km/h with 1.0, 0.5
   and 0.25 m elements, differences from 0.25 m (about 8 minutes); ``batch_full``,
   the shipped model at 8 speeds over its first 0.3 s, vmapped against 8 single runs
   (about 6 minutes).

Run from the repository root: ``python -m benchmarks.pantograph_catenary [PART ...]``
(default all; about 45 minutes on the 2-core machine); writes
benchmarks/results/pantograph_catenary.json (and a .md beside it, not committed:
``python -m benchmarks.report`` puts these tables into benchmarks/RESULTS.md).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ancf_jax.models.catenary import (CatenaryDesign, against_ranges, analyse_pantograph_run,  # noqa: E402
                                      moving_equilibrium, pantograph_catenary, run_pantograph_catenary)
from ancf_jax.simulation import simulate, simulate_batch  # noqa: E402

from .common import table, write  # noqa: E402

RUN = dict(spans=3, span_length=10.0, droppers=(2.0, 5.0, 8.0), alpha=0.06, beta=7.6e-5)
SHIPPED = dict(alpha=0.06, beta=7.6e-5)
#: the statistics compared between runs of the shipped model
STAT_KEYS = ("mean_N", "std_N", "stat_max_N", "stat_min_N", "max_N", "min_N", "uplift_support_mm", "contact_loss_pct")


def _shipped_solver() -> dict:
    """The shipped scenario's step and solver (``[solver]``: generalized-α, 2 ms,
    factors carried up to 16 steps, Newton tolerance 1e-7 m) as ``simulate`` keywords
    (``dt``, ``solver``, ``options``; no ``t_end``)."""
    from ancf_jax.scenario import load_scenario
    kw = load_scenario("pantograph_catenary").solver.simulate_kwargs()
    return dict(dt=kw["dt"], solver=kw["solver"], options=kw["options"])


def scaling(shipped: bool = False, spans_list=(2, 4, 10), steps: int = 200) -> dict:
    """Cost per step at 2, 4 and 10 spans (0.5 m elements), ``steps`` steps each: at
    h = 1 ms with the default solver (factors every step), or with ``shipped`` the
    scenario's step and solver (:func:`_shipped_solver`)."""
    kw = _shipped_solver() if shipped else dict(dt=1e-3)
    rows = []
    for spans in spans_list:
        m, _ = pantograph_catenary(CatenaryDesign(spans=spans, element_length=0.5, **SHIPPED), speed=250 / 3.6)
        system, guess = m.build(assemble=False)
        t0 = time.perf_counter()
        state, _ = moving_equilibrium(system, guess)
        statics_s = time.perf_counter() - t0
        r = simulate(system, state, t_end=steps * kw["dt"], progress=False, **kw)
        elements = sum(int(b.mesh.n_elements) for b in system.beams)
        rows.append(dict(spans=spans, elements=elements, coordinates=system.n_coordinates,
                         statics_s=statics_s, compile_s=r.compile_time_s,
                         step_ms=1e3 * r.wall_time_s / steps, newton_per_step=float(np.sum(r.iterations)) / steps))
        print(rows[-1], flush=True)
    e = np.array([r["elements"] for r in rows], float)
    c = np.array([r["step_ms"] for r in rows])
    exponent = float(np.polyfit(np.log(e), np.log(c), 1)[0])
    marginal = float(np.polyfit(e, c, 1)[0]) * 1e3  # µs per element-step
    settings = dict(dt=kw["dt"], solver="shipped scenario's [solver]" if shipped else "default (factors every step)")
    return dict(runs=rows, exponent=exponent, marginal_us_per_element=marginal, steps=steps, settings=settings)


def scaling_shipped() -> dict:
    """:func:`scaling` at the shipped scenario's step and solver (issue 21's target: the
    mesh and step that the convergence study chose)."""
    return scaling(shipped=True)


def reuse(spans: int = 2, reps: int = 5) -> dict:
    from ancf_jax.integrators.generalized_alpha import AcrossSteps, GeneralizedAlpha
    m, _ = pantograph_catenary(CatenaryDesign(spans=spans, element_length=0.5, **SHIPPED), speed=250 / 3.6)
    system, guess = m.build(assemble=False)
    state, _ = moving_equilibrium(system, guess)
    solvers = {"per-step": GeneralizedAlpha(), "across-steps(16)": GeneralizedAlpha(factor_reuse=AcrossSteps(16))}
    kw = dict(t_end=0.2, dt=1e-3, progress=False)
    first = {k: simulate(system, state, solver=s, **kw) for k, s in solvers.items()}
    walls = {k: [] for k in solvers}
    for _ in range(reps):
        for k, s in solvers.items():
            walls[k].append(simulate(system, state, solver=s, **kw).wall_time_s)
    ref = first["per-step"]
    rows = []
    for k, r in first.items():
        memory = r.checkpoint.carry.memory
        rows.append(dict(solver=k, status=r.status, compile_s=r.compile_time_s, step_ms=1e3 * min(walls[k]) / 200,
                         step_ms_all=[1e3 * w / 200 for w in walls[k]],
                         newton_per_step=float(np.sum(r.iterations)) / 200,
                         factorizations_per_step=None if memory is None else int(memory.factorizations) / 200,
                         max_q_difference_m=float(np.max(np.abs(r.q - ref.q)))))
        print(rows[-1], flush=True)
    return dict(spans=spans, coordinates=system.n_coordinates, steps=200, runs=rows)


def _rms_against(r, ref) -> float:
    """RMS difference [N] of the filtered contact force of run ``r`` from ``ref``'s over
    the evaluated window, at ``ref``'s samples (``r``'s by a cubic spline in x where its
    output step is coarser: the 20 Hz force sampled at ≥ 250 Hz)."""
    from scipy.interpolate import CubicSpline
    sel = (ref.x >= ref.window[0]) & (ref.x <= ref.window[1])
    f = r.filtered[sel] if len(r.x) == len(ref.x) else CubicSpline(r.x, r.filtered)(ref.x[sel])
    return float(np.sqrt(np.mean((f - ref.filtered[sel]) ** 2)))


def convergence() -> dict:
    # joint refinement, then the step alone at the shipped 0.5 m (outputs at the step
    # where it is coarser than 1 ms: outputs are taken at steps)
    levels = [(1.0, 1e-3), (0.5, 5e-4), (0.25, 2.5e-4), (0.5, 1e-3), (0.5, 2e-3), (0.5, 4e-3), (0.125, 1.25e-4)]
    runs = {}
    for el, dt in levels:
        r = run_pantograph_catenary(CatenaryDesign(element_length=el, **RUN), speed_kmh=250, dt=dt,
                                    output_dt=max(dt, 1e-3), pad_to=240, spans=(2, 2))
        runs[(el, dt)] = r
        print(el, dt, {k: v for k, v in r.statistics.items() if k.endswith("_N")}, flush=True)
    ref = runs[(0.125, 1.25e-4)]
    out = []
    for (el, dt), r in runs.items():
        out.append(dict(element_length=el, dt=dt, rms_error_N=_rms_against(r, ref), **{k: r.statistics[k] for k in (
            "mean_N", "std_N", "max_N", "min_N", "uplift_support_mm")}))
    return dict(reference=dict(element_length=0.125, dt=1.25e-4), levels=out)


def tolerance() -> dict:
    """The Newton tolerance (on the position correction [m]) at the shipped mesh and
    step, factors carried across steps as the scenario does: how far the contact force
    and the statistics move from the run at 1e-10 m, against the discretization error
    (:func:`convergence`), and the Newton iterations per step."""
    from ancf_jax.integrators.generalized_alpha import AcrossSteps, GeneralizedAlpha
    from ancf_jax.newton import ModifiedNewton
    runs = {}
    for tol in (1e-10, 1e-8, 1e-7, 1e-6):
        solver = GeneralizedAlpha(root_finder=ModifiedNewton(tolerance=tol), factor_reuse=AcrossSteps(16))
        runs[tol] = run_pantograph_catenary(CatenaryDesign(element_length=0.5, **RUN), speed_kmh=250, dt=2e-3,
                                            output_dt=2e-3, pad_to=240, spans=(2, 2), solver=solver)
    ref = runs[1e-10]
    out = []
    for tol, r in runs.items():
        out.append(dict(tolerance_m=tol, newton_per_step=float(np.mean(r.results.iterations[1:])),  # [0]: t = 0
                        max_force_difference_N=float(np.max(np.abs(r.force - ref.force))),
                        max_statistic_difference_N=max(abs(r.statistics[k] - ref.statistics[k]) for k in (
                            "mean_N", "std_N", "stat_max_N", "stat_min_N", "max_N", "min_N"))))
        print(out[-1], flush=True)
    return dict(element_length=0.5, dt=2e-3, levels=out)


def _shipped_run(speed_kmh: float, *overrides: str):
    """The shipped scenario at ``speed_kmh`` with ``--set`` style ``overrides``, as the
    CLI runs it: (statistics, results, build + statics time [s])."""
    from ancf_jax.scenario import load_scenario
    from ancf_jax.scenario.build import pantograph_start
    sc = load_scenario("pantograph_catenary", [f"pantograph.speed_kmh={speed_kmh}", *overrides])
    t0 = time.perf_counter()
    system, state = sc.build()
    build_s = time.perf_counter() - t0
    r = simulate(system, state, **{**sc.solver.simulate_kwargs(), "progress": False})
    p = sc.spec.pantograph
    run = analyse_pantograph_run(r, sc.spec.catenary.design(), speed_kmh=speed_kmh, start=pantograph_start(sc.spec),
                                 spans=p.spans, cutoff=p.cutoff)
    return dict(run.statistics), r, build_s


def full() -> dict:
    out = []
    for v in (250.0, 300.0):
        stats, r, build_s = _shipped_run(v)
        out.append(dict(statistics=stats, en50318_2002=against_ranges(stats), build_and_statics_s=build_s,
                        compile_s=r.compile_time_s, wall_s=r.wall_time_s, simulated_s=float(r.t[-1]),
                        real_time_factor=r.wall_time_s / float(r.t[-1]), steps=int(r.info["steps"])))
        print(json.dumps(out[-1], default=str)[:600], flush=True)
    return dict(runs=out)


def full_steps() -> dict:
    """The shipped scenario at 250 km/h at steps of 0.5, 1 and 2 ms (outputs at every
    step, its other settings as shipped): the statistics' changes against the 0.5 ms
    run, where the contact opens and closes (the reduced catenary of
    :func:`convergence` never loses contact) and the wall time."""
    runs = {}
    for dt in (5e-4, 1e-3, 2e-3):
        stats, r, _ = _shipped_run(250.0, f"solver.dt={dt}", f"outputs.dt={dt}")
        runs[dt] = (stats, r.wall_time_s, float(r.t[-1]))
        print(dt, runs[dt], flush=True)
    ref = runs[5e-4][0]
    return dict(speed_kmh=250.0, reference_dt=5e-4, runs=[dict(
        dt=dt, wall_s=w, real_time_factor=w / t, statistics={k: s[k] for k in STAT_KEYS},
        difference={k: s[k] - ref[k] for k in STAT_KEYS}) for dt, (s, w, t) in runs.items()])


def full_mesh(lengths=(1.0, 0.5, 0.25), *overrides: str) -> dict:
    """The shipped scenario at 250 km/h and its 2 ms step with elements of ``lengths``
    [m] (``overrides``: more ``--set`` style settings, e.g. a reduced line for a smoke
    run): the statistics' differences from the finest mesh, where the contact opens
    and closes (the reduced catenary of :func:`convergence` never loses contact)."""
    runs = {}
    for el in lengths:
        stats, r, _ = _shipped_run(250.0, f"catenary.element_length={el}", *overrides)
        runs[el] = (stats, r.wall_time_s, float(r.t[-1]), r.system.n_coordinates)
        print(el, runs[el][:3], flush=True)
    finest = min(lengths)
    ref = runs[finest][0]
    return dict(speed_kmh=250.0, reference_element_length=finest, overrides=list(overrides), runs=[dict(
        element_length=el, coordinates=n, wall_s=w, real_time_factor=w / t, statistics={k: s[k] for k in STAT_KEYS},
        difference={k: s[k] - ref[k] for k in STAT_KEYS}) for el, (s, w, t, n) in runs.items()])


def _batch_against_singles(systems, states, **kw) -> dict:
    """One vmapped run of ``systems`` against their single runs (``simulate``'s
    keywords ``kw``, the same step count): wall and compile times, the largest
    difference of q."""
    res = simulate_batch(systems, states, progress=False, **kw)
    batch_wall = res[0].info.get("batch_wall_time_s", sum(r.wall_time_s for r in res))
    singles = [simulate(s, st, progress=False, **kw) for s, st in zip(systems, states)]
    single_wall = sum(r.wall_time_s for r in singles)
    agree = max(float(np.max(np.abs(np.asarray(a.q) - np.asarray(b.q)))) for a, b in zip(res, singles))
    return dict(steps=int(round(kw["t_end"] / kw["dt"])), batch_wall_s=batch_wall, singles_wall_s=single_wall,
                batch_compile_s=res[0].compile_time_s, single_compile_s=singles[0].compile_time_s,
                max_q_difference_m=agree)


def batch() -> dict:
    speeds = np.linspace(150, 350, 8)
    systems, states = [], []
    for v in speeds:
        m, _ = pantograph_catenary(CatenaryDesign(element_length=0.5, **RUN), speed=float(v) / 3.6)
        s, g = m.build(assemble=False)
        st, _ = moving_equilibrium(s, g)
        systems.append(s)
        states.append(st)
    return dict(speeds_kmh=speeds.tolist(), **_batch_against_singles(systems, states, t_end=0.3, dt=1e-3))


def batch_full(t_end: float = 0.3, *overrides: str) -> dict:
    """The shipped scenario (10 spans, its step and solver) at 8 speeds (150–350 km/h)
    in one vmapped run over the first ``t_end`` seconds against 8 single runs of the
    same steps (``overrides``: ``--set`` style settings, e.g. a reduced line for a
    smoke run)."""
    from ancf_jax.scenario import load_scenario
    speeds = np.linspace(150, 350, 8)
    systems, states = [], []
    for v in speeds:
        s, st = load_scenario("pantograph_catenary", [f"pantograph.speed_kmh={float(v)}", *overrides]).build()
        systems.append(s)
        states.append(st)
    kw = dict(_shipped_solver(), t_end=t_end)
    return dict(speeds_kmh=speeds.tolist(), coordinates=systems[0].n_coordinates, overrides=list(overrides),
                dt=kw["dt"], **_batch_against_singles(systems, states, **kw))


PARTS = dict(scaling=scaling, convergence=convergence, tolerance=tolerance, full=full, full_steps=full_steps,
             batch=batch, reuse=reuse, scaling_shipped=scaling_shipped, full_mesh=full_mesh, batch_full=batch_full)


def markdown(data: dict) -> str:
    md = []
    for part, settings in (("scaling", "h = 1 ms, factors every step"),
                           ("scaling_shipped", "the shipped scenario's step and solver: h = 2 ms, factors carried "
                            "up to 16 steps, Newton tolerance 1e-7 m")):
        if part not in data:
            continue
        s = data[part]
        md.append(f"Cost per step (generalized-α, {settings}, 0.5 m elements, both wires interleaved, "
                  f"{s.get('steps', 200)} steps):\n\n" + table(
                      ["spans", "elements", "coordinates", "statics [s]", "compile [s]", "step [ms]", "Newton/step"],
                      [[r["spans"], r["elements"], r["coordinates"], f"{r['statics_s']:.1f}", f"{r['compile_s']:.1f}",
                        f"{r['step_ms']:.2f}", f"{r['newton_per_step']:.2f}"] for r in s["runs"]])
                  + f"\n\nexponent {s['exponent']:.2f}, marginal {s['marginal_us_per_element']:.1f} µs per element-step")
    if "convergence" in data:
        md.append("Convergence (3 spans of 10 m, span 2, against 0.125 m / 0.125 ms):\n\n" + table(
            ["element [m]", "h [s]", "RMS error [N]", "mean [N]", "σ [N]", "max [N]", "min [N]", "uplift [mm]"],
            [[r["element_length"], r["dt"], f"{r['rms_error_N']:.3f}", f"{r['mean_N']:.2f}", f"{r['std_N']:.2f}",
              f"{r['max_N']:.2f}", f"{r['min_N']:.2f}", f"{r['uplift_support_mm']:.2f}"]
             for r in data["convergence"]["levels"]]))
    if "tolerance" in data:
        u = data["tolerance"]
        md.append(f"Newton tolerance ({u['element_length']} m, h = {u['dt'] * 1e3:g} ms, factors carried across "
                  f"steps), against the run at 1e-10 m:\n\n" + table(
                      ["tolerance [m]", "Newton/step", "largest ΔF [N]", "largest Δ statistic [N]"],
                      [[f"{r['tolerance_m']:g}", f"{r['newton_per_step']:.2f}", f"{r['max_force_difference_N']:.1e}",
                        f"{r['max_statistic_difference_N']:.1e}"] for r in u["levels"]]))
    if "full" in data:
        rows = []
        for r in data["full"]["runs"]:
            s = r["statistics"]
            for row in r["en50318_2002"] or []:
                rows.append([s["speed_kmh"], row["key"], f"{row['value']:.2f}", f"{row['low']}–{row['high']}",
                             "inside" if row["inside"] else "outside"])
        md.append("Shipped model (10 spans, spans 5–6) against EN 50318:2002:\n\n"
                  + table(["km/h", "statistic", "value", "range", ""], rows) + "\n\n" + "\n".join(
                      f"- {r['statistics']['speed_kmh']:g} km/h: {r['steps']} steps, wall {r['wall_s']:.0f} s, "
                      f"real-time factor {r['real_time_factor']:.1f}, compile {r['compile_s']:.0f} s, build + "
                      f"statics {r['build_and_statics_s']:.0f} s" for r in data["full"]["runs"]))
    for part, what, ref_key, label, scale, unit in (("full_steps", "step", "dt", "h", 1e3, "ms"),
                                                    ("full_mesh", "element length (h = 2 ms)", "element_length",
                                                     "element", 1.0, "m")):
        if part not in data:
            continue
        u = data[part]
        keys = list(u["runs"][0]["statistics"])
        ref = u[f"reference_{ref_key}"]
        md.append(f"Shipped model at {u['speed_kmh']:g} km/h by {what}, differences from the "
                  f"{ref * scale:g} {unit} run{' (' + ', '.join(u['overrides']) + ')' if u.get('overrides') else ''}"
                  f":\n\n" + table(
                      [f"{label} [{unit}]", "real-time factor"] + keys,
                      [[f"{r[ref_key] * scale:g}", f"{r['real_time_factor']:.1f}"]
                       + [f"{r['statistics'][k]:.2f}" if r[ref_key] == ref else f"{r['difference'][k]:+.2f}"
                          for k in keys] for r in u["runs"]]))
    if "reuse" in data:
        u = data["reuse"]
        md.append(f"Newton-matrix factors per step or carried across steps ({u['spans']} spans, "
                  f"{u['coordinates']} coordinates, h = 1 ms, {u['steps']} steps, interleaved, best of "
                  f"{len(u['runs'][0]['step_ms_all'])}):\n\n" + table(
                      ["factors", "step [ms]", "Newton/step", "factorizations/step", "largest Δq [m]"],
                      [[r["solver"], f"{r['step_ms']:.2f}", f"{r['newton_per_step']:.2f}",
                        "≥ 1" if r["factorizations_per_step"] is None else f"{r['factorizations_per_step']:.3f}",
                        f"{r['max_q_difference_m']:.1e}"] for r in u["runs"]]))
    for part, model in (("batch", "reduced catenary, h = 1 ms"),
                        ("batch_full", "shipped model, its step and solver")):
        if part not in data:
            continue
        b = data[part]
        if b.get("overrides"):
            model += ", " + ", ".join(b["overrides"])
        md.append(f"Batch of {len(b['speeds_kmh'])} speeds ({model}, {b['steps']} steps): vmapped "
                  f"{b['batch_wall_s']:.1f} s against {len(b['speeds_kmh'])} single runs {b['singles_wall_s']:.1f} s "
                  f"(compile {b['batch_compile_s']:.0f} s and {b['single_compile_s']:.0f} s); largest difference "
                  f"of q {b['max_q_difference_m']:.1e} m.")
    return "\n\n".join(md)


def main(argv=None) -> None:
    parts = (argv if argv is not None else sys.argv[1:]) or list(PARTS)
    path = Path(__file__).parent / "results" / "pantograph_catenary.json"
    data = json.loads(path.read_text()) if path.exists() else {}
    data.pop("stamp", None)
    for p in parts:
        data[p] = PARTS[p]()
    md = markdown(data)
    out = write("pantograph_catenary", data, md)
    print(md)
    print(f"written {out}")


if __name__ == "__main__":
    main()
