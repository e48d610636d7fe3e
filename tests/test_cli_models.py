"""The command-line contracts of ``ancf-jax run|static|modal`` for M1 and M2."""

import csv
import json

import numpy as np
import pytest

from ancf_jax.cli import main
from ancf_jax.outputs import unit_suffix

from .json_units import assert_unit_keys


@pytest.mark.parametrize("argv,option", [
    (["run", "m1", "--t-end", "0"], "--t-end"),
    (["run", "m1", "--dt", "-1e-3"], "--dt"),
    (["run", "m1", "--elements", "0"], "--elements"),
    (["run", "m2", "--elements", "12,0"], "--elements"),
    (["run", "m1", "--solver", "euler"], "--solver"),
    (["run", "m1", "--output-dt", "nan"], "--output-dt"),
    (["static", "m1", "--elements", "-2"], "--elements"),
    (["modal", "m1", "--modes", "0"], "--modes"),
    (["modal", "m1", "--about", "deformed"], "--about"),
    (["run", "m3"], "m3"),
    (["run", "m1", "--set", "solver.dt=-1"], "solver.dt"),
    (["run", "m1", "--rho-inf", "1.5"], "--rho-inf"),
    (["run", "m2", "--elements", "12,x"], "--elements"),
    (["check", "m1", "--set", "beams.beam.elements=0"], "beams.beam.elements"),
])
def test_bad_options_exit_nonzero_with_one_line(argv, option, capsys):
    try:
        code = main(argv)
    except SystemExit as e:  # errors found by argparse itself
        code = e.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert option in err


def test_static_m1_json(capsys):
    assert main(["static", "m1", "--json"]) == 0
    data = assert_unit_keys(json.loads(capsys.readouterr().out))
    assert set(data) == {"tip_x_m", "tip_y_m", "tip_rotation_rad", "sigma_e1_mid_Pa", "units"}
    assert data["units"] == {"tip_x_m": "m", "tip_y_m": "m", "tip_rotation_rad": "rad", "sigma_e1_mid_Pa": "Pa"}
    assert data["tip_y_m"] < -0.2 and data["sigma_e1_mid_Pa"] > 0  # upper fibre in tension


