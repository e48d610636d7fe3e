"""Why a run stopped: one enumeration of failures, with their messages.

As diffrax's ``RESULTS``: traced code carries a failure as an integer code (a
:class:`Failure` member is an ``int``, so ``jnp.where(bad, Failure.NEWTON, code)``
works under ``jit`` and ``vmap``); the host turns the code into the machine-readable
``reason`` of :class:`~ancf_jax.results.Results` and
:class:`~ancf_jax.errors.SimulationError` and into the sentence a user reads. The
checks that produce the codes live in one place, :mod:`ancf_jax.integrate`
(:func:`~ancf_jax.integrate.step_rejected`, :func:`~ancf_jax.integrate.step_status`).
"""

from __future__ import annotations

import enum


class Failure(enum.IntEnum):
    """Status of a run or a step (0: none).

    ========================  ====================  ==================================
    member                    ``reason``            cause
    ========================  ====================  ==================================
    ``OK``                    ``ok``                no failure
    ``NAN``                   ``nan``               non-finite state
    ``NEWTON``                ``newton``            Newton did not converge in a step
    ``DRIFT``                 ``constraint_drift``  max|Φ| above ``drift_tolerance``
    ``LEFT_BEAM``             ``left_beam``         a sliding joint off its beam
    ``SLIDING_JUMP``          ``sliding_jump``      a sliding joint jumped in one step
    ``ADAPTIVE``              ``solver``            an adaptive (diffrax) solver failed
                                                    otherwise (a linear or nonlinear
                                                    solve inside it)
    ``INTERRUPTED``           ``interrupted``       stopped by the user (Ctrl-C) at a
                                                    chunk boundary
    ``MAX_STEPS``             ``max_steps``         an adaptive solver used up its
                                                    ``max_steps`` in an output chunk
    ``STEP_SIZE``             ``step_size``         an adaptive solver's step fell
                                                    below its minimum
    ========================  ====================  ==================================

    An adaptive solve's outcome (diffrax's ``RESULTS``) maps to a member by
    :func:`ancf_jax.integrate.adaptive_failure`.

    ``NAN``, ``NEWTON`` and ``SLIDING_JUMP`` are the failures a smaller step can cure
    (:attr:`retryable`): the fixed-step loop redoes such a step in substeps.
    ``INTERRUPTED`` never appears in traced code: the host's chunk loop sets it when a
    ``KeyboardInterrupt`` arrives (the rows computed until then are kept).
    """

    OK = 0
    NAN = 1
    NEWTON = 2
    DRIFT = 3
    LEFT_BEAM = 4
    SLIDING_JUMP = 5
    ADAPTIVE = 6
    INTERRUPTED = 7
    MAX_STEPS = 8
    STEP_SIZE = 9

    @property
    def reason(self) -> str:
        """Machine-readable reason (``Results.status``, ``SimulationError.reason``)."""
        return _REASONS[self]

    @property
    def retryable(self) -> bool:
        """Whether a smaller step can cure it (see the class docstring)."""
        return self in (Failure.NAN, Failure.NEWTON, Failure.SLIDING_JUMP)

    def explanation(self, **context) -> str:
        """The cause in words. ``context`` fills in the numbers the message names:
        ``drift_tolerance``, ``max_sliding_step`` (:class:`~ancf_jax.integrate.RunOptions`),
        ``joint`` (which sliding joint left its beam), ``max_steps`` (adaptive solvers),
        ``solver`` (the integrator's name, e.g. ``rk4``: a message names the kind of
        step that failed, and only an implicit solver's mentions its Newton iteration)."""
        return _MESSAGES[self].format(**{**_CONTEXT_DEFAULTS, **context})

    def message(self, time: float, **context) -> str:
        """One line: ``simulation stopped at t = … s: <explanation>``."""
        return f"simulation stopped at t = {time:.6g} s: {self.explanation(**context)}"

    @classmethod
    def from_reason(cls, reason: str) -> "Failure":
        """The member whose :attr:`reason` is ``reason``."""
        for member in cls:
            if member.reason == reason:
                return member
        raise ValueError(f"unknown failure reason {reason!r}; known: {[m.reason for m in cls]}")


_REASONS = {
    Failure.OK: "ok",
    Failure.NAN: "nan",
    Failure.NEWTON: "newton",
    Failure.DRIFT: "constraint_drift",
    Failure.LEFT_BEAM: "left_beam",
    Failure.SLIDING_JUMP: "sliding_jump",
    Failure.ADAPTIVE: "solver",
    Failure.INTERRUPTED: "interrupted",
    Failure.MAX_STEPS: "max_steps",
    Failure.STEP_SIZE: "step_size",
}

_MESSAGES = {
    Failure.OK: "no failure",
    Failure.NAN: ("the state became NaN or infinite in a {solver} step (the step may be too large "
                  "for it; reduce dt)"),
    Failure.NEWTON: "the Newton iteration of an implicit {solver} step did not converge (reduce dt)",
    Failure.DRIFT: ("the constraint violation exceeded drift_tolerance = {drift_tolerance:g} "
                    "(reduce dt or tighten the solver tolerances)"),
    Failure.LEFT_BEAM: "{joint} left its beam at an end",
    Failure.SLIDING_JUMP: ("a sliding joint moved more than {max_sliding_step:g} of an element length in "
                           "one step: the Newton iteration found a spurious solution (reduce dt, or raise "
                           "rho_inf towards 1)"),
    Failure.ADAPTIVE: "the adaptive {solver} solver failed (a linear or nonlinear solve inside it failed)",
    Failure.INTERRUPTED: "interrupted (Ctrl-C); the results up to then are kept",
    Failure.MAX_STEPS: ("the adaptive {solver} solver took max_steps = {max_steps} steps without reaching the "
                        "end of an output chunk (raise max_steps; steps this small mean a stiff system, for "
                        "which an implicit solver suits)"),
    Failure.STEP_SIZE: ("the adaptive {solver} solver's step size fell below its minimum (the system is too "
                        "stiff or not smooth enough for it)"),
}

_CONTEXT_DEFAULTS = dict(drift_tolerance=float("nan"), max_sliding_step=float("nan"),
                         joint="a sliding joint", max_steps="?", solver="time")
