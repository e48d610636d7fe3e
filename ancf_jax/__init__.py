"""ancf_jax: a JAX-accelerated, differentiable simulator for very flexible beams and
cables (absolute nodal coordinate formulation) coupled with rigid multibody systems.

Implements Seo, Jung & Park, "Nonlinear Dynamic Analysis of a Large Deformable Beam
Using Absolute Nodal Coordinates" (planar ANCF beam, Eqs. 1–21) and goes beyond it.

Importing the package turns on float64 in JAX: the stiff axial modes of a steel wire
make float32 simulations diverge. It also turns on JAX's persistent compilation cache
(``~/.cache/ancf_jax/xla``; ``ANCF_JAX_CACHE=0`` turns it off, see
:mod:`ancf_jax._cache`), so a model compiled once starts at once in later processes,
and adds XLA:CPU flags chosen by measurement to ``XLA_FLAGS`` (``ANCF_JAX_XLA_FLAGS=0``
turns that off, see :mod:`ancf_jax._xla`); :func:`compiler_options` sets XLA compiler
options for the programs compiled in a ``with`` block.
"""

from ._xla import configure_xla_flags as _configure_xla_flags

_configure_xla_flags()

import jax as _jax  # noqa: E402

_jax.config.update("jax_enable_x64", True)

from ._cache import configure_compilation_cache as _configure_compilation_cache  # noqa: E402

_configure_compilation_cache()

from ._version import __version__  # noqa: E402
from ._xla import compiler_options  # noqa: E402
from .errors import (ConstraintError, InexactNewtonMatrixWarning, ModelError, SimulationError,  # noqa: E402
                     SimulationInterrupted, StaticsError, VelocityProjectionWarning)

__all__ = [
    "__version__",
    "compiler_options",
    "ModelError",
    "ConstraintError",
    "StaticsError",
    "SimulationError",
    "SimulationInterrupted",
    "VelocityProjectionWarning",
    "InexactNewtonMatrixWarning",
]
