"""RatSLAM with experience mapping (Milford, Prasser & Wyeth, ACRA 2005)."""

from .config import (
    ExperienceMapConfig,
    LocalViewConfig,
    PoseCellConfig,
    RatSLAMConfig,
    ReentryFusionConfig,
    ViewConfig,
    YawBiasConfig,
)
from .pipeline import RatSLAM
from .published import PAPER_REENTRIES

__all__ = [
    "PAPER_REENTRIES",
    "ExperienceMapConfig",
    "LocalViewConfig",
    "PoseCellConfig",
    "RatSLAM",
    "RatSLAMConfig",
    "ReentryFusionConfig",
    "ViewConfig",
    "YawBiasConfig",
]
