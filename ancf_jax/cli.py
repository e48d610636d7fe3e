"""Command-line interface ``ancf-jax``.

``ancf-jax run|static|modal|check|fatigue|sweep|synth|fit MODEL [options]`` with MODEL a shipped
scenario (m1, m2, …) or a scenario file (TOML or JSON); see ``ancf-jax COMMAND --help``.

Exit status:

* 0: done;
* 1: a simulation failed (or a fit did not converge, or a static equilibrium was not
  found): what it computed up to then is written, and one line on stderr says when
  and why;
* 2: bad input: one line naming the option or scenario key and what it accepts. Every
  option, the scenario, the output location (``--out``) and the size of the run
  (``--max-steps``) are checked before anything is compiled;
* 130: interrupted (Ctrl-C): a run stops at the next chunk boundary and writes what it
  computed, with status ``interrupted``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
import time
from pathlib import Path

from ._version import __version__
from .errors import ModelError, StaticsError
from .failures import Failure

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


def _int_at_least(low: int):
    """argparse type: an integer >= low."""
    def parse(text: str) -> int:
        try:
            x = int(text)
        except ValueError:
            x = None
        if x is None or x < low:
            raise argparse.ArgumentTypeError(f"must be an integer >= {low}, got {text!r}")
        return x
    return parse


_positive_int = _int_at_least(1)
_nonnegative_int = _int_at_least(0)


def _window(text: str) -> tuple[float, float]:
    parts = text.split(",")
    try:
        lo, hi = (float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be two times T0,T1 in seconds, got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        raise argparse.ArgumentTypeError(f"must be two finite times T0 < T1, got {text!r}")
    return lo, hi


def _int_list(text: str) -> list[int]:
    parts = text.split(",")
    if not all(p.strip() for p in parts):
        raise argparse.ArgumentTypeError(f"must be integers >= 1 separated by commas, got {text!r}")
    try:
        values = [int(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be integers >= 1 separated by commas, got {text!r}") from None
    if any(v < 1 for v in values):
        raise argparse.ArgumentTypeError(f"must be integers >= 1 separated by commas, got {text!r}")
    return sorted(set(values))


#: ``modal --about`` values: the scenario format's names (modal.about) and the old
#: command-line names kept as aliases
_ABOUT = {"initial": "initial", "equilibrium": "equilibrium", "reference": "initial", "static": "equilibrium"}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``ancf-jax`` with its subcommands run, static, modal, check."""
    from .simulation import MAX_STEPS, SOLVERS

    parser = _Parser(prog="ancf-jax",
                     description="Differentiable planar ANCF beams and cables with rigid multibody "
                                 "systems (Seo, Jung & Park), on JAX. MODEL is a shipped scenario "
                                 "(m1, m2, flexible_pendulum, cantilever_tip_load, hanging_chain, "
                                 "cable_car, hauled_cabin, pantograph_catenary) or a scenario file (.toml or .json). "
                                 "Exit status: 0 done, 1 failed "
                                 "run (results up to then written), 2 bad input (one line), 130 "
                                 "interrupted (results up to then written).")
    parser.add_argument("--version", action="version", version=f"ancf-jax {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    def common(p, elements_help):
        p.add_argument("model", metavar="MODEL", help="m1, m2, another shipped scenario, FILE.toml or FILE.json")
        p.add_argument("--elements", type=str, default=None, help=elements_help)
        p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                       help="override a scenario key (dotted path, TOML value); repeatable")

    run = sub.add_parser("run", help="simulate and write CSV/NPZ/JSON and figures",
                         description="Simulate a model and write results and figures "
                                     "(default directory results/MODEL). A pantograph scenario with "
                                     "--set 'pantograph.speed_kmh=[V1, V2, ...]' runs the speeds in one "
                                     "vmapped batch (results in OUT/<V>kmh/ and OUT/speeds.csv).")
    common(run, "element count of the (single) beam; comma-separated counts run as one vmapped "
                "batch (m1 default 6, m2 default 12,18,24)")
    run.add_argument("--t-end", type=_positive_float, default=None, help="end time [s]")
    run.add_argument("--dt", type=_positive_float, default=None,
                     help="time step [s] (without --output-dt, a shorter output step of the scenario is "
                          "raised to it, with a note)")
    run.add_argument("--output-dt", type=_positive_float, default=None, help="output interval [s]")
    run.add_argument("--solver", choices=SOLVERS, default=None, help="integrator")
    run.add_argument("--rho-inf", type=_nonnegative_float, default=None,
                     help="generalized-alpha spectral radius at infinity, in [0, 1]")
    run.add_argument("--locate-crossings", action="store_true",
                     help="split fixed steps where a sliding joint crosses a node")
    run.add_argument("--out", type=Path, default=None, help="output directory (default results/MODEL)")
    run.add_argument("--max-steps", type=_positive_int, default=None,
                     help=f"run even if it takes more than {MAX_STEPS:.0e} time steps: the most steps "
                          "accepted (a longer run is refused before compiling)")
    run.add_argument("--continue-from", type=Path, default=None, metavar="FILE.npz",
                     help="continue the fixed-step run that wrote FILE.npz from where it stopped (same model, "
                          "--elements, --set and solver; --t-end is then the span added)")
    run.add_argument("--animate", action="store_true", help="also write an animation (GIF)")
    run.add_argument("--no-figures", action="store_true", help="skip the figures")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument("--vtk", action="store_true",
                     help="also write VTK files for ParaView (DIR/vtk/NAME.pvd; needs the sweep extra)")

    static = sub.add_parser("static", help="static equilibrium (sliding joints held)")
    common(static, "element count of the (single) beam")
    static.add_argument("--json", action="store_true",
                        help="print one JSON object: keys with their unit (tip_y_m, sigma_e1_mid_Pa) and units")

    modal = sub.add_parser("modal", help="natural frequencies [Hz]",
                           description="Natural frequencies [Hz] of the model linearized about its initial "
                                       "state or its static equilibrium. A negative frequency (-sqrt(-omega^2)/2pi) "
                                       "marks omega^2 < 0: the configuration is unstable about the chosen state "
                                       "(e.g. a slack cable in its reference shape; try --about equilibrium); a "
                                       "note says so (the key note with --json).")
    common(modal, "element count of the (single) beam")
    modal.add_argument("--about", choices=tuple(_ABOUT), default=None,
                       help="linearize about the initial state or the static equilibrium (with the "
                            "stress stiffness); reference and static are the old names of initial and "
                            "equilibrium (default: the scenario's modal.about)")
    modal.add_argument("--modes", type=_positive_int, default=None,
                       help="number of lowest modes (default: the scenario's modal.modes)")
    modal.add_argument("--json", action="store_true",
                       help='print {"frequencies_hz": [...]} (and "note" when a frequency is negative)')

    fatigue = sub.add_parser("fatigue", help="fatigue damage and life along the beams of a run",
                             description="Simulate a model with its scenario settings and assess fatigue "
                                         "with its [fatigue] table (defaults: rainflow, Eurocode 3 detail "
                                         "160 MPa, Barlow points of every element, both surface fibres); "
                                         "writes damage.csv (beam,s,damage,life_repeats), fatigue.json and "
                                         "figures (default directory results/MODEL-fatigue).")
    common(fatigue, "element count of the (single) beam")
    fatigue.add_argument("--t-end", type=_positive_float, default=None, help="end time [s]")
    fatigue.add_argument("--dt", type=_positive_float, default=None,
                         help="time step [s] (a shorter output step of the scenario is raised to it, with a note)")
    fatigue.add_argument("--out", type=Path, default=None, help="output directory (default results/MODEL-fatigue)")
    fatigue.add_argument("--max-steps", type=_positive_int, default=None,
                         help=f"the most time steps accepted (default {MAX_STEPS:.0e})")
    fatigue.add_argument("--study", action="append", default=[], metavar="PARAM=V1,V2,...",
                         help="instead of one run: a vmapped study of Dirlik damage over these values of "
                              "a parameter (alpha, beta, E, mass.BODY, optionally .BEAM; repeat for more "
                              "parameters, equally many values each), with d(damage)/d(parameter) through "
                              "the run; writes study.csv and study.json")
    fatigue.add_argument("--no-figures", action="store_true", help="skip the figures")
    fatigue.add_argument("--no-progress", action="store_true", help="no progress bar")

    check = sub.add_parser("check", help="validate a scenario without running it",
                           description="Validate a scenario without running it: the file, the joints "
                                       "(redundant or conflicting, from the rank of the constraint "
                                       "Jacobian at the initial state), the time functions on the "
                                       "run's step and output time grids and the size of the run "
                                       "(time steps, output; --max-steps); prints a summary.")
    check.add_argument("model", metavar="MODEL", help="shipped scenario name, FILE.toml or FILE.json")
    check.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                       help="override a scenario key before validating it (dotted path, TOML value, "
                            "e.g. solver.dt=1e-4), as run does; repeatable")
    check.add_argument("--max-steps", type=_positive_int, default=None,
                       help=f"the most time steps accepted, as for run (default {MAX_STEPS:.0e}): a longer "
                            "run is refused here as run would refuse it")

    synth = sub.add_parser("synth", help="synthetic measurements t,y of a model output (noisy)",
                           description="Simulate a model with given Rayleigh coefficients and write "
                                       "its output (default tip_y: M1's tip Y-displacement) at a sample "
                                       "rate with Gaussian noise as CSV columns t,y.")
    common(synth, "element count of the (single) beam")
    synth.add_argument("--alpha", type=_nonnegative_float, default=None,
                       help="Rayleigh alpha [1/s] (default: the model's)")
    synth.add_argument("--beta", type=_nonnegative_float, default=None,
                       help="Rayleigh beta [s] (default: the model's)")
    synth.add_argument("--noise", type=_nonnegative_float, required=True,
                       help="standard deviation of the Gaussian noise [m]")
    synth.add_argument("--rate", type=_positive_float, default=1000.0, help="sample rate [Hz] (default 1000)")
    synth.add_argument("--t-end", type=_positive_float, default=None,
                       help="last sample time [s] (default: the model's t_end)")
    synth.add_argument("--dt", type=_positive_float, default=None,
                       help="solver step [s] (default: the scenario's solver.dt)")
    synth.add_argument("--seed", type=_nonnegative_int, default=0, help="seed of the noise (default 0)")
    synth.add_argument("--output", default="tip_y", help="output column to sample (default tip_y)")
    synth.add_argument("--max-steps", type=_positive_int, default=None,
                       help=f"the most time steps accepted (default {MAX_STEPS:.0e}; a longer run is "
                            "refused before compiling)")
    synth.add_argument("--out", type=Path, required=True, help="CSV file to write")

    sweep = sub.add_parser("sweep", help="parameter sweep into a Zarr store (local devices or Ray)",
                           description="Run a design over dotted scenario keys (--param KEY=LOW:HIGH, "
                                       "KEY=LOW:HIGH:log, KEY=[V1, V2, ...]) in vmapped chunks, locally or "
                                       "on a Ray cluster, into an xarray/Zarr store that --resume completes.")
    sweep.add_argument("model", metavar="MODEL", help="m1, m2, another shipped scenario, or FILE.toml")
    sweep.add_argument("--param", dest="params", action="append", default=[], metavar="KEY=LOW:HIGH",
                       help="swept key: KEY=LOW:HIGH, KEY=LOW:HIGH:log or KEY=[V1, V2, ...]; repeatable")
    sweep.add_argument("--design", choices=("grid", "random", "lhs", "sobol", "saltelli"), default="lhs",
                       help="grid, random, lhs (default), sobol, or saltelli (for Sobol indices)")
    sweep.add_argument("--samples", type=_positive_int, default=None,
                       help="members (random, lhs, sobol) or base samples (saltelli)")
    sweep.add_argument("--levels", type=_int_at_least(2), default=3, help="grid levels per range (default 3)")
    sweep.add_argument("--seed", type=_nonnegative_int, default=0, help="design seed (default 0)")
    sweep.add_argument("--backend", choices=("local", "ray"), default="local",
                       help="local (this process, all its devices) or ray")
    sweep.add_argument("--address", default=None, help="Ray cluster address (default: a new local one)")
    sweep.add_argument("--chunk-size", type=_positive_int, default=None,
                       help="members per vmapped chunk (default: sized to memory)")
    sweep.add_argument("--resume", action="store_true", help="complete an interrupted sweep in --out")
    sweep.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                       help="override a scenario key for every member; repeatable")
    sweep.add_argument("--out", type=Path, required=True, help="the Zarr store (a directory)")
    sweep.add_argument("--netcdf", type=Path, default=None, help="also export the store to this NetCDF file")
    sweep.add_argument("--no-progress", action="store_true", help="no progress bar")

    fit = sub.add_parser("fit", help="identify Rayleigh alpha, beta (and E, tip_mass) from measured data",
                         description="Fit model parameters to measured samples t,y of a model output "
                                     "(default tip_y) by Levenberg-Marquardt with exact forward-mode "
                                     "derivatives through the simulation; writes fit.json and fit.png.")
    common(fit, "element count of the (single) beam")
    fit.add_argument("--data", type=Path, action="append", required=True, metavar="CSV",
                     help="measured samples with columns t,y (optional w: weights); repeat for a "
                          "batch of data sets fitted under one vmap, or with --joint for one fit of all")
    fit.add_argument("--joint", action="store_true",
                     help="fit one parameter set to all --data records together (experiments with other "
                          "loads or initial conditions: follow a --data by --record-set and --record-noise "
                          "for that record); fit.json reports the joint estimate and each record's residuals")
    fit.add_argument("--record-set", action=_RecordOption, type=str, metavar="KEY=VALUE",
                     help="with --joint: override a scenario key for the record of the preceding --data "
                          "only (on top of --set); repeatable")
    fit.add_argument("--record-noise", action=_RecordOption, type=_positive_float, metavar="SIGMA",
                     help="with --joint: the noise level of the preceding --data record (output units; "
                          "default --noise): weights 1/SIGMA^2 and that record's RMS-against-noise test")
    fit.add_argument("--params", default="alpha,beta",
                     help="parameters to fit, comma-separated: alpha, beta, E, tip_mass, speed.NAME, or any real "
                          "scalar of the scenario by its dotted key (beams.beam.section.I, gravity[1]) "
                          "(default alpha,beta)")
    fit.add_argument("--init", action="append", default=[], metavar="NAME=VALUE,...",
                     help="initial values, e.g. alpha=0.01,beta=1e-5 (default: the model's); repeat "
                          "for several starts fitted under one vmap")
    fit.add_argument("--output", default="tip_y", help="output column the data measure (default tip_y)")
    fit.add_argument("--window", type=_window, default=None, metavar="T0,T1",
                     help="fit only the samples with T0 <= t <= T1 [s]")
    fit.add_argument("--method", choices=("lm", "adam"), default="lm",
                     help="Levenberg-Marquardt (default) or Adam (optax)")
    fit.add_argument("--max-iter", type=_positive_int, default=None, help="iteration limit")
    fit.add_argument("--t-end", type=_positive_float, default=None,
                     help="simulated span [s] (default: the model's t_end); data must lie inside it")
    fit.add_argument("--dt", type=_positive_float, default=None,
                     help="solver step [s] (default: the scenario's solver.dt)")
    fit.add_argument("--nuisance", default="", metavar="NAMES",
                     help="nuisance parameters of the measurement fitted with the others, comma-separated: "
                          "time_offset (trigger delay: the record's t is the model's t + tau), offset, gain "
                          "(the sensor reads gain * y + offset); default none; with --joint each record has "
                          "its own, reported as NAME@k for record k")
    fit.add_argument("--max-steps", type=_positive_int, default=None,
                     help=f"the most time steps of one simulation accepted (default {MAX_STEPS:.0e}; a "
                          "longer one is refused before compiling)")
    fit.add_argument("--max-time-offset", type=_positive_float, default=None,
                     help="bound |tau| on a fitted time offset [s] (default 0.05)")
    fit.add_argument("--noise", type=_positive_float, default=None,
                     help="the data's noise level (standard deviation of a sample, output units): the "
                          "residual RMS is tested against it")
    fit.add_argument("--no-refine", action="store_true",
                     help="skip the discretization check (by default the estimate is re-evaluated with "
                          "the step halved and the mesh doubled, and the model refined while an estimate "
                          "moves by more than 0.3 standard errors)")
    fit.add_argument("--refine-budget", type=_nonnegative_int, default=2,
                     help="most refinement rounds of the discretization check (default 2; 0: check only)")
    fit.add_argument("--no-strain-check", action="store_true",
                     help="skip the model-form check (by default, after the discretization check, the "
                          "estimate is re-evaluated with the beams' other strain measures and the combined "
                          "uncertainty reported)")
    fit.add_argument("--bootstrap", type=_nonnegative_int, default=0, metavar="N",
                     help="parametric bootstrap with N synthetic records fitted as one vmapped batch "
                          "(default 0: off)")
    fit.add_argument("--profile", action="append", default=[], metavar="NAME",
                     help="profile-likelihood interval of a fitted parameter (delta = 4 on each side, the "
                          "others refitted; compared with Gauss-Newton's +-2 SE); repeatable")
    fit.add_argument("--out", type=Path, default=None, help="output directory (default results/MODEL-fit)")
    fit.add_argument("--no-figures", action="store_true", help="skip the figure")
    fit.add_argument("--no-progress", action="store_true", help="no per-iteration lines")
    return parser


