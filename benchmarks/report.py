"""Render benchmarks/RESULTS.md (and png plots) from benchmarks/results/*.json only.

    python -m benchmarks.report [--results DIR] [--out FILE]

Every number in RESULTS.md comes from a JSON file written by a benchmark section, and
each table names the command that made it; nothing is rerun here.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from . import common
from .common import table

OUT = Path(__file__).resolve().parent / "RESULTS.md"
DEFAULT_RESULTS = Path(__file__).resolve().parent / "results"
SECTIONS = ("agreement", "single_run", "batch", "gradient", "scaling", "work_precision", "compile_time")

#: the issue's targets: (key, description, limit)
TARGETS = (
    ("m1_single", "M1 (6 el.) single run at equal accuracy, ancf_jax / Exudyn run time", 0.35),
    ("m2_single", "M2 (24 el.) single run to 2 mm, ancf_jax / Exudyn run time at its most accurate setting "
     "(none is within 2 mm)", 0.2),
    ("batch_256", "batch of 256 M1 variants: ancf_jax cost per simulation / one Exudyn run", 0.12),
    ("batch_256_gpu", "the same on the lent GPU (batch_gpu.json) / one Exudyn run on the CPU machine", 0.05),
    ("gradient", "value + gradient w.r.t. (α, β) / one forward run", 3.0),
    ("compile_m1", "compile time of M1 [s]", 3.0),
    ("compile_m2", "compile time of the three-mesh M2 batch [s]", 8.0),
    ("scaling", "per-step cost exponent p (cost ∝ n^p), 24 to 384 elements", 1.0),
    ("suite", "the test suite, README's command, 2-core machine: pytest seconds", 480.0),
)


#: written on a GPU machine by ``python -m benchmarks.batch_gpu`` (not by benchmarks.run)
EXTRA = ("batch_gpu", "batch_gpu_dense")
#: written by ``python -m benchmarks.step_profile`` (not by benchmarks.run); rendered
#: after the single runs
PROFILE = "step_profile"
#: written by ``python -m benchmarks.kernel_census`` (not by benchmarks.run); rendered
#: after the step profile
CENSUS = "kernel_census"
#: written by ``python -m benchmarks.border_elimination`` (not by benchmarks.run);
#: rendered after the kernel census
BORDER = "border_elimination"
#: written by ``python -m benchmarks.eigen_threads`` (not by benchmarks.run); rendered
#: after the border elimination
EIGEN = "eigen_threads"
#: written by ``python -m benchmarks.pantograph_catenary`` (issue 21; not by
#: benchmarks.run); rendered last, with its own targets
PANTOGRAPH = "pantograph_catenary"
#: written by ``python -m benchmarks.suite_time`` (not by benchmarks.run); rendered last
SUITE = "suite_time"
#: written by ``python -m benchmarks.suite_time --studies``; rendered after the suite
STUDIES = "studies"



def _dense(options) -> bool:
    """Whether ancf_jax ran the dense LU (``linear_solver = "dense"``; results written
    before the solver-core rewrite say ``dense = true``)."""
    options = options or {}
    return bool(options.get("dense")) or options.get("linear_solver") == "dense"

def load(results: Path) -> dict:
    out = {}
    for name in SECTIONS + EXTRA + (PROFILE, CENSUS, BORDER, EIGEN, PANTOGRAPH, SUITE, STUDIES):
        p = results / f"{name}.json"
        if p.exists():
            out[name] = json.loads(p.read_text())
    return out


def f(x, digits=3, unit=""):
    if x is None:
        return "–"
    if isinstance(x, str):
        return x
    if not math.isfinite(x):
        return "∞" if x > 0 else "–"
    return f"{x:.{digits}g}{unit}"


def ms(x):
    return "–" if x is None else f"{x * 1e3:.3g} ms"


def _quick(d):
    return " (quick)" if d.get("quick") else ""


def _source(d):
    return f"\n_Command: `{d.get('command', '?')}`{_quick(d)}; {d['stamp']['date']}._\n" if "stamp" in d else ""


def _missing(d):
    return d.get("exudyn_missing") or ("" if d.get("exudyn", True) else "Exudyn not available")


# ------------------------------------------------------------------ target evaluation
def targets(data: dict) -> list:
    """[(key, description, limit, value or None, met or None, detail)]"""
    rows = []
    sr = {r["model"]: r for r in data.get("single_run", {}).get("rows", [])}
    for key, model in (("m1_single", "M1"), ("m2_single", "M2")):
        r = sr.get(model)
        value, detail = None, "not run"
        if r is not None:
            value = r.get("ratio_run")
            if value is None:
                detail = r.get("exudyn", {}).get("missing") or _none_within(r)
            else:
                a, e = r["ancf_jax"], r["exudyn"]
                ac, ec = a["chosen"], e["chosen"]
                a_step = a["timing"]["median_run_s"] / max(1, ac["steps"])
                e_step = e["timing"]["median_run_s"] / max(1, ec["steps"])
                step_ratio = ac["steps"] / max(1, ec["steps"])
                cost_ratio = a_step / e_step if e_step else float("nan")
                what = ("per-step cost dominates" if abs(math.log(max(cost_ratio, 1e-300))) >=
                        abs(math.log(max(step_ratio, 1e-300))) else "the step count dominates")
                detail = (("Exudyn " + e["chosen_is"] + "; " if e.get("chosen_is") else "")
                          + f"steps ×{step_ratio:.3g}, cost per step ×{cost_ratio:.3g} ({what}): "
                          f"ancf_jax h = {ac['dt']:g} s, {ac['steps']} steps, "
                          f"{ac['iterations'] / max(1, ac['steps']):.2g} Newton it./step, {ms(a_step)}/step; "
                          f"Exudyn h = {ec['dt']:g} s, {ec['steps']} steps, "
                          f"{ec['iterations'] / max(1, ec['steps']):.2g} it./step, {ms(e_step)}/step")
        prof = data.get(PROFILE)
        if model == "M1" and prof and value is not None:
            us, pp = 1e6, prof["parts_s"]
            detail += (f"; profile of the step (µs, Profile of the M1 step below): residuals "
                       f"{prof['iterations_per_step'] * pp['residual'] * us:.0f}, Newton matrix and its "
                       f"factorization {prof['factorizations_per_step'] * (pp['newton_matrix'] + pp['factorization']) * us:.0f}, "
                       f"solves {prof['iterations_per_step'] * pp['solve'] * us:.0f}, powers {pp['powers'] * us:.0f}, "
                       f"control flow of the loops {(prof['control_flow_s'] + prof['run_loop_s']) * us:.0f}, of "
                       f"{prof['simulate_per_step_s'] * us:.0f}")
        census = next((dict(r, stamp=data[CENSUS]["stamp"]) for r in data.get(CENSUS, {}).get("rows", [])
                       if r["model"] == "M1" and r["elements"] == 6), None)
        if model == "M1" and value is not None and census:
            detail += (f"; the step runs {census['kernels_per_step']:.0f} XLA:CPU kernels at "
                       f"{census['iterations_per_step']:.2g} Newton it., {census['ns_per_kernel']:.0f} ns each "
                       f"on average ({census['stamp']['date'][:10]}, Kernels per step below)")
        if model == "M1" and value is not None:
            detail += _loop_kernel_target_note() + _m1_ratio_note(target=True)
        rows.append((key, value, detail))
    b = data.get("batch", {})
    value, detail = None, "not run"
    if b:
        rows_b = {r["size"]: r for r in b.get("rows", [])}
        size = 256 if 256 in rows_b else (max(rows_b) if rows_b else None)
        if size is not None and "per_simulation_ratio_vs_one_exudyn_run" in rows_b[size]:
            value = rows_b[size]["per_simulation_ratio_vs_one_exudyn_run"]
            detail = (f"batch of {size}{' (256 not run in quick mode)' if size != 256 else ''}: "
                      f"{ms(rows_b[size]['ancf_jax']['per_simulation_s'])} per simulation vs "
                      f"{ms(b['exudyn_serial']['median_run_s'])} per Exudyn run")
            if 1 in rows_b:
                one = rows_b[1]["ancf_jax"]["per_simulation_s"]
                detail += (f"; what dominates: the arithmetic of every member on "
                           f"{data['batch'].get('stamp', {}).get('cores', '?')} CPU cores. vmap amortises the "
                           f"per-operation overhead (batch of 1: {ms(one)} per simulation, "
                           f"{one / rows_b[size]['ancf_jax']['per_simulation_s']:.2g}× more) but adds no "
                           f"arithmetic units; the target needs "
                           f"{rows_b[size]['per_simulation_ratio_vs_one_exudyn_run'] / dict((k, l) for k, _, l in TARGETS)['batch_256']:.2g}× more (GPU row)")
        else:
            detail = _missing(b) or "no batch rows"
    detail += _threaded_batch_detail()
    rows.append(("batch_256", value, detail))
    rows.append(("batch_256_gpu", *_gpu_batch_target(data)))
    rows.append(("gradient", *_gradient_target(data.get("gradient", {}))))
    c = data.get("compile_time", {})
    for key, name in (("compile_m1", "m1"), ("compile_m2", "m2_batch")):
        detail = "not run"
        if c.get(name):
            detail = f"first call {f(c[name]['first_call_s'])} s"
            parts = c[name].get("parts")
            if parts:
                detail += (f"; separately: chunk program trace+lower {f(parts['chunk_lower_s'])} s + XLA "
                           f"{f(parts['chunk_xla_s'])} s, initial-state program {f(parts['init_lower_s'])} s + "
                           f"{f(parts['init_xla_s'])} s (run-once options; in a run its XLA compilation "
                           f"overlaps the chunk program's tracing)")
        rows.append((key, c.get(name, {}).get("compile_s"), detail))
    s = data.get("scaling", {})
    counts = [r["elements"] for r in s.get("rows", [])]
    detail = (f"fit over {[n for n in counts if n >= s.get('fit_from', 24)]} elements"
              + (f"; Exudyn p = {f(s['exponent'].get('exudyn'))}" if s.get("exponent", {}).get("exudyn") is not None else "")
              if s else "not run")
    p_fit = s.get("exponent", {}).get("ancf_jax") if s else None
    marginal = (s.get("marginal") or {}).get("ancf_jax") if s else None
    if marginal:
        detail += (f"; marginal cost {f(marginal['per_element_s'] * 1e6)} µs per element and step "
                   f"(cost = a + b n over n ≥ {s.get('fit_from', 24)}: a = {f(marginal['fixed_s'] * 1e6)} µs), "
                   f"local exponent {f(marginal['last_exponent'])} from {marginal['last_counts'][0]} to "
                   f"{marginal['last_counts'][1]} elements")
    per_it = [r["ancf_jax"]["per_step_s"] / r["ancf_jax"]["iterations_per_step"] / r["elements"]
              for r in s.get("rows", []) if r["elements"] >= s.get("fit_from", 24)
              and r.get("ancf_jax", {}).get("status", "ok") == "ok" and r["ancf_jax"].get("iterations_per_step")]
    if len(per_it) >= 2:
        # the cost per element and Newton iteration over the fitted counts: a trend in it is
        # growth of the work; a scatter without one is the machine's timing noise
        detail += (f"; cost per element and Newton iteration {f(min(per_it) * 1e6)}–{f(max(per_it) * 1e6)} µs "
                   f"over those counts (in count order: "
                   + ", ".join(f(x * 1e6) for x in per_it) + ")")
    prof = s.get("profiles") if s else None
    if prof and len(prof) >= 2:
        a, b = prof[0], prof[-1]
        detail += (f"; from {a['elements']} to {b['elements']} elements the step's timed parts grow "
                   f"×{b['model_s'] / a['model_s']:.2f} and the rest of the step "
                   f"×{b['control_flow_s'] / a['control_flow_s']:.2f} (profile in the section below)")
    if s and max(counts, default=0) < 384:
        # the target is about 24 to 384 elements; a fit over fewer counts says little
        detail = f"not run up to 384 elements; {detail}: p = {f(p_fit)}"
        p_fit = None
    rows.append(("scaling", p_fit, detail))
    rows.append(("suite", *_suite_target(data.get(SUITE))))
    out = []
    for (key, desc, limit), (_, value, detail) in zip(TARGETS, rows):
        met = None if value is None else value <= limit
        if key == "scaling" and met and marginal and marginal["last_exponent"] > limit:
            # the fit is under the limit, but the step grows faster than n between the two
            # largest meshes: relatively costly small meshes, not linear cost, kept the fit
            # down (the target: a per-step overhead must not make the exponent look good)
            met = False
        out.append((key, desc, limit, value, met, detail))
    return out


def _suite_target(d):
    """(pytest seconds, detail) of the suite's time (suite_time.json)."""
    if not d:
        return None, "not run (`python -m benchmarks.suite_time`)"
    top = ", ".join(f"{m['module'].removeprefix('tests/')} {m['wall_s']:.0f} s" for m in d["modules"][:6])
    detail = (f"{d['tests']} tests, {d['worker_wall_s']:.0f} s of worker time on 2 workers "
              f"({d['worker_cpu_s']:.0f} s CPU in the workers; notebooks, the sweep suite and the Exudyn "
              f"cross-check run in child processes); longest modules: {top} (section below)")
    if "worker_compile_s" in d:
        detail += (f"; what the workers' time is made of: XLA compilation {d['worker_compile_s']:.0f} s, "
                   f"lowering {d['worker_lower_s']:.0f} s, tracing {d['worker_trace_s']:.0f} s (JAX's own "
                   f"event time spans), the rest running programs, Python and waiting for child processes")
    if d.get("note"):
        detail += f"; {d['note']}"
    return d.get("pytest_s"), detail


