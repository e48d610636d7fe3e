"""Translation from other multibody codes (:mod:`ancf_jax.interop.exudyn`)."""
