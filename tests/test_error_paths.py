"""Nothing lost, nothing silent (issue 25): bad input exits with status 2 and one line
naming the option or key and what it accepts, before anything is compiled; Ctrl-C
keeps what was computed and exits with status 130.

Most cases fail before compiling and take well under a second; the Ctrl-C cases run a
two-element pendulum for a few chunks.
"""

import csv
import json
import os
import tomllib
from pathlib import Path

import numpy as np
import pytest

from ancf_jax import simulation
from ancf_jax.cli import main
from ancf_jax.errors import ModelError, SimulationInterrupted
from ancf_jax.failures import Failure
from ancf_jax.integrate import RunLimits, RunOptions
from ancf_jax.simulation import MAX_STEPS, check_run_size

from .json_units import assert_unit_keys

M1 = Path(__file__).resolve().parents[1] / "ancf_jax" / "models" / "m1.toml"


def run_cli(argv, capsys):
    """(exit status, stdout, the stderr lines) of ``ancf-jax argv``."""
    try:
        code = main(argv)
    except SystemExit as e:  # argparse's own errors
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err.strip().splitlines()


def usage_error(argv, capsys, *fragments):
    """Assert exit 2 with one stderr line containing every fragment; returns the line."""
    code, _, err = run_cli(argv, capsys)
    assert code == 2, (code, err)
    assert len(err) == 1, err
    for f in fragments:
        assert f in err[0], err[0]
    return err[0]


# ------------------------------------------------------------------ 1. output locations
def out_commands(out):
    """Every subcommand with --out, given output location ``out``."""
    return [["run", "m1", "--out", str(out)],
            ["fatigue", "m1", "--out", str(out)],
            ["fit", "m1", "--data", "nothing.csv", "--out", str(out)],
            ["synth", "m1", "--noise", "0", "--out", str(out / "data.csv") if out.is_dir() else str(out)]]


