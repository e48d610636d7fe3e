"""Exceptions raised by ancf_jax.

Every error names what went wrong in the user's terms: the parameter and its accepted
range for bad input, the time and the reason for a failed simulation.
"""

from __future__ import annotations

from typing import Any


class ModelError(ValueError):
    """Invalid model input (a parameter out of range, an unknown name, a bad topology).

    Raised while a model is being built, before anything is compiled.
    """


class ConstraintError(ModelError):
    """Redundant or conflicting constraints, detected from the rank of Φ_q at assembly."""


class VelocityProjectionWarning(UserWarning):
    """Initial velocities that were given had to change to satisfy the joints.

    Issued by :func:`ancf_jax.model.project_velocities` (at assembly) with the body,
    beam or sliding joint whose given velocity changed and by how much.
    """


class InexactNewtonMatrixWarning(UserWarning):
    """A joint not declared linear in the beam coordinates is in a Newton matrix.

    Issued by :func:`ancf_jax.dae.iteration_matrix` (while tracing, before compilation)
    naming the joint: the matrix leaves out its constraint Hessian between beam
    coordinates, exact only when Φ is linear in them
    (:class:`ancf_jax.joints.AbstractConstraint`); otherwise Newton converges more slowly
    or fails (reported as a Newton failure), the solution it reaches is unaffected;
    derivatives refine their tangent solves against the residual's exact linearization
    (``GeneralizedAlpha.tangent_refinement``).
    """


class StaticsError(RuntimeError):
    """The static Newton solver did not converge.

    Attributes:
        load_step: index of the load step that failed (0-based).
        load_factor: the load factor of that step.
        residual: the residual norm reached.
        state: the last converged configuration (a :class:`~ancf_jax.system.State`).
    """

    def __init__(self, message: str, *, load_step: int, load_factor: float,
                 residual: float, state: Any = None):
        super().__init__(message)
        self.load_step = load_step
        self.load_factor = load_factor
        self.residual = residual
        self.state = state


class SimulationError(RuntimeError):
    """A simulation stopped: NaN, Newton failure, constraint drift, or a sliding joint
    that left its beam.

    Attributes:
        time: the simulation time [s] at which the failure was detected.
        reason: a short machine-readable reason code.
        results: the :class:`~ancf_jax.results.Results` computed up to the failure.
    """

    def __init__(self, message: str, *, time: float, reason: str, results: Any = None):
        super().__init__(message)
        self.time = time
        self.reason = reason
        self.results = results


class SimulationInterrupted(KeyboardInterrupt):
    """A simulation stopped by the user (Ctrl-C) with ``on_failure="raise"``.

    A ``KeyboardInterrupt`` (so that ``except Exception`` does not swallow Ctrl-C) that
    carries what was computed: the chunk loop stops at the next chunk boundary.

    Attributes:
        time: the last simulation time [s] computed.
        reason: ``"interrupted"`` (:attr:`ancf_jax.failures.Failure.INTERRUPTED`).
        results: the :class:`~ancf_jax.results.Results` computed up to then (a list of
            them for :func:`~ancf_jax.simulation.simulate_batch`).
    """

    def __init__(self, message: str, *, time: float, reason: str = "interrupted", results: Any = None):
        super().__init__(message)
        self.time = time
        self.reason = reason
        self.results = results
