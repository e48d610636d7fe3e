"""The documentation site builds without a warning: ``mkdocs build --strict`` (API
reference from the docstrings by mkdocstrings; a docstring parameter that is not in the
signature, or a broken link, fails the build)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_mkdocs_build_strict(tmp_path):
    pytest.importorskip("mkdocs", reason="needs the test extra (mkdocs, mkdocstrings[python])")
    pytest.importorskip("mkdocstrings_handlers.python", reason="needs the test extra (mkdocstrings[python])")
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                          cwd=ROOT, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, "mkdocs build --strict failed:\n" + "\n".join(
        line for line in log.splitlines() if "WARNING" in line or "ERROR" in line or "Error" in line)
    assert (tmp_path / "site" / "api" / "element" / "index.html").exists()


def test_every_module_is_in_the_api_reference():
    """Each public module of the package has a ``::: module`` entry in docs/api/*.md, so a
    new module cannot be left out of the reference."""
    documented = set()
    for page in (ROOT / "docs" / "api").glob("*.md"):
        documented |= {line.split()[1] for line in page.read_text(encoding="utf-8").splitlines()
                       if line.startswith("::: ")}
    modules = set()
    for path in (ROOT / "ancf_jax").rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if any(p.startswith("_") for p in parts):
            continue
        modules.add(".".join(parts))
    missing = sorted(modules - documented)
    assert not missing, f"add these modules to a page in docs/api/ (and mkdocs.yml nav if new): {missing}"