def sec_suite(d) -> str:
    from .suite_time import markdown
    return ("## Test suite time\n\nPer test module (each runs whole in one of the two xdist workers; "
            "setup, call and teardown of every test summed):\n\n" + markdown(d)
            + f"\n_Command: `{d.get('command', 'python -m benchmarks.suite_time')}`; "
            f"{d.get('stamp', {}).get('date', '?')}._\n")


def sec_studies(d) -> str:
    from .suite_time import markdown
    return ("## Validation studies\n\nThe tests marked `study` (outside README's test command, which CI runs): "
            f"{d.get('summary', '?')}, commit "
            f"{d.get('commit') or '?'}{'; ' + d['note'] if d.get('note') else ''}.\n\n" + markdown(d)
            + f"\n_Command: `{d.get('command', 'python -m benchmarks.suite_time --studies')}`; "
            f"{d.get('stamp', {}).get('date', '?')}._\n")


def _gpu_batch_target(data):
    """(ratio, detail) of the GPU batch of 256 against one Exudyn run of batch.json; the
    ratio only where both spans are equal (no extrapolation across spans)."""
    b = data.get("batch", {})
    found = []  # (per simulation at 256, data) of each GPU run (block-tridiagonal, dense)
    for name in EXTRA:
        rows_g = {r["size"]: r for r in data.get(name, {}).get("rows", [])}
        if 256 in rows_g:
            found.append((rows_g[256]["ancf_jax"]["per_simulation_s"], data[name]))
    if not found:
        return None, "no GPU batch of 256 (python -m benchmarks.batch_gpu on a GPU machine)"
    per, g = min(found, key=lambda x: x[0])
    solver = "dense LU" if _dense(g["settings"]["ancf_jax"]["options"]) else "block-tridiagonal"
    detail = f"{g.get('device', 'GPU')}, {solver}: {ms(per)} per simulation (0–{g['t_end']:g} s)"
    ex = b.get("exudyn_serial")
    if not ex:
        return None, detail + "; no Exudyn run in batch.json"
    if abs(b["t_end"] - g["t_end"]) > 1e-12:
        return None, detail + f"; batch.json's Exudyn run spans 0–{b['t_end']:g} s: not compared"
    if not _same_settings(g, b):
        return None, detail + "; run at other ancf_jax settings than batch.json's (not equal accuracy): not compared"
    return per / ex["median_run_s"], detail + f" vs {ms(ex['median_run_s'])} per Exudyn run (CPU machine)"


