"""Command-line interface ``ancf-jax``.

``ancf-jax run|static|modal|check MODEL [options]`` with MODEL a shipped scenario
(m1, m2, …) or a scenario file; see ``ancf-jax COMMAND --help``. Every option and the
scenario are checked before anything is compiled; a bad option exits with status 2
and one line naming it; a failed simulation writes what it computed and exits with
status 1.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from ._version import __version__

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
    """The argument parser of ``ancf-jax`` with its subcommands run, static, modal, check."""
    from .simulation import SOLVERS

    parser = _Parser(prog="ancf-jax",
                     description="Differentiable planar ANCF beams and cables with rigid multibody "
                                 "systems (Seo, Jung & Park), on JAX. MODEL is a shipped scenario "
                                 "(m1, m2, flexible_pendulum, cantilever_tip_load, hanging_chain, "
                                 "cable_car) or a scenario file (.toml).")
    parser.add_argument("--version", action="version", version=f"ancf-jax {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    def common(p, elements_help):
        p.add_argument("model", metavar="MODEL", help="m1, m2, another shipped scenario, or FILE.toml")
        p.add_argument("--elements", type=str, default=None, help=elements_help)
        p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                       help="override a scenario key (dotted path, TOML value); repeatable")

    run = sub.add_parser("run", help="simulate and write CSV/NPZ/JSON and figures",
                         description="Simulate a model and write results and figures "
                                     "(default directory results/MODEL).")
    common(run, "element count of the (single) beam; comma-separated counts run as one vmapped "
                "batch (m1 default 6, m2 default 12,18,24)")
    run.add_argument("--t-end", type=_positive_float, default=None, help="end time [s]")
    run.add_argument("--dt", type=_positive_float, default=None, help="time step [s]")
    run.add_argument("--output-dt", type=_positive_float, default=None, help="output interval [s]")
    run.add_argument("--solver", choices=SOLVERS, default=None, help="integrator")
    run.add_argument("--rho-inf", type=_nonnegative_float, default=None,
                     help="generalized-alpha spectral radius at infinity, in [0, 1]")
    run.add_argument("--locate-crossings", action="store_true",
                     help="split fixed steps where a sliding joint crosses a node")
    run.add_argument("--out", type=Path, default=None, help="output directory (default results/MODEL)")
    run.add_argument("--animate", action="store_true", help="also write an animation (GIF)")
    run.add_argument("--no-figures", action="store_true", help="skip the figures")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")

    static = sub.add_parser("static", help="static equilibrium (sliding joints held)")
    common(static, "element count of the (single) beam")
    static.add_argument("--json", action="store_true", help="print one JSON object")

    modal = sub.add_parser("modal", help="natural frequencies [Hz]")
    common(modal, "element count of the (single) beam")
    modal.add_argument("--about", choices=("reference", "static"), default="reference",
                       help="linearize about the reference (initial) configuration or the static "
                            "equilibrium (with the stress stiffness)")
    modal.add_argument("--modes", type=_positive_int, default=6, help="number of modes")
    modal.add_argument("--json", action="store_true", help='print {"frequencies_hz": [...]}')

    check = sub.add_parser("check", help="validate a scenario without running it")
    check.add_argument("model", metavar="MODEL", help="shipped scenario name or FILE.toml")
    check.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    return parser


# ---------------------------------------------------------------------------- helpers
class _UsageError(Exception):
    """A one-line command-line error (exit status 2)."""


def _load(source, overrides):
    from .scenario import ScenarioError, load_scenario
    try:
        return load_scenario(source, overrides)
    except ScenarioError as e:
        raise _UsageError(str(e)) from None


def _counts(args, sc, default_many: bool) -> list[int] | None:
    """Element counts from --elements (None: the scenario's own)."""
    if args.elements is None:
        if default_many and sc.name == "m2":
            from .models.m2 import ELEMENT_COUNTS
            return list(ELEMENT_COUNTS)
        return None
    try:
        counts = _int_list(args.elements) if default_many else [_positive_int(args.elements)]
    except argparse.ArgumentTypeError as e:
        raise _UsageError(f"argument --elements: {e}") from None
    if len(sc.beam_elements) != 1:
        raise _UsageError("argument --elements: the scenario has "
                          f"{len(sc.beam_elements)} beams; use --set beams.NAME.elements=N")
    return counts


def _scenarios(args, default_many=False, extra=()):
    """The scenario(s) to run: one per element count."""
    base = _load(args.model, list(args.overrides) + list(extra))
    counts = _counts(args, base, default_many)
    if counts is None:
        return base, {"": base}
    beam = next(iter(base.beam_elements))
    return base, {n: _load(args.model, list(args.overrides) + list(extra) + [f"beams.{beam}.elements={n}"])
                  for n in counts}


# ---------------------------------------------------------------------------- commands
def _run(args) -> int:
    from .reports import report_m1, report_m2, report_scenario
    from .simulation import simulate, simulate_batch

    extra = []
    if args.t_end is not None:
        extra.append(f"solver.t_end={args.t_end!r}")
    if args.dt is not None:
        extra.append(f"solver.dt={args.dt!r}")
    if args.solver is not None:
        extra.append(f'solver.name="{args.solver}"')
    if args.output_dt is not None:
        extra.append(f"outputs.dt={args.output_dt!r}")
    if args.rho_inf is not None:
        if args.rho_inf > 1.0:
            raise _UsageError(f"argument --rho-inf: must be in [0, 1], got {args.rho_inf}")
        extra.append(f"solver.generalized_alpha.rho_inf={args.rho_inf!r}")
    base, scs = _scenarios(args, default_many=True, extra=extra)
    settings = base.solver
    if args.rho_inf is not None and settings.solver != "generalized-alpha":
        raise _UsageError("argument --rho-inf: needs --solver generalized-alpha")
    kw = settings.simulate_kwargs()
    kw["locate_crossings"] = kw["locate_crossings"] or args.locate_crossings
    kw.update(progress=False if args.no_progress else None, on_failure="return")
    out = Path(args.out) if args.out is not None else Path("results") / base.name
    labels = list(scs)
    if len(labels) > 1 and settings.solver in ("generalized-alpha", "rk4"):
        n_max = max(labels)
        built = [scs[n].build(pad_to={next(iter(scs[n].beam_elements)): n_max}) for n in labels]
        results = simulate_batch([b[0] for b in built], [b[1] for b in built], **kw)
    else:
        results = []
        for n in labels:
            system, state = scs[n].build()
            results.append(simulate(system, state, **kw))
    runs = dict(zip(labels, results))
    figures = not args.no_figures
    if base.name == "m1" and len(runs) == 1:
        r = results[0]
        summary = report_m1(r, out, figures=figures, outputs=base.outputs)
        print(f"M1, {summary['elements']} elements, {r.solver}, dt = {r.dt:g} s: tip y min "
              f"{summary['tip_y_min']:.6f} m, max |sigma_e1_mid| {summary['max_abs_sigma_e1_mid'] / 1e6:.2f} MPa; "
              f"compile {r.compile_time_s:.1f} s, run {r.wall_time_s:.2f} s -> {out}/")
    elif base.name == "m2" and all(isinstance(k, int) for k in runs):
        summary = report_m2(runs, out, figures=figures, animate=args.animate, outputs=base.outputs)
        dist = ", ".join(f"{k.replace('_vs_', ' vs ')}: {v['max_m'] * 1e3:.1f} mm"
                         for k, v in summary["point1_distances"].items())
        print(f"M2, {labels} elements ({results[0].solver}, dt = {results[0].dt:g} s"
              f"{', one vmapped batch' if len(labels) > 1 else ''}): "
              f"max distance of point-1 trajectories {dist or 'n/a'}; compile "
              f"{results[0].compile_time_s:.1f} s, run {summary['batch_wall_time_s']:.2f} s -> {out}/")
    else:
        report_scenario(base.name, runs, base.outputs, out, figures=figures, animate=args.animate)
        r = results[0]
        print(f"{base.name}: {len(runs)} run(s), {r.solver}, dt = {r.dt:g} s, t_end = {r.t[-1]:g} s; "
              f"compile {r.compile_time_s:.1f} s, run {sum(x.wall_time_s for x in results):.2f} s -> {out}/")
    failed = [f"{'' if k == '' else f'{k} elements: '}{r.message}" for k, r in runs.items() if r.status != "ok"]
    for msg in failed:
        print(f"ancf-jax run: {msg} (results up to then are written)", file=sys.stderr)
    return 1 if failed else 0


def _static_data(sc):
    """Equilibrium quantities; M1 and M2 report the keys of their command contracts."""
    import numpy as np

    from .outputs import evaluate
    res = sc.static_results()
    cols = {k: float(v[0]) for k, v in evaluate(res, sc.outputs).items() if k != "t"}
    system, q = res.system, res.q[0]
    if sc.name == "m1":
        n = int(system.beams[0].mesh.n_elements)
        tip = np.asarray(system.beam_nodes(q, 0))[n]
        return dict(tip_x=cols["tip_x"], tip_y=cols["tip_y"],
                    tip_rotation=float(math.atan2(tip[3], tip[2])), sigma_e1_mid=cols["sigma_e1_mid"])
    if sc.name == "m2":
        lam = res.multipliers("A")[0]
        return dict(point1_x=cols["point1_x"], point1_y=cols["point1_y"], rb2_x=cols["rb2_x"],
                    rb2_y=cols["rb2_y"], horizontal_tension=float(lam[0]))
    return cols


def _static(args) -> int:
    _, scs = _scenarios(args)
    sc = next(iter(scs.values()))
    data = _static_data(sc)
    if args.json:
        print(json.dumps(data))
        return 0
    n = ", ".join(f"{b}: {k} elements" for b, k in sc.beam_elements.items())
    title = {"m1": "M1 static equilibrium under gravity",
             "m2": "M2 held equilibrium (trolley held at s0)"}.get(sc.name, f"{sc.name} static equilibrium")
    print(f"{title} ({n}):")
    units = dict(tip_rotation="rad", sigma_e1_mid="Pa", horizontal_tension="N")
    for k, v in data.items():
        print(f"  {k:20s} {v: .9g} {units.get(k, 'm' if k.endswith(('_x', '_y')) else '')}")
    return 0


def _modal(args) -> int:
    from .modal import modal_analysis
    _, scs = _scenarios(args)
    sc = next(iter(scs.values()))
    if args.about == "static":
        system, sol = sc.equilibrium()
        q, lam = sol.state.q, sol.multipliers
    else:
        system, state = sc.model().build()
        q, lam = state.q, None
    res = modal_analysis(system, q, lam, n_modes=args.modes)
    freqs = [float(f) for f in res.frequencies_hz]
    if args.json:
        print(json.dumps({"frequencies_hz": freqs}))
    else:
        n = ", ".join(f"{b}: {k} elements" for b, k in sc.beam_elements.items())
        print(f"{sc.name} natural frequencies about the {args.about} configuration ({n}):")
        for i, f in enumerate(freqs, 1):
            print(f"  mode {i:2d}: {f:14.6f} Hz")
    return 0


def _check(args) -> int:
    sc = _load(args.model, args.overrides)
    print(sc.summary())
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``ancf-jax``: parse ``argv`` (default ``sys.argv[1:]``), run the
    command and return the exit status (0 ok, 1 failed run, 2 bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    try:
        return {"run": _run, "static": _static, "modal": _modal, "check": _check}[args.command](args)
    except _UsageError as e:
        print(f"ancf-jax {args.command}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