# ---------------------------------------------------------------------------- helpers
class _UsageError(Exception):
    """A one-line command-line error (exit status 2)."""


class _RecordOption(argparse.Action):
    """``fit --record-set`` / ``--record-noise``: an option of the record named by the
    preceding ``--data`` (stored in ``namespace.records``: {index: {"set": [...],
    "noise": σ}})."""

    def __call__(self, parser, namespace, values, option_string=None):
        data = getattr(namespace, "data", None) or []
        if not data:
            parser.error(f"argument {option_string}: must follow the --data CSV of the record it applies to")
        records = getattr(namespace, "records", None) or {}
        rec = records.setdefault(len(data) - 1, {"set": [], "noise": None, "options": []})
        if option_string == "--record-noise":
            if rec["noise"] is not None:
                parser.error(f"argument --record-noise: given twice for the record {data[-1]}")
            rec["noise"] = values
        else:
            rec["set"].append(values)
        rec["options"].append(option_string)
        namespace.records = records


def _check_out(path, option: str = "--out", *, file: bool = False) -> Path:
    """Refuse an output location that cannot be written (an existing file where a
    directory is wanted, a path under a file, a directory without write permission)
    before anything is compiled. ``file``: ``path`` is a file to write, not a directory."""
    path = Path(path)
    accepted = ("a file path in a writable directory" if file else
                "a new or existing directory where files can be written")

    def fail(reason):
        raise _UsageError(f"argument {option}: {reason} (accepted: {accepted})")

    if path.exists():
        if file and path.is_dir():
            fail(f"{path} is a directory")
        if not file and not path.is_dir():
            fail(f"{path} exists and is not a directory")
        if not os.access(path, os.W_OK | (0 if file else os.X_OK)):
            fail(f"{path} is not writable")
        return path
    parent = path.absolute().parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        fail(f"{path} is under {parent}, which is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        fail(f"cannot create {path}: {parent} is not writable")
    return path


def _limits(args):
    """The :class:`~ancf_jax.integrate.RunLimits` of ``--max-steps``."""
    from .integrate import RunLimits
    return RunLimits() if args.max_steps is None else RunLimits(max_steps=args.max_steps)


def _check_size(args, scs, settings):
    """Refuse a runaway run (steps, output size) before anything is built or compiled;
    the state size is counted from the scenario (4 per node, 3 per body, point mass of
    a moving mass or chain, 1 per sliding joint, a moving mass's included)."""
    from .errors import ModelError
    from .simulation import FIXED_STEP_SOLVERS, check_run_size
    names = dict(t_end="--t-end" if getattr(args, "t_end", None) is not None else "solver.t_end",
                 dt="--dt" if getattr(args, "dt", None) is not None else "solver.dt",
                 output_dt=("--output-dt" if getattr(args, "output_dt", None) is not None else "outputs.dt"),
                 max_steps="--max-steps", max_output_bytes="")
    for sc in scs.values():
        bodies = (len(sc.spec.bodies) + len(sc.spec.moving_masses)
                  + sum(len(c.heights) for c in sc.spec.chains.values()))
        n = (sum(4 * (k + 1) for k in sc.beam_elements.values()) + 3 * bodies
             + sum(j.type == "sliding" for j in sc.spec.joints.values()) + len(sc.spec.moving_masses))
        try:
            check_run_size(settings.t_end, settings.dt, settings.output_dt, n, batch=len(scs),
                           fixed_step=settings.solver in FIXED_STEP_SOLVERS,
                           limits=_limits(args), names=names)
        except ModelError as e:
            raise _UsageError(str(e)) from None


def _output_step_for(args, command: str, overrides) -> list[str]:
    """``--dt`` without ``--output-dt``: when the scenario's output step (``outputs.dt``,
    after ``overrides``) is shorter than ``--dt``, raise it to ``--dt`` and say so in one
    line on stderr (outputs are taken at steps, so a shorter one cannot be kept). Returns
    the override to add (none when nothing changes or ``outputs.dt`` is set with --set)."""
    if args.dt is None or getattr(args, "output_dt", None) is not None:
        return []
    if any(item.partition("=")[0].strip() == "outputs.dt" for item in overrides):
        return []  # asked for explicitly: the scenario check names it if it conflicts
    from .scenario.loader import _parse, apply_overrides, resolve
    try:  # the raw file with the overrides; its errors are reported by the full load
        path = resolve(args.model)
        data = _parse(str(path), path, path.read_text(encoding="utf-8"))
        apply_overrides(data, overrides, str(path))
        out_dt = float(data.get("outputs", {}).get("dt"))
    except Exception:  # noqa: BLE001 - no outputs.dt, or a file the full load refuses
        return []
    if not (math.isfinite(out_dt) and out_dt < args.dt * (1 - 1e-9)):
        return []
    print(f"ancf-jax {command}: note: the scenario's output step outputs.dt = {out_dt:g} s is shorter than "
          f"--dt = {args.dt:g} s: outputs every {args.dt:g} s (give --output-dt to choose another)"
          if command == "run" else
          f"ancf-jax {command}: note: the scenario's output step outputs.dt = {out_dt:g} s is shorter than "
          f"--dt = {args.dt:g} s: outputs every {args.dt:g} s", file=sys.stderr)
    return [f"outputs.dt={args.dt!r}"]


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


def _simulate_all(scs, settings, kw) -> dict:
    """Simulate each scenario of ``scs`` ({label: Scenario}) with ``simulate`` keyword
    arguments ``kw``; several element counts of a fixed-step solver run as one padded,
    vmapped batch. Returns {label: Results}."""
    from .simulation import FIXED_STEP_SOLVERS, simulate, simulate_batch
    from .errors import ModelError
    labels = list(scs)
    try:
        if len(labels) > 1 and settings.solver in FIXED_STEP_SOLVERS:
            n_max = max(labels)
            built = [scs[n].build(pad_to={next(iter(scs[n].beam_elements)): n_max}) for n in labels]
            return dict(zip(labels, simulate_batch([b[0] for b in built], [b[1] for b in built], **kw)))
        built = {n: scs[n].build() for n in labels}
    except ModelError as e:  # e.g. redundant or conflicting joints, found at assembly
        raise _UsageError(f"{scs[labels[0]].path}: {e}") from None
    try:
        return {n: simulate(*built[n], **kw) for n in labels}
    except ModelError as e:  # refused before compiling (run size)
        raise _UsageError(str(e)) from None


def _continue(args, scs, kw) -> dict:
    """``run --continue-from``: one run from the checkpoint of an earlier run's NPZ."""
    from .errors import ModelError
    from .simulation import load_checkpoint, simulate
    if len(scs) != 1:
        raise _UsageError("argument --continue-from: continues one run (give one element count)")
    (label, sc), = scs.items()
    try:
        system, _ = sc.build()
    except ModelError as e:  # e.g. conflicting joints: the model's error, not the file's
        raise _UsageError(f"{sc.path}: {e}") from None
    try:
        checkpoint = load_checkpoint(args.continue_from)
    except (OSError, ValueError, KeyError, ModelError) as e:
        raise _UsageError(f"argument --continue-from: {e}") from None
    if tuple(checkpoint.q.shape) != (system.n_coordinates,):
        raise _UsageError(f"argument --continue-from: {args.continue_from} holds {checkpoint.q.shape[0]} "
                          f"coordinates, the model {system.n_coordinates}; give the model, --elements and "
                          "--set of the run it continues")
    try:
        return {label: simulate(system, checkpoint, **kw)}
    except ModelError as e:  # e.g. another solver than the checkpoint's
        raise _UsageError(f"argument --continue-from: {e}") from None


def _problems(command: str, runs: dict) -> int:
    """Print one line per failed or interrupted run; the exit status (0, 1, or 130
    when interrupted)."""
    bad = {k: r for k, r in runs.items() if r.status != "ok"}
    for k, r in bad.items():
        print(f"ancf-jax {command}: {'' if k == '' else f'{k} elements: '}{r.message} "
              f"(results up to then are written)", file=sys.stderr)
    if any(r.status == Failure.INTERRUPTED.reason for r in bad.values()):
        return 130
    return 1 if bad else 0


# ---------------------------------------------------------------------------- commands
def _run(args) -> int:
    from .reports import report_m1, report_m2, report_scenario

    extra = []
    if args.t_end is not None:
        extra.append(f"solver.t_end={args.t_end!r}")
    if args.dt is not None:
        extra.append(f"solver.dt={args.dt!r}")
    if args.solver is not None:
        extra.append(f'solver.name="{args.solver}"')
    if args.output_dt is not None:
        if args.dt is not None and args.output_dt < args.dt * (1 - 1e-9):
            raise _UsageError(f"argument --output-dt: {args.output_dt:g} s is shorter than --dt = {args.dt:g} s "
                              f"(accepted: a number >= {args.dt:g} [s]; outputs are taken at steps)")
        extra.append(f"outputs.dt={args.output_dt!r}")
    extra += _output_step_for(args, "run", list(args.overrides) + extra)
    if args.rho_inf is not None:
        if args.rho_inf > 1.0:
            raise _UsageError(f"argument --rho-inf: must be in [0, 1], got {args.rho_inf}")
        extra.append(f"solver.generalized_alpha.rho_inf={args.rho_inf!r}")
    if args.out is not None:
        _check_out(args.out)
    speeds, rest = _speed_list(args.overrides)
    if speeds is not None:
        return _run_speeds(args, speeds, rest, extra)
    base, scs = _scenarios(args, default_many=True, extra=extra)
    settings = base.solver
    _check_rho_inf(args, settings)
    kw = _run_kwargs(args, settings)
    out = _check_out(Path(args.out) if args.out is not None else Path("results") / base.name)
    _check_size(args, scs, settings)
    runs = _continue(args, scs, kw) if args.continue_from is not None else _simulate_all(scs, settings, kw)
    labels, results = list(runs), list(runs.values())
    figures = not args.no_figures
    if base.name == "m1" and len(runs) == 1:
        r = results[0]
        summary = report_m1(r, out, figures=figures, outputs=base.outputs,
                            precision=base.spec.outputs.precision)
        print(f"M1, {summary['elements']} elements, {r.solver}, dt = {r.dt:g} s: tip y min "
              f"{summary['tip_y_min_m']:.6f} m, max |sigma_e1_mid| {summary['max_abs_sigma_e1_mid_Pa'] / 1e6:.2f} MPa; "
              f"compile {r.compile_time_s:.1f} s, run {r.wall_time_s:.2f} s -> {out}/")
    elif base.name == "m2" and all(isinstance(k, int) for k in runs):
        summary = report_m2(runs, out, figures=figures, animate=args.animate, outputs=base.outputs,
                            precision=base.spec.outputs.precision)
        dist = ", ".join(f"{k.replace('_vs_', ' vs ')}: {v['max_m'] * 1e3:.1f} mm"
                         for k, v in summary["point1_distances"].items())
        print(f"M2, {labels} elements ({results[0].solver}, dt = {results[0].dt:g} s"
              f"{', one vmapped batch' if len(labels) > 1 else ''}): "
              f"max distance of point-1 trajectories {dist or 'n/a'}; compile "
              f"{results[0].compile_time_s:.1f} s, run {summary['batch_wall_time_s']:.2f} s -> {out}/")
    elif base.spec.pantograph is not None and len(runs) == 1:
        from .models.catenary import analyse_pantograph_run
        from .reports import report_pantograph
        from .scenario.build import pantograph_start
        p, r = base.spec.pantograph, results[0]
        run = analyse_pantograph_run(r, base.spec.catenary.design(), speed_kmh=p.speed_kmh,
                                     start=pantograph_start(base.spec), spans=p.spans, cutoff=p.cutoff,
                                     trailing=p.trailing or ())
        data = report_pantograph(run, out, figures=figures, precision=base.spec.outputs.precision)
        outside = [row["key"] for row in data["en50318_2002"] or () if not row["inside"]]
        ranges = ("" if data["en50318_2002"] is None else
                  f"; EN 50318:2002 ranges: {'all inside' if not outside else 'outside: ' + ', '.join(outside)}")
        print(f"{base.name}: {p.speed_kmh:g} km/h, spans {data['spans_evaluated']}: contact force mean "
              f"{data['mean_N']:.1f} N, std {data['std_N']:.1f} N, max {data['max_N']:.1f} N, min "
              f"{data['min_N']:.1f} N, uplift {data['uplift_support_mm']:.1f} mm, loss "
              f"{data['contact_loss_pct']:.1f} %{ranges}; compile {r.compile_time_s:.1f} s, run "
              f"{r.wall_time_s:.1f} s -> {out}/")
    else:
        report_scenario(base.name, runs, base.outputs, out, figures=figures, animate=args.animate,
                        precision=base.spec.outputs.precision)
        r = results[0]
        print(f"{base.name}: {len(runs)} run(s), {r.solver}, dt = {r.dt:g} s, t_end = {r.t[-1]:g} s; "
              f"compile {r.compile_time_s:.1f} s, run {sum(x.wall_time_s for x in results):.2f} s -> {out}/")
    if args.vtk:
        from .sweep.vtk import write_vtk
        for k, r in runs.items():
            name = base.name if k == "" or len(runs) == 1 else f"{base.name}_n{k}"
            print(f"VTK: {write_vtk(r, out / 'vtk', name=name)}")
    return _problems("run", runs)


#: the scenario key that takes a list of speeds on the command line (``run``)
SPEED_KEY = ("pantograph", "speed_kmh")


def _speed_list(overrides):
    """(speeds, the other overrides): the values of ``--set pantograph.speed_kmh=[V1,
    V2, ...]`` (a TOML array; the last such item), or (None, overrides) without one."""
    from .scenario.loader import parse_override
    speeds, rest = None, []
    for item in overrides:
        try:
            path, value = parse_override(item)
        except ValueError:  # reported by the scenario's load
            path, value = (), None
        if path == SPEED_KEY and isinstance(value, list):
            speeds = value
        else:
            rest.append(item)
    return speeds, rest


def _check_rho_inf(args, settings) -> None:
    if args.rho_inf is not None and settings.solver != "generalized-alpha":
        raise _UsageError("argument --rho-inf: needs --solver generalized-alpha")


def _run_kwargs(args, settings) -> dict:
    """``simulate``'s keyword arguments of ``run`` from the scenario's solver settings and
    the command line (--locate-crossings, --no-progress, the size limits)."""
    kw = settings.simulate_kwargs()
    if args.locate_crossings:
        kw["options"] = dataclasses.replace(kw["options"], locate_crossings=True)
    kw.update(progress=False if args.no_progress else None, on_failure="return", limits=_limits(args))
    return kw


def _run_speeds(args, speeds, overrides, extra) -> int:
    """``run MODEL --set pantograph.speed_kmh=[V1, V2, ...]``: one scenario per speed,
    each run by :func:`~ancf_jax.simulation.simulate` over threads
    (:func:`~ancf_jax.simulation.simulate_each`: one compiled program, fixed-step
    solvers) to the longest speed's end, each member cut at the output nearest its own
    end (the single-speed run's duration) and written to ``OUT/<V>kmh/`` as a
    single-speed run writes ``OUT/``; ``OUT/speeds.csv`` holds one row of statistics
    per speed. (Not one vmapped batch: on the CPU the shipped line's batch of 8 speeds
    ran 370 s against 22 s for its 8 single runs, ``python -m
    benchmarks.pantograph_catenary batch_full``.)"""
    import numpy as np

    from .models.catenary import STATISTICS_KEYS, analyse_pantograph_run
    from .outputs import write_csv
    from .reports import report_pantograph
    from .scenario.build import pantograph_start
    from .errors import SimulationInterrupted
    from .simulation import FIXED_STEP_SOLVERS, simulate_each
    key = ".".join(SPEED_KEY)
    for given, flag in ((args.elements, "--elements"), (args.continue_from, "--continue-from")):
        if given is not None:
            raise _UsageError(f"argument {flag}: does not combine with a list of speeds (--set {key}=[...])")
    if not speeds or len(speeds) > 64:
        raise _UsageError(f"--set {key}={speeds!r}: expected an array of 1 to 64 speeds [km/h]")
    scs = {}
    for v in speeds:
        value = float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v
        sc = _load(args.model, list(overrides) + list(extra) + [f"{key}={value!r}"])
        if sc.spec.pantograph is None:
            raise _UsageError(f"--set {key}=[...]: {sc.path} has no [pantograph] table")
        label = f"{value:g}kmh"
        if label in scs:
            raise _UsageError(f"--set {key}={speeds!r}: {value:g} km/h is given twice")
        scs[label] = sc
    base = next(iter(scs.values()))
    settings = base.solver
    if settings.solver not in FIXED_STEP_SOLVERS:
        raise _UsageError(f"--set {key}=[...]: a list of speeds runs fixed-step solvers "
                          f"({', '.join(FIXED_STEP_SOLVERS)}), not {settings.solver}")
    _check_rho_inf(args, settings)
    ends = {label: sc.solver.t_end for label, sc in scs.items()}
    settings = dataclasses.replace(settings, t_end=max(ends.values()))
    kw = _run_kwargs(args, settings)
    out = _check_out(Path(args.out) if args.out is not None else Path("results") / base.name)
    _check_size(args, scs, settings)
    try:
        built = [sc.build() for sc in scs.values()]
    except ModelError as e:
        raise _UsageError(f"{base.path}: {e}") from None
    t0 = time.perf_counter()
    try:
        results = simulate_each([b[0] for b in built], [b[1] for b in built], **kw)
    except SimulationInterrupted as e:  # Ctrl-C: the members that ran are written, the others named
        results = e.results
    wall = time.perf_counter() - t0
    rows, status = [], 0
    for (label, sc), r in zip(scs.items(), results):
        if r is None:
            print(f"ancf-jax run: {sc.spec.pantograph.speed_kmh:g} km/h: not run (interrupted)", file=sys.stderr)
            status = 130
            continue
        r = r.until(float(r.t[np.argmin(np.abs(np.asarray(r.t) - ends[label]))]))  # the output nearest its end
        p = sc.spec.pantograph
        run = analyse_pantograph_run(r, sc.spec.catenary.design(), speed_kmh=p.speed_kmh,
                                     start=pantograph_start(sc.spec), spans=p.spans, cutoff=p.cutoff,
                                     trailing=p.trailing or ())
        data = report_pantograph(run, out / label, figures=not args.no_figures,
                                 precision=base.spec.outputs.precision)
        rows.append({k: data[k] for k in STATISTICS_KEYS if k != "spans_evaluated"})
        print(f"{base.name}: {p.speed_kmh:g} km/h: contact force mean {data['mean_N']:.1f} N, std "
              f"{data['std_N']:.1f} N, max {data['max_N']:.1f} N, min {data['min_N']:.1f} N, uplift "
              f"{data['uplift_support_mm']:.1f} mm, loss {data['contact_loss_pct']:.1f} % -> {out / label}/")
        if r.status != "ok":
            print(f"ancf-jax run: {p.speed_kmh:g} km/h: {r.message} (results up to then are written)",
                  file=sys.stderr)
            status = 130 if r.status == Failure.INTERRUPTED.reason else max(status, 1)
        if args.vtk:
            from .sweep.vtk import write_vtk
            print(f"VTK: {write_vtk(r, out / label / 'vtk', name=f'{base.name}_{label}')}")
    if rows:
        write_csv(out / "speeds.csv", {k: np.array([row[k] for row in rows], float) for k in rows[0]},
                  base.spec.outputs.precision)
        print(f"{base.name}: {len(rows)} speeds, one compiled program (compile {results[0].compile_time_s:.1f} s), "
              f"{wall:.1f} s in all -> {out}/speeds.csv")
    return status


def _fatigue(args) -> int:
    from .errors import ModelError
    from .fatigue import analyse, settings_from_table
    extra = [f"solver.{k}={v!r}" for k, v in (("t_end", args.t_end), ("dt", args.dt)) if v is not None]
    extra += _output_step_for(args, "fatigue", list(args.overrides) + extra)
    if args.out is not None:
        _check_out(args.out)
    base, scs = _scenarios(args, extra=extra)
    sc = next(iter(scs.values()))
    try:
        settings = settings_from_table(sc.spec.fatigue)
    except ModelError as e:
        raise _UsageError(str(e)) from None
    if settings.t_start >= sc.solver.t_end:
        raise _UsageError(f"fatigue.t_start = {settings.t_start:g} s is not before solver.t_end = "
                          f"{sc.solver.t_end:g} s")
    if args.study:
        return _fatigue_study(args, base, sc, settings)
    kw = sc.solver.simulate_kwargs()
    kw.update(progress=False if args.no_progress else None, on_failure="return", limits=_limits(args))
    out = _check_out(Path(args.out) if args.out is not None else Path("results") / f"{base.name}-fatigue")
    _check_size(args, scs, sc.solver)
    r = next(iter(_simulate_all(scs, sc.solver, kw).values()))
    try:
        res = analyse(r, settings)
    except ModelError as e:
        print(f"ancf-jax fatigue: {r.message or e} (nothing written)", file=sys.stderr)
        return 1
    data = res.write(out, figures=not args.no_figures)
    if r.status != "ok":
        data["status"] = r.status
        data["message"] = r.message
        (out / "fatigue.json").write_text(json.dumps(data, indent=2))
    hs = data["hot_spot"]
    life = data["life_repeats"]
    print(f"{base.name}: fatigue by {settings.method} over {res.duration:g} s at {len(res.s)} points: max damage "
          f"{data['max_damage']:.3g} per run at {hs['beam']} s = {hs['s_m']:.4g} m ({hs['fibre']}), life "
          f"{'infinite' if life is None else f'{life:.3g} runs'}; compile {r.compile_time_s:.1f} s, run "
          f"{r.wall_time_s:.2f} s -> {out}/")
    if r.status != "ok":
        print(f"ancf-jax fatigue: {r.message} (damage of the run up to then is written)", file=sys.stderr)
        return 130 if r.status == Failure.INTERRUPTED.reason else 1
    return 0


def _fatigue_study(args, base, sc, settings) -> int:
    """``ancf-jax fatigue MODEL --study PARAM=V1,V2,...`` (see the --study help)."""
    import numpy as np

    from .errors import ModelError
    from .fatigue import study
    from .identification.parameters import resolve
    from .integrate import NO_RETRIES
    names, columns = [], []
    for item in args.study:
        name, eq, text = item.partition("=")
        try:
            vals = [float(v) for v in text.split(",")] if eq and text.strip() else []
        except ValueError:
            vals = []
        if not name.strip() or not vals or not all(math.isfinite(v) for v in vals):
            raise _UsageError(f"--study {item!r}: expected PARAM=V1,V2,... with finite numbers")
        names.append(name.strip())
        columns.append(vals)
    if len({len(c) for c in columns}) != 1:
        raise _UsageError("--study: every parameter needs equally many values "
                          f"(got {', '.join(f'{n}: {len(c)}' for n, c in zip(names, columns))})")
    out = _check_out(Path(args.out) if args.out is not None else Path("results") / f"{base.name}-fatigue")
    _check_size(args, {base.name: sc}, sc.solver)
    system, state = sc.build()
    try:
        resolve(system, names)
        run = sc.solver.simulate_kwargs()  # the study runs without step retries
        solver, options = run["solver"], dataclasses.replace(run["options"],
                                                             max_halvings=NO_RETRIES.max_halvings)
    except ModelError as e:
        raise _UsageError(f"--study: {e}") from None
    res = study(system, state, names, np.array(columns).T, settings, t_end=sc.solver.t_end,
                dt=sc.solver.dt, output_dt=sc.solver.output_dt, solver=solver, options=options)
    res.write(out)
    for v, d, hs, g, c in zip(res.values, res.max_damage, res.hot_spot, res.max_damage_gradient(), res.status):
        vals = ", ".join(f"{n} = {x:.6g}" for n, x in zip(res.names, v))
        grads = ", ".join(f"dD/d{n} = {x:.3g}" for n, x in zip(res.names, g))
        print(f"{base.name}: {vals}: max damage {d:.4g} per run (Dirlik) at {hs['beam']} s = {hs['s_m']:.4g} m; "
              f"{grads}" + ("" if c == 0 else " (run failed: see study.csv)"))
    print(f"-> {out}/study.csv, study.json")
    return 0 if (res.status == 0).all() else 1


def _sweep(args) -> int:
    # the store and the NetCDF file: checked before anything is imported, built or run
    _check_out(args.out)
    if args.netcdf is not None:
        _check_out(args.netcdf, "--netcdf", file=True)
    try:
        from .sweep import SweepError, parse_param, run_sweep
        from .sweep.store import to_netcdf
    except ImportError as e:
        raise _UsageError(str(e)) from None
    if args.address is not None and args.backend != "ray":
        raise _UsageError("argument --address: needs --backend ray")
    if args.design != "grid" and args.samples is None:
        raise _UsageError(f"argument --samples: the {args.design} design needs --samples N")
    try:
        params = [parse_param(p) for p in args.params]
        ds = run_sweep(args.model, params, out=args.out, design=args.design, samples=args.samples,
                       levels=args.levels, seed=args.seed, overrides=args.overrides, backend=args.backend,
                       address=args.address, resume=args.resume, chunk_size=args.chunk_size,
                       progress=False if args.no_progress else None)
    except SweepError as e:
        raise _UsageError(str(e)) from None
    except KeyboardInterrupt:  # the chunks stored until then stay in the store
        if not Path(args.out).exists():
            print("ancf-jax sweep: interrupted (Ctrl-C) before the store was created", file=sys.stderr)
            return 130
        from .sweep.store import open_store
        ds = open_store(args.out)
        print(f"ancf-jax sweep: interrupted (Ctrl-C): {int((ds['stored'].values == 1).sum())} of "
              f"{ds.sizes['member']} members stored in {args.out}; --resume (same arguments) runs the rest",
              file=sys.stderr)
        return 130
    status = ds["status"].values
    counts = {s: int((status == s).sum()) for s in sorted(set(status.tolist()))}
    run = json.loads(ds.attrs["runs"])[-1]
    if args.netcdf is not None:
        to_netcdf(args.out, args.netcdf)
    summary = ", ".join(f"{v} {k or 'missing'}" for k, v in counts.items())
    print(f"{args.model}: {len(status)} members ({summary}); "
          f"this run {run['stored']} members in {run['wall_s']:.1f} s on {run['backend']} -> {args.out}")
    return 0 if counts.get("ok", 0) == len(status) else 1


def _static_data(sc) -> tuple[dict, dict]:
    """Equilibrium quantities and their units ({name: value}, {name: unit}); M1 and M2
    report the quantities of their command contracts, other scenarios their output
    columns."""
    import numpy as np

    from .outputs import evaluate
    res = sc.static_results()
    cols = {k: float(v[0]) for k, v in evaluate(res, sc.outputs).items() if k != "t"}
    units = {o.name: o.unit for o in sc.outputs}
    system, q = res.system, res.q[0]
    if sc.name == "m1":
        n = int(system.beams[0].mesh.n_elements)
        tip = np.asarray(system.beam_nodes(q, 0))[n]
        data = dict(tip_x=cols["tip_x"], tip_y=cols["tip_y"],
                    tip_rotation=float(math.atan2(tip[3], tip[2])), sigma_e1_mid=cols["sigma_e1_mid"])
        return data, dict(units, tip_rotation="rad")
    if sc.name == "m2":
        lam = res.multipliers("A")[0]
        data = dict(point1_x=cols["point1_x"], point1_y=cols["point1_y"], rb2_x=cols["rb2_x"],
                    rb2_y=cols["rb2_y"], horizontal_tension=float(lam[0]))
        return data, dict(units, horizontal_tension="N")
    return cols, units


def _static(args) -> int:
    from .outputs import unit_suffix
    _, scs = _scenarios(args)
    sc = next(iter(scs.values()))
    data, units = _static_data(sc)
    if args.json:  # keys with their unit (tip_y_m, sigma_e1_mid_Pa) and the units map
        keyed = {f"{k}{unit_suffix(units[k])}": (v, units[k]) for k, v in data.items()}
        print(json.dumps({**{k: v for k, (v, _) in keyed.items()}, "units": {k: u for k, (_, u) in keyed.items()}}))
        return 0
    n = ", ".join(f"{b}: {k} elements" for b, k in sc.beam_elements.items())
    title = {"m1": "M1 static equilibrium under gravity",
             "m2": "M2 held equilibrium (trolley held at s0)"}.get(sc.name, f"{sc.name} static equilibrium")
    print(f"{title} ({n}):")
    for k, v in data.items():
        print(f"  {k:20s} {v: .9g} {'' if units[k] == '-' else units[k]}")
    return 0


def _modal(args) -> int:
    from .modal import degrees_of_freedom, modal_analysis
    _, scs = _scenarios(args)
    sc = next(iter(scs.values()))
    about = _ABOUT[args.about] if args.about is not None else sc.modal_settings.about
    modes, option = ((args.modes, "argument --modes") if args.modes is not None else
                     (sc.modal_settings.modes, f"{sc.path}: modal.modes"))
    if about == "equilibrium":
        system, sol = sc.equilibrium()
        q, lam = sol.state.q, sol.multipliers
    else:
        system, state = sc.model().build()
        q, lam = state.q, None
    dof = degrees_of_freedom(system)
    if modes > dof:
        raise _UsageError(f"{option}: {modes} modes asked, {sc.name} has {dof} degrees of "
                          f"freedom (accepted: an integer 1 .. {dof})")
    res = modal_analysis(system, q, lam, n_modes=modes)
    freqs = [float(f) for f in res.frequencies_hz]
    note = _negative_frequency_note(freqs, about)
    if args.json:
        print(json.dumps({"frequencies_hz": freqs, **({"note": note} if note else {})}))
    else:
        n = ", ".join(f"{b}: {k} elements" for b, k in sc.beam_elements.items())
        print(f"{sc.name} natural frequencies about the {about} {'state' if about == 'initial' else 'configuration'} ({n}):")
        for i, f in enumerate(freqs, 1):
            print(f"  mode {i:2d}: {f:14.6f} Hz")
        if note:
            print(f"note: {note}")
    return 0


def _negative_frequency_note(freqs, about: str) -> str | None:
    """One line explaining negative frequencies (ω² < 0), None when there are none."""
    count = sum(f < 0.0 for f in freqs)
    if not count:
        return None
    where = ("about the initial state, e.g. a slack or sagging cable in its reference shape: use "
             "--about equilibrium (the static equilibrium, with its stress stiffness)" if about == "initial" else
             "about the static equilibrium: it is not a stable one (a buckled or slack configuration)")
    return (f"{count} negative frequenc{'y' if count == 1 else 'ies'} (-sqrt(-omega^2)/2pi where omega^2 < 0): the "
            f"configuration is unstable {where}")


def _check(args) -> int:
    from .errors import ModelError
    sc = _load(args.model, args.overrides)
    _check_size(args, {"": sc}, sc.solver)  # what run refuses as too long, check refuses too
    try:  # the joints: rank of the constraint Jacobian at the initial state, assembly
        sc.model().build()
    except ModelError as e:
        raise _UsageError(f"{sc.path}: {e}") from None
    print(sc.summary())
    return 0


def _check_identification_size(args, elements):
    """The run-size check of ``synth``/``fit`` (their simulation outputs every step),
    from the scenario as :meth:`~ancf_jax.identification.Problem.from_scenario` reads it."""
    import types
    extra = [] if args.dt is None else [f"solver.dt={args.dt!r}", f"outputs.dt={args.dt!r}"]
    sc = _load(args.model, list(args.overrides) + extra)
    if elements is not None and len(sc.beam_elements) == 1:
        beam = next(iter(sc.beam_elements))
        sc = _load(args.model, list(args.overrides) + extra + [f"beams.{beam}.elements={elements}"])
    run = sc.solver
    settings = types.SimpleNamespace(t_end=run.t_end if args.t_end is None else args.t_end, dt=run.dt,
                                     output_dt=run.dt, solver=run.solver)
    _check_size(args, {"": sc}, settings)


def _identification_problem(args, params, nuisance=()):
    """The identification problem of ``synth``/``fit`` (one-line errors, nothing compiled)."""
    from .errors import ModelError
    from .identification import Problem
    from .scenario import ScenarioError
    elements = None
    if args.elements is not None:
        try:
            elements = _positive_int(args.elements)
        except argparse.ArgumentTypeError as e:
            raise _UsageError(f"argument --elements: {e}") from None
    _check_identification_size(args, elements)
    try:
        extra = {}
        if nuisance:
            extra["nuisance"] = nuisance
        if getattr(args, "max_time_offset", None) is not None:
            extra["max_time_offset"] = args.max_time_offset
        return Problem.from_scenario(args.model, params, output=args.output, overrides=args.overrides,
                                     elements=elements, t_end=args.t_end, dt=args.dt, **extra)
    except (ScenarioError, ModelError) as e:
        raise _UsageError(str(e)) from None


def _synth(args) -> int:
    import time

    from .errors import ModelError
    from .identification import synthesize, write_csv
    _check_out(args.out, file=True)
    problem = _identification_problem(args, ("alpha", "beta"))
    values = {k: v for k, v in (("alpha", args.alpha), ("beta", args.beta)) if v is not None}
    t0 = time.perf_counter()
    try:
        data, _ = synthesize(problem, values, noise=args.noise, rate=args.rate, seed=args.seed)
    except ModelError as e:
        raise _UsageError(str(e)) from None
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(args.out, data.t, data.y)
    p = problem.vector(values)
    print(f"{problem.name}: {len(data)} samples of {problem.output.name} at {args.rate:g} Hz over "
          f"[{data.t[0]:g}, {data.t[-1]:g}] s (alpha = {p[0]:g} 1/s, beta = {p[1]:g} s, noise "
          f"{args.noise:g}, seed {args.seed}); compile {problem.compile_time_s:.1f} s, total "
          f"{time.perf_counter() - t0:.1f} s -> {args.out}")
    return 0


def _parse_init(text: str) -> dict:
    out = {}
    for item in (x for x in text.split(",") if x.strip()):
        name, eq, value = item.partition("=")
        try:
            v = float(value)
        except ValueError:
            v = math.nan
        signed = name.strip() in ("time_offset", "offset")  # nuisance parameters that may be < 0
        if not eq or not name.strip() or not math.isfinite(v) or (v < 0 and not signed):
            raise _UsageError(f"argument --init: expected NAME=VALUE pairs with values >= 0 (time_offset "
                              f"and offset: any sign) separated by commas, got {text!r}")
        out[name.strip()] = v
    return out


def _joint_problems(args, names, records, nuisance=()) -> list:
    """One identification problem per ``--data`` record of ``fit --joint``: the model
    with ``--set`` and the record's own ``--record-set`` overrides (one-line errors
    naming the record, nothing compiled)."""
    problems = []
    for k, path in enumerate(args.data):
        sets = records.get(k, {}).get("set", [])
        try:
            pr = _identification_problem(argparse.Namespace(**{**vars(args), "overrides": args.overrides + sets}),
                                         names, nuisance)
        except _UsageError as e:
            if not sets:
                raise
            raise _UsageError(f"argument --record-set (record {k + 1}, {path}): {e}") from None
        if sets:
            pr.name = f"{pr.name} [{', '.join(sets)}]"
        problems.append(pr)
    return problems


def _check_joint(args, inits, records) -> list | None:
    """Refuse what ``fit --joint`` cannot do (before anything is built); returns the
    records' noise levels (``--record-noise``, else ``--noise``; None if none is stated)."""
    if records and not args.joint:
        option = next(iter(records.values()))["options"][0]
        raise _UsageError(f"argument {option}: only with --joint (it sets one record of a joint fit)")
    if args.profile and ((len(args.data) > 1 and not args.joint) or len(inits) > 1):
        raise _UsageError("argument --profile: needs one --data (or --joint) and at most one --init")
    if not args.joint:
        return None
    if len(args.data) < 2:
        raise _UsageError(f"argument --joint: needs at least two --data records, got {len(args.data)}")
    if len(inits) > 1:
        raise _UsageError(f"argument --joint: give at most one --init (a joint fit has one start), got {len(inits)}")
    if args.bootstrap:
        raise _UsageError("argument --bootstrap: not with --joint (the bootstrap resamples one record)")
    noise = [records.get(k, {}).get("noise") or args.noise for k in range(len(args.data))]
    if all(n is None for n in noise):
        return None
    if any(n is None for n in noise):
        k = noise.index(None)
        raise _UsageError(f"argument --record-noise: record {k + 1} ({args.data[k]}) has no noise level; give "
                          "--record-noise after every --data, or --noise for the records without one")
    return noise


def _fit(args) -> int:
    from .errors import ModelError, SimulationError
    from .identification import JointProblem, bootstrap, fit, fit_batch, profile_interval, read_csv
    from .identification.data import DataError
    if args.out is not None:
        _check_out(args.out)
    requested = [p.strip() for p in args.params.split(",") if p.strip()]
    if not requested:
        raise _UsageError("argument --params: give at least one parameter")
    inits = [_parse_init(t) for t in args.init]
    records = getattr(args, "records", None) or {}
    noises = _check_joint(args, inits, records)
    datasets = []
    for path in args.data:
        try:
            datasets.append(read_csv(path))
        except DataError as e:
            raise _UsageError(str(e)) from None
    # alpha and beta are always reported (fixed at the model's values unless fitted)
    names = list(dict.fromkeys(["alpha", "beta"] + requested))
    nuisance = [n.strip() for n in args.nuisance.split(",") if n.strip()]
    problem = _identification_problem(args, names, nuisance)
    joint = None
    if args.joint:
        try:
            joint = JointProblem(_joint_problems(args, names, records, nuisance), datasets, noises,
                                 window=args.window)
        except (DataError, ModelError) as e:
            raise _UsageError(str(e)) from None
    target = joint or problem  # a joint fit's nuisance parameters are per record: offset@2
    free = [p.name for p in problem.params if p.name in requested] + list(target.nuisance)
    for i in inits:
        unknown = set(i) - set(target.names)
        if unknown:
            raise _UsageError(f"argument --init: unknown parameter(s) {', '.join(sorted(unknown))} "
                              f"(parameters: {', '.join(target.names)})")
    for name in args.profile:
        if name not in free:
            raise _UsageError(f"argument --profile: {name!r} is not a fitted parameter (fitted: {', '.join(free)})")
    out = _check_out(Path(args.out) if args.out is not None else Path("results") / f"{problem.name}-fit")
    options = dict(free=free, method=args.method, max_iterations=args.max_iter, progress=not args.no_progress)
    try:
        if joint is not None:
            results = [joint.fit(inits[0] if inits else None, **options)]
            if not args.no_refine:
                results[0].discretization = dict(
                    checked=False, notes=[], summary="not checked: a joint fit has no discretization check "
                    "(check the model with a fit of one record, or pass --no-refine)")
        elif len(datasets) == 1 and len(inits) <= 1:
            # one record: the discretization check (and refinement) unless --no-refine
            results = [fit(problem, datasets[0], inits[0] if inits else None, discretization=not args.no_refine,
                           refine_budget=args.refine_budget, strain_measure=not args.no_strain_check,
                           window=args.window, noise=args.noise, **options)]
            if args.bootstrap:
                bootstrap(problem, results[0], args.bootstrap)
        else:
            if args.bootstrap:
                raise _UsageError("argument --bootstrap: needs one --data and at most one --init")
            results = fit_batch(problem, datasets, inits or None, window=args.window, noise=args.noise, **options)
        if args.profile:
            results[0].profiles = {n: profile_interval(joint or problem, results[0], n) for n in args.profile}
    except (DataError, ModelError) as e:
        raise _UsageError(str(e)) from None
    except SimulationError as e:
        print(f"ancf-jax fit: {e}", file=sys.stderr)
        return 1
    out.mkdir(parents=True, exist_ok=True)
    if len(results) == 1:
        best = results[0]
        report = best.to_dict()
    elif len(datasets) > 1:
        best = None
        report = {"fits": [r.to_dict() for r in results]}
    else:  # several starts on one data set: report the lowest loss, list every start
        best = min(results, key=lambda r: r.loss_history[-1])
        report = best.to_dict()
        report["starts"] = [dict(init=r.to_dict()["init"], estimates=dict(zip(r.names, map(float, r.estimates))),
                                 loss=r.loss_history[-1], iterations=r.iterations, converged=r.converged)
                            for r in results]
    (out / "fit.json").write_text(json.dumps(report, indent=2))
    shown = results if best is None else [best]
    for k, r in enumerate(shown):
        print(r.summary())
        if not args.no_figures:
            name = "fit.png" if len(shown) == 1 else f"fit_{k + 1}.png"
            r.figure(out / name, ylabel=f"{problem.output.name}")
    print(f"-> {out}/")
    return 0 if all(r.converged for r in results) else 1


def _model_path(args) -> str:
    """``"FILE: "`` of the command's scenario for a message (``""`` when it cannot be named)."""
    model = getattr(args, "model", None)
    if model is None:
        return ""
    try:
        from .scenario.loader import resolve
        return f"{resolve(model)}: "
    except Exception:  # noqa: BLE001 - only for the message
        return f"{model}: "


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``ancf-jax``: parse ``argv`` (default ``sys.argv[1:]``), run the
    command and return the exit status (0 ok, 1 failed run, 2 bad input, 130
    interrupted; see the module docstring)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    try:
        return {"run": _run, "static": _static, "modal": _modal, "check": _check, "synth": _synth,
                "fit": _fit, "fatigue": _fatigue, "sweep": _sweep}[args.command](args)
    except _UsageError as e:
        print(f"ancf-jax {args.command}: error: {e}", file=sys.stderr)
        return 2
    except ModelError as e:  # bad model input found while building (e.g. conflicting joints), before compiling
        print(f"ancf-jax {args.command}: error: {_model_path(args)}{e}", file=sys.stderr)
        return 2
    except StaticsError as e:  # a static equilibrium (the command's, or a run's initial state) not found
        print(f"ancf-jax {args.command}: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # before or after the time loop (which keeps its results)
        print(f"ancf-jax {args.command}: interrupted (Ctrl-C) before any result was written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
