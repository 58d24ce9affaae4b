"""Stokes images in OpenEXR files: float32 channels named ``S<i>.<band>``
(and an ``R, G, B`` preview), the band order in the header attribute
``stokesBands`` and the image's metadata as ``pbrdf:<key>`` string
attributes. Channels are looked up by name, never by position (OpenEXR
sorts them alphabetically), and the band order survives that sorting. The
one exception is an image Mitsuba wrote from a bare tensor
(``mi.util.write_bitmap(path, mi.render(scene))``), whose channels lose their
names (``ch00, ch01, ...``); those are read with the ``stokes`` integrator's
layout and a warning. Stokes conventions: :mod:`mitsuba_pbrdf.stokes.image`.

::

    write_stokes_exr("a.exr", stokes)                 # StokesImage, or (H, W, 4[, n_bands]) array
    write_stokes_exr("b.exr", stokes, bands=["450nm", "550nm", "650nm"])
    image = read_stokes_exr("a.exr")                  # StokesImage
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
import warnings

import numpy as np

from ..outputs import atomic_path, utf8_text
from .image import StokesImage, _from_channels, as_stokes_image

__all__ = ["write_stokes_exr", "read_stokes_exr", "write_exr", "read_exr", "read_exr_channels"]

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
    Written atomically (:mod:`mitsuba_pbrdf.outputs`): a failure leaves no
    partial file and any previous file untouched. Returns the path.

    *image* is a :class:`StokesImage` or a NumPy array (see
    :func:`as_stokes_image`, which takes *bands*). *compression* is ``"zip"``
    (default, lossless), ``"piz"`` (lossless) or ``"none"``.
    """
    if not isinstance(image, StokesImage):
        image = as_stokes_image(image, bands)
    elif bands is not None and list(bands) != image.bands:
        raise ValueError("bands= is only for arrays; a StokesImage has its own bands")
    bad = [b for b in image.bands if "," in b or not b]
    if bad:
        raise ValueError(f"band names must be non-empty and without commas, got {bad}")

    channels = {}
    if image.rgb is not None:
        for c, name in enumerate("RGB"):
            channels[name] = image.rgb[:, :, c]
    for i in range(4):
        for b, band in enumerate(image.bands):
            channels[f"S{i}.{band}"] = image.stokes[:, :, i, b]
    return write_exr(path, channels, image.metadata, compression,
                     {_BANDS_ATTRIBUTE: ",".join(image.bands)})


def write_exr(path, channels, metadata=None, compression: str = "zip", attributes=None) -> str:
    """Write float32 images ``{channel name: (H, W) array}`` as an OpenEXR file,
    atomically, with *metadata* as ``pbrdf:<key>`` string attributes (and
    *attributes* as they are). Returns the path."""
    import OpenEXR

    comp = {
        "zip": OpenEXR.ZIP_COMPRESSION,
        "piz": OpenEXR.PIZ_COMPRESSION,
        "none": OpenEXR.NO_COMPRESSION,
    }[compression]
    path = os.fspath(path)
    channels = {name: np.ascontiguousarray(a, dtype=np.float32) for name, a in channels.items()}
    header = {"compression": comp, "type": OpenEXR.scanlineimage, **(attributes or {})}
    from ..outputs import escape_text

    for key, value in (metadata or {}).items():  # titles and sources hold file names
        header[_HEADER_PREFIX + escape_text(key, "line")] = escape_text(value, "line")
    with atomic_path(path) as tmp, OpenEXR.File(header, channels) as f:
        with _library_output() as noise:
            try:
                if utf8_text(tmp):
                    f.write(tmp)
                else:  # a name OpenEXR cannot take (see _read_checked): through memory
                    import io

                    buffer = io.BytesIO()
                    f.write(buffer)
                    with open(tmp, "wb") as out:
                        out.write(buffer.getvalue())
            except RuntimeError as e:
                raise OSError(None, _first_line(noise.text()) or " ".join(str(e).split()),
                              tmp) from None
    return path


class _Captured:
    """What :func:`_library_output` captured (bytes), and its text."""

    data = b""

    def text(self):
        return self.data.decode("utf-8", "replace")


@contextlib.contextmanager
def _library_output():
    """Capture what C libraries (OpenEXR) print on the standard output and
    error streams (file descriptors 1 and 2) while the block runs; the text is
    in ``.text()`` afterwards, and never reaches the terminal."""
    captured = _Captured()
    for stream in (os.sys.stdout, os.sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile() as sink:
        try:
            os.dup2(sink.fileno(), 1)
            os.dup2(sink.fileno(), 2)
            yield captured
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            sink.seek(0)
            captured.data = sink.read()


def _first_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[0] if lines else ""


def read_stokes_exr(path) -> StokesImage:
    """Read a Stokes image from an OpenEXR file, looking channels up by name.

    Reads the files :func:`write_stokes_exr` writes and those Mitsuba writes
    (``film.write``, ``mi.util.write_bitmap(path, film.bitmap())``, half or
    full float). Raises ``FileNotFoundError`` for a missing file,
    ``ValueError`` for a damaged one (what OpenEXR prints about it is kept out
    of the terminal and quoted in the message) and :class:`StokesChannelError`
    for an EXR without Stokes channels.
    """
    path = os.fspath(path)
    header, channels = _read_checked(path)
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


def read_exr(path):
    """``(metadata, channels)`` of an OpenEXR file: its ``pbrdf:<key>``
    attributes as ``{key: str}`` and ``{name: (H, W) float32}``. Raises as
    :func:`read_exr_channels` does."""
    header, channels = _read_checked(os.fspath(path))
    metadata = {k[len(_HEADER_PREFIX):]: str(v) for k, v in header.items()
                if k.startswith(_HEADER_PREFIX)}
    return metadata, {name: np.asarray(p, dtype=np.float32) for name, p in channels.items()}


def read_exr_channels(path) -> dict:
    """The channels ``{name: (H, W) float32}`` of an OpenEXR file (any names).
    Raises ``FileNotFoundError`` or ``ValueError`` as :func:`read_stokes_exr` does."""
    _, channels = _read_checked(os.fspath(path))
    return {name: np.asarray(pixels, dtype=np.float32) for name, pixels in channels.items()}


def _read_checked(path: str):
    """(header, {name: pixels}) of an OpenEXR file; ``FileNotFoundError`` for a
    missing file, ``ValueError`` for a damaged one: OpenEXR fails on it or
    reads it with a complaint (and missing pixels), which is kept out of the
    terminal and quoted in the message."""
    import OpenEXR

    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: no such file")
    error = None
    with _library_output() as noise:  # OpenEXR prints warnings of its own
        try:
            # OpenEXR takes a path only as UTF-8 text: a name with bytes that are
            # not (Python decodes them as lone surrogates) is read from a stream
            with contextlib.ExitStack() as stack:
                source = path if utf8_text(path) else stack.enter_context(open(path, "rb"))
                with OpenEXR.File(source, separate_channels=True) as f:
                    header = dict(f.header())
                    channels = {name: ch.pixels for name, ch in f.channels().items()}
        except Exception as e:  # OpenEXR raises plain RuntimeErrors
            error = e
    complaint = _first_line(noise.text())
    if error is not None or complaint:
        detail = (complaint or " ".join(str(error).split())).removeprefix(f"{path}: ")
        raise ValueError(f"{path}: not a readable OpenEXR file, truncated or corrupt "
                         f"({detail})") from error
    return header, channels
