"""Command-line interface ``ancf-jax``.

``ancf-jax run m1|m2 ...``, ``ancf-jax static ...``, ``ancf-jax modal ...``; see
``ancf-jax COMMAND --help``. Every option is checked before anything is compiled; a bad
option exits with status 2 and one line naming it; a failed simulation writes what it
computed and exits with status 1.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from ._version import __version__

MODELS = ("m1", "m2")


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``ancf-jax run: error: argument --t-end: ...``."""

    def error(self, message):  # pragma: no cover - exercised through main()
        self.exit(2, f"{self.prog}: error: {message}\n")


def _positive_float(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text!r}") from None
    if not math.isfinite(x) or x <= 0.0:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text!r}")
    return x


def _nonnegative_float(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number >= 0, got {text!r}") from None
    if not math.isfinite(x) or x < 0.0:
        raise argparse.ArgumentTypeError(f"must be a number >= 0, got {text!r}")
    return x


def _positive_int(text: str) -> int:
    try:
        x = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}") from None
    if x < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return x


def _int_list(text: str) -> list[int]:
    parts = [p for p in text.split(",") if p.strip()]
    if not parts:
        raise argparse.ArgumentTypeError(f"must be integers >= 1 separated by commas, got {text!r}")
    try:
        values = [int(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be integers >= 1 separated by commas, got {text!r}") from None
    if any(v < 1 for v in values):
        raise argparse.ArgumentTypeError(f"must be integers >= 1 separated by commas, got {text!r}")
    return sorted(set(values))


def build_parser() -> argparse.ArgumentParser:
    from .simulation import SOLVERS

    parser = _Parser(prog="ancf-jax",
                     description="Differentiable planar ANCF beams and cables with rigid multibody "
                                 "systems (Seo, Jung & Park), on JAX.")
    parser.add_argument("--version", action="version", version=f"ancf-jax {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    run = sub.add_parser("run", help="simulate a model and write CSV/NPZ/JSON and figures",
                         description="Simulate M1 (cantilever with tip body) or M2 (bodies sliding on a "
                                     "catenary cable) and write results and figures.")
    run.add_argument("model", choices=MODELS, help="built-in model")
    run.add_argument("--elements", type=str, default=None,
                     help="element count (m1, default 6) or comma-separated counts run as one "
                          "vmapped batch (m2, default 12,18,24)")
    run.add_argument("--t-end", type=_positive_float, default=None, help="end time [s] (m1: 2, m2: 3)")
    run.add_argument("--dt", type=_positive_float, default=None, help="time step [s] (default 1e-3)")
    run.add_argument("--output-dt", type=_positive_float, default=None,
                     help="output interval [s] (m1: 1e-3, m2: 1e-2)")
    run.add_argument("--solver", choices=SOLVERS, default=None, help="integrator (default generalized-alpha)")
    run.add_argument("--rho-inf", type=_nonnegative_float, default=None,
                     help="generalized-alpha spectral radius at infinity (m1: 0.9, m2: 0.5)")
    run.add_argument("--locate-crossings", action="store_true",
                     help="split fixed steps where a sliding joint crosses a node")
    run.add_argument("--out", type=Path, default=None, help="output directory (default results/MODEL)")
    run.add_argument("--animate", action="store_true", help="also write an animation (m2)")
    run.add_argument("--no-figures", action="store_true", help="skip the figures")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")

    static = sub.add_parser("static", help="static equilibrium under gravity")
    static.add_argument("model", choices=MODELS)
    static.add_argument("--elements", type=_positive_int, default=None, help="element count")
    static.add_argument("--json", action="store_true", help="print one JSON object")

    modal = sub.add_parser("modal", help="natural frequencies [Hz]")
    modal.add_argument("model", choices=MODELS)
    modal.add_argument("--elements", type=_positive_int, default=None, help="element count")
    modal.add_argument("--about", choices=("reference", "static"), default="reference",
                       help="linearize about the straight reference or the static equilibrium")
    modal.add_argument("--modes", type=_positive_int, default=6, help="number of modes")
    modal.add_argument("--json", action="store_true", help='print {"frequencies_hz": [...]}')
    return parser


# ---------------------------------------------------------------------------- commands
def _run(args) -> int:
    from .errors import SimulationError
    from .models import m1 as m1_def
    from .models import m2 as m2_def
    from .reports import report_m1, report_m2
    from .simulation import simulate, simulate_batch

    spec = m1_def if args.model == "m1" else m2_def
    defaults = spec.RUN
    if args.elements is None:
        counts = [6] if args.model == "m1" else list(m2_def.ELEMENT_COUNTS)
    else:
        try:
            counts = _int_list(args.elements) if args.model == "m2" else [_positive_int(args.elements)]
        except argparse.ArgumentTypeError as e:
            print(f"ancf-jax run: error: argument --elements: {e}", file=sys.stderr)
            return 2
    t_end = defaults["t_end"] if args.t_end is None else args.t_end
    dt = defaults["dt"] if args.dt is None else args.dt
    output_dt = defaults["output_dt"] if args.output_dt is None else args.output_dt
    solver = defaults["solver"] if args.solver is None else args.solver
    options = dict(defaults["solver_options"]) if solver == "generalized-alpha" else {}
    if args.rho_inf is not None:
        if solver != "generalized-alpha" or args.rho_inf > 1.0:
            print("ancf-jax run: error: argument --rho-inf: needs --solver generalized-alpha and a value "
                  f"in [0, 1], got {args.rho_inf}", file=sys.stderr)
            return 2
        options["rho_inf"] = args.rho_inf
    out = Path(args.out) if args.out is not None else Path("results") / args.model
    progress = False if args.no_progress else None
    kw = dict(t_end=t_end, dt=dt, output_dt=output_dt, solver=solver, solver_options=options,
              locate_crossings=args.locate_crossings, progress=progress, on_failure="return")
    failed = []
    if args.model == "m1":
        system, state = m1_def.m1_model(counts[0]).build()
        res = simulate(system, state, **kw)
        summary = report_m1(res, out, figures=not args.no_figures)
        if res.status != "ok":
            failed.append(res.message)
        print(f"M1, {counts[0]} elements, {res.solver}, dt = {res.dt:g} s: tip y min "
              f"{summary['tip_y_min']:.6f} m, max |sigma_e1_mid| {summary['max_abs_sigma_e1_mid'] / 1e6:.2f} MPa; "
              f"compile {res.compile_time_s:.1f} s, run {res.wall_time_s:.2f} s -> {out}/")
    else:
        n_max = max(counts)
        if solver in ("generalized-alpha", "rk4"):
            built = [m2_def.m2_initial(n, pad_to=n_max) for n in counts]
            results = simulate_batch([b[0] for b in built], [b[1] for b in built], **kw)
        else:
            results = []
            for n in counts:
                system, state, _ = m2_def.m2_initial(n)
                results.append(simulate(system, state, **kw))
        runs = dict(zip(counts, results))
        summary = report_m2(runs, out, figures=not args.no_figures, animate=args.animate)
        for n, r in runs.items():
            if r.status != "ok":
                failed.append(f"{n} elements: {r.message}")
        dist = ", ".join(f"{k.replace('_vs_', ' vs ')}: {v['max_m'] * 1e3:.1f} mm"
                         for k, v in summary["point1_distances"].items())
        print(f"M2, {counts} elements ({results[0].solver}, dt = {results[0].dt:g} s, one vmapped batch): "
              f"max distance of point-1 trajectories {dist}; compile {results[0].compile_time_s:.1f} s, "
              f"run {summary['batch_wall_time_s']:.2f} s -> {out}/")
    if failed:
        for msg in failed:
            print(f"ancf-jax run: {msg} (results up to then are written)", file=sys.stderr)
        return 1
    del SimulationError
    return 0


def _static_m1(n):
    import numpy as np

    from .models import m1 as m1_def
    from .statics import solve_static
    system, state = m1_def.m1_model(n).build()
    sol = solve_static(system, state, load_steps=10)
    nodes = np.asarray(system.beam_nodes(sol.state.q, 0))
    tip = nodes[int(system.beams[0].mesh.n_elements)]
    sigma = float(system.beams[0].element_stress(system.beam_nodes(sol.state.q, 0), m1_def.STRESS_ELEMENT,
                                                 m1_def.STRESS_XI, m1_def.STRESS_FIBRE))
    return dict(tip_x=float(tip[0]), tip_y=float(tip[1]),
                tip_rotation=float(math.atan2(tip[3], tip[2])), sigma_e1_mid=sigma), system, sol


def _static_m2(n):
    import numpy as np

    from .models import m2 as m2_def
    from .statics import solve_static
    system, state = m2_def.m2_model(n, hold=True).build()
    sol = solve_static(system, state, load_steps=10)
    q = sol.state.q
    s = system.sliding(q, 0)
    p1 = np.asarray(system.beams[0].position(system.beam_nodes(q, 0), s))
    cabin = np.asarray(system.body_pose(q, 1))
    labels = system.constraint_owner()
    lam = np.asarray(sol.multipliers)
    i_a = labels.index("A")
    return dict(point1_x=float(p1[0]), point1_y=float(p1[1]), rb2_x=float(cabin[0]), rb2_y=float(cabin[1]),
                horizontal_tension=float(lam[i_a])), system, sol


def _static(args) -> int:
    n = args.elements or (6 if args.model == "m1" else 24)
    data, _, _ = (_static_m1 if args.model == "m1" else _static_m2)(n)
    if args.json:
        print(json.dumps(data))
    elif args.model == "m1":
        print(f"M1 static equilibrium under gravity, {n} elements:\n"
              f"  tip position      x = {data['tip_x']:.9f} m, y = {data['tip_y']:.9f} m\n"
              f"  tip rotation      {data['tip_rotation']:.9f} rad\n"
              f"  sigma_e1_mid      {data['sigma_e1_mid'] / 1e6:.6f} MPa (E1 midpoint, y = +0.5 mm)")
    else:
        print(f"M2 held equilibrium (trolley held at s0), {n} elements:\n"
              f"  point 1           x = {data['point1_x']:.9f} m, y = {data['point1_y']:.9f} m\n"
              f"  cabin centre      x = {data['rb2_x']:.9f} m, y = {data['rb2_y']:.9f} m\n"
              f"  horizontal cable tension at A  {data['horizontal_tension']:.6f} N")
    return 0


def _modal(args) -> int:
    from .modal import modal_analysis
    n = args.elements or (6 if args.model == "m1" else 24)
    if args.about == "static":
        _, system, sol = (_static_m1 if args.model == "m1" else _static_m2)(n)
        res = modal_analysis(system, sol.state.q, sol.multipliers, n_modes=args.modes)
    else:
        if args.model == "m1":
            from .models.m1 import m1_model
            system, state = m1_model(n).build()
        else:
            from .models.m2 import m2_model
            system, state = m2_model(n, hold=True).build()
        res = modal_analysis(system, state.q, n_modes=args.modes)
    freqs = [float(f) for f in res.frequencies_hz]
    if args.json:
        print(json.dumps({"frequencies_hz": freqs}))
    else:
        print(f"{args.model.upper()} natural frequencies about the {args.about} configuration, {n} elements:")
        for i, f in enumerate(freqs, 1):
            print(f"  mode {i:2d}: {f:14.6f} Hz")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    return {"run": _run, "static": _static, "modal": _modal}[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
