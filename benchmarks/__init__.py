"""Benchmarks and cross-checks of ancf_jax (run as ``python -m benchmarks.<name>``)."""
