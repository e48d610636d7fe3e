"""Files and figures of runs of the built-in models (what ``ancf-jax run`` writes).

Every report writes CSV (the named outputs), NPZ (full histories), ``summary.json``
and figures into an output directory, and returns the summary dict.

Units: CSV headers are bare column names; ``summary.json`` has ``units`` ({column:
unit}) and the keys of its dimensional scalars end in their unit
(:func:`~ancf_jax.outputs.unit_suffix`: ``max_abs_sigma_e1_mid_Pa``, ``tip_y_min_m``,
``dt_s``; a column's ``{name}_min``/``_max`` carry the column's unit, none when it is
dimensionless); NPZ files hold ``units`` ({array: unit}, JSON text).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Sequence

import numpy as np

from . import plotting
from .models import m1 as m1_def
from .models import m2 as m2_def
from .outputs import evaluate, output_units, unit_suffix, write_csv
from .results import Results


def _json(path: Path, data: dict) -> dict:
    path.write_text(json.dumps(data, indent=2, default=float))
    return data


def _times(t_end: float, count: int) -> list[float]:
    return list(np.linspace(0.0, t_end, count))


# ---------------------------------------------------------------------------- M1
def report_m1(results: Results, out_dir: str | Path, *, figures: bool = True,
              outputs=m1_def.OUTPUTS, precision: int | None = None) -> dict:
    """Write M1's CSV, NPZ, summary and Figs. 5–8 into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    n = int(results.system.beams[0].mesh.n_elements)
    cols = evaluate(results, outputs)
    write_csv(out / f"m1_n{n}.csv", cols, precision)
    sig_approx = results.stress("beam", m1_def.STRESS_S, m1_def.STRESS_FIBRE, "small_strain")
    s, sigma = results.stress_along("beam", 11)
    results.save_npz(out / f"m1_n{n}.npz", stress_s=s, stress_sigma=sigma,
                     sigma_e1_mid=cols["sigma_e1_mid"], sigma_e1_mid_small_strain=sig_approx,
                     tip=np.column_stack([cols["tip_x"], cols["tip_y"]]),
                     units=dict(stress_s="m", stress_sigma="Pa", sigma_e1_mid="Pa",
                                sigma_e1_mid_small_strain="Pa", tip="m"))
    base = results.summary()
    summary = dict(model="m1", elements=n, solver=results.solver, dt_s=results.dt,
                   t_end_s=float(results.t[-1]), wall_time_s=results.wall_time_s,
                   compile_time_s=results.compile_time_s,
                   tip_y_min_m=float(np.min(cols["tip_y"])),
                   tip_y_min_time_s=float(results.t[int(np.argmin(cols["tip_y"]))]),
                   tip_y_final_m=float(cols["tip_y"][-1]),
                   max_abs_sigma_e1_mid_Pa=float(np.max(np.abs(cols["sigma_e1_mid"]))),
                   max_abs_sigma_e1_mid_small_strain_Pa=float(np.max(np.abs(sig_approx))),
                   max_abs_stress_along_beam_Pa=float(np.nanmax(np.abs(sigma))),
                   max_constraint_violation=base["max_constraint_violation"],
                   max_velocity_constraint_violation=base["max_velocity_constraint_violation"],
                   energy_balance_error=base["energy_balance_error"],
                   newton_iterations=base["newton_iterations"], status=results.status,
                   units=output_units(outputs))
    _json(out / "summary.json", summary)
    if figures:
        t = results.t
        plotting.time_history(t, {"tip Y displacement": 1e3 * cols["tip_y"]},
                              ylabel="Y-displacement of N7 [mm]",
                              title=f"M1 tip displacement (Fig. 6), {n} elements",
                              path=out / "fig6_tip_displacement.png")
        plotting.time_history(t, {"exact curvature (Eq. 16)": 1e-6 * cols["sigma_e1_mid"],
                                  "approximate curvature (Eq. 17)": 1e-6 * sig_approx},
                              ylabel=f"σ at s = L/12 = {m1_def.STRESS_S} m, y = +0.5 mm [MPa]",
                              title="M1 dynamic stress (Fig. 7)", path=out / "fig7_stress_e1_mid.png",
                              styles={"approximate curvature (Eq. 17)": dict(ls="--")},
                              difference=("exact curvature (Eq. 16)", "approximate curvature (Eq. 17)"))
        plotting.stress_map(t, s, sigma, title="M1 stress along the beam (Fig. 8), exact curvature",
                            path=out / "fig8_stress_map.png")
        plotting.deformed_shapes(results, "beam", _times(float(t[-1]) if len(t) > 1 else 0.0, 9),
                                 bodies=("tip",), title="M1 large deformation (Fig. 5)",
                                 path=out / "fig5_shapes.png")
    return summary


