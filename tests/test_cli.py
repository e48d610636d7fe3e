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
