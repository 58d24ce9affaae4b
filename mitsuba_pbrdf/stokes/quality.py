"""Unusable pixels of a Stokes image: non-finite values, negative intensity,
and polarization above 1.

A physical Stokes vector has S0 >= 0 and a degree of polarization
sqrt(S1² + S2² + S3²) / S0 <= 1. :func:`assess` counts the pixels that break
this, so that pictures mark them (:mod:`mitsuba_pbrdf.visualization.panels`) and
commands warn about them, or refuse an image with no usable pixel.

Which Stokes vector is checked, and how strictly:

* the luminance vector (:func:`~mitsuba_pbrdf.stokes.image.luminance_stokes`,
  what the pictures draw by default): strictly. It is a combination of the
  spectral Stokes vectors with positive weights (the CIE ȳ curve), each
  physical, so only float32 rounding can push it out: the tolerance
  :data:`LUMINANCE_TOLERANCE` (1e-3 of S0) is above the worst-case rounding of
  a float32 sum of 10^4 samples (10^4 x 6e-8 = 6e-4). Renders through an ideal
  polarizer (DoP = 1) stay within 2e-6.
* one R, G or B band (``band="R"``): these mix wavelengths with the negative
  weights of the XYZ-to-sRGB matrix, so for saturated spectra a band's vector
  can legitimately be slightly unphysical. A band pixel counts only when it is
  out of range by more than :data:`BAND_TOLERANCE` (5 %) of the pixel's
  luminance S0. Other bands (single wavelengths, ``Y``) are checked strictly.
* non-finite: any of the image's Stokes channels (every band) or its RGB
  preview is NaN or infinite.

::

    q = assess(image)            # or assess(image, band="R")
    q.unusable                   # (H, W) bool mask
    print(q.summary())           # "3 of 768 pixels unusable (2 non-finite, 1 with DoP > 1)"
    require_usable(image, "cube.exr", bands=image.bands)  # ValueError if a band has none

The rule every reader of Stokes data applies (``view``, ``view --cube``,
``view --spectrum``, ``polcam``, the targets of ``recover-normals``):
:func:`require_usable` refuses an image in which a judged Stokes vector
(the luminance one, or each band it will draw or convert) has no usable pixel.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .image import StokesImage, luminance_stokes

__all__ = ["LUMINANCE_TOLERANCE", "BAND_TOLERANCE", "StokesQuality", "assess",
           "require_usable", "UnusableImageError"]

#: Relative tolerance of the luminance Stokes vector (see the module docstring).
LUMINANCE_TOLERANCE = 1e-3
#: Tolerance of one R, G or B band, as a fraction of the pixel's luminance S0.
BAND_TOLERANCE = 0.05
_MIXED_BANDS = ("R", "G", "B")


@dataclass
class StokesQuality:
    """Masks (H, W) of the pixels that cannot be drawn faithfully, and counts."""

    non_finite: np.ndarray
    negative_s0: np.ndarray
    overpolarized: np.ndarray
    black: bool
    what: str

    @property
    def unusable(self) -> np.ndarray:
        """Pixels that are non-finite, have S0 < 0 or a degree of polarization > 1."""
        return self.non_finite | self.negative_s0 | self.overpolarized

    @property
    def pixels(self) -> int:
        return int(self.non_finite.size)

    @property
    def count(self) -> int:
        """Number of unusable pixels."""
        return int(self.unusable.sum())

    @property
    def usable(self) -> int:
        """Number of usable pixels."""
        return self.pixels - self.count

    def summary(self) -> str:
        """One line: how many pixels are unusable and why; '' when none are."""
        if not self.count:
            return ""
        parts = [f"{n} {label}" for n, label in (
            (int(self.non_finite.sum()), "non-finite"),
            (int(self.negative_s0.sum()), "with S0 < 0"),
            (int(self.overpolarized.sum()), "with degree of polarization > 1"),
        ) if n]
        return (f"{self.count} of {self.pixels} pixels unusable in the {self.what} "
                f"({', '.join(parts)})")


def assess(image: StokesImage, band: Optional[str] = None) -> StokesQuality:
    """The unusable pixels of *image*, judged on its luminance Stokes vector or
    on *band*'s (see the module docstring for the tolerances)."""
    with np.errstate(invalid="ignore", over="ignore"):
        finite = np.isfinite(image.stokes).all(axis=(2, 3))
        if image.rgb is not None:
            finite &= np.isfinite(image.rgb).all(axis=-1)
        lum = luminance_stokes(image).astype(np.float64)
        lum = np.where(finite[..., None], lum, 0.0)
        luminance = lum[..., 0]
        if band is None:
            s, slack, what = lum, LUMINANCE_TOLERANCE * np.abs(luminance), "luminance Stokes vector"
        else:
            s = np.where(finite[..., None], image.band(band).astype(np.float64), 0.0)
            if band in _MIXED_BANDS:
                slack = BAND_TOLERANCE * np.abs(luminance)
            else:
                slack = LUMINANCE_TOLERANCE * np.abs(s[..., 0])
            what = f"band {band}"
        polarized = np.sqrt(s[..., 1] ** 2 + s[..., 2] ** 2 + s[..., 3] ** 2)
        negative = finite & (s[..., 0] < -slack)
        over = finite & ~negative & (polarized - s[..., 0] > slack) & (polarized > 0)
    black = bool(finite.any()) and not bool(np.any(luminance[finite] > 0))
    return StokesQuality(non_finite=~finite, negative_s0=negative, overpolarized=over,
                         black=black, what=what)


class UnusableImageError(ValueError):
    """A Stokes image (or one of its bands) has no usable pixel."""


def require_usable(image: StokesImage, source: Optional[str] = None, bands=None,
                   band: Optional[str] = None):
    """The unusable-pixel rule of every reader of Stokes data: the assessment
    of *band* (None: the luminance vector), and of each of *bands* when given
    (a cube's readers draw or convert every band); :class:`UnusableImageError`
    naming *source* (the file) when one of them has no usable pixel. Returns
    the assessment of *band*."""
    quality = assess(image, band)
    judged = [(band, quality)] + [(b, assess(image, b)) for b in (bands or ()) if b != band]
    for name, q in judged:
        if q.usable == 0:
            where = f"{source}: " if source else ""
            raise UnusableImageError(f"{where}no usable pixel: {q.summary()}")
    return quality
