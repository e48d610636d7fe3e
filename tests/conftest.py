"""Shared fixtures and helpers. JAX compile time dominates the suite: build systems
once per module and reuse compiled functions."""

import os

import ancf_jax  # noqa: F401  (turns on float64)
import numpy as np
import pytest


@pytest.fixture(scope="session")
def rng():
    return np.random.default_rng(20261122)


def pytest_configure(config):
    os.environ.setdefault("ANCF_JAX_QUICK", "1")
