"""Pixel arrays computed from a Stokes image for pictures (no matplotlib axes):
the HSV polarization composite and the ratios S1/S0, S2/S0, S3/S0 with their
shared symmetric scale. The panels of :mod:`mitsuba_pbrdf.visualization.panels`
draw them; AoLP angles are in the Stokes frame of the image (0 = image right,
positive counter-clockwise)."""

from __future__ import annotations

from typing import Optional, Union

import numpy as np

from .colours import auto_limit, resolve_limit
from ..stokes.quality import StokesQuality, assess
from ..stokes.image import StokesImage, aolp, dolp
from .tonemap import _LUMA, linear_rgb, pixel_stokes, tonemap

__all__ = ["polarization_hsv", "stokes_ratios", "stokes_limit"]


def polarization_hsv(
    image: StokesImage,
    dolp_limit: Union[float, str] = 1.0,
    exposure: Optional[float] = None,
    percentile: float = 99.0,
    band: Optional[str] = None,
) -> np.ndarray:
    """The usual polarization composite as RGB in [0, 1], shape (H, W, 3):
    hue = AoLP (a full turn of hue for 180°, as :func:`~mitsuba_pbrdf.visualization.panels.draw_aolp`), saturation
    = DoLP / *dolp_limit* (``"auto"``: see :func:`~mitsuba_pbrdf.visualization.panels.draw_dolp`), value =
    tone-mapped intensity (luminance)."""
    from matplotlib.colors import hsv_to_rgb

    s = pixel_stokes(image, band)
    with np.errstate(invalid="ignore"):
        d = np.nan_to_num(dolp(s, axis=-1))
        hue = (np.nan_to_num(np.degrees(aolp(s, axis=-1))) % 180.0) / 180.0
    top, _ = resolve_limit(dolp_limit, np.where(s[..., 0] > 0, d, np.nan))
    saturation = np.clip(d / top, 0.0, 1.0)
    srgb, _ = tonemap(linear_rgb(image, band), exposure, percentile)
    value = np.clip(srgb @ _LUMA, 0.0, 1.0)
    return hsv_to_rgb(np.stack([hue, saturation, value], axis=-1).astype(np.float32))


def stokes_ratios(image: StokesImage, band: Optional[str] = None,
                  quality: Optional[StokesQuality] = None) -> np.ndarray:
    """S1/S0, S2/S0, S3/S0, shape (H, W, 3); NaN where S0 <= 0 or the pixel is
    unusable."""
    quality = assess(image, band) if quality is None else quality
    s = pixel_stokes(image, band).astype(np.float64)
    ok = ~quality.unusable & (s[..., 0] > 1e-12)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ok[..., None], s[..., 1:] / s[..., :1], np.nan)


def stokes_limit(image: StokesImage, components=(1, 2, 3), percentile: float = 99.0,
                 band: Optional[str] = None, quality: Optional[StokesQuality] = None) -> float:
    """One symmetric scale for S_i/S0 of *components*: the *percentile*-th
    percentile of their |values| rounded up (1, 2, 2.5, 5 x 10^k), at most 1."""
    ratios = stokes_ratios(image, band, quality)[..., [i - 1 for i in components]]
    return auto_limit(np.abs(ratios), percentile=percentile)
