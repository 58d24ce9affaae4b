"""Stokes images and their files; NumPy (and OpenEXR for the files), no Mitsuba.

* :mod:`.image`: the :class:`StokesImage` record and derived quantities
  (DoLP, AoLP, DoCP, ...), and the conversion of a Mitsuba film's channels;
* :mod:`.quality`: unusable pixels (non-finite, S0 < 0, polarization > 1);
* :mod:`.exr`: Stokes images, and any channels, in OpenEXR files.
"""

from .exr import read_stokes_exr, write_stokes_exr
from .image import (StokesChannelError, StokesImage, aolp, as_stokes_image, channel_names, docp,
                    dolp, dop, from_mitsuba, intensity, luminance_stokes)

__all__ = ["read_stokes_exr", "write_stokes_exr", "StokesChannelError", "StokesImage", "aolp",
           "as_stokes_image", "channel_names", "docp", "dolp", "dop", "from_mitsuba", "intensity",
           "luminance_stokes"]
