"""Time integrators of the constrained equations of motion (Eqs. 10–14, 21).

:mod:`.generalized_alpha` (implicit, index 3, the default), :mod:`.rk4` (the paper's
classical RK4 with projection), :mod:`.diffrax_solvers` (adaptive explicit and implicit
diffrax solvers, index 1 with Baumgarte terms) and :mod:`.base` (the interface and
carry they share). Select them by name in :func:`ancf_jax.simulation.simulate`.
"""
