"""The pytest workers stay free of native libraries that bring their own threads and
codecs (Zarr's numcodecs, Ray, Exudyn, Jupyter's pyzmq): xdist workers that had loaded
one of them crashed at random inside XLA's executable serialization, in later,
unrelated tests. Those libraries are used in child processes instead (the sweep suite,
the Exudyn cases, the notebooks). This module is imported at collection, so the check
sees what pytest and its plugins loaded (zarr's plugin is disabled in pyproject.toml)."""

import sys

FOREIGN = ("numcodecs", "zarr", "ray", "exudyn", "zmq")
AT_COLLECTION = [m for m in FOREIGN if m in sys.modules]


def test_nothing_foreign_was_loaded_by_pytest_or_its_plugins():
    assert AT_COLLECTION == [], f"loaded into the pytest process at collection: {AT_COLLECTION}"