# ---------------------------------------------------------------------------- M2
def report_m2(runs: dict[int, Results], out_dir: str | Path, *, figures: bool = True,
              animate: bool = False, outputs=m2_def.OUTPUTS, precision: int | None = None) -> dict:
    """Write M2's per-mesh CSV/NPZ, the summary and Figs. 12–13 into ``out_dir``.

    ``runs`` maps element count → results. The summary states the distances between
    the point-1 trajectories of the meshes (the paper's conclusion, Fig. 13).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    counts = sorted(runs)
    per = {}
    cols_all = {}
    for n in counts:
        r = runs[n]
        cols = evaluate(r, outputs)
        cols_all[n] = cols
        write_csv(out / f"m2_n{n}.csv", cols, precision)
        reaction = r.sliding_reaction("slider")
        s, sigma = r.stress_along("cable", 11)
        r.save_npz(out / f"m2_n{n}.npz", stress_s=s, stress_sigma=sigma, sliding_reaction=reaction,
                   **{k: v for k, v in cols.items() if k != "t"},
                   units=dict(output_units(outputs), stress_s="m", stress_sigma="Pa", sliding_reaction="N"))
        base = r.summary()
        i_min = int(np.argmin(cols["point1_y"]))
        per[str(n)] = dict(elements=n, status=r.status, wall_time_s=r.wall_time_s,
                           compile_time_s=r.compile_time_s,
                           batch_wall_time_s=r.info.get("batch_wall_time_s", r.wall_time_s),
                           point1_y_min_m=float(cols["point1_y"][i_min]),
                           point1_y_min_time_s=float(r.t[i_min]),
                           s_final_m=float(cols["s"][-1]),
                           max_constraint_violation=base["max_constraint_violation"],
                           max_velocity_constraint_violation=base["max_velocity_constraint_violation"],
                           energy_balance_error=base["energy_balance_error"],
                           max_abs_bending_stress_Pa=float(np.nanmax(np.abs(sigma))),
                           max_abs_normal_reaction_N=float(np.max(np.abs(reaction[:, 0]))),
                           newton_iterations=base["newton_iterations"])
    distances = {}
    ref = counts[-1]
    for n in counts[:-1]:
        k = min(len(cols_all[n]["t"]), len(cols_all[ref]["t"]))
        d = np.hypot(cols_all[n]["point1_x"][:k] - cols_all[ref]["point1_x"][:k],
                     cols_all[n]["point1_y"][:k] - cols_all[ref]["point1_y"][:k])
        distances[f"{n}_vs_{ref}"] = dict(max_m=float(d.max()), rms_m=float(np.sqrt(np.mean(d**2))),
                                          final_m=float(d[-1]),
                                          max_before_1_3s_m=float(d[cols_all[ref]["t"][:k] <= 1.3].max()))
    r0 = runs[counts[0]]
    summary = dict(model="m2", element_counts=counts, solver=r0.solver, dt_s=r0.dt,
                   t_end_s=float(r0.t[-1]), compile_time_s=r0.compile_time_s,
                   batch_wall_time_s=r0.info.get("batch_wall_time_s", sum(runs[n].wall_time_s for n in counts)),
                   runs=per, point1_distances=distances, units=output_units(outputs))
    _json(out / "summary.json", summary)
    if figures:
        plotting.trajectories({f"{n} elements": (cols_all[n]["point1_x"], cols_all[n]["point1_y"])
                               for n in counts}, title="M2: trajectory of point 1 (Fig. 13)",
                              path=out / "fig13_point1_trajectories.png", t=cols_all[ref]["t"],
                              reference=f"{ref} elements" if len(counts) > 1 else None)
        rn = runs[ref]
        plotting.deformed_shapes(rn, "cable", _times(float(rn.t[-1]), 7), bodies=("trolley", "cabin"),
                                 links=(("trolley", "cabin"),),
                                 title=f"M2: cable and bodies, {ref} elements (Fig. 12)",
                                 path=out / f"fig12_shapes_n{ref}.png")
        s, sigma = rn.stress_along("cable", 11)
        plotting.stress_map(rn.t, s, sigma, title=f"M2: bending stress along the cable, {ref} elements",
                            path=out / f"stress_map_n{ref}.png")
        plotting.time_history(rn.t, {f"{n} elements": runs[n].sliding_reaction("slider")[:, 0]
                                     for n in counts}, ylabel="normal reaction [N]",
                              title="M2: sliding-joint reaction normal to the cable",
                              path=out / "sliding_reaction.png")
        plotting.time_history(rn.t, {f"{n} elements": cols_all[n]["s"] for n in counts},
                              ylabel="s [m]", title="M2: arc-length coordinate of the trolley",
                              path=out / "sliding_coordinate.png")
    if animate:
        rn = runs[ref]
        path = plotting.animate(rn, "cable", out / f"m2_n{ref}.gif", bodies=("trolley", "cabin"),
                                links=(("trolley", "cabin"),), title=f"M2, {ref} elements")
        summary["animation"] = path.name
        _json(out / "summary.json", summary)
    return summary


# ---------------------------------------------------------------------------- any scenario
def report_scenario(name: str, runs: dict, outputs, out_dir: str | Path, *, figures: bool = True,
                    animate: bool = False, precision: int | None = None) -> dict:
    """Write CSV/NPZ per run, ``summary.json`` and default figures for any scenario.

    ``runs`` maps a label (the element count of a one-beam scenario, or "") to results;
    files are ``{name}.csv`` or ``{name}_n{N}.csv``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    per = {}
    for label, r in runs.items():
        stem = f"{name}_n{label}" if label != "" else name
        cols = evaluate(r, outputs)
        write_csv(out / f"{stem}.csv", cols, precision)
        extra = {}
        for b in r.system.beam_names:
            s, sigma = r.stress_along(b, 11)
            extra[f"stress_s_{b}"], extra[f"stress_sigma_{b}"] = s, sigma
        r.save_npz(out / f"{stem}.npz", **extra,
                   units={k: "m" if k.startswith("stress_s_") else "Pa" for k in extra})
        base = r.summary()
        entry = dict(base)
        suffix = {o.name: unit_suffix(o.unit) for o in outputs}  # "": dimensionless, see units
        entry.update({f"{k}_min{suffix[k]}": float(np.min(v)) for k, v in cols.items() if k != "t"})
        entry.update({f"{k}_max{suffix[k]}": float(np.max(v)) for k, v in cols.items() if k != "t"})
        entry["max_abs_bending_stress_Pa"] = {b: float(np.nanmax(np.abs(extra[f"stress_sigma_{b}"])))
                                              for b in r.system.beam_names}
        per[str(label) if label != "" else name] = entry
        if figures:
            series = {k: v for k, v in cols.items() if k != "t"}
            if series:
                for k, v in list(series.items())[:12]:
                    plotting.time_history(r.t, {k: v}, ylabel=k, title=f"{name}: {k}",
                                          path=out / f"{stem}_{k}.png")
            t_end = float(r.t[-1])
            for b in r.system.beam_names:
                plotting.deformed_shapes(r, b, _times(t_end, 7), bodies=r.system.body_names,
                                         title=f"{name}: {b} at chosen times",
                                         path=out / f"{stem}_shapes_{b}.png")
                plotting.stress_map(r.t, extra[f"stress_s_{b}"], extra[f"stress_sigma_{b}"],
                                    title=f"{name}: bending stress along {b}",
                                    path=out / f"{stem}_stress_{b}.png")
        if animate and r.system.beam_names:
            path = plotting.animate(r, r.system.beam_names[0], out / f"{stem}.gif",
                                    bodies=r.system.body_names, title=name)
            entry["animation"] = path.name
    summary = dict(model=name, runs=per, units=output_units(outputs))
    _json(out / "summary.json", summary)
    return summary


