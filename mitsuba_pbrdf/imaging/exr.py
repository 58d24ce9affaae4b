"""Stokes images in OpenEXR files: float32 channels named ``S<i>.<band>``
(and an ``R, G, B`` preview), the band order in the header attribute
``stokesBands`` and the image's metadata as ``pbrdf:<key>`` string
attributes. Channels are looked up by name, never by position (OpenEXR
sorts them alphabetically), and the band order survives that sorting. The
one exception is an image Mitsuba wrote from a bare tensor
(``mi.util.write_bitmap(path, mi.render(scene))``), whose channels lose their
names (``ch00, ch01, ...``); those are read with the ``stokes`` integrator's
layout and a warning. Stokes conventions: :mod:`mitsuba_pbrdf.imaging.stokes`.

::

    write_stokes_exr("a.exr", stokes)                 # StokesImage, or (H, W, 4[, n_bands]) array
    write_stokes_exr("b.exr", stokes, bands=["450nm", "550nm", "650nm"])
    image = read_stokes_exr("a.exr")                  # StokesImage
"""

from __future__ import annotations

import os
import re
import warnings

import numpy as np

from .stokes import StokesImage, _from_channels, as_stokes_image

__all__ = ["write_stokes_exr", "read_stokes_exr"]

_UNNAMED = re.compile(r"^ch\d+$")
#: Keys of StokesImage.metadata that are written to / read from the EXR header.
_HEADER_PREFIX = "pbrdf:"
#: Header attribute holding the band order (comma-separated band names).
_BANDS_ATTRIBUTE = "stokesBands"



def _unnamed_layout(n: int):
    """Channel names of the ``stokes`` integrator's output, for an image whose
    names were lost (Mitsuba names them ch00, ch01, ...). None if unknown."""
    base = {15: ["R", "G", "B"], 16: ["R", "G", "B", "A"], 13: ["Y"], 14: ["Y", "A"]}.get(n)
    if base is None:
        return None
    return base + [f"S{i}.{b}" for i in range(4) for b in "RGB"]


def write_stokes_exr(path, image, compression: str = "zip", bands=None) -> str:
    """Write a Stokes image as a float32 OpenEXR file with named channels
    (``R, G, B`` when a preview is present, then ``S0.<band> ... S3.<band>``),
    the band order, and ``image.metadata`` as string header attributes.
    Returns the path.

    *image* is a :class:`StokesImage` or a NumPy array (see
    :func:`as_stokes_image`, which takes *bands*). *compression* is ``"zip"``
    (default, lossless), ``"piz"`` (lossless) or ``"none"``.
    """
    import OpenEXR

    if not isinstance(image, StokesImage):
        image = as_stokes_image(image, bands)
    elif bands is not None and list(bands) != image.bands:
        raise ValueError("bands= is only for arrays; a StokesImage has its own bands")
    bad = [b for b in image.bands if "," in b or not b]
    if bad:
        raise ValueError(f"band names must be non-empty and without commas, got {bad}")

    comp = {
        "zip": OpenEXR.ZIP_COMPRESSION,
        "piz": OpenEXR.PIZ_COMPRESSION,
        "none": OpenEXR.NO_COMPRESSION,
    }[compression]
    path = os.fspath(path)
    channels = {}
    if image.rgb is not None:
        for c, name in enumerate("RGB"):
            channels[name] = np.ascontiguousarray(image.rgb[:, :, c])
    for i in range(4):
        for b, band in enumerate(image.bands):
            channels[f"S{i}.{band}"] = np.ascontiguousarray(image.stokes[:, :, i, b])
    header = {"compression": comp, "type": OpenEXR.scanlineimage,
              _BANDS_ATTRIBUTE: ",".join(image.bands)}
    for key, value in image.metadata.items():
        header[_HEADER_PREFIX + key] = str(value)
    parent = os.path.dirname(path)
    if parent:
        os.makedirs(parent, exist_ok=True)
    with OpenEXR.File(header, channels) as f:
        f.write(path)
    return path


def read_stokes_exr(path) -> StokesImage:
    """Read a Stokes image from an OpenEXR file, looking channels up by name.

    Reads the files :func:`write_stokes_exr` writes and those Mitsuba writes
    (``film.write``, ``mi.util.write_bitmap(path, film.bitmap())``, half or
    full float). Raises ``FileNotFoundError`` for a missing file and
    :class:`StokesChannelError` for an EXR without Stokes channels.
    """
    import OpenEXR

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: no such file")
    try:
        with OpenEXR.File(path, separate_channels=True) as f:
            header = dict(f.header())
            channels = {name: ch.pixels for name, ch in f.channels().items()}
    except Exception as e:  # OpenEXR raises plain RuntimeErrors
        raise ValueError(f"{path}: not a readable OpenEXR file ({e})") from e

    names = list(channels)
    if names and all(_UNNAMED.match(n) for n in names):
        layout = _unnamed_layout(len(names))
        if layout is not None:
            warnings.warn(
                f"{path}: channels have no names ({names[0]} ... {names[-1]}); reading them "
                f"in the order of Mitsuba's 'stokes' integrator ({', '.join(layout[:4])}, ...). "
                "Write film.bitmap() instead of the render tensor to keep the names.",
                stacklevel=2,
            )
            channels = {layout[int(n[2:])]: channels[n] for n in names}

    image = _from_channels(channels, path)
    order = str(header.get(_BANDS_ATTRIBUTE, "")).split(",")
    if sorted(order) == sorted(image.bands) and order != image.bands:
        index = [image.bands.index(b) for b in order]
        image = StokesImage(image.stokes[..., index], order, image.rgb)
    image.metadata = {
        k[len(_HEADER_PREFIX):]: str(v)
        for k, v in header.items()
        if k.startswith(_HEADER_PREFIX)
    }
    return image
