"""Fatigue from the dynamic stress: cycles, damage along the beams, life, gradients.

* :func:`cycles`: rainflow cycles (ASTM E1049-85) of a stress history.
* :class:`SNCurve`, :func:`equivalent_range`: S–N curves with knee and cut-off
  (Eurocode 3 detail categories, power laws, endurance limits) and mean-stress
  corrections (Goodman, Gerber).
* :func:`miner`, :func:`rainflow_damage`, :func:`life`: Palmgren–Miner damage and life.
* :func:`dirlik_damage`, :func:`narrow_band_damage`: spectral damage in JAX (``jax.grad``).
* :func:`fibre_stress`, :func:`stress_history`: σ = K_t (N/A ± E c κ) along beams.
* :func:`analyse`: damage and life along every beam of a run; files and figures.
* :func:`study`, :func:`damage_function`: damage as a differentiable function of model
  parameters through the simulated run; vmapped studies with ∂D/∂p in one call.

Layering: this package belongs to the analysis layer; it imports the element, beam,
system and results modules (and, for studies, the pure run of :mod:`ancf_jax.simulation`
and the parameter names of :mod:`ancf_jax.identification.parameters`), and nothing
below imports it.
"""

from .analysis import (METHODS, Concentration, FatigueResult, FatigueSettings, analyse, settings_from_table,
                       sinusoid_damage)
from .damage import life, miner, rainflow_damage
from .rainflow import cycles, reversals
from .sn import CORRECTIONS, SNCurve, equivalent_range
from .spectral import (dirlik_coefficients, dirlik_damage, narrow_band_damage, rayleigh_damage,
                       spectral_moments, welch)
from .stress import fibre_stress, points_along, points_at, stress_history
from .study import StudyResult, damage_function, study

__all__ = ["cycles", "reversals", "SNCurve", "equivalent_range", "CORRECTIONS", "miner",
           "rainflow_damage", "life", "welch", "spectral_moments", "dirlik_coefficients",
           "dirlik_damage", "narrow_band_damage", "rayleigh_damage", "fibre_stress", "points_along",
           "points_at", "stress_history", "analyse", "FatigueSettings", "FatigueResult",
           "Concentration", "METHODS", "sinusoid_damage", "settings_from_table", "study", "damage_function",
           "StudyResult"]
