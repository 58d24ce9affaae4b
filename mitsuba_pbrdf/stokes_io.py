"""Deprecated: use :mod:`mitsuba_pbrdf.stokes` (:mod:`.stokes.image` for
Stokes images, :mod:`.stokes.exr` for EXR files). Kept so that old imports
still work."""

import warnings

from .stokes.exr import read_stokes_exr, write_stokes_exr
from .stokes.image import (StokesChannelError, StokesImage, aolp, as_stokes_image,
                           channel_names, docp, dolp, dop, from_mitsuba, intensity,
                           luminance_stokes)

__all__ = ["StokesImage", "StokesChannelError", "from_mitsuba", "as_stokes_image",
           "channel_names", "write_stokes_exr", "read_stokes_exr", "intensity", "dolp", "aolp",
           "docp", "dop", "luminance_stokes"]

warnings.warn("mitsuba_pbrdf.stokes_io is deprecated; use mitsuba_pbrdf.stokes",
              DeprecationWarning, stacklevel=2)
