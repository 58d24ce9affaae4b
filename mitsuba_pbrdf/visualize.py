"""Deprecated: use :mod:`mitsuba_pbrdf.pictures.panels`. Kept so that old imports
still work."""

import warnings

from .pictures.panels import *  # noqa: F401,F403
from .pictures.panels import __all__  # noqa: F401

warnings.warn("mitsuba_pbrdf.visualize is deprecated; use mitsuba_pbrdf.pictures.panels",
              DeprecationWarning, stacklevel=2)
