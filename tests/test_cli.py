"""The console script."""

import shutil
import subprocess
import sys

import pytest

from ancf_jax import __version__
from ancf_jax.cli import main


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert __version__ in capsys.readouterr().out


def test_help(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    assert "ancf-jax" in capsys.readouterr().out


@pytest.mark.skipif(shutil.which("ancf-jax") is None, reason="console script not installed")
def test_console_script_version():
    out = subprocess.run(["ancf-jax", "--version"], capture_output=True, text=True, check=True)
    assert __version__ in out.stdout


def test_a_static_equilibrium_not_found_is_one_line_and_exit_1(monkeypatch, capsys):
    """A StaticsError (here from the scenario's static solve: a fine mesh whose residual
    stalls above the tolerance, as hauled_cabin at 96 elements did) is a failed run:
    one line on stderr, exit 1, no traceback."""
    from ancf_jax.errors import StaticsError
    from ancf_jax.scenario.scenario import Scenario

    def fails(self):
        raise StaticsError("static Newton solver did not converge in load step 1 of 10", load_step=1,
                           load_factor=0.1, residual=4.87e-7)
    monkeypatch.setattr(Scenario, "static_results", fails)
    assert main(["static", "m1", "--json"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["ancf-jax static: static Newton solver did not converge in load step 1 of 10"]
