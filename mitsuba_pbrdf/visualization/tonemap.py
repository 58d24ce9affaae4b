"""Linear RGB of a Stokes image and its tone mapping to sRGB for pictures,
and the Stokes vector a picture draws for each pixel (luminance or one band)."""

from __future__ import annotations

from typing import Optional

import numpy as np

from ..stokes.image import StokesImage, luminance_stokes

__all__ = ["linear_rgb", "auto_exposure", "shared_exposure", "tonemap", "pixel_stokes"]

#: Rec. 709 luminance weights of linear R, G, B.
_LUMA = np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)


def _srgb_encode(linear: np.ndarray) -> np.ndarray:
    linear = np.clip(linear, 0.0, 1.0)
    return np.where(
        linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1.0 / 2.4) - 0.055
    )


def linear_rgb(image: StokesImage, band: Optional[str] = None) -> np.ndarray:
    """Linear RGB (H, W, 3) of the image: its preview, the RGB bands of S0,
    the mean of its bands, or S0 of *band* in grey."""
    if band is not None:
        return np.repeat(image.band(band)[:, :, :1], 3, axis=-1)
    if image.rgb is not None:
        return image.rgb
    s0 = image.s0
    if all(b in image.bands for b in "RGB"):
        return np.stack([s0[:, :, image.bands.index(b)] for b in "RGB"], axis=-1)
    return np.repeat(s0.mean(axis=-1, keepdims=True), 3, axis=-1)


def auto_exposure(rgb: np.ndarray, percentile: float = 99.0) -> float:
    """The scale that maps the *percentile*-th percentile of the luminance of
    the non-black pixels of linear *rgb* (H, W, 3) to 1 (1.0 for a black image)."""
    rgb = np.nan_to_num(np.asarray(rgb, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    lum = rgb @ _LUMA
    lit = lum[lum > 0]
    ref = float(np.percentile(lit, percentile)) if lit.size else 0.0
    return 1.0 / ref if ref > 0 else 1.0


def shared_exposure(images, percentile: float = 99.0) -> float:
    """One :func:`auto_exposure` for several Stokes images together (their
    :func:`linear_rgb` pixels pooled), so that they can be compared."""
    rgb = np.concatenate([linear_rgb(im).reshape(-1, 3) for im in images], axis=0)
    return auto_exposure(rgb[None], percentile)


def tonemap(rgb: np.ndarray, exposure: Optional[float] = None, percentile: float = 99.0):
    """Linear RGB (H, W, 3) to sRGB-encoded floats in [0, 1].

    With ``exposure=None`` the scale is chosen by :func:`auto_exposure` (the
    *percentile*-th percentile of the luminance of the non-black pixels maps to
    1; brighter pixels, e.g. the highlight core, clip). Pass the same
    *exposure* to compare pictures. Returns ``(srgb, exposure)``.
    """
    rgb = np.nan_to_num(np.asarray(rgb, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    if exposure is None:
        exposure = auto_exposure(rgb, percentile)
    return _srgb_encode(rgb * exposure), float(exposure)


def pixel_stokes(image: StokesImage, band: Optional[str] = None) -> np.ndarray:
    """One Stokes vector per pixel, shape (H, W, 4): the luminance combination
    of the bands (:func:`~mitsuba_pbrdf.stokes.image.luminance_stokes`), or the
    band named *band*."""
    return luminance_stokes(image) if band is None else image.band(band)
