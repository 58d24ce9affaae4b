"""Deprecated: use :mod:`mitsuba_pbrdf.imaging.panels`. Kept so that old imports
still work."""

import warnings

from .imaging.panels import *  # noqa: F401,F403
from .imaging.panels import __all__  # noqa: F401

warnings.warn("mitsuba_pbrdf.visualize is deprecated; use mitsuba_pbrdf.imaging.panels",
              DeprecationWarning, stacklevel=2)
