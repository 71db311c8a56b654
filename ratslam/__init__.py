"""RatSLAM with experience mapping (Milford, Prasser & Wyeth, ACRA 2005)."""

from .config import (
    PAPER_REENTRIES,
    ExperienceMapConfig,
    LocalViewConfig,
    PoseCellConfig,
    RatSLAMConfig,
    ReentryFusionConfig,
    ViewConfig,
    YawBiasConfig,
)
from .pipeline import RatSLAM

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
