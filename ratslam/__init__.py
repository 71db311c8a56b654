"""RatSLAM with experience mapping (Milford, Prasser & Wyeth, ACRA 2005)."""

from .config import RatSLAMConfig
from .pipeline import RatSLAM

__all__ = ["RatSLAM", "RatSLAMConfig"]
