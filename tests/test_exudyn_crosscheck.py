"""Cross-check against Exudyn (``exudyn`` is in the test extra; a checkout without it
skips this module, except under CI, where a missing Exudyn is an error).

The Exudyn twins are translated from the ancf_jax systems (benchmarks/exudyn_models.py),
so any difference measures the codes, not the inputs. Tolerances are set from measured
agreement (benchmarks/EXUDYN.md) with margin, and each test has a negative control: the
same comparison with one known difference must fail the tolerance by orders of magnitude.
"""

import importlib.util
import multiprocessing as mp
import os
import sys
from concurrent.futures import ProcessPoolExecutor

import pytest

if not os.environ.get("CI") and importlib.util.find_spec("exudyn") is None:
    pytest.skip("exudyn is not installed (it is in the test extra)", allow_module_level=True)


@pytest.fixture(scope="module")
def exudyn_process():
    """One spawned interpreter for the module's cases (tests/exudyn_cases.py): Exudyn is
    imported there, never in the pytest worker."""
    with ProcessPoolExecutor(max_workers=1, mp_context=mp.get_context("spawn")) as pool:
        yield pool


def _call(name):
    """In the child: import the cases (and Exudyn) and run one."""
    import tests.exudyn_cases as cases
    getattr(cases, name)()


def run_case(pool, name):
    """Run ``tests.exudyn_cases.<name>`` in the Exudyn process; its failures re-raise here."""
    pool.submit(_call, name).result()
    assert "exudyn" not in sys.modules  # the pytest worker stayed free of Exudyn


def test_exudyn_quadrature_rules(exudyn_process):
    run_case(exudyn_process, "exudyn_quadrature_rules")


def test_m1_matches_exudyn(exudyn_process):
    run_case(exudyn_process, "m1_matches_exudyn")


def test_sliding_joint_term(exudyn_process):
    run_case(exudyn_process, "sliding_joint_term")


def test_strain_rate_damping_element_matches_exudyn(exudyn_process):
    run_case(exudyn_process, "strain_rate_damping_element")


def test_curved_reference_element_matches_exudyn(exudyn_process):
    run_case(exudyn_process, "curved_reference_element")


def test_strain_rate_damping_dynamics_matches_exudyn(exudyn_process):
    run_case(exudyn_process, "strain_rate_damping_dynamics")


def test_from_exudyn_matches_exudyn(exudyn_process):
    run_case(exudyn_process, "from_exudyn_dynamics")


def test_from_exudyn_eigenvalues_match_exudyn(exudyn_process):
    run_case(exudyn_process, "from_exudyn_eigenvalues")


def test_explicit_solvers_match_exudyn(exudyn_process):
    run_case(exudyn_process, "explicit_solvers_match_exudyn")


def test_to_exudyn_matches_ancf_jax(exudyn_process):
    run_case(exudyn_process, "to_exudyn_matches_ancf_jax")


@pytest.mark.study
def test_from_exudyn_sliding_joint_and_curved_cables(exudyn_process):
    run_case(exudyn_process, "from_exudyn_sliding_and_curved")


def test_index2_matches_exudyn(exudyn_process):
    run_case(exudyn_process, "index2_matches_exudyn")


def test_bilinear_law_matches_exudyn(exudyn_process):
    run_case(exudyn_process, "bilinear_law_matches_exudyn")


def test_from_exudyn_rigid_mechanism(exudyn_process):
    run_case(exudyn_process, "from_exudyn_rigid_mechanism")


@pytest.mark.study
def test_from_exudyn_formulations_and_offsets(exudyn_process):
    run_case(exudyn_process, "from_exudyn_formulations_and_offsets")
