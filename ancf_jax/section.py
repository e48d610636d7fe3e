"""Cross-section and material of a beam: E, A, I, mass per length, outer fibre.

A section is given either by E, A and I (:class:`Section`) or, as Exudyn's cable
takes it, by the stiffnesses EA, EI and ρA (:meth:`Section.from_stiffness`).
"""

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
        modulus_known: False for a section given by its stiffnesses only
            (:meth:`from_stiffness` without ``youngs_modulus``): E, A and I are then not
            known separately, the element sees EA and EI exactly, and stresses raise
            (static).
    """

    youngs_modulus: jnp.ndarray
    area: jnp.ndarray
    second_moment: jnp.ndarray
    mass_per_length: jnp.ndarray
    fibre_distance: jnp.ndarray
    modulus_known: bool = eqx.field(static=True)

    def __init__(self, youngs_modulus, area, second_moment, mass_per_length,
                 fibre_distance=None, *, modulus_known: bool = True):
        self.youngs_modulus = jnp.asarray(check_positive("youngs_modulus (E)", youngs_modulus, "Pa"), float)
        self.area = jnp.asarray(check_positive("area (A)", area, "m^2"), float)
        self.second_moment = jnp.asarray(check_positive("second_moment (I)", second_moment, "m^4"), float)
        self.mass_per_length = jnp.asarray(
            check_positive("mass_per_length (rho*A)", mass_per_length, "kg/m"), float)
        if fibre_distance is None:
            fibre_distance = math.sqrt(2.0 * float(second_moment) / float(area))  # circle-equivalent
        self.fibre_distance = jnp.asarray(check_positive("fibre_distance", fibre_distance, "m"), float)
        self.modulus_known = bool(modulus_known)

    @classmethod
    def from_stiffness(cls, axial_stiffness, bending_stiffness, mass_per_length, *,
                       fibre_distance=None, youngs_modulus=None):
        """A section given as Exudyn's cable takes it: EA [N], EI [N·m²] and ρA [kg/m].

        Args:
            axial_stiffness: EA [N] > 0.
            bending_stiffness: EI [N·m²] > 0.
            mass_per_length: ρA [kg/m] > 0.
            fibre_distance: outer-fibre distance c [m] for stresses (default
                √(2 EI/EA) = √(2I/A), the circle-equivalent value of :class:`Section`).
            youngs_modulus: E [Pa], optional: needed only for stresses (σ = −E y κ,
                Eq. 18; A = EA/E and I = EI/E then). Without it the stored E is 1 and
                A, I hold EA, EI, so that the element energy (Eq. 8) sees EA and EI
                exactly; stresses then raise a :class:`~ancf_jax.errors.ModelError`.
        """
        ea = check_positive("axial_stiffness (EA)", axial_stiffness, "N")
        ei = check_positive("bending_stiffness (EI)", bending_stiffness, "N*m^2")
        if fibre_distance is None:
            fibre_distance = math.sqrt(2.0 * float(ei) / float(ea))
        if youngs_modulus is None:
            return cls(1.0, ea, ei, mass_per_length, fibre_distance, modulus_known=False)
        e = check_positive("youngs_modulus (E)", youngs_modulus, "Pa")
        return cls(e, float(ea) / float(e), float(ei) / float(e), mass_per_length, fibre_distance)

    def require_modulus(self, what: str) -> None:
        """Raise a one-line :class:`~ancf_jax.errors.ModelError` if E is not known
        (a section from :meth:`from_stiffness` without ``youngs_modulus``)."""
        if not self.modulus_known:
            from .errors import ModelError
            raise ModelError(f"{what} needs Young's modulus: the section was given by EA and EI "
                             "only; give youngs_modulus (E > 0, Pa) to Section.from_stiffness "
                             "(scenario: key E next to EA and EI)")

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
