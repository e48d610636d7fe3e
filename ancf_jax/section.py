"""Cross-section and material of a beam: E, A, I, mass per length, outer fibre."""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp

from .validation import check_positive


class Section(eqx.Module):
    """Beam cross-section and material (all SI).

    Attributes:
        youngs_modulus: E [Pa].
        area: A [m²].
        second_moment: I [m⁴] (area moment about the bending axis).
        mass_per_length: ρA [kg/m].
        fibre_distance: distance of the outer fibre from the centre line [m], used as the
            default y of bending stresses (Eq. 18).
    """

    youngs_modulus: jnp.ndarray
    area: jnp.ndarray
    second_moment: jnp.ndarray
    mass_per_length: jnp.ndarray
    fibre_distance: jnp.ndarray

    def __init__(self, youngs_modulus, area, second_moment, mass_per_length,
                 fibre_distance=None):
        self.youngs_modulus = jnp.asarray(check_positive("youngs_modulus (E)", youngs_modulus, "Pa"), float)
        self.area = jnp.asarray(check_positive("area (A)", area, "m^2"), float)
        self.second_moment = jnp.asarray(check_positive("second_moment (I)", second_moment, "m^4"), float)
        self.mass_per_length = jnp.asarray(
            check_positive("mass_per_length (rho*A)", mass_per_length, "kg/m"), float)
        if fibre_distance is None:
            fibre_distance = math.sqrt(2.0 * float(second_moment) / float(area))  # circle-equivalent
        self.fibre_distance = jnp.asarray(check_positive("fibre_distance", fibre_distance, "m"), float)

    @classmethod
    def circle(cls, diameter, youngs_modulus, *, density=None, mass_per_length=None,
               area=None, second_moment=None):
        """Solid circular section of the given diameter [m].

        Exactly one of ``density`` [kg/m³] or ``mass_per_length`` [kg/m] must be given.
        ``area`` and ``second_moment`` override the values computed from the diameter
        (e.g. to use the rounded values printed in a table).
        """
        d = check_positive("diameter", diameter, "m")
        a = math.pi * d * d / 4.0 if area is None else area
        i = math.pi * d**4 / 64.0 if second_moment is None else second_moment
        if (density is None) == (mass_per_length is None):
            from .errors import ModelError
            raise ModelError("give exactly one of density (kg/m^3) or mass_per_length (kg/m)")
        mpl = mass_per_length if mass_per_length is not None else check_positive(
            "density", density, "kg/m^3") * float(a)
        return cls(youngs_modulus, a, i, mpl, fibre_distance=d / 2.0)

    @property
    def axial_stiffness(self):
        """EA [N]."""
        return self.youngs_modulus * self.area

    @property
    def bending_stiffness(self):
        """EI [N·m²]."""
        return self.youngs_modulus * self.second_moment
