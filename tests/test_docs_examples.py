"""docs/examples.md is the composition of the committed study tables (no drift)."""

from benchmarks.examples_doc import DOC, compose


def test_examples_page_matches_the_study_tables():
    assert DOC.read_text() == compose(), "regenerate with: python -m benchmarks.examples_doc"
