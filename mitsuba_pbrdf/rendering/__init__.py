"""Rendering a scene file into a Stokes image.

* :mod:`.render`: render a scene file in passes into a
  :class:`~mitsuba_pbrdf.stokes.StokesImage`; the checks before it renders;
* :mod:`.modes`: the render modes, one interface: the scene's R, G, B, one passband, a Stokes cube;
* :mod:`.passes`: the pass planner and its seeding policy (also used by
  :mod:`mitsuba_pbrdf.inverse`);
* :mod:`.progress`: a progress bar or log lines over long work;
* :mod:`.scene_params`: checks of the values given to a scene's ``$key`` parameters;
* :mod:`.scene_files`: the scenes shipped with the package;
* :mod:`.narrowband`: Stokes renders at one wavelength or averaged over a passband;
* :mod:`.bands`, :mod:`.cube`: Stokes cubes, one image band per passband of a list;
* :mod:`.scene_loading`: loading a scene file; Mitsuba's loader errors and Ctrl-C in the package's
  terms;
* :mod:`.scene_setup`: a scene file as Mitsuba's parser reads it (``<include>`` s and ``<ref>`` s
  resolved) made ready for a Stokes render: its integrator inside ``stokes``, its size, a
  passband's sensor response; the checks of that before loading.

Stokes images and their files are :mod:`mitsuba_pbrdf.stokes`, pictures of them
:mod:`mitsuba_pbrdf.visualization`, what a polarization camera records
:mod:`mitsuba_pbrdf.camera`.
"""

from .render import RenderTimings, SceneLoadError, load_scene, render_scene, render_scene_timed

__all__ = ["RenderTimings", "SceneLoadError", "load_scene", "render_scene", "render_scene_timed"]