def report_pantograph(run, out_dir: str | Path, *, figures: bool = True, precision: int | None = None) -> dict:
    """Write a pantograph–catenary run (:class:`~ancf_jax.models.catenary.PantographRun`):
    ``statistics.json`` (the keys of :data:`~ancf_jax.models.catenary.STATISTICS_KEYS`,
    the EN 50318:2002 ranges at 250 and 300 km/h as ``en50318_2002`` rows, the
    evaluated window and the run's diagnostics), ``contact_force.csv``
    (``t,x,contact_force_N,contact_force_filtered_N``) and figures: the contact force
    along the track, the contact wire's uplift at the poles and the droppers' slack
    map (which dropper is slack where the pantograph is). With trailing pantographs
    (all of the above is the leading one's): ``statistics.json`` adds ``trailing``,
    one entry per trailing pantograph (``spacing_m`` and the same keys, null where it
    did not reach the evaluated spans), and ``contact_force.csv`` the columns
    ``pantograph<k>_x,pantograph<k>_contact_force_N,pantograph<k>_contact_force_filtered_N``
    of each trailing pantograph k = 2, 3, … that reached them."""
    from .models.catenary import STATISTICS_KEYS, against_ranges, pantograph_name
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    stats = {k: run.statistics[k] for k in STATISTICS_KEYS}
    if "trailing" in run.statistics:
        stats["trailing"] = run.statistics["trailing"]
    # the units convention (README, docs/scenario-format.md): the statistics' keys end
    # in their unit; what cannot carry one is in the units map
    units = {"spans_evaluated": "-", "value": "the unit of the row's key", "low": "the unit of the row's key",
             "high": "the unit of the row's key"}
    data = dict(stats, en50318_2002=against_ranges(stats), window_m=list(run.window),
                run=run.results.summary(), units=units)
    _json(out / "statistics.json", data)
    columns = dict(t=run.t, x=run.x, contact_force_N=run.force, contact_force_filtered_N=run.filtered)
    for k, behind in enumerate(run.trailing):
        if behind is not None:
            name = pantograph_name(k + 2)
            columns.update({f"{name}_x": behind.x, f"{name}_contact_force_N": behind.force,
                            f"{name}_contact_force_filtered_N": behind.filtered})
    write_csv(out / "contact_force.csv", columns, precision)
    if figures:
        plotting.pantograph_figures(run, out)
    return data