def _same_settings(gpu, batch) -> bool:
    """The GPU rows ran ancf_jax at the CPU batch's step and options (dense aside), so
    both meet the same accuracy."""
    a, c = gpu["settings"]["ancf_jax"], batch.get("settings", {}).get("ancf_jax", {})
    strip = lambda o: {k: v for k, v in (o or {}).items() if k not in ("dense", "linear_solver")}  # noqa: E731
    return c.get("dt") is not None and abs(a["dt"] - c["dt"]) < 1e-15 and strip(a["options"]) == strip(c["options"])


def sec_batch_gpu(d, batch):
    """Table of the GPU batch rows (benchmarks/batch_gpu.py)."""
    solver = "dense LU" if _dense(d["settings"]["ancf_jax"]["options"]) else "block-tridiagonal solver"
    out = [f"## Batch throughput on a GPU ({d.get('device', '?')}, {solver})\n\n"
           f"{d['model']}, {d['parameters']}, 0–{d['t_end']:g} s, one vmapped program per size "
           f"(h = {d['settings']['ancf_jax']['dt']:g} s, options {d['settings']['ancf_jax']['options']}, "
           f"{d['settings']['ancf_jax']['source']}); jax {d['stamp'].get('jax')} on the {d['stamp'].get('jax_backend')} "
           f"backend, {d['stamp'].get('date')}. Command: `{d['command']}` on the lent GPU machine.\n\n"]
    ex = (batch or {}).get("exudyn_serial")
    same = ex is not None and abs(batch["t_end"] - d["t_end"]) < 1e-12 and _same_settings(d, batch)
    rows = []
    for r in d["rows"]:
        a = r["ancf_jax"]
        rows.append([r["size"], f(a["compile_s"]), f(a["median_batch_run_s"]), ms(a["per_simulation_s"]),
                     f"{a['ok']}/{r['size']}", f(a["per_simulation_s"] / ex["median_run_s"]) if same else "–"])
    out.append(table(["variants", "compile [s]", "batch run [s]", "per simulation", "ok",
                      "per sim. / one Exudyn run (CPU machine)"], rows))
    if not same:
        out.append("\nNo Exudyn run over the same span and at the same ancf_jax settings in batch.json: "
                   "the ratio column is left empty (run `python -m benchmarks.run --only batch` in the "
                   "same mode as single_run.json).\n")
    if d.get("s0"):
        out.append(_s0_batch(d["s0"]))
    return "".join(out)


def _none_within(r) -> str:
    """Which code found no settings within the tolerance, and its smallest error."""
    out = []
    for code in ("ancf_jax", "exudyn"):
        c = r.get(code, {})
        if not c.get("chosen"):
            errs = [t["error"] for t in c.get("tried", []) if t.get("status") == "ok" and math.isfinite(t["error"])]
            best = f"smallest error {f(min(errs))} m" if errs else "no completed run"
            out.append(f"{code}: no settings within {f(r.get('tolerance'))} m ({best})")
    return "; ".join(out) or "no settings within tolerance"


def _target_table(data):
    rows = []
    for key, desc, limit, value, met, detail in targets(data):
        if met is None:
            verdict = "not measured"
        elif met:
            verdict = "met"
        elif key == "scaling" and value <= limit:
            verdict = (f"missed: p = {value:.3g} ≤ {limit:g} by the fit, but the step grows faster than n "
                       "between the two largest meshes (local exponent in the next column)")
        elif key == "scaling":
            verdict = f"missed: p = {value:.3g} > {limit:g}"
        else:
            verdict = f"missed by {value / limit:.3g}×"
        rows.append([desc, f"≤ {limit:g}", f(value), verdict, detail])
    return table(["target", "limit", "measured", "verdict", "what it is made of"], rows)