def test_modal_m1_json(capsys):
    assert main(["modal", "m1", "--modes", "3", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert list(data) == ["frequencies_hz"] and len(data["frequencies_hz"]) == 3
    f = data["frequencies_hz"]
    assert 0 < f[0] < f[1] < f[2]


def test_run_m1_writes_every_file(tmp_path, capsys):
    out = tmp_path / "m1"
    assert main(["run", "m1", "--t-end", "0.05", "--out", str(out), "--no-progress"]) == 0
    with open(out / "m1_n6.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["t", "tip_x", "tip_y", "sigma_e1_mid"]
    assert len(rows) == 1 + 51 and float(rows[-1][0]) == pytest.approx(0.05)
    summary = assert_unit_keys(out / "summary.json")  # keys of dimensional numbers end in their unit
    for key in ("elements", "solver", "dt_s", "t_end_s", "wall_time_s", "compile_time_s", "tip_y_min_m",
                "tip_y_min_time_s", "tip_y_final_m", "max_abs_sigma_e1_mid_Pa", "max_abs_sigma_e1_mid_small_strain_Pa",
                "max_abs_stress_along_beam_Pa", "max_constraint_violation", "energy_balance_error"):
        assert key in summary
    assert summary["elements"] == 6 and summary["t_end_s"] == pytest.approx(0.05)
    assert summary["units"] == {"t": "s", "tip_x": "m", "tip_y": "m", "sigma_e1_mid": "Pa"}
    npz = np.load(out / "m1_n6.npz")
    labels = list(npz["coordinate_labels"])  # one per column of q, v, acc, with units
    assert len(labels) == npz["q"].shape[1] == 3 + 4 * 7
    assert labels[:3] == ["body:tip.x [m]", "body:tip.y [m]", "body:tip.theta [rad]"]
    assert labels[3] == "beam:beam.node[0].x [m]" and labels[-1] == "beam:beam.node[6].slope_y [-]"
    assert list(npz["work_labels"]) == ["dissipated [J]", "external [J]", "constraint [J]"]
    units = json.loads(str(npz["units"]))  # a unit for every array of the file
    assert set(units) == set(npz.files) - {"units"}
    assert "unspecified" not in units.values()
    assert units["t"] == "s" and units["work"] == "J" and "coordinate_labels" in units["q"]
    assert "per s" in units["v"] and "constraint_labels" in units["lam"]
    assert units["stress_sigma"] == units["sigma_e1_mid"] == "Pa" and units["stress_s"] == units["tip"] == "m"
    for name in ("m1_n6.npz", "fig5_shapes.png", "fig6_tip_displacement.png",
                 "fig7_stress_e1_mid.png", "fig8_stress_map.png"):
        assert (out / name).stat().st_size > 0


def test_a_run_continued_from_its_npz_equals_one_run(tmp_path):
    """run --continue-from: 0.05 s, then 0.05 s more from the first run's checkpoint
    (generalized-α's memory included), equals one 0.1 s run bit for bit (the same
    compiled program); without the memory, from q and v alone, it would differ."""
    one, first, second = tmp_path / "one", tmp_path / "first", tmp_path / "second"
    common = ["--no-progress", "--no-figures"]
    assert main(["run", "m1", "--t-end", "0.1", "--out", str(one), *common]) == 0
    assert main(["run", "m1", "--t-end", "0.05", "--out", str(first), *common]) == 0
    assert main(["run", "m1", "--t-end", "0.05", "--continue-from", str(first / "m1_n6.npz"),
                 "--out", str(second), *common]) == 0
    whole = np.loadtxt(one / "m1_n6.csv", delimiter=",", skiprows=1)
    cont = np.loadtxt(second / "m1_n6.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(cont[:, 0], whole[50:, 0], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(cont[:, 1:], whole[50:, 1:])
    # another mesh than the checkpoint's: bad input, before compiling
    assert main(["run", "m1", "--elements", "4", "--t-end", "0.05", "--continue-from",
                 str(first / "m1_n6.npz"), "--out", str(tmp_path / "x"), *common]) == 2


def test_check_summarizes_without_running(capsys):
    assert main(["check", "m2"]) == 0
    out = capsys.readouterr().out
    assert "valid scenario 'm2'" in out and "sliding" in out and "point1_x" in out


def test_static_m2_json_keys(capsys):
    assert main(["static", "m2", "--elements", "12", "--json"]) == 0
    data = assert_unit_keys(json.loads(capsys.readouterr().out))
    assert set(data) == {"point1_x_m", "point1_y_m", "rb2_x_m", "rb2_y_m", "horizontal_tension_N", "units"}
    assert data["rb2_y_m"] == pytest.approx(data["point1_y_m"] - 0.5)  # cabin hangs below
    assert data["horizontal_tension_N"] > 0 and data["units"]["horizontal_tension_N"] == "N"


def test_run_any_scenario_file_with_overrides(tmp_path, capsys):
    out = tmp_path / "pend"
    argv = ["run", "flexible_pendulum", "--set", "beams.pendulum.elements=4", "--t-end", "0.01",
            "--out", str(out), "--no-progress"]
    assert main(argv) == 0
    summary = assert_unit_keys(out / "summary.json")
    assert summary["model"] == "flexible_pendulum"
    run = summary["runs"]["flexible_pendulum"]
    assert run["t_end_s"] == pytest.approx(0.01) and "dt_s" in run and "failure_time_s" in run
    for name, unit in summary["units"].items():  # each column's extremes carry its unit
        if name != "t":
            assert f"{name}_min{unit_suffix(unit)}" in run and f"{name}_max{unit_suffix(unit)}" in run
    csvs = sorted(p.name for p in out.glob("*.csv"))
    assert csvs == ["flexible_pendulum.csv"]
    with open(out / csvs[0]) as f:
        header = next(csv.reader(f))
    assert header[0] == "t" and len(header) > 1
