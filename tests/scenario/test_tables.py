"""Tabulated time functions and the file-path rule."""

import os

import jax
import numpy as np
import pytest

from ancf_jax.scenario import ScenarioError, load_scenario
from ancf_jax.scenario.tables import TableError, resolve_data_path, table_from_csv, table_from_rows

from .conftest import BASE, write


def test_inline_table_interpolates_and_holds_the_ends():
    f = table_from_rows([[0.0, 0.0], [1.0, 2.0], [3, -2]])
    t = np.array([-1.0, 0.0, 0.5, 1.0, 2.0, 3.0, 9.0])
    np.testing.assert_allclose(np.asarray(jax.vmap(f)(t)), [0, 0, 1, 2, 0, -2, -2])
    assert f == table_from_rows([[0, 0], [1, 2], [3, -2]])


@pytest.mark.parametrize("rows,reason", [
    ([[0, 1]], "at least 2 rows"),
    ([[0, 1], [0, 2]], "increase strictly"),
    ([[1, 1], [0, 2]], "increase strictly"),
    ([[0, 1], [1, "2"]], "two numbers"),
    ([[0, 1], [1, 2, 3]], "two numbers"),
    ([[0, 1], [1, float("nan")]], "finite"),
    ([[0, True], [1, 2]], "two numbers"),
])
def test_bad_tables(rows, reason):
    with pytest.raises(TableError, match=reason):
        table_from_rows(rows)


def test_csv_with_and_without_header(tmp_path):
    (tmp_path / "a.csv").write_text("t,force\n0,0\n0.5,1\n1,0\n")
    (tmp_path / "b.csv").write_text("# comment\n0, 0\n\n0.5, 1\n1.0, 0\n")
    a, b = table_from_csv("a.csv", tmp_path), table_from_csv("b.csv", tmp_path)
    assert a == b
    assert float(a(0.25)) == pytest.approx(0.5)
    (tmp_path / "c.csv").write_text("t,f\n0,0\nx,1\n")
    with pytest.raises(TableError, match="line 3 is not two numbers"):
        table_from_csv("c.csv", tmp_path)


def test_paths_inside_the_directory_are_read(tmp_path):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "f.csv").write_text("0,1\n1,2\n")
    assert resolve_data_path("data/f.csv", tmp_path) == (tmp_path / "data" / "f.csv").resolve()
    os.symlink(tmp_path / "data" / "f.csv", tmp_path / "link.csv")  # a link that stays inside
    assert table_from_csv("link.csv", tmp_path) == table_from_csv("data/f.csv", tmp_path)


@pytest.fixture
def outside(tmp_path):
    """A scenario directory and a secret file next to (outside) it."""
    inside = tmp_path / "scenario"
    inside.mkdir()
    secret = tmp_path / "secret.csv"
    secret.write_text("0,271828.5\n1,271828.5\n")  # a value no path or message holds
    return inside, secret


@pytest.mark.parametrize("name,reason", [
    ("/etc/passwd", "absolute path"),
    ("C:\\Windows\\x.csv", "absolute path"),
    ("\\\\server\\share\\x.csv", "absolute path"),
    ("../secret.csv", "'..'"),
    ("sub/../../secret.csv", "'..'"),
    ("..\\secret.csv", "'..'"),
    ("~/secret.csv", "'~'"),
    ("missing.csv", "does not exist"),
    (".", "does not exist"),
    ("", "non-empty"),
])
def test_paths_that_break_the_rule(outside, name, reason):
    inside, _ = outside
    with pytest.raises(TableError, match=reason):
        resolve_data_path(name, inside)


def test_symlinks_leading_outside_are_refused(outside):
    inside, secret = outside
    os.symlink(secret, inside / "link.csv")
    os.symlink(secret.parent, inside / "up")
    for name in ("link.csv", "up/secret.csv"):
        with pytest.raises(TableError, match="outside the scenario's directory"):
            resolve_data_path(name, inside)


def test_scenario_reads_its_data_file_and_refuses_others(outside, no_build):
    inside, secret = outside
    (inside / "push.csv").write_text("t,f\n0,0\n1,1\n")
    ok = BASE.replace('"0.5 * sin(2*pi*t)"', '{ file = "push.csv" }')
    sc = load_scenario(str(write(inside, ok)))
    f = sc.spec.loads["push"].time_function
    assert f.kind == "file" and float(f(0.5)) == pytest.approx(0.5)
    os.symlink(secret, inside / "evil.csv")
    for name in ("evil.csv", "../secret.csv", str(secret)):
        bad = BASE.replace('"0.5 * sin(2*pi*t)"', '{ file = "%s" }' % name)
        with no_build():
            with pytest.raises(ScenarioError) as err:
                load_scenario(str(write(inside, bad)))
        assert err.value.key == "loads.push.time_function"
        assert "271828" not in str(err.value)  # ("42" failed in a tmp dir pytest-42)