# ------------------------------------------------------------------ plots
def _loglog(plt, path: Path, series, xlabel: str, ylabel: str, title: str) -> None:
    """One log-log figure: ``series`` is a list of (x, y, style, label)."""
    fig, ax = plt.subplots(figsize=(6, 4))
    for x, y, style, label in series:
        ax.loglog(x, y, style, label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _plots(data, results: Path) -> dict:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover
        return {}
    made = {}
    wp = data.get("work_precision")
    if wp and wp.get("rows"):
        series = []
        for solver in wp["solvers"]:
            pts = [(r["run_s"], r["error"]) for r in wp["rows"] if r["solver"] == solver
                   and r["status"] == "ok" and math.isfinite(r["error"]) and r["error"] > 0]
            if pts:
                series.append((*zip(*sorted(pts)), "o-", solver))
        _loglog(plt, results / "work_precision.png", series, "run time [s]",
                "max |tip Y − reference| [m]", f"M1 work–precision, 0–{wp['t_end']:g} s{_quick(wp)}")
        made["work_precision"] = "results/work_precision.png"
    sc = data.get("scaling")
    if sc and sc.get("rows"):
        series = []
        for code in ("ancf_jax", "exudyn"):
            pts = [(r["elements"], r[code]["per_step_s"]) for r in sc["rows"] if code in r]
            if pts:
                series.append((*zip(*pts), "o-", code))
        _loglog(plt, results / "scaling.png", series, "elements", "run time per step [s]",
                f"M1 per-step cost{_quick(sc)}")
        made["scaling"] = "results/scaling.png"
    bt = data.get("batch")
    if bt and bt.get("rows"):
        sizes = [r["size"] for r in bt["rows"]]
        series = [(sizes, [r["ancf_jax"]["per_simulation_s"] for r in bt["rows"]], "o-", "ancf_jax vmap")]
        if all("exudyn" in r for r in bt["rows"]):
            series += [(sizes, [r["exudyn"]["serial_per_simulation_s"] for r in bt["rows"]], "s--",
                        "Exudyn serial"),
                       (sizes, [r["exudyn"]["pool_per_simulation_s"] for r in bt["rows"]], "^-",
                        "Exudyn pool")]
        _loglog(plt, results / "batch.png", series, "batch size", "wall time per simulation [s]",
                f"M1 variants{_quick(bt)}")
        made["batch"] = "results/batch.png"
    return made


# ------------------------------------------------------------------ sections
def _error_block(d):
    return f"**This section failed:** `{d['error']}`\n" if d.get("error") else ""


def sec_agreement(d):
    out = ["## Agreement before timing\n\n", _error_block(d)]
    if _missing(d):
        out.append(f"Exudyn rows: {_missing(d)}.\n")
    rows = [[r["model"], r["n_elements"], r["exudyn_variant"], f"{r['t_compared']:.2f}", r["compared_output"],
             f(r["max_distance_m"]), r["ancf"]["status"], r["exudyn"]["status"]] for r in d.get("rows", [])]
    if rows:
        out.append("Identical settings in both codes (h = 1 ms, ρ∞ = 0.9, full Newton, tight tolerances); "
                   "maximum over the compared span of the distance between the codes.\n\n")
        out.append(table(["model", "elements", "Exudyn", "span [s]", "output", "max difference [m]",
                          "ancf_jax", "Exudyn"], rows))
    out.append(_source(d))
    return "".join(out)


def _m1_ratio_note(target: bool = False) -> str:
    """The latest re-measurement of M1's single-run ratio (benchmarks/m1_ratio.py), if
    any: a paragraph of the single-run section, or (``target``) a clause of the M1
    target row."""
    path = Path(__file__).parent / "results" / "m1_ratio.json"
    if not path.exists():
        return ""
    m = json.loads(path.read_text())
    median = f"median {m['pair_ratio_median']:.2f}, " if "pair_ratio_median" in m else ""
    spread = (f"; the pairs' own ratios {median}{m['pair_ratio_quartiles'][0]:.2f}–{m['pair_ratio_quartiles'][1]:.2f} "
              "(quartiles)" if "pair_ratio_quartiles" in m else "")
    if target:
        return (f"; re-measured {m['stamp']['date'][:10]} on {m['stamp'].get('machine', '?')} "
                f"(`PYTHONPATH=. python benchmarks/m1_ratio.py`, same settings, interleaved): "
                f"**{m['ratio']:.2f}** ({m['ancf_run_s']:.3f} s against {m['exudyn_run_s']:.3f} s{spread})")
    return (f"Re-measured on {m['stamp']['date'][:10]} (`PYTHONPATH=. python benchmarks/m1_ratio.py`: the "
            f"settings below, interleaved, median of {m.get('reps', 5)}): ancf_jax {m['ancf_run_s']:.3f} s "
            f"against Exudyn {m['exudyn_run_s']:.3f} s, ratio {m['ratio']:.2f}{spread}.\n\n")


def _loop_kernels() -> dict | None:
    path = Path(__file__).parent / "results" / "loop_kernels.json"
    return json.loads(path.read_text()) if path.exists() else None


def _loop_kernel_target_note() -> str:
    """The M1 ratio with loop kernels (benchmarks/loop_kernels.py), for the target row."""
    m = _loop_kernels()
    if not m or "m1_ratio_loop_kernels" not in m or m.get("quick"):
        return ""
    row = m["rows"][0]
    return (f". **With loop kernels** (opt-in `ANCF_JAX_LOOP_KERNELS=1`, Loop kernels below): "
            f"**{m['m1_ratio_loop_kernels']:.2f}** (met; default {m['m1_ratio_default']:.2f} in the same run), "
            f"at a first-call compile of {row['loop_kernels']['compile_s']:.1f} s instead of "
            f"{row['default']['compile_s']:.1f} s, so off by default")


def sec_loop_kernels(m) -> str:
    out = ["### Loop kernels (opt-in)\n\n",
           "`ANCF_JAX_LOOP_KERNELS=1` (ancf_jax/_xla.py) lets XLA:CPU compile a small model's Newton "
           "loop into one kernel instead of dispatching a kernel per fusion; small LUs then avoid LAPACK. "
           "Fresh processes, no compilation cache, each model at single_run's ancf_jax settings, output at "
           f"every step, median of {m['reps']} runs:\n\n"]
    rows = []
    for r in m["rows"]:
        d, k = r["default"], r["loop_kernels"]
        rows.append([f"{r['model']} ({r['elements']} el., 0–{r['t_end']:g} s)", f"{d['run_s']:.4f}",
                     f"{k['run_s']:.4f}", f"{r['run_ratio']:.2f}", f"{d['compile_s']:.2f}", f"{k['compile_s']:.2f}",
                     f"{r['max_difference_m']:.1e}"])
    out.append(table(["model", "run, default [s]", "run, loop kernels [s]", "run ratio", "compile, default [s]",
                      "compile, loop kernels [s]", "max output difference [m]"], rows) + "\n")
    if "exudyn_m1" in m:
        e = m["exudyn_m1"]
        out.append(f"Exudyn M1 at its chosen settings (h = {e['dt']:g} s), median of {len(e['runs_s'])} runs "
                   f"before and after the children: {e['run_s']:.4f} s; ancf_jax / Exudyn: default "
                   f"{m['m1_ratio_default']:.3f}, loop kernels {m['m1_ratio_loop_kernels']:.3f}.\n\n")
    out.append(f"_Command: `python -m benchmarks.loop_kernels`; {m['stamp']['date']}._\n")
    return "".join(out)


#: share of the step below which eliminating fixed coordinates is not worth building
BORDER_WORTH = 0.05


def sec_border_elimination(m) -> str:
    """The fixed coordinates' elimination measured (benchmarks/border_elimination.py);
    the verdict from the numbers: worth building where the reduced solve would save
    :data:`BORDER_WORTH` of the bare step or more."""
    t, us = m["timings"], 1e6
    rows = [[name, f"{t[name]['single_s'] * us:.2f}", f"{t[name]['batch_member_s'] * us:.2f}"]
            for name in ("full", "reduced", "eliminated")]
    step, bound, net = m["bare_step_s"], m["saving_bound_single_s"], m["saving_single_s"]
    share = bound / step
    verdict = (f"not built: the reduced solve would save {share:.1%} of the step, below {BORDER_WORTH:.0%} "
               "(README, Performance: a version built in the solver ran no faster)" if share < BORDER_WORTH
               else f"worth building: the reduced solve would save {share:.1%} of the step")
    this = (f"saves {net * us:.2f} µs against" if net > 0 else f"costs {-net * us:.2f} µs more than") + " the full solve"
    member = m["saving_batch_member_s"]
    this_b = (f"{member * us:.2f} µs less" if member > 0 else f"{-member * us:.2f} µs more") + " per batch member"
    return ("### Fixed coordinates eliminated from the Newton solve\n\n"
            f"{m['model']} ({m['elements']} el.): the clamp's selection rows of Φ_q taken out of the border "
            f"({m['border']} → {m['border_reduced']} border unknowns; chain positions "
            f"{m['fixed_chain_positions']} kept as identity rows, reactions recovered from the chain rows). "
            f"The eliminated solve equals the full one to {m['relative_difference']:.1e} (relative). "
            "Per step (one factorization of a matrix that changes every call, two solves), best of dependent "
            f"calls in one loop, and per member of a vmapped batch of {m['batch']}:\n\n"
            + table(["solve", "one run [µs per step]", f"batch of {m['batch']} [µs per member-step]"], rows)
            + f"\nBest of {m.get('rounds', 1)} interleaved rounds. The reduced system alone is {bound * us:.2f} µs "
            f"faster per step than the full solve ({(t['full']['batch_member_s'] - t['reduced']['batch_member_s']) * us:.2f} "
            "µs per batch member), against a "
            f"bare step of {step * us:.1f} µs in the same process (`benchmarks.step_profile`'s bare step, from the "
            f"initial state); the elimination as written here {this} ({this_b}). Verdict: {verdict}.\n\n"
            f"_Command: `{m['command']}`; {m['stamp']['date']}._\n")


def sec_eigen_threads(m) -> str:
    """Eigen's thread pool in XLA:CPU's dot calls, on against off
    (benchmarks/eigen_threads.py); speed-up = median with the pool / median without."""
    rows = []
    for r in m["rows"]:
        on, off = r["median_s"]["on"] * 1e3, r["median_s"]["off"] * 1e3  # all units are ms
        digits = 3 if off < 10 else 1
        rows.append([r["case"], r["unit"], f"{on:.{digits}f}", f"{off:.{digits}f}", f"{r['speedup']:.2f}",
                     "–" if "max_dq_m" not in r else f"{r['max_dq_m']:.1e}"])
    return ("### Eigen's threads in XLA's dot calls\n\n"
            f"`{m['option']}` on (XLA's default) and off (ancf_jax's default since 2026-12-08, `ancf_jax/_xla.py`), "
            "each case compiled both ways in one process as per-program compiler options and run interleaved; "
            f"medians of {m['reps']} rounds"
            + "".join(f" ({r['case']}: of {r['rounds']})" for r in m["rows"] if "rounds" in r) + ":\n\n"
            + table(["case", "unit", "on", "off", "speed-up (on / off)", "largest Δq [m]"], rows)
            + f"\n_Command: `{m['command']}`; {m['stamp']['date']}._\n")


def sec_single(d):
    out = ["## Single runs at equal accuracy\n\n", _m1_ratio_note(), _error_block(d)]
    for r in d.get("rows", []):
        out.append(f"\n### {r['model']}, {r['n_elements']} elements, 0–{r['t_end']:g} s\n\n"
                   f"Tolerance: {r['error_measure']} ≤ {r['tolerance']:g}. Reference: ancf_jax, "
                   f"h = {r['reference']['dt']:g} s, full Newton (its error against 2h: "
                   f"{f(r['reference']['error_estimate'])} m).\n\n")
        rows = []
        for code in ("ancf_jax", "exudyn"):
            c = r.get(code, {})
            if c.get("missing"):
                rows.append([code, c["missing"], "", "", "", "", ""])
                continue
            ch = c.get("chosen")
            if not ch:
                rows.append([code, "no tried setting within tolerance", "", "", "", "", ""])
                continue
            t = c["timing"]
            setup = (f"compile {f(t['compile_s'])} s (once)" if code == "ancf_jax"
                     else f"build {f(t['median_setup_s'])} s (every run)")
            what = f" ({c['chosen_is']})" if c.get("chosen_is") else ""
            rows.append([code, f"h = {ch['dt']:g} s, {ch['options']}{what}", f(ch["error"]), ch["steps"],
                         ch["iterations"], f"{f(t['median_run_s'])} s ({t['reps']} reps)", setup])
        out.append(table(["code", "fastest settings within tolerance", "error [m]", "steps", "Newton it.",
                          "median run time", "setup"], rows))
        if r.get("ratio_run") is not None:
            out.append(f"\nancf_jax / Exudyn median run time: **{r['ratio_run']:.3g}**.\n")
        tried = []
        for code in ("ancf_jax", "exudyn"):
            for t in r.get(code, {}).get("tried", []):
                tried.append([code, f"{t['dt']:g}", t["options"], t["status"], f(t["error"]), f(t["run_s"])])
        if tried:
            out.append("\n<details><summary>settings tried</summary>\n\n"
                       + table(["code", "h [s]", "options", "status", "error [m]", "run [s]"], tried)
                       + "\n</details>\n")
    out.append(_source(d))
    return "".join(out)


def sec_step_profile(d):
    """Where the time of one M1 step goes (benchmarks/step_profile.py)."""
    us = 1e6
    p = d["parts_s"]
    it, nf = d["iterations_per_step"], d["factorizations_per_step"]
    rows = [["residual (M q̈ − Q + Φ_qᵀλ, Φ)", f"{p['residual'] * us:.3g}", f"× {it:.2f} it.",
             f"{it * p['residual'] * us:.3g}"],
            ["Newton solve with the factors", f"{p['solve'] * us:.3g}", f"× {it:.2f} it.",
             f"{it * p['solve'] * us:.3g}"],
            ["Newton matrix (Φ_q, element tangents, assembly)", f"{p['newton_matrix'] * us:.3g}",
             f"× {nf:.2f} fact.", f"{nf * p['newton_matrix'] * us:.3g}"],
            ["its factorization", f"{p['factorization'] * us:.3g}", f"× {nf:.2f} fact.",
             f"{nf * p['factorization'] * us:.3g}"],
            ["energy-balance powers", f"{p['powers'] * us:.3g}", "× 1", f"{p['powers'] * us:.3g}"],
            ["**sum of the parts**", "", "", f"**{d['model_s'] * us:.3g}**"],
            ["control flow of the step (Newton loop, bookkeeping): bare step − sum", "", "",
             f"{d['control_flow_s'] * us:.3g}"],
            ["**bare step** (`lax.scan` of the step)", "", "", f"**{d['bare_step_s'] * us:.3g}**"],
            ["run loop (status checks, outputs, chunks): simulate − bare step", "", "",
             f"{d['run_loop_s'] * us:.3g}"],
            ["**simulate**, per step", "", "", f"**{d['simulate_per_step_s'] * us:.3g}**"]]
    return (f"### Profile of the M1 step\n\nM1, {d['elements']} elements ({d['coordinates']} coordinates, "
            f"{d['multipliers']} multipliers), h = {d['h']:g} s, {d['options']} (single_run's choice), "
            f"0–{d['t_end']:g} s: {it:.2f} Newton iterations and {nf:.2f} factorizations per step. Each part "
            "jitted alone in a loop of calls on changing input, best of 5 (µs):\n\n"
            + table(["part", "per call [µs]", "calls per step", "per step [µs]"], rows)
            + f"\n_Command: `python -m benchmarks.step_profile`; {d['stamp']['date']}._\n")


def sec_kernel_census(d, top=8):
    """How many XLA:CPU kernels a step runs (benchmarks/kernel_census.py)."""
    rows = []
    for r in d["rows"]:
        kinds = ", ".join(f"{k} {c:.0f}" for k, c in list(r["kinds"].items())[:top])
        rows.append([f"{r['model']} ({r['elements']} el., {r['coordinates']} coord.)", f"{r['iterations_per_step']:.2f}",
                     f"{r['kernels_per_step']:.0f}", f"{r['kernels_per_iteration']:.0f}",
                     f"{r['step_s'] * 1e6:.3g}", f"{r['ns_per_kernel']:.0f}", kinds])
    return ("### Kernels per step\n\nXLA:CPU runs a compiled program as a sequence of kernels dispatched one "
            "after the other, a while loop's body at every iteration. Counted exactly from the trace of "
            f"`{d['flag']}` (one event per kernel run), bare generalized-α step (`lax.scan` of the step, "
            "single_run's settings, from the initial state); the step's time from a second fresh process "
            "without the flag (best of 5); per iteration: kernels per step / Newton iterations per step; "
            "time per kernel: step time / kernels:\n\n"
            + table(["model", "Newton it./step", "kernels per step", "per iteration", "step [µs]",
                     "ns per kernel", f"most frequent kinds (per step, first {top})"], rows)
            + f"\n_Command: `{d['command']}`; {d['stamp']['date']}._\n")


def _threaded_batch_detail() -> str:
    """The same batch as threads of single runs (batch_threads*.json), for the target
    row: the verdict stays on the vmapped batch the target names."""
    results = Path(__file__).parent / "results"
    parts = []
    for name, how in (("batch_threads", "threads of single runs (`simulate_each`)"),
                      ("batch_threads_loop_kernels", "with loop kernels on (opt-in)")):
        path = results / f"{name}.json"
        if path.exists():
            m = json.loads(path.read_text())
            parts.append(f"{how} {f(m['ratio_to_one_exudyn_run']['two_threads'])} "
                         f"({ms(m['per_simulation_s']['two_threads'])} per simulation, {m['members']} members)")
    return ("; the same variants as " + ", ".join(parts) + " (batch_threads)") if parts else ""


def _batch_threads_note() -> str:
    """The CPU batch as threads of single runs (benchmarks/batch_threads.py), if measured:
    with XLA's default flags and, where measured, with loop kernels on."""
    results = Path(__file__).parent / "results"
    out = []
    for name, how in (("batch_threads", ""), ("batch_threads_loop_kernels",
                                             " with loop kernels on (`ANCF_JAX_LOOP_KERNELS=1`, opt-in)")):
        path = results / f"{name}.json"
        if not path.exists():
            continue
        m = json.loads(path.read_text())
        p, r = m["per_simulation_s"], m["ratio_to_one_exudyn_run"]
        env = "ANCF_JAX_LOOP_KERNELS=1 " if m.get("loop_kernels") else ""
        out.append(f"\nThe same variants as single runs over threads{how} (`simulate_each`, "
                   f"`{env}python -m benchmarks.batch_threads`, {m['stamp']['date'][:10]}, first {m['members']} "
                   f"members, one process): {ms(p['two_threads'])} per simulation in two threads against "
                   f"{ms(p['vmapped'])} vmapped and {ms(p['sequential'])} one after the other; per simulation / "
                   f"one Exudyn run ({ms(m['exudyn_run_s'])}, same process) {f(r['two_threads'])} (vmapped "
                   f"{f(r['vmapped'])}).\n")
    if out:
        out.append("On the CPU a vmapped member costs more than a single run; the threads use both cores.\n")
    return "".join(out)


def sec_batch(d, plots):
    out = ["## Batch throughput (M1 variants; M2 s₀ variants)\n\n", _error_block(d)]
    if d.get("rows"):
        out.append(f"{d['model']}, {d['parameters']}, 0–{d['t_end']:g} s. ancf_jax: one vmapped program "
                   f"(h = {d['settings']['ancf_jax']['dt']:g} s, {d['settings']['ancf_jax']['source']}); "
                   f"Exudyn: h = {d['settings']['exudyn']['dt']:g} s "
                   f"({d['settings']['exudyn']['source']}).\n\n")
        rows = []
        for r in d["rows"]:
            a, e = r["ancf_jax"], r.get("exudyn")
            row = [r["size"], f(a["compile_s"]), f(a["median_batch_run_s"]), ms(a["per_simulation_s"]),
                   f"{a['ok']}/{r['size']}"]
            if e:
                row += [f(e["serial_total_s"]) + (" (extrapolated)" if e["serial_extrapolated"] else ""),
                        f(e["pool_total_s"]) + f" ({e['pool_workers']} proc.)",
                        f(r["per_simulation_ratio_vs_one_exudyn_run"])]
            else:
                row += [_missing(d), "", ""]
            rows.append(row)
        out.append(table(["variants", "ancf_jax compile [s]", "ancf_jax batch run [s]", "per simulation",
                          "ok", "Exudyn serial [s]", "Exudyn pool [s]", "ancf_jax per sim. / one Exudyn run"],
                         rows))
        if d.get("exudyn_serial"):
            s = d["exudyn_serial"]
            out.append(f"\nOne Exudyn run: {f(s['median_run_s'])} s (median of {s['measured']}; "
                       f"{f(s['median_run_plus_build_s'])} s with the model build). Final tip Y of the "
                       f"serial Exudyn runs vs the ancf_jax batch members: max {f(s['final_tip_y_max_difference_to_ancf_m'])} m. "
                       f"Pool start-up: {f(d['exudyn_pool']['startup_s'])} s (not included).\n")
        out.append(_batch_threads_note())
        if "batch" in plots:
            out.append(f"\n![batch]({plots['batch']})\n")
    if d.get("s0"):
        out.append(_s0_batch(d["s0"]))
    out.append(_source(d))
    return "".join(out)


def _s0_batch(s):
    """Table of the M2 s₀ batch (see benchmarks/batch.py)."""
    out = [f"\n### M2 variants of the trolley start s₀\n\n{s['model']}, {s['parameters']}, "
           f"0–{s['t_end']:g} s, h = {s['dt']:g} s in both codes (ancf_jax options {s['solver_options']}); "
           "every variant starts from its own static equilibrium (solved before timing).\n\n"]
    rows = []
    for r in s["rows"]:
        a, e = r["ancf_jax"], r.get("exudyn")
        rows.append([r["size"], f(a["compile_s"]), f(a["batch_run_s"]), ms(a["per_simulation_s"]),
                     f"{a['ok']}/{r['size']}",
                     ms(e["median_run_s"]) if e else "not run", f"{e['ok']}/{r['size']}" if e else "",
                     (f(e["final_point1_max_difference_to_ancf_m"])
                      + (f" ({e['compared']} ok in both)" if "compared" in e else "")) if e else "",
                     f(r["per_simulation_ratio_vs_one_exudyn_run"]) if e else ""])
    out.append(table(["variants", "ancf_jax compile [s]", "ancf_jax batch run [s]", "per simulation", "ok",
                      "one Exudyn run", "Exudyn ok", "final point 1 max diff [m]",
                      "ancf_jax per sim. / one Exudyn run"], rows))
    failed = max((r["ancf_jax"].get("failed", []) for r in s["rows"]), key=len, default=[])
    if failed:
        out.append("\nancf_jax members that stopped (largest batch): "
                   + "; ".join(f"s₀ = {x['s0']:.3f} m: {x['status']} at t = {x['time_s']:.3g} s" for x in failed)
                   + ". A stopped member keeps its last state (reported, never silently continued).\n")
    if s.get("command"):
        out.append(f"\n_s₀ rows: `{s['command']}`._\n")
    return "".join(out)


def _gradient_target(g):
    """(ratio, detail) of the gradient target: at equal accuracy when the refinement
    sweep found a setting within tolerance, else at the solver's defaults."""
    if not g or "median_forward_s" not in g:
        return None, f"section failed: {g['error']}" if g.get("error") else "not run"
    detail = (f"forward {f(g['median_forward_s'])} s, value+grad {f(g['median_value_and_grad_s'])} s "
              f"(default tangent solves)")
    fm = g.get("ratio_forward_mode_to_forward")
    fm_detail = ("" if fm is None else
                 f"; forward mode (one JVP per parameter, vmapped; the identification fit's jacfwd) "
                 f"{f(g['median_forward_mode_s'])} s at the default tangent solves, x{f(fm)}")
    if g.get("ratio_at_equal_accuracy") is None:
        ratio = g.get("ratio_value_and_grad_to_forward")
        return (ratio if fm is None else min(ratio, fm)), detail + fm_detail
    row = next(r for r in g["refinement_sweep"] if r["refinement"] == g["chosen_refinement"])
    if row["refinement"] == "exact":
        how = ("the exact Newton matrix (with the β-rate term the iteration's matrix leaves out) factored "
               "at the step's solution, 1 solve")
    else:
        how = (f"the iteration's Newton matrix factored at the step's solution ({row['refinement'] + 1} solves, "
               f"{row['refinement']} residual linearizations kept for the backward pass)")
    default = next((r for r in g["refinement_sweep"] if r["default"]), None)

    def label(r):
        return "the exact tangent matrix" if r["refinement"] == "exact" else f"refinement {r['refinement']}"
    detail = (f"at equal accuracy (gradient within {g['gradient_tolerance']:g} of the most refined): "
              f"{label(row)}, value+grad {f(row['median_value_and_grad_s'])} s, forward "
              f"{f(g['median_forward_s'])} s; every step's tangent system is solved with {how}; "
              + ("the default" if row["default"] else
                 f"at the default ({'–' if default is None else label(default)}) "
                 f"{f(g['ratio_value_and_grad_to_forward'])}") + fm_detail)
    unrefined = next((r for r in g["refinement_sweep"] if r["refinement"] == 0), None)
    if unrefined is not None and unrefined is not row:
        detail += (f"; the iteration's matrix without refinement x{f(unrefined['ratio_to_forward'])}, but "
                   f"{unrefined['rel_difference_to_reference']:.1e} off: it leaves out the rate term of β "
                   f"(set after the build; with the term, the forward iteration would be slower)")
    ratio = g["ratio_at_equal_accuracy"]
    return (ratio if fm is None else min(ratio, fm)), detail


def sec_gradient(d):
    out = ["## Gradient of the identification loss\n\n", _error_block(d)]
    if "median_forward_s" in d:
        out.append(f"Loss: {d['loss']} (`ancf_jax.identification` "
                   f"{'present' if d['identification_module_available'] else 'absent'} when run). "
                   f"M1, 0–{d['t_end']:g} s, h = {d['dt']:g} s, at (α, β) = {tuple(d['theta0'])}.\n")
        if d.get("dt_tried"):
            out.append("`trajectory` has no step retries (reverse mode), so the step is halved from the "
                       "equal-accuracy one until the runs complete: "
                       + ", ".join(f"h = {t['dt']:g} s: {'ok' if all(x == 0 for x in t['status']) else 'Newton failure'}"
                                   for t in d["dt_tried"]) + ".\n")
        out.append("\n")
        rows = [["forward (loss value)", f(d["compile_forward_s"]), f(d["median_forward_s"]), "1"],
                ["value + gradient (jax.value_and_grad)", f(d["compile_value_and_grad_s"]),
                 f(d["median_value_and_grad_s"]), f(d["ratio_value_and_grad_to_forward"])],
                ["gradient by central differences (4 forward)", "(forward's)", f(d["median_finite_differences_s"]),
                 f(d["ratio_fd_to_forward"])]]
        if "median_forward_mode_s" in d:
            rows.insert(2, ["value + gradient by forward mode (a JVP per parameter, vmapped)",
                            f(d["compile_forward_mode_s"]), f(d["median_forward_mode_s"]),
                            f(d["ratio_forward_mode_to_forward"])])
        if d.get("exudyn_forward"):
            e = d["exudyn_forward"]
            rows.append([f"Exudyn forward run (h = {e['dt']:g} s; {e['note']})", "–",
                         f(e["median_run_s"]), f(e["median_run_s"] / d["median_forward_s"])])
        else:
            rows.append(["Exudyn", _missing(d), "", ""])
        out.append(table(["what", "compile [s]", "median run [s]", "/ forward"], rows))
        out.append(f"\nGradient (AD): {[f(g, 6) for g in d['gradient']]}; central differences: "
                   f"{[f(g, 6) for g in d['gradient_fd']]}; relative difference "
                   f"{[f(x, 2) for x in d['gradient_rel_difference']]}"
                   + (f"; forward mode against reverse mode: {f(d['forward_mode_rel_difference_to_reverse'], 2)}"
                      if "forward_mode_rel_difference_to_reverse" in d else "") + ".\n")
        if d.get("refinement_sweep"):
            sweep = d["refinement_sweep"]
            out.append(f"\nIterative refinement of the tangent solves (equal accuracy: each gradient component "
                       f"within {d['gradient_tolerance']:g} of the refinement-{sweep[-1]['refinement']} "
                       f"gradient):\n\n")
            out.append(table(["refinement", "compile [s]", "median value+grad [s]", "/ forward",
                              "max relative difference to the most refined", "chosen"],
                             [[f"{r['refinement']}{' (default)' if r['default'] else ''}", f(r["compile_s"]),
                               f(r["median_value_and_grad_s"]), f(r["ratio_to_forward"]),
                               "reference" if r is sweep[-1] else f(r["rel_difference_to_reference"], 2),
                               "✓" if r["refinement"] == d.get("chosen_refinement") else ""]
                              for r in sweep]))
    out.append(_source(d))
    return "".join(out)


def _scaling_profiles(profiles) -> str:
    """The steps of the largest counts taken apart (benchmarks/step_profile.profile),
    per step [ms], and how each part grows from the first profiled count to the last."""
    def parts(p):
        q, it, nf = p["parts_s"], p["iterations_per_step"], p["factorizations_per_step"]
        return {"residuals": it * q["residual"], "solves": it * q["solve"],
                "Newton matrix + factorization": nf * (q["newton_matrix"] + q["factorization"]),
                "powers": q["powers"], "sum of the parts": p["model_s"],
                "the rest of the step (bare step − parts)": p["control_flow_s"],
                "bare step": p["bare_step_s"], "run loop (simulate − bare step)": p["run_loop_s"],
                "simulate": p["simulate_per_step_s"]}
    cols = [parts(p) for p in profiles]
    head = ["per step [ms]"] + [f"{p['elements']} el. ({p['iterations_per_step']:.2f} it., "
                                f"{p['factorizations_per_step']:.2f} fact.)" for p in profiles]
    rows = [[k] + [f"{c[k] * 1e3:.3g}" for c in cols] for k in cols[0]]
    if len(profiles) >= 2:
        head.append(f"× from {profiles[0]['elements']} to {profiles[-1]['elements']}")
        for r, k in zip(rows, cols[0]):
            r.append(f"{cols[-1][k] / cols[0][k]:.2f}" if cols[0][k] > 0 else "–")
    return ("\nThe steps of the two largest meshes taken apart (`benchmarks.step_profile.profile`: each part "
            "jitted alone in a loop of calls, best of 5, at the run's state at mid-span; iterations and "
            "factorizations per step as the run took them):\n\n" + table(head, rows))


def sec_scaling(d, plots):
    out = ["## Per-step cost against element count\n\n", _error_block(d)]
    if d.get("rows"):
        out.append(f"M1, h = {d['dt']:g} s, 0–{d['t_end']:g} s, each code with its default settings.\n\n")
        rows = []
        for r in d["rows"]:
            st = lambda c: "" if r[c].get("status", "ok") == "ok" else f" ({r[c]['status']})"  # noqa: E731
            row = [r["elements"], ms(r["ancf_jax"]["per_step_s"]) + st("ancf_jax"),
                   f(r["ancf_jax"]["iterations_per_step"], 2),
                   f(r["ancf_compile_s"]) if r["ancf_compile_s"] > 0 else "cached (earlier section)"]
            row += ([ms(r["exudyn"]["per_step_s"]) + st("exudyn"), f(r["exudyn"]["iterations_per_step"], 2),
                     r.get("exudyn_newton", "modified")]
                    if "exudyn" in r else
                    [f"not run (above {d['exudyn_max']} elements)" if d.get("exudyn_max") and d.get("exudyn")
                     and r["elements"] > d["exudyn_max"] else _missing(d), "", ""])
            rows.append(row)
        out.append(table(["elements", "ancf_jax per step", "ancf_jax it./step", "ancf_jax compile [s]",
                          "Exudyn per step", "Exudyn it./step", "Exudyn Newton"], rows))
        ex = d.get("exponent", {})
        out.append(f"\nFitted exponent (n ≥ {d['fit_from']}): ancf_jax {f(ex.get('ancf_jax'))}, "
                   f"Exudyn {f(ex.get('exudyn')) if 'exudyn' in ex else _missing(d)}.\n")
        mg = (d.get("marginal") or {}).get("ancf_jax")
        if mg:
            out.append(f"\nMarginal cost of ancf_jax (cost = a + b n, least squares over n ≥ {d['fit_from']}): "
                       f"b = {f(mg['per_element_s'] * 1e6)} µs per element and step, fixed part a = "
                       f"{f(mg['fixed_s'] * 1e6)} µs per step; local exponent between {mg['last_counts'][0]} "
                       f"and {mg['last_counts'][1]} elements {f(mg['last_exponent'])} (where the fixed part "
                       "matters least).\n")
        if d.get("profiles"):
            out.append(_scaling_profiles(d["profiles"]))
        if "scaling" in plots:
            out.append(f"\n![scaling]({plots['scaling']})\n")
    out.append(_source(d))
    return "".join(out)


def sec_wp(d, plots):
    out = ["## Work–precision of the ancf_jax solvers\n\n", _error_block(d)]
    if d.get("rows"):
        out.append(f"{d['model']}, 0–{d['t_end']:g} s; error: {d['error_measure']}; reference "
                   f"generalized-α h = {d['reference']['dt']:g} s (error estimate "
                   f"{f(d['reference']['error_estimate'])} m).\n\n")
        floor = 3 * d["reference"]["error_estimate"]
        out.append(f"Errors below 3× the reference's own error estimate ({f(floor)} m) only say "
                   "\"at least as accurate as the reference\" (marked ≤).\n\n")
        rows = [[r["solver"], f"h = {r['dt']:g} s" if "dt" in r else f"rtol = {r['rtol']:g}", r["status"],
                 ("≤ " if r["error"] < floor else "") + f(r["error"]), f(r["run_s"]), r["steps"],
                 f(r["compile_s"]) if r["compile_s"] > 0 else "cached"] for r in d["rows"]]
        out.append(table(["solver", "setting", "status", "error [m]", "run [s]", "steps", "compile [s]"], rows))
        if "work_precision" in plots:
            out.append(f"\n![work-precision]({plots['work_precision']})\n")
    out.append(_source(d))
    return "".join(out)


def sec_compile(d):
    out = ["## Compile time (fresh process)\n\n", _error_block(d)]
    if d.get("m1"):
        rows = [["M1, 6 elements, simulate", f(d["m1"]["compile_s"]), f(d["m1"]["first_call_s"])],
                [f"M2 batch {tuple(d['m2_counts'])} padded, simulate_batch", f(d["m2_batch"]["compile_s"]),
                 f(d["m2_batch"]["first_call_s"])]]
        out.append(table(["program", "compile [s]", "first call incl. compile [s]"], rows))
    out.append(_source(d))
    return "".join(out)


def pantograph_targets(d) -> list:
    """Issue 21's targets from pantograph_catenary.json: [target, limit, measured,
    verdict, what it is made of]."""
    rows = []
    full = {r["statistics"]["speed_kmh"]: r for r in d.get("full", {}).get("runs", [])}
    r = full.get(250.0)
    if r:
        end_to_end = (r["build_and_statics_s"] + r["compile_s"] + r["wall_s"]) / r["simulated_s"]
        rows.append(["real-time factor of the full 10-span run at 250 km/h (wall / simulated time, 2 cores)",
                     "≤ 10", f"{r['real_time_factor']:.2f}", "met" if r["real_time_factor"] <= 10 else "missed",
                     f"time stepping: {r['wall_s']:.1f} s for {r['simulated_s']:.2f} s, {r['steps']} steps; "
                     f"without the build and static solve ({r['build_and_statics_s']:.1f} s) and the compile "
                     f"({r['compile_s']:.1f} s): end to end {end_to_end:.1f}"
                     + (f"; 300 km/h: {full[300.0]['real_time_factor']:.2f}" if 300.0 in full else "")])
    else:
        rows.append(["real-time factor of the full run at 250 km/h", "≤ 10", "–", "not measured", "not run"])
    s = d.get("scaling_shipped") or d.get("scaling")
    if s:
        e = [x["elements"] for x in s["runs"]]
        where = ("at the shipped step and solver" if "scaling_shipped" in d else
                 "at h = 1 ms with factors every step, not the shipped 2 ms / factors carried up to 16 steps / "
                 "tolerance 1e-7 m (`python -m benchmarks.pantograph_catenary scaling_shipped`)")
        rows.append(["cost per step ∝ elements^p, up to ≥ 2,400 elements", "p ≤ 1", f"{s['exponent']:.2f}",
                     ("met" if s["exponent"] <= 1 and max(e) >= 2400 else "missed") if "scaling_shipped" in d
                     else "measured at other settings",
                     f"{e} elements {where}; marginal cost {s['marginal_us_per_element']:.1f} µs per element-step"])
    for part, model in (("batch_full", "shipped 10-span model"), ("batch", "reduced catenary (3 × 10 m): "
                                                                           "not the full model")):
        b = d.get(part)
        if b:
            rows.append([f"vmapped batch of {len(b['speeds_kmh'])} speeds against as many single runs", "reported",
                         f"{b['batch_wall_s']:.1f} s vs {b['singles_wall_s']:.1f} s", "reported",
                         f"{model}, {b['steps']} steps; results equal to {b['max_q_difference_m']:.0e} m"])
            break
    for v, r in sorted(full.items()):
        verdicts = r.get("en50318_2002") or []
        inside = [x["key"] for x in verdicts if x["inside"]]
        rows.append([f"statistics inside the EN 50318:2002 ranges at {v:g} km/h, or the docs say why not", "all",
                     f"{len(inside)} of {len(verdicts)}", "outside: explained in docs/pantograph-catenary.md "
                     "(model data)" if len(inside) < len(verdicts) else "met", "inside: " + (", ".join(inside) or
                                                                                             "none")])
    conv = [name for name, part in (("mesh and step on the reduced catenary", "convergence"),
                                    ("step on the full model", "full_steps"),
                                    ("mesh on the full model", "full_mesh")) if part in d]
    rows.append(["mesh and step convergence of the statistics shown", "shown", ", ".join(conv) or "–",
                 "shown" if conv else "not measured",
                 "" if "full_mesh" in d else "no mesh study on the full model yet "
                 "(`python -m benchmarks.pantograph_catenary full_mesh`)"])
    return rows


def sec_pantograph(d) -> str:
    """Issue 21: the targets, then the benchmark's own tables (its ``markdown``)."""
    from .pantograph_catenary import markdown
    return ("## Pantograph–catenary at full scale (issue 21)\n\n"
            + table(["target", "limit", "measured", "verdict", "what it is made of"], pantograph_targets(d))
            + "\n" + markdown(d) + "\n\n_Command: `python -m benchmarks.pantograph_catenary [PART ...]` "
            f"(parts: {', '.join(k for k in d if k != 'stamp')}); {d.get('stamp', {}).get('date', '?')}._\n")


def render(results: Path | None = None, out: Path | None = None) -> Path:
    """Write RESULTS.md (default: benchmarks/RESULTS.md, or RESULTS.md inside a
    redirected results folder) and the plots from the JSON files in ``results``."""
    results = Path(results or common.RESULTS)
    if out is None:
        out = OUT if results.resolve() == DEFAULT_RESULTS.resolve() else results / "RESULTS.md"
    data = load(results)
    plots = _plots(data, results) if data else {}
    parts = ["# ancf_jax ↔ Exudyn benchmarks\n\n",
             "Generated by `python -m benchmarks.report` from `benchmarks/results/*.json` (written by "
             "`python -m benchmarks.run`); see `benchmarks/README.md` for what each row means.\n\n"]
    if not data:
        parts.append("No results yet: run `python -m benchmarks.run --quick`.\n")
        out.write_text("".join(parts))
        return out
    if any(d.get("quick") for d in data.values()):
        parts.append("**Quick mode** results are included (marked): small counts, short spans, "
                     "few repetitions — indicative only.\n\n")
    stamps = []
    for name, d in data.items():
        s = d.get("stamp", {})
        stamps.append([name, s.get("date", "?"), "quick" if d.get("quick") else "full", s.get("machine", "?"),
                       s.get("cores", "?"), s.get("jax", "?"), s.get("ancf_jax", "?"),
                       s.get("exudyn") if d.get("exudyn", True) and s.get("exudyn") else "not used"])
    parts.append("## Machine, versions, date\n\n" + table(
        ["section", "date", "mode", "machine", "cores", "jax", "ancf_jax", "Exudyn"], stamps) + "\n")
    parts.append("## Targets\n\n" + _target_table(data) + "\n")
    renderers = dict(agreement=sec_agreement, single_run=sec_single, batch=lambda d: sec_batch(d, plots),
                     gradient=sec_gradient, scaling=lambda d: sec_scaling(d, plots),
                     work_precision=lambda d: sec_wp(d, plots), compile_time=sec_compile)
    for name in SECTIONS:
        if name in data:
            parts.append(renderers[name](data[name]) + "\n")
        if name == "single_run" and PROFILE in data:
            parts.append(sec_step_profile(data[PROFILE]) + "\n")
        if name == "single_run" and CENSUS in data:
            parts.append(sec_kernel_census(data[CENSUS]) + "\n")
        if name == "single_run" and BORDER in data:
            parts.append(sec_border_elimination(data[BORDER]) + "\n")
        if name == "single_run" and EIGEN in data:
            parts.append(sec_eigen_threads(data[EIGEN]) + "\n")
        if name == "single_run" and _loop_kernels():
            parts.append(sec_loop_kernels(_loop_kernels()) + "\n")
        if name == "batch":
            parts += [sec_batch_gpu(data[g], data.get("batch")) + "\n" for g in EXTRA if g in data]
    if PANTOGRAPH in data:
        parts.append(sec_pantograph(data[PANTOGRAPH]) + "\n")
    if SUITE in data:
        parts.append(sec_suite(data[SUITE]) + "\n")
    if STUDIES in data:
        parts.append(sec_studies(data[STUDIES]) + "\n")
    out.write_text("".join(parts))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", type=Path, default=None)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    print(render(args.results, args.out))


if __name__ == "__main__":
    main()
