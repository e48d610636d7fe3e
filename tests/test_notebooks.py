"""The notebooks in ``notebooks/``: every percent-format script runs top to bottom in
quick mode (``ANCF_JAX_QUICK=1``) as a Jupyter notebook without a cell error, and every
``.ipynb`` holds the same cells as its script (jupytext pairing), so the two cannot
diverge. Each notebook is one test, so ``pytest -n 2`` runs two at a time.
"""

import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
SCRIPTS = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.py"))
IDS = [p.stem for p in SCRIPTS]

jupytext = pytest.importorskip("jupytext", reason="needs the test extra (jupytext)")


def _cells(nb):
    return [(c.cell_type, c.source.strip()) for c in nb.cells]


def test_every_notebook_has_a_script_and_a_notebook():
    assert SCRIPTS, "no notebooks found"
    stems = {p.stem for p in NOTEBOOKS.glob("*.ipynb")}
    assert stems == set(IDS), f"unpaired: {sorted(stems ^ set(IDS))} (run jupytext --sync notebooks/*.py)"


@pytest.mark.parametrize("script", SCRIPTS, ids=IDS)
def test_notebook_matches_its_script(script):
    """The .ipynb has the cells of the .py, in order (run ``jupytext --sync`` after editing)."""
    py = jupytext.read(script)
    ipynb = jupytext.read(script.with_suffix(".ipynb"))
    assert _cells(ipynb) == _cells(py), f"{script.name} and its .ipynb differ: run jupytext --sync {script}"
    assert all(not c.get("outputs") for c in ipynb.cells if c.cell_type == "code"), \
        f"{script.with_suffix('.ipynb').name} is committed with outputs; clear them"


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS, ids=IDS)
def test_notebook_runs_in_quick_mode(script, tmp_path, monkeypatch):
    """Execute the notebook in a fresh kernel (its directory as working directory); a
    cell error fails the test with the cell and the traceback."""
    nbclient = pytest.importorskip("nbclient", reason="needs the test extra (nbclient, ipykernel)")
    pytest.importorskip("ipykernel", reason="needs the test extra (ipykernel)")
    monkeypatch.setenv("ANCF_JAX_QUICK", "1")
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel's inline backend renders the figures
    # the kernel imports this checkout of ancf_jax, whatever is installed
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    nb = jupytext.read(script)
    work = tmp_path / "notebooks"
    work.mkdir()
    client = nbclient.NotebookClient(nb, timeout=900, kernel_name="python3",
                                     resources={"metadata": {"path": str(work)}})
    try:
        client.execute()  # the kernel runs the interpreter of this test session
    except nbclient.exceptions.CellExecutionError as err:
        pytest.fail(f"{script.name}: a cell failed\n{err}", pytrace=False)
    finally:
        import nbformat
        nbformat.write(nb, tmp_path / script.with_suffix(".ipynb").name)  # executed copy, for debugging
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    figures = [o for o in outputs if "image/png" in o.get("data", {})]
    assert figures, f"{script.name} displayed no figure (is the inline backend selected?)"
