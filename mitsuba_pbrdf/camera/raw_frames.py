"""Looking at what ``pbrdf polcam`` writes: its files turned back into Stokes
images that ``pbrdf view`` draws, and 8-bit previews of its raw frames.

* :func:`demosaic`: a raw frame (:func:`~.polcam.mono_mosaic`,
  :func:`~.polcam.colour_mosaic`) to a Stokes image by super-pixels, the
  simplest demosaicing: each 2 x 2 block of the mono sensor (4 x 4 of the
  colour sensor, whose two green quads are averaged) gives one pixel with
  S0 = (I0 + I45 + I90 + I135) / 2, S1 = I0 - I90, S2 = I45 - I135, S3 = 0
  (a linear polarizer sees no circular polarization). Half (a quarter) of
  the resolution, and each block's four angles come from four neighbouring
  pixels, so edges show a little false polarization.
* :func:`stokes_of_polarizer_images`: the same from the four full-resolution
  polarizer images ``<stem>_I0.exr`` ... ``<stem>_I135.exr``.
* :func:`read_polcam_exr`: either of these from a file that ``pbrdf polcam``
  wrote (its ``pbrdf:polcam`` header attribute says which);
  :func:`read_viewable_exr`: a Stokes EXR or such a file, what ``pbrdf view`` reads.
* :func:`mosaic_preview`: a raw frame as an 8-bit greyscale picture: the ADC
  counts of an N-bit frame scaled so full scale is white (a 12-bit frame in a
  16-bit PNG uses 1/16 of the range and looks black), or the frame's own
  99.9th percentile as white; sRGB-encoded.
"""

from __future__ import annotations

import os
import re
from typing import Optional, Tuple

import numpy as np

from ..stokes.image import StokesImage
from .polcam import ANGLES, colour_layout, mono_layout, stokes_from_intensities

__all__ = ["demosaic", "stokes_of_polarizer_images", "read_polcam_exr", "read_viewable_exr",
           "polarizer_siblings",
           "mosaic_preview", "mosaic_previews"]

_POLARIZER_FILE = re.compile(r"^(?P<stem>.*)_I(?P<angle>0|45|90|135)\.exr$")


def _stokes(images: dict) -> np.ndarray:
    """(..., 4) float32 Stokes vectors from the four polarizer intensities {angle: (...)}."""
    return stokes_from_intensities(images).astype(np.float32)


def demosaic(frame: np.ndarray, sensor: str = "mono", band: str = "Y") -> StokesImage:
    """The Stokes image of a raw frame (H, W) by super-pixels (module
    docstring): one band *band* for the mono sensor, R, G, B for the colour
    one. ValueError for a frame whose size is not a multiple of the block."""
    frame = np.asarray(frame, dtype=np.float32)
    if frame.ndim != 2:
        raise ValueError(f"a raw frame is one channel (H, W), got shape {frame.shape}")
    period = 2 if sensor == "mono" else 4
    h, w = frame.shape
    if h % period or w % period or not h or not w:
        raise ValueError(f"the {sensor} sensor's frame is made of {period} x {period} blocks; "
                         f"a {w}x{h} frame is not")
    if sensor == "mono":
        angles = mono_layout(period, period)
        images = {angles[r, c]: frame[r::period, c::period] for r in range(2) for c in range(2)}
        return StokesImage(_stokes(images)[..., None], [band])
    if sensor != "colour":
        raise ValueError(f"sensor must be 'mono' or 'colour', got {sensor!r}")
    angles, colours = colour_layout(period, period)
    planes = []
    for colour in range(3):
        images = {}
        for a in ANGLES:
            where = np.argwhere((angles == a) & (colours == colour))
            images[a] = np.mean([frame[r::period, c::period] for r, c in where], axis=0)
        planes.append(_stokes(images))
    return StokesImage(np.stack(planes, axis=-1), ["R", "G", "B"])


def stokes_of_polarizer_images(images: dict, bands) -> StokesImage:
    """The Stokes image of the four polarizer images ``{angle: {band: (H, W)}}``."""
    stokes = np.stack([_stokes({a: images[a][b] for a in ANGLES}) for b in bands], axis=-1)
    return StokesImage(stokes, list(bands))


def _band_order(names) -> list:
    """Channel names in band order (OpenEXR lists them alphabetically): R, G,
    B, or wavelength bands (``460nm``) by wavelength."""
    names = list(names)
    if sorted(names) == ["B", "G", "R"]:
        return ["R", "G", "B"]
    try:
        return sorted(names, key=lambda n: float(n.removesuffix("nm")))
    except ValueError:
        return names


def read_polcam_exr(path) -> Optional[StokesImage]:
    """The Stokes image of a file ``pbrdf polcam`` wrote: a raw frame
    (``..._mosaic.exr``, ``..._mosaic_rgb.exr``; a cube's mosaic has one channel
    per band) demosaiced, or a polarizer image ``<stem>_I<angle>.exr`` together
    with the other three beside it. None for an EXR that is neither (no
    ``pbrdf:polcam`` attribute); ``FileNotFoundError`` naming a missing sibling."""
    from ..stokes.exr import read_exr

    path = os.fspath(path)
    metadata, channels = read_exr(path)
    kind = metadata.get("polcam")
    if kind is None:
        return None
    if kind.startswith("mosaic"):
        sensor = "colour" if kind == "mosaic_rgb" else "mono"
        parts = [demosaic(channels[name], sensor, name) for name in _band_order(channels)]
        if len(parts) == 1:
            image = parts[0]
        else:  # a cube's mosaic: one mono frame per band
            image = StokesImage(np.concatenate([p.stokes for p in parts], axis=-1),
                                [b for p in parts for b in p.bands])
        how = f"{'2 x 2' if sensor == 'mono' else '4 x 4'} super-pixels"
    else:
        match = _POLARIZER_FILE.match(os.path.basename(path))
        if match is None:
            return None
        stem = match.group("stem")
        images = {}
        for a, sibling in zip(ANGLES, _polarizer_files(path, match)):
            if not os.path.isfile(sibling):
                raise FileNotFoundError(f"{sibling}: the Stokes image of a polarizer image "
                                        "needs all four (I0, I45, I90, I135) beside it")
            images[a] = read_exr(sibling)[1]
            _same_frame(images[a], channels, sibling, path)
        image = stokes_of_polarizer_images(images, _band_order(channels))
        how = f"{stem}_I0/I45/I90/I135.exr"
    image.metadata = dict(metadata, title=f"{os.path.basename(path)}: the Stokes image of "
                                          f"the polarization camera ({how}; S3 unseen)")
    return image


