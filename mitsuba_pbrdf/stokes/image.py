"""Stokes images as NumPy arrays, and the quantities derived from the Stokes
vector (intensity, DoLP, AoLP, DoCP, DoP).

Mitsuba's ``stokes`` integrator writes a multichannel image: the base channels
(``R, G, B`` in RGB/spectral variants, ``Y`` in mono variants), then one channel
per Stokes component and colour band, named ``S<i>.<band>``: ``S0.R, S0.G, S0.B,
S1.R, ..., S3.B``. (Mitsuba 3.9.1 names the Stokes bands ``R, G, B`` in mono
variants too, with the three bands equal.) Channels are always looked up by
name, never by position (:func:`from_mitsuba`; EXR files:
:mod:`mitsuba_pbrdf.stokes.exr`).

Bands need not be colours: any names work (``S0.550nm``, ``S0.Y``, ...), e.g.
for per-wavelength Stokes images assembled from several mono renders.

NumPy API::

    image = as_stokes_image(stokes)                   # (H, W, 4) or (H, W, 4, n_bands) array
    image = from_mitsuba(mi.render(scene), scene.sensors()[0].film())
    image.stokes, image.bands, image.s0, image.band("R"), dolp(image), aolp(image)

Conventions (``docs/conventions.md``): Stokes components are in the frame Mitsuba
uses for the camera rays: x-axis = cross(ray direction, camera up), i.e. the
image's right, y-axis the image's up, for light travelling towards the camera.
S1 > 0 means more light polarized along the x-axis (horizontal), S2 > 0 along
+45° (counter-clockwise in the picture). AoLP is ``0.5 * atan2(S2, S1)`` in
radians, in ``(-pi/2, pi/2]``.

Nothing here needs a Mitsuba variant: :func:`from_mitsuba` only reads the
channel names off a film or bitmap that the caller already has.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Mapping, Optional

import numpy as np

__all__ = [
    "StokesImage",
    "StokesChannelError",
    "from_mitsuba",
    "as_stokes_image",
    "channel_names",
    "intensity",
    "dolp",
    "aolp",
    "docp",
    "dop",
    "luminance_stokes",
]

#: Order in which well-known band names are listed; other bands follow in file order.
_BAND_ORDER = ("R", "G", "B", "Y")
#: Rec. 709 luminance weights of linear R, G, B.
_LUMINANCE_WEIGHTS = {"R": 0.2126, "G": 0.7152, "B": 0.0722}
_STOKES_NAME = re.compile(r"^S([0-3])\.(.+)$")


class StokesChannelError(ValueError):
    """An image has no (or an incomplete set of) Stokes channels."""


@dataclass
class StokesImage:
    """A Stokes image.

    Attributes
    ----------
    stokes : ndarray, shape (H, W, 4, n_bands), float32
        ``stokes[y, x, i, b]`` is Stokes component ``S_i`` of band ``bands[b]``.
    bands : list of str
        Band names, e.g. ``["R", "G", "B"]`` or ``["Y"]``.
    rgb : ndarray, shape (H, W, 3), float32, optional
        The film's linear preview (its ``R, G, B`` channels, or ``Y`` repeated).
    metadata : dict of str to str
        Free-form provenance (scene, variant, spp, timings, ...); written to the
        EXR header as string attributes.
    """

    stokes: np.ndarray
    bands: list
    rgb: Optional[np.ndarray] = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        self.stokes = np.ascontiguousarray(self.stokes, dtype=np.float32)
        self.bands = [str(b) for b in self.bands]
        if self.stokes.ndim != 4 or self.stokes.shape[2] != 4:
            raise ValueError(
                f"stokes must have shape (H, W, 4, n_bands), got {self.stokes.shape}"
            )
        if self.stokes.shape[3] != len(self.bands):
            raise ValueError(
                f"stokes has {self.stokes.shape[3]} bands but {len(self.bands)} band "
                f"names were given: {self.bands}"
            )
        if len(set(self.bands)) != len(self.bands):
            raise ValueError(f"band names must be unique, got {self.bands}")
        if self.rgb is not None:
            self.rgb = np.ascontiguousarray(self.rgb, dtype=np.float32)
            if self.rgb.shape != self.stokes.shape[:2] + (3,):
                raise ValueError(
                    f"rgb must have shape {self.stokes.shape[:2] + (3,)}, got {self.rgb.shape}"
                )
        self.metadata = {str(k): str(v) for k, v in self.metadata.items()}

    @property
    def height(self) -> int:
        """Image height in pixels."""
        return self.stokes.shape[0]

    @property
    def width(self) -> int:
        """Image width in pixels."""
        return self.stokes.shape[1]

    @property
    def s0(self) -> np.ndarray:
        """S0 (intensity), shape (H, W, n_bands)."""
        return self.stokes[:, :, 0, :]

    @property
    def s1(self) -> np.ndarray:
        """S1 (horizontal minus vertical), shape (H, W, n_bands)."""
        return self.stokes[:, :, 1, :]

    @property
    def s2(self) -> np.ndarray:
        """S2 (+45° minus -45°), shape (H, W, n_bands)."""
        return self.stokes[:, :, 2, :]

    @property
    def s3(self) -> np.ndarray:
        """S3 (circular), shape (H, W, n_bands)."""
        return self.stokes[:, :, 3, :]

    def band(self, name: str) -> np.ndarray:
        """Stokes vectors of one band, shape (H, W, 4)."""
        try:
            return self.stokes[:, :, :, self.bands.index(name)]
        except ValueError:
            raise KeyError(f"no band {name!r}; bands are {self.bands}") from None

    def channel_names(self) -> list:
        """Names of the Stokes channels, ``S0.<band>, ..., S3.<band>``."""
        return [f"S{i}.{b}" for i in range(4) for b in self.bands]


# --------------------------------------------------------------------------
# Building a StokesImage from named channels


def _order_bands(bands):
    known = [b for b in _BAND_ORDER if b in bands]
    return known + [b for b in bands if b not in known]


def _from_channels(channels: Mapping[str, np.ndarray], source: str) -> StokesImage:
    """Assemble a StokesImage from a {channel name: (H, W) array} mapping."""
    names = list(channels)
    bands = []
    for name in names:
        m = _STOKES_NAME.match(name)
        if m and m.group(1) == "0" and m.group(2) not in bands:
            bands.append(m.group(2))
    if not bands:
        raise StokesChannelError(
            f"{source}: no Stokes channels (S0.<band> ... S3.<band>, as written by "
            f"Mitsuba's 'stokes' integrator); channels found: {_list(names)}"
        )
    bands = _order_bands(bands)
    missing = [f"S{i}.{b}" for i in range(4) for b in bands if f"S{i}.{b}" not in channels]
    if missing:
        raise StokesChannelError(
            f"{source}: incomplete Stokes channels, missing {_list(missing)}; "
            f"channels found: {_list(names)}"
        )
    stokes = np.stack(
        [np.stack([_plane(channels[f"S{i}.{b}"]) for b in bands], axis=-1) for i in range(4)],
        axis=2,
    )
    if all(c in channels for c in "RGB"):
        rgb = np.stack([_plane(channels[c]) for c in "RGB"], axis=-1)
    elif "Y" in channels:
        rgb = np.repeat(_plane(channels["Y"])[..., None], 3, axis=-1)
    else:
        rgb = None
    return StokesImage(stokes=stokes, bands=bands, rgb=rgb)


def _plane(a) -> np.ndarray:
    return np.asarray(a, dtype=np.float32)


def _list(names, limit=24):
    names = list(names)
    if not names:
        return "(none)"
    more = f", ... ({len(names)} in all)" if len(names) > limit else ""
    return ", ".join(names[:limit]) + more


def channel_names(source) -> list:
    """Channel names of a Mitsuba film or bitmap, in the order of the tensor that
    ``mi.render`` returns (``film.bitmap()``'s struct, without the weight channel).

    *source* is a ``mi.Film`` (after rendering), a ``mi.Bitmap``, or a ``mi.Struct``.
    """
    if hasattr(source, "bitmap"):  # a Film
        source = source.bitmap(raw=False)
    if hasattr(source, "struct_"):  # a Bitmap
        source = source.struct_()
    return [f.name for f in source]


def from_mitsuba(image, channel_names_or_film=None) -> StokesImage:
    """Build a :class:`StokesImage` from Mitsuba's output.

    Parameters
    ----------
    image
        Either the tensor returned by ``mi.render`` (or any array of shape
        (H, W, C)), or a ``mi.Bitmap`` such as ``film.bitmap()`` (whose own
        channel names are then used).
    channel_names_or_film
        For a tensor: its C channel names, or the ``mi.Film`` it came from
        (``scene.sensors()[0].film()``), whose names are read off
        ``film.bitmap()``.

    Example
    -------
    >>> img = mi.render(scene)
    >>> stokes = from_mitsuba(img, scene.sensors()[0].film())
    """
    if channel_names_or_film is None:
        if not hasattr(image, "struct_"):
            raise TypeError(
                "from_mitsuba(tensor) needs the channel names or the film: "
                "from_mitsuba(img, scene.sensors()[0].film())"
            )
        names = channel_names(image)
    elif isinstance(channel_names_or_film, (list, tuple)):
        names = [str(n) for n in channel_names_or_film]
    else:
        names = channel_names(channel_names_or_film)
    array = np.array(image, dtype=np.float32, copy=True)
    if array.ndim == 2:
        array = array[..., None]
    if array.ndim != 3 or array.shape[2] != len(names):
        raise ValueError(
            f"image has shape {array.shape} but {len(names)} channel names were given: "
            f"{_list(names)}"
        )
    channels = {name: array[:, :, c] for c, name in enumerate(names)}
    return _from_channels(channels, "Mitsuba film output")



def as_stokes_image(stokes, bands=None, rgb=None, metadata=None) -> StokesImage:
    """A :class:`StokesImage` from a NumPy array of shape (H, W, 4) (one band)
    or (H, W, 4, n_bands). *bands* defaults to ``["Y"]`` for one band,
    ``["R", "G", "B"]`` for three, else ``["B0", "B1", ...]``."""
    stokes = np.asarray(stokes, dtype=np.float32)
    if stokes.ndim == 3:
        stokes = stokes[..., None]
    if bands is None:
        n = stokes.shape[-1] if stokes.ndim == 4 else 0
        bands = ["Y"] if n == 1 else ["R", "G", "B"] if n == 3 else [f"B{i}" for i in range(n)]
    return StokesImage(stokes=stokes, bands=list(bands), rgb=rgb, metadata=dict(metadata or {}))


# --------------------------------------------------------------------------
# Derived quantities
#
# Each accepts a StokesImage or an array whose Stokes components lie on `axis`
# (default -2, the layout of StokesImage.stokes: (..., 4, n_bands)); the result
# has that axis removed.


def _components(x, axis):
    a = x.stokes if isinstance(x, StokesImage) else np.asarray(x)
    if isinstance(x, StokesImage):
        axis = -2
    if a.shape[axis] != 4:
        raise ValueError(f"expected 4 Stokes components on axis {axis}, got shape {a.shape}")
    return [np.take(a, i, axis=axis) for i in range(4)]


def _ratio(num, s0, eps):
    num = np.asarray(num, dtype=np.result_type(num, np.float32))
    out = np.zeros_like(num)
    ok = s0 > eps
    np.divide(num, s0, out=out, where=ok)
    return out


def intensity(x, axis: int = -2) -> np.ndarray:
    """S0."""
    return _components(x, axis)[0]


def dolp(x, axis: int = -2, eps: float = 1e-8) -> np.ndarray:
    """Degree of linear polarization sqrt(S1² + S2²) / S0; 0 where S0 <= eps.

    Not clipped: Monte Carlo noise, or colour conversion of spectral Stokes
    vectors into RGB, can push it slightly above 1.
    """
    s0, s1, s2, _ = _components(x, axis)
    return _ratio(np.hypot(s1, s2), s0, eps)


def aolp(x, axis: int = -2) -> np.ndarray:
    """Angle of linear polarization 0.5 * atan2(S2, S1), radians in (-pi/2, pi/2]."""
    _, s1, s2, _ = _components(x, axis)
    return 0.5 * np.arctan2(s2, s1)


def docp(x, axis: int = -2, eps: float = 1e-8, signed: bool = False) -> np.ndarray:
    """Degree of circular polarization |S3| / S0 (S3 / S0 when *signed*); 0 where S0 <= eps."""
    s0, _, _, s3 = _components(x, axis)
    return _ratio(s3 if signed else np.abs(s3), s0, eps)


def dop(x, axis: int = -2, eps: float = 1e-8) -> np.ndarray:
    """Degree of polarization sqrt(S1² + S2² + S3²) / S0; 0 where S0 <= eps."""
    s0, s1, s2, s3 = _components(x, axis)
    return _ratio(np.sqrt(s1 * s1 + s2 * s2 + s3 * s3), s0, eps)


def luminance_stokes(image: StokesImage) -> np.ndarray:
    """One Stokes vector per pixel, shape (H, W, 4): the Rec. 709 luminance
    combination of the R, G, B bands (their mean for other band sets). Stokes
    vectors add, so DoLP/AoLP of this are those of the light a luminance
    (panchromatic) polarimeter would see."""
    if all(b in image.bands for b in "RGB"):
        w = np.array([_LUMINANCE_WEIGHTS.get(b, 0.0) for b in image.bands], dtype=np.float32)
    else:
        w = np.full(len(image.bands), 1.0 / len(image.bands), dtype=np.float32)
    return image.stokes @ w
