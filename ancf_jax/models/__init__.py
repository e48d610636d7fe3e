"""Ready-made models of the paper (defined exactly in docs/models.md): M1, M2, H1."""

from .m1 import m1_model
from .m2 import m2_model

__all__ = ["m1_model", "m2_model"]
