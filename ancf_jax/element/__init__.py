"""Physics of one planar ANCF beam element: shape functions (Eqs. 1–4), mass (Eqs. 5–6),
strain energy (Eq. 8), curvature and stress (Eqs. 15–18)."""

from .mass import gravity_load, mass_matrix
from .quadrature import gauss_legendre, gauss_lobatto
from .shape_functions import (position, shape_functions, shape_functions_dx,
                              shape_functions_dxx, shape_matrix, slope, slope_derivative)
from .strain_energy import Formulation, axial_strain, cross2, curvature, strain_energy
from .stress import BARLOW_POINTS, bending_moment, bending_stress

__all__ = [
    "shape_functions", "shape_functions_dx", "shape_functions_dxx", "shape_matrix",
    "position", "slope", "slope_derivative",
    "mass_matrix", "gravity_load",
    "Formulation", "strain_energy", "axial_strain", "curvature", "cross2",
    "bending_stress", "bending_moment", "BARLOW_POINTS",
    "gauss_legendre", "gauss_lobatto",
]
