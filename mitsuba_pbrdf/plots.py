"""Deprecated: use :mod:`mitsuba_pbrdf.figures.pbrdf_plots` (plots) and
:class:`mitsuba_pbrdf.reference.PBRDFParams` (the parameter record). Kept so
that old imports still work."""

import warnings

from .figures.pbrdf_plots import *  # noqa: F401,F403
from .figures.pbrdf_plots import __all__  # noqa: F401

warnings.warn("mitsuba_pbrdf.plots is deprecated; use mitsuba_pbrdf.figures.pbrdf_plots",
              DeprecationWarning, stacklevel=2)
