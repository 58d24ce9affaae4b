"""Rendering Stokes images and looking at them.

* :mod:`.render`: render a scene file in passes into a :class:`StokesImage`;
* :mod:`.passes`: the pass planner and its seeding policy (also used by
  :mod:`mitsuba_pbrdf.inverse`);
* :mod:`.stokes`: the :class:`StokesImage` record and derived quantities
  (DoLP, AoLP, DoCP, ...);
* :mod:`.exr`: Stokes images in OpenEXR files;
* :mod:`.polcam`: what a polarization camera records (polarizer images, sensor
  mosaics, sensor noise);
* :mod:`.narrowband`: Stokes renders at one wavelength or over a narrow band;
* :mod:`.panels`: pictures (intensity, DoLP, AoLP, ... panels and sheets).
"""

from .exr import read_stokes_exr, write_stokes_exr
from .render import RenderTimings, SceneLoadError, load_scene, render_scene, render_scene_timed
from .stokes import (StokesChannelError, StokesImage, aolp, as_stokes_image, channel_names, docp,
                     dolp, dop, from_mitsuba, intensity, luminance_stokes)

__all__ = ["read_stokes_exr", "write_stokes_exr", "RenderTimings", "SceneLoadError", "load_scene",
           "render_scene", "render_scene_timed", "StokesChannelError", "StokesImage", "aolp",
           "as_stokes_image", "channel_names", "docp", "dolp", "dop", "from_mitsuba", "intensity",
           "luminance_stokes"]
