"""``pbrdf render``'s files in one call: :func:`render_files` renders a
request that :func:`mitsuba_pbrdf.rendering.render.check_render` checked,
judges its pixels (:func:`mitsuba_pbrdf.stokes.quality.require_usable`) and
writes the Stokes EXR (:func:`mitsuba_pbrdf.stokes.exr.write_stokes_exr`) and
the overview PNG (:func:`.panels.save_overview_png`), both or neither."""

from __future__ import annotations

import os
from dataclasses import dataclass

from ..rendering.render import RenderRequest, RenderTimings
from ..stokes.image import StokesImage
from ..stokes.quality import StokesQuality, require_usable

__all__ = ["RenderedFiles", "render_files", "render_title"]


@dataclass(frozen=True)
class RenderedFiles:
    """What :func:`render_files` rendered and wrote: the Stokes image, its
    timings, the assessment of its pixels in the band the PNG draws
    (:func:`~mitsuba_pbrdf.stokes.quality.assess`) and the two paths."""
    image: StokesImage
    timings: RenderTimings
    quality: StokesQuality
    exr: str
    png: str


def render_title(request: RenderRequest, image: StokesImage) -> str:
    """The picture's title: the scene's name, the variant, the samples (and
    passes) and the render mode (``default: llvm_ad_spectral_polarized, 64 spp``)."""
    name = os.path.splitext(os.path.basename(request.scene_path))[0]
    passes = int(image.metadata.get("passes", 1))
    mode = request.mode.describe()
    return (f"{name}: {request.variant}, {image.metadata['spp']} spp"
            + (f" in {passes} passes" if passes > 1 else "") + (f", {mode}" if mode else ""))


def render_files(request: RenderRequest, exr, png, seed: int = 0, progress=False,
                 **picture) -> RenderedFiles:
    """Render a checked request to a Stokes EXR and its overview PNG.

    Parameters
    ----------
    request : RenderRequest
        From :func:`mitsuba_pbrdf.rendering.render.check_render`.
    exr, png : str or os.PathLike
        The two files, each replaced if it exists.
    seed : int
        The sampler's seed of the first pass.
    progress : bool or str
        As :func:`~mitsuba_pbrdf.rendering.render.render_request` takes it.
    **picture
        :func:`.panels.save_overview_png`'s options (``panels``, ``band``,
        ``dolp_limit`` ...); ``band`` is also the band whose pixels are judged.

    Returns
    -------
    RenderedFiles

    Raises
    ------
    SceneLoadError
        Mitsuba cannot load the scene.
    UnusableImageError
        The render has no usable pixel; nothing is written.
    OSError
        A file cannot be written; neither is then left.

    Example
    -------
    >>> from mitsuba_pbrdf.rendering.render import check_render
    >>> request = check_render("scenes/default.xml", spp=4, size="32x24")  # doctest: +SKIP
    >>> render_files(request, "out/default.exr", "out/default.png").quality  # doctest: +SKIP
    """
    # looked up when called, where the work starts (the tests stub it there)
    from ..outputs import together
    from ..rendering.render import render_request
    from ..stokes.exr import write_stokes_exr
    from .panels import save_overview_png

    image, timings = render_request(request, seed=seed, progress=progress)
    quality = require_usable(image, f"the render of {request.scene_path}",
                             band=picture.get("band"))
    image.metadata["title"] = render_title(request, image)
    with together():  # both files or neither (mitsuba_pbrdf.outputs)
        exr = write_stokes_exr(exr, image)
        png = save_overview_png(png, image, quality=quality, **picture)
    return RenderedFiles(image, timings, quality, exr, png)
