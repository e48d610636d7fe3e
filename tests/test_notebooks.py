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

# jupytext imports jupyter_client and so pyzmq: it is used only in child interpreters
# (see _EXECUTE), the worker reads notebooks with nbformat
if __import__("importlib").util.find_spec("jupytext") is None:  # found, not imported
    pytest.skip("needs the test extra (jupytext)", allow_module_level=True)
nbformat = pytest.importorskip("nbformat", reason="needs the test extra (nbformat)")

#: prints the cells of the paired scripts, as jupytext reads them, as JSON {path: cells}
_SCRIPT_CELLS = """
import json, sys
import jupytext
print(json.dumps({p: [[c.cell_type, c.source.strip()] for c in jupytext.read(p).cells] for p in sys.argv[1:]}))
"""


def _child(code, *args, timeout=1200):
    import subprocess
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], env=env, capture_output=True,
                          text=True, timeout=timeout)


def _cells(nb):
    return [[c.cell_type, c.source.strip()] for c in nb.cells]


def test_every_notebook_has_a_script_and_a_notebook():
    assert SCRIPTS, "no notebooks found"
    stems = {p.stem for p in NOTEBOOKS.glob("*.ipynb")}
    assert stems == set(IDS), f"unpaired: {sorted(stems ^ set(IDS))} (run jupytext --sync notebooks/*.py)"


@pytest.fixture(scope="module")
def script_cells():
    """{script path: its cells as jupytext reads them}: every script in one child
    interpreter (jupytext's imports cost more than reading six scripts)."""
    import json
    proc = _child(_SCRIPT_CELLS, *SCRIPTS, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout)


@pytest.mark.parametrize("script", SCRIPTS, ids=IDS)
def test_notebook_matches_its_script(script, script_cells):
    """The .ipynb has the cells of the .py, in order (run ``jupytext --sync`` after editing)."""
    ipynb = nbformat.read(script.with_suffix(".ipynb"), as_version=4)
    assert _cells(ipynb) == script_cells[str(script)], \
        f"{script.name} and its .ipynb differ: run jupytext --sync {script}"
    assert all(not c.get("outputs") for c in ipynb.cells if c.cell_type == "code"), \
        f"{script.with_suffix('.ipynb').name} is committed with outputs; clear them"


#: executes one notebook in a fresh kernel and writes the executed copy; run in a child
#: interpreter so that Jupyter's client (pyzmq and tornado, with their native I/O
#: threads) never loads into the xdist worker, whose later XLA executable
#: serializations crashed in workers holding such libraries (see tests/test_sweep.py)
_EXECUTE = """
import sys
import jupytext, nbclient, nbformat
script, work, out = sys.argv[1:4]
nb = jupytext.read(script)
client = nbclient.NotebookClient(nb, timeout=900, kernel_name="python3",
                                 resources={"metadata": {"path": work}})
try:
    client.execute()
except nbclient.exceptions.CellExecutionError as err:
    print(err, file=sys.stderr)
    sys.exit(3)
finally:
    nbformat.write(nb, out)
"""


#: notebooks whose kernels compile ancf_jax's programs at LLVM level 3, not the suite's 0
#: (tests/conftest.py), with the same options as the identification modules
#: (``ANCF_JAX_COMPILER_OPTIONS``, the modules' COMPILER_OPTIONS): their fits run one
#: program many times, and they find the programs those modules compiled in the
#: persistent cache. Measured as scripts, quick mode, one at a time (2026-12-07, 2
#: cores), fresh caches, level 0 against 3: 04_identification 79 s against 49 s, the
#: others faster at 0 or equal (01 16/21 s, 02 22/27, 03 38/40, 05 38/51, 06 52/52); at
#: level 3 after the two identification modules filled the cache: 04 34 s, 06 38 s.
OPTIMIZED = {"04_identification", "06_measured_record"}


#: the notebooks executed only with the validation studies (``-m study``,
#: ``python -m benchmarks.suite_time --studies``): the identification and measured-record notebooks
#: (the fits of tests/test_identification.py and test_identification_real.py, 47 s
#: each) and the performance notebook (timings, 34 s); 01-03, the element and the
#: paper's two examples, run in the default suite
STUDIES = {"04_identification", "05_performance", "06_measured_record"}


@pytest.mark.slow
@pytest.mark.parametrize("script", [pytest.param(p, marks=pytest.mark.study) if p.stem in STUDIES else p
                                    for p in SCRIPTS], ids=IDS)
def test_notebook_runs_in_quick_mode(script, tmp_path):
    """Execute the notebook in a fresh kernel (its directory as working directory); a
    cell error fails the test with the cell and the traceback."""
    from importlib.util import find_spec  # found, not imported (see _EXECUTE)

    if find_spec("nbclient") is None or find_spec("ipykernel") is None:
        pytest.skip("needs the test extra (nbclient, ipykernel)")
    env = dict(os.environ, ANCF_JAX_QUICK="1")
    if script.stem in OPTIMIZED:
        from tests.test_identification import COMPILER_OPTIONS
        env["ANCF_JAX_COMPILER_OPTIONS"] = ",".join(f"{k}={v}" for k, v in COMPILER_OPTIONS.items())
    env.pop("MPLBACKEND", None)  # the kernel's inline backend renders the figures
    # the kernel imports this checkout of ancf_jax, whatever is installed
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    work = tmp_path / "notebooks"
    work.mkdir()
    executed = tmp_path / script.with_suffix(".ipynb").name  # executed copy, for debugging
    import subprocess
    proc = subprocess.run([sys.executable, "-c", _EXECUTE, str(script), str(work), str(executed)],
                          env=env, capture_output=True, text=True, timeout=1200)
    if proc.returncode == 3:
        pytest.fail(f"{script.name}: a cell failed\n{proc.stderr[-6000:]}", pytrace=False)
    assert proc.returncode == 0, proc.stderr[-6000:]
    assert "zmq" not in sys.modules, "the Jupyter client was loaded into the pytest worker"
    nb = nbformat.read(executed, as_version=4)
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    figures = [o for o in outputs if "image/png" in o.get("data", {})]
    assert figures, f"{script.name} displayed no figure (is the inline backend selected?)"