def test_out_that_is_a_file_is_refused_before_compiling(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    afile = tmp_path / "afile"
    afile.write_text("x")
    for argv in out_commands(afile)[:3]:
        usage_error(argv, capsys, "argument --out", "not a directory", "accepted:")
    usage_error(["synth", "m1", "--noise", "0", "--out", str(tmp_path)], capsys,
                "argument --out", "is a directory")
    assert afile.read_text() == "x"


def test_out_under_a_file_is_refused(tmp_path, capsys):
    afile = tmp_path / "afile"
    afile.write_text("x")
    for argv in out_commands(afile / "sub"):
        usage_error(argv, capsys, "argument --out", "which is not a directory")


def test_sweep_out_and_netcdf_locations_are_checked_before_running(tmp_path, capsys):
    """sweep checks its store (--out) and --netcdf file before importing zarr or
    compiling: a bad location used to be found after every member had run."""
    afile = tmp_path / "afile"
    afile.write_text("x")
    sweep = ["sweep", "m1", "--param", "beams.beam.section.E=[1e11, 2e11]", "--design", "grid"]
    usage_error([*sweep, "--out", str(afile)], capsys, "argument --out", "not a directory")
    usage_error([*sweep, "--out", str(afile / "store.zarr")], capsys, "argument --out", "which is not a directory")
    usage_error([*sweep, "--out", str(tmp_path / "store.zarr"), "--netcdf", str(afile / "x.nc")], capsys,
                "argument --netcdf", "which is not a directory")
    usage_error([*sweep, "--out", str(tmp_path / "store.zarr"), "--netcdf", str(tmp_path)], capsys,
                "argument --netcdf", "is a directory")
    assert not (tmp_path / "store.zarr").exists()


def test_out_in_a_read_only_directory_is_refused(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        if os.access(ro, os.W_OK):
            pytest.skip("running as root: a read-only directory is still writable")
        for argv in out_commands(ro / "new"):
            usage_error(argv, capsys, "argument --out", "not writable")
    finally:
        ro.chmod(0o700)


def test_out_where_the_access_check_refuses_is_refused(tmp_path, capsys, monkeypatch):
    """The same refusal where the suite runs as root (CI; the test above skips there):
    the permission check answers "not writable" for the read-only directory, so
    _check_out's refusal runs for run, fatigue, fit, synth and sweep (--out and
    --netcdf), an existing directory and a new path in it alike."""
    import ancf_jax.cli

    ro = tmp_path / "ro"
    ro.mkdir()
    real_access = os.access

    def access(path, mode, **kw):
        return False if Path(path) == ro else real_access(path, mode, **kw)

    monkeypatch.setattr(ancf_jax.cli.os, "access", access)
    sweep = ["sweep", "m1", "--param", "beams.beam.section.E=[1e11, 2e11]", "--design", "grid"]
    for argv in [*out_commands(ro / "new"), [*sweep, "--out", str(ro / "store.zarr")]]:
        usage_error(argv, capsys, "argument --out", "cannot create", f"{ro} is not writable")
    usage_error(["run", "m1", "--out", str(ro)], capsys, "argument --out", f"{ro} is not writable")
    usage_error([*sweep, "--out", str(tmp_path / "store.zarr"), "--netcdf", str(ro / "x.nc")], capsys,
                "argument --netcdf", f"{ro} is not writable")
    assert list(ro.iterdir()) == []


# ------------------------------------------------------------------ 2. Ctrl-C
class _InterruptingBar:
    """A progress bar whose second update raises KeyboardInterrupt (as Ctrl-C would
    between two chunks)."""

    def __init__(self, *a, **k):
        self.updates = 0

    def update(self, n):
        self.updates += 1
        if self.updates == 2:
            raise KeyboardInterrupt

    def close(self):
        pass


@pytest.fixture
def interrupting(monkeypatch):
    monkeypatch.setattr(simulation, "_progress", _InterruptingBar)
    monkeypatch.setattr(simulation, "STEPS_PER_CHUNK", 5)  # 20 steps: 4 chunks


def pendulum():
    from ancf_jax.scenario import load_scenario
    return load_scenario("flexible_pendulum", ["beams.pendulum.elements=2", "solver.t_end=0.02",
                                               "solver.dt=1e-3", "outputs.dt=1e-3"])


def test_ctrl_c_keeps_the_chunks_computed(interrupting):
    sc = pendulum()
    system, state = sc.build()
    kw = sc.solver.simulate_kwargs()
    res = simulation.simulate(system, state, **{**kw, "on_failure": "return"})
    assert res.status == "interrupted" == Failure.INTERRUPTED.reason
    assert len(res.t) == 1 + 2 * 5  # the initial row and two chunks
    assert res.failure_time == pytest.approx(res.t[-1])
    assert "interrupted" in res.message and "\n" not in res.message
    with pytest.raises(SimulationInterrupted) as err:
        simulation.simulate(system, state, **kw)
    assert isinstance(err.value, KeyboardInterrupt) and not isinstance(err.value, Exception)
    assert len(err.value.results.t) == 11


def test_run_interrupted_writes_results_and_exits_130(interrupting, tmp_path, capsys):
    out = tmp_path / "pend"
    code, _, err = run_cli(["run", "flexible_pendulum", "--set", "beams.pendulum.elements=2",
                            "--t-end", "0.02", "--dt", "1e-3", "--output-dt", "1e-3", "--out", str(out),
                            "--no-figures"], capsys)
    assert code == 130
    assert len(err) == 1 and "interrupted" in err[0]
    summary = assert_unit_keys(out / "summary.json")
    assert summary["runs"]["flexible_pendulum"]["status"] == "interrupted"
    assert summary["runs"]["flexible_pendulum"]["failure_time_s"] > 0
    with open(out / "flexible_pendulum.csv") as f:
        rows = list(csv.reader(f))
    assert 1 < len(rows) - 1 < 21


# ------------------------------------------------------------------ 3. runaway runs
@pytest.mark.parametrize("argv,fragment", [
    (["run", "m1", "--dt", "1e-12"], "--dt = 1e-12 s"),
    (["run", "m1", "--t-end", "1e9"], "--t-end = 1e+09 s"),
    (["fatigue", "m1", "--dt", "1e-12"], "--dt = 1e-12 s"),
    (["synth", "m1", "--noise", "0", "--dt", "1e-12", "--out", "x.csv"], "--dt = 1e-12 s"),
    (["fit", "m1", "--data", "data.csv", "--dt", "1e-12"], "--dt = 1e-12 s"),
    (["fit", "m1", "--data", "data.csv", "--t-end", "1e9"], "--t-end = 1e+09 s"),
    (["check", "m1", "--set", "solver.dt=1e-12"], "solver.dt = 1e-12 s"),
])
def test_runaway_runs_are_refused_with_the_estimate(argv, fragment, capsys, tmp_path, monkeypatch):
    """run, fatigue, synth, fit and check refuse a run of more than MAX_STEPS steps
    before compiling, with the estimate and the option that allows it."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "data.csv").write_text("t,y\n" + "".join(f"{k / 100},0.0\n" for k in range(20)))
    line = usage_error(argv, capsys, fragment, "time steps", "--max-steps")
    assert "2e+12" in line or "1e+12" in line


def test_check_and_synth_take_max_steps(capsys, tmp_path):
    """--max-steps lifts the limit in check (which then validates) as in run."""
    code, out, err = run_cli(["check", "m1", "--set", "solver.t_end=200", "--max-steps", "300000"], capsys)
    assert code == 0 and "valid scenario 'm1'" in out, err
    usage_error(["check", "m1", "--set", "solver.t_end=200", "--max-steps", "1000"], capsys,
                "solver.t_end = 200 s", "2e+05 time steps", "--max-steps = 1e+03")
    usage_error(["synth", "m1", "--noise", "0", "--max-steps", "10", "--out", str(tmp_path / "y.csv")],
                capsys, "time steps", "--max-steps = 10")


@pytest.mark.parametrize("make, match", [
    (lambda: RunOptions(drift_tolerance=-1e-6), r"^drift_tolerance must be a finite number > 0 m, got -1e-06$"),
    (lambda: RunOptions(max_halvings=31), r"^max_halvings must be an integer in 0\.\.30, got 31$"),
    (lambda: RunOptions(max_halvings=1.5), r"^max_halvings must be an integer in 0\.\.30, got 1\.5$"),
    (lambda: RunOptions(crossing_iterations=0), r"^crossing_iterations must be an integer in 1\.\.50"),
    (lambda: RunOptions(locate_crossings="yes"), r"^locate_crossings must be true or false"),
    (lambda: RunOptions(max_sliding_step=0.0), r"^max_sliding_step must be a finite number > 0"),
    (lambda: RunLimits(max_steps=0), r"^max_steps must be an integer >= 1, got 0$"),
    (lambda: RunLimits(max_output_bytes=float("inf")), r"^max_output_bytes must be a finite number > 0"),
    (lambda: RunLimits(chunks=0), r"^chunks must be an integer >= 1, got 0$"),
])
def test_run_options_refuse_bad_values_on_construction(make, match):
    """RunOptions and RunLimits check their values when they are made (one line, the
    parameter and its accepted range), before any run is prepared."""
    with pytest.raises(ModelError, match=match):
        make()


def test_simulate_refuses_options_of_the_wrong_type_before_compiling():
    from ancf_jax.models.m1 import m1_model
    system, state = m1_model(2).build()
    for kw, match in ((dict(options={"locate_crossings": True}), r"^options must be a RunOptions, got dict$"),
                      (dict(limits=10), r"^limits must be a RunLimits, got int$"),
                      (dict(solver=3), r"^solver must be one of .* or an AbstractSolver instance")):
        with pytest.raises(ModelError, match=match):
            simulation.simulate(system, state, t_end=0.01, **kw)


def test_max_steps_is_checked_and_lifts_the_limit():
    n = MAX_STEPS * 2
    with pytest.raises(ModelError, match=r"max_steps"):
        check_run_size(n * 1e-3, 1e-3, 1.0, 10)
    steps, size = check_run_size(n * 1e-3, 1e-3, 1.0, 10, limits=RunLimits(max_steps=n))
    assert steps == n and size < 2**30
    with pytest.raises(ModelError, match=r"GiB of output"):
        check_run_size(1e6, 1e-3, None, 10_000, limits=RunLimits(max_steps=10**10))


def test_adaptive_runs_count_output_not_steps():
    check_run_size(1.0, 1e-12, 1e-3, 10, fixed_step=False)
    with pytest.raises(ModelError, match="output"):
        check_run_size(1.0, 1e-12, None, 10, fixed_step=False)


# ------------------------------------------------------------------ 4. time functions, messages
@pytest.mark.parametrize("expr,value", [("1/t", "inf"), ("log(t)", "-inf"), ("1e400*t", "nan")])
def test_time_functions_not_finite_on_the_grid_are_refused(expr, value, capsys):
    load = f'loads.spin={{type="torque", body="tip", torque=1.0, time_function="{expr}"}}'
    for command in ("check", "run"):
        usage_error([command, "m1", "--set", load], capsys, "loads.spin.time_function", repr(expr),
                    "not finite at t = 0 s", f"value {value}")


def test_time_functions_are_checked_at_the_steps_between_outputs(capsys):
    """1/(t - 0.005) is finite at every output time (0, 0.01, ...) but infinite at the
    fifth step of 0.001 s, where the solver evaluates it."""
    load = 'loads.spin={type="torque", body="tip", torque=1.0, time_function="1/(t-0.005)"}'
    usage_error(["check", "m1", "--set", load, "--set", "outputs.dt=0.01", "--set", "solver.dt=0.001"], capsys,
                "loads.spin.time_function", "not finite at t = 0.005 s", "every time step")


def test_prescribed_motion_not_finite_later_names_the_joint(tmp_path, capsys):
    data = tomllib.loads(M1.read_text())
    data["joints"]["drive"] = {"type": "prescribed_body", "body": "tip", "coordinate": "theta",
                               "value": "sqrt(1 - t)"}
    path = tmp_path / "m1.json"
    path.write_text(json.dumps(data))
    usage_error(["check", str(path)], capsys, "joints.drive.value", "not finite at t = 1.001 s")


def test_failure_messages_name_the_solver():
    nan = Failure.NAN.message(0.5, solver="rk4")
    assert "rk4" in nan and "Newton" not in nan
    newton = Failure.NEWTON.message(0.5, solver="generalized-alpha")
    assert "implicit generalized-alpha step" in newton
    assert "tsit5" in Failure.ADAPTIVE.explanation(solver="tsit5", max_steps=10)


def test_every_failure_has_a_reason_and_a_message():
    reasons = [member.reason for member in Failure]
    assert len(set(reasons)) == len(Failure) and all(reasons)
    for member in Failure:
        assert Failure.from_reason(member.reason) is member
        text = member.message(0.5, solver="tsit5", max_steps=7, drift_tolerance=1e-6, max_sliding_step=0.5)
        assert text.startswith("simulation stopped at t = 0.5 s: ") and "{" not in text and "\n" not in text


def test_diffrax_outcomes_map_to_failures():
    """Each diffrax.RESULTS member maps to a Failure (unlisted ones: ADAPTIVE)."""
    import diffrax

    from ancf_jax.integrate import ADAPTIVE_FAILURES, adaptive_failure
    names = list(diffrax.RESULTS._name_to_item)
    assert set(ADAPTIVE_FAILURES) <= set(names)
    for name in names:
        expected = ADAPTIVE_FAILURES.get(name, Failure.ADAPTIVE)
        assert int(adaptive_failure(getattr(diffrax.RESULTS, name))) == expected, name


def test_adaptive_run_out_of_steps_says_so():
    """A tsit5 run allowed 3 steps per output chunk stops with reason max_steps and the
    message naming the limit (not nan: the rows diffrax did not reach are not finite),
    keeping the rows before."""
    sc = pendulum()
    system, state = sc.build()
    kw = {**sc.solver.simulate_kwargs(), "solver": simulation.make_solver("tsit5", max_steps=3)}
    res = simulation.simulate(system, state, **kw, on_failure="return", progress=False)
    assert res.status == "max_steps" == Failure.MAX_STEPS.reason
    assert "adaptive tsit5 solver took max_steps = 3 steps" in res.message
    assert len(res.t) >= 1 and np.all(np.isfinite(res.q)) and res.failure_time > 0.0


# ------------------------------------------------------------------ 5. silent acceptances
def test_zero_length_ramp_is_refused(capsys):
    load = 'loads.spin={type="torque", body="tip", torque=1.0, time_function="ramp(t, 1, 1)"}'
    usage_error(["check", "m1", "--set", load], capsys, "loads.spin.time_function", "t1 > t0",
                "zero-length")


def test_body_far_from_its_fixed_joint_needs_local(capsys):
    """A tip body 5 m from the node it is fixed to was welded on through an invisible
    rigid arm: without local it is refused naming the joint; with local (an intended
    arm) it is accepted."""
    far = "bodies.tip.position=[5.0, 0.0]"
    usage_error(["check", "m1", "--set", far], capsys, "joints.tip_joint.local", "4.598 m", "rigid arm",
                "accepted: local = [x, y]")
    code, out, err = run_cli(["check", "m1", "--set", far, "--set", "joints.tip_joint.local=[-4.598, 0.0]"],
                             capsys)
    assert code == 0 and "valid scenario 'm1'" in out, err


def test_model_refuses_a_hidden_rigid_arm():
    from ancf_jax import mesh
    from ancf_jax.model import Model, node
    from ancf_jax.section import Section

    def model(position, local=None):
        m = Model(gravity=(0.0, 0.0))
        m.add_beam("arm", mesh.straight((0, 0), (1, 0), 1.0, 2), Section(1e6, 1e-4, 1e-10, 0.1))
        m.add_body("tip", mass=0.1, inertia=1e-4, position=position)
        m.clamp("root", "arm", node=0)
        m.fixed("weld", node("arm", -1), body="tip", local=local)
        return m

    with pytest.raises(ModelError, match=r"fixed joint 'weld': body 'tip' starts 5 m from node -1 of beam 'arm'"
                                         r".*rigid arm.*give local"):
        model((1.0, 5.0)).build()
    model((1.0, 5.0), local=(0.0, -5.0)).build()  # an intended arm
    model((1.0 + 1e-13, 0.0)).build()  # round-off is not an arm


def test_zero_length_spring_is_refused(capsys):
    """A spring-damper whose ends coincide at the start failed one step in as 'state
    became NaN' (its direction is undefined at zero length): refused naming the load,
    by the scenario check where the file fixes both points, else by the build."""
    spring = 'loads.s={{type="spring_damper", a={a}, b={{body="tip"}}, stiffness=100.0}}'
    usage_error(["check", "m1", "--set", spring.format(a="{ground=[0.402, 0.0]}")], capsys,
                "loads.s", "coincide at the initial state", "accepted: two points that start apart")
    usage_error(["check", "m1", "--set", spring.format(a='{beam="beam", s=0.402}')], capsys,
                "spring-damper 's'", "coincide at the initial state", "s = 0.402 m on beam 'beam' and body 'tip'")
    from ancf_jax.model import Model, body_point
    with pytest.raises(ModelError, match="spring-damper 'k': both ends are body 'b'"):
        Model().spring_damper("k", body_point("b"), body_point("b"), stiffness=1.0)


def test_empty_element_count_is_refused(capsys):
    usage_error(["run", "m2", "--elements", "6,,"], capsys, "argument --elements", "'6,,'")


def test_output_interval_longer_than_the_run_is_refused(capsys):
    usage_error(["run", "m1", "--t-end", "0.5", "--output-dt", "1"], capsys, "outputs.dt",
                "longer than the run", "0.001 .. 0.5")


@pytest.mark.parametrize("command", ["run", "fatigue"])
def test_dt_longer_than_the_output_step_raises_the_output_step(command, capsys, tmp_path):
    """--dt 0.05 on M1 (outputs every 1 ms) used to fail naming outputs.dt, which the
    user never gave: the output step is raised to --dt with a one-line note (here the
    run is then refused by --max-steps 1, before compiling, on the raised grid)."""
    code, _, err = run_cli([command, "m1", "--dt", "0.05", "--max-steps", "1", "--out", str(tmp_path / "o")],
                           capsys)
    assert code == 2 and len(err) == 2, err
    assert "note" in err[0] and "outputs.dt = 0.001 s" in err[0] and "outputs every 0.05 s" in err[0]
    assert "--dt = 0.05 s needs about 40 time steps" in err[1]
    # an output step asked for explicitly is not changed: the two options are named
    usage_error(["run", "m1", "--dt", "0.05", "--output-dt", "0.01"], capsys, "argument --output-dt",
                "shorter than --dt = 0.05 s", "accepted: a number >= 0.05")


def test_more_modes_than_degrees_of_freedom_names_the_maximum(capsys):
    usage_error(["modal", "m1", "--modes", "10000"], capsys, "argument --modes", "1 .. 24")


# ------------------------------------------------------------------ 6. JSON scenarios
def test_json_scenario_is_read_as_documented(tmp_path, capsys, monkeypatch):
    data = tomllib.loads(M1.read_text())
    (tmp_path / "m1.json").write_text(json.dumps(data, indent=1))
    monkeypatch.chdir(tmp_path)
    for source in ("m1.json", "./m1.json", str(tmp_path / "m1.json")):
        code, out, err = run_cli(["check", source], capsys)
        assert code == 0, err
        assert "valid scenario 'm1'" in out and "tip_y" in out
    (tmp_path / "bad.json").write_text('{"solver": {"t_end": 1.0,}}')
    usage_error(["check", "bad.json"], capsys, "bad.json: line 1, column", "invalid JSON")


# ------------------------------------------------------------------ 7. joints in check
def test_check_finds_conflicting_joints(capsys):
    pin = 'joints.pin={type="pin", point={beam="beam", node=0}, location=[0.1, 0.0]}'
    line = usage_error(["check", "m1", "--set", pin], capsys, "conflicting", "clamp", "pin")
    assert "redundant" not in line


def test_check_finds_redundant_joints(capsys):
    pin = 'joints.pin={type="pin", point={beam="beam", node=0}}'
    usage_error(["check", "m1", "--set", pin], capsys, "redundant", "clamp", "pin")


@pytest.mark.parametrize("command", [
    ["run"], ["static"], ["modal"], ["fatigue", "--study", "alpha=0.1,0.2"],
    ["run", "--continue-from", "earlier.npz"],
], ids=["run", "static", "modal", "fatigue-study", "continue-from"])
def test_run_refuses_conflicting_joints_with_one_line(command, capsys, tmp_path):
    """Every command that builds the model refuses conflicting joints with one line
    and exit 2 (static, modal, fatigue --study and --continue-from gave a traceback)."""
    pin = 'joints.pin={type="pin", point={beam="beam", node=0}, location=[0.1, 0.0]}'
    out = ["--out", str(tmp_path / "o")] if command[0] in ("run", "fatigue") else []
    usage_error([command[0], "m1", "--set", pin, *command[1:], *out], capsys, "conflicting", "m1.toml")
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------------------ 8. modal names, [modal] table
def test_modal_about_accepts_the_schema_names_and_the_old_aliases(capsys):
    freqs = {}
    for about in ("equilibrium", "static", "initial", "reference"):
        code, out, err = run_cli(["modal", "m1", "--about", about, "--modes", "2", "--json"], capsys)
        assert code == 0, err
        freqs[about] = json.loads(out)["frequencies_hz"]
    assert freqs["equilibrium"] == freqs["static"] and freqs["initial"] == freqs["reference"]
    assert freqs["equilibrium"] != freqs["initial"]  # the stress stiffness counts


def test_modal_honours_the_modal_table(capsys):
    code, out, _ = run_cli(["modal", "m1", "--set", "modal.modes=3", "--json"], capsys)
    assert code == 0 and len(json.loads(out)["frequencies_hz"]) == 3
    usage_error(["modal", "m1", "--set", "modal.modes=500"], capsys, "modal.modes", "1 .. 24")


def test_negative_frequencies_are_explained(capsys, monkeypatch):
    """omega^2 < 0 (a slack cable about its reference shape) printed negative
    frequencies without a word: a note says what they mean and what to try, in the
    table and as the JSON key note (modal_analysis is replaced: nothing is compiled)."""
    from ancf_jax import modal
    from ancf_jax.cli import _negative_frequency_note

    assert _negative_frequency_note([1.0, 2.0], "initial") is None
    assert "--about equilibrium" in _negative_frequency_note([-0.5, 2.0], "initial")
    assert "not a stable one" in _negative_frequency_note([-0.5, -0.1], "equilibrium")
    fake = modal.ModalResult(np.array([-0.7, 3.0]), np.array([-4.4, 18.8]), np.zeros((2, 31)))
    monkeypatch.setattr(modal, "modal_analysis", lambda *a, **k: fake)
    code, out, _ = run_cli(["modal", "m1", "--about", "initial", "--modes", "2", "--json"], capsys)
    data = json.loads(out)
    assert code == 0 and data["frequencies_hz"] == [-0.7, 3.0]
    assert "1 negative frequency" in data["note"] and "unstable" in data["note"]
    assert "--about equilibrium" in data["note"]
    code, out, _ = run_cli(["modal", "m1", "--about", "initial", "--modes", "2"], capsys)
    assert code == 0 and out.splitlines()[-1].startswith("note: 1 negative frequency")
    code, out, _ = run_cli(["modal", "--help"], capsys)
    assert "negative frequency" in " ".join(out.split())


def test_check_help_says_what_set_does(capsys):
    code, out, _ = run_cli(["check", "--help"], capsys)
    assert code == 0 and "override a scenario key" in out
