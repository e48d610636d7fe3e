"""Lazy imports of the optional dependencies of the sweep layer (extra ``sweep``)."""

from __future__ import annotations

import importlib


def need(module: str, pip_name: str | None = None):
    """Import ``module`` or raise an ImportError naming the extra that installs it."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise ImportError(f"ancf_jax.sweep needs {pip_name or module}: pip install 'ancf_jax[sweep]' "
                          f"({e})") from None