def read_viewable_exr(path) -> Tuple[StokesImage, bool]:
    """The Stokes image of a Stokes EXR, or of a file ``pbrdf polcam`` wrote.

    Parameters
    ----------
    path : str or os.PathLike
        A Stokes EXR (channels ``S0.<band>`` ... ``S3.<band>``), or a raw
        frame or polarizer image of ``pbrdf polcam`` (:func:`read_polcam_exr`).

    Returns
    -------
    image : StokesImage
    from_camera : bool
        Whether *image* is what the polarization camera measures (no S3).

    Raises
    ------
    ValueError
        Neither kind of file (the Stokes reader's error,
        :class:`~mitsuba_pbrdf.stokes.image.StokesChannelError`), or an
        unreadable one, naming the file.
    FileNotFoundError
        A polarizer image without the other three beside it.

    Example
    -------
    >>> from mitsuba_pbrdf.camera.raw_frames import read_viewable_exr
    >>> image, from_camera = read_viewable_exr("out/plate_mosaic.exr")  # doctest: +SKIP
    """
    from ..stokes.exr import read_stokes_exr
    from ..stokes.image import StokesChannelError

    try:
        return read_stokes_exr(path), False
    except StokesChannelError:
        image = read_polcam_exr(path)
        if image is None:
            raise
        return image, True


def _polarizer_files(path: str, match) -> list:
    folder, stem = os.path.dirname(path), match.group("stem")
    return [os.path.join(folder, f"{stem}_I{a}.exr") for a in ANGLES]


def polarizer_siblings(path) -> list:
    """The other three polarizer images that :func:`read_polcam_exr` reads
    with the polarizer image *path* (``<stem>_I<angle>.exr``), told by its
    name; none for another name."""
    path = os.fspath(path)
    match = _POLARIZER_FILE.match(os.path.basename(path))
    if match is None:
        return []
    return [p for p in _polarizer_files(path, match) if os.path.basename(p)
            != os.path.basename(path)]


def _same_frame(sibling: dict, channels: dict, sibling_path: str, path: str):
    """ValueError naming *sibling_path* unless its channels are those of
    *path*'s (*channels*), of the same size: the four images of one camera."""
    if sorted(sibling) != sorted(channels):
        raise ValueError(f"{sibling_path}: channels {', '.join(sorted(sibling)) or 'none'}, "
                         f"but {os.path.basename(path)} has {', '.join(sorted(channels))}: "
                         "not the polarizer images of one camera")
    shapes = {np.shape(a) for a in (*sibling.values(), *channels.values())}
    if len(shapes) > 1:
        size = next(np.shape(a) for a in channels.values())
        other = next(np.shape(a) for a in sibling.values() if np.shape(a) != size)
        raise ValueError(f"{sibling_path}: {other[1]}x{other[0]} pixels, but "
                         f"{os.path.basename(path)} has {size[1]}x{size[0]}: not the polarizer "
                         "images of one camera")


def mosaic_preview(frame: np.ndarray, bits: Optional[int] = None) -> np.ndarray:
    """An 8-bit greyscale picture (H, W) uint8 of a raw frame: ADC counts of a
    *bits*-bit frame with full scale as white, else (a float frame) its 99.9th
    percentile as white; sRGB-encoded, as a viewer expects."""
    frame = np.asarray(frame, dtype=np.float64)
    if bits is not None:
        top = float(2 ** int(bits) - 1)
    else:
        finite = frame[np.isfinite(frame)]
        top = float(np.percentile(finite, 99.9)) if finite.size else 0.0
    linear = np.clip(np.nan_to_num(frame / top if top > 0 else frame * 0.0), 0.0, 1.0)
    srgb = np.where(linear <= 0.0031308, 12.92 * linear,
                    1.055 * np.power(linear, 1 / 2.4) - 0.055)
    return np.rint(srgb * 255).astype(np.uint8)


def mosaic_previews(outputs: dict, stem: str, bits: Optional[int] = None) -> dict:
    """``{file name: 8-bit picture}`` of the raw frames among
    :func:`~.polcam.polcam_outputs`' results: ``<stem>_mosaic_preview.png``
    (``_mosaic_rgb_preview.png``; a cube's ``_mosaic_<band>_preview.png``), from
    the ADC counts where the sensor model has *bits*, else from the frame."""
    previews = {}
    for name in ("mosaic", "mosaic_rgb"):
        frames = outputs.get(name)
        if frames is None:
            continue
        for channel, frame in frames.items():
            suffix = name if channel == "Y" else f"{name}_{channel}"
            counts = outputs.get(f"{suffix}.png")
            picture = (mosaic_preview(counts, bits) if counts is not None and bits is not None
                       else mosaic_preview(frame))
            previews[f"{stem}_{suffix}_preview.png"] = picture
    return previews
