"""Narrow-band Stokes images (``pbrdf render --wavelength NM[:WIDTH]``): the
Stokes image at one wavelength (a laser line) or averaged over a passband (a
bandpass filter: :class:`Passband`), from Mitsuba's ``stokes`` integrator in a
spectral variant.

Why it needs care: the ``stokes`` integrator writes each Stokes component as

    S_i.c = mean over the ray's 4 wavelengths λ of  K_c(λ) S_i(λ),
    K_c(λ) = sRGB_c(CIE xyz(λ)) / p_rgb(λ),

whatever the sensor samples (it divides by ``pdf_rgb_spectrum``, the pdf
Mitsuba samples wavelengths with by default, and converts to sRGB). This
module gives the sensor a spectral response (``srf``) that Mitsuba samples the
wavelengths from: zero outside the passband [λ0 - W/2, λ0 + W/2], and inside it
proportional to 1 / |K_c(λ)| for the colour channel c with the largest
response (R at 632.8 nm), tabulated at :func:`passband_response`'s points (spacing
at most 0.5 nm; K_c is smooth on that scale) and interpolated linearly, as
Mitsuba's ``regular`` spectrum does (:func:`passband_srf`; the sensors are
found wherever the scene keeps them, :mod:`.scene_setup`). With that sampling pdf p(λ) = srf(λ) / Z,

    E[S_i.c] = ∫ p K_c S_i dλ = sign(K_c) / Z ∫_passband S_i dλ,

so the passband average of S_i is ``sign(K_c) Z / W * S_i.c`` (:func:`passband_image`);
for a line (W = 0, rendered as a passband :data:`LINE_WIDTH` wide) it is
``S_i.c / K_c(λ0)``. K_c is computed with Mitsuba's own ``pdf_rgb_spectrum`` and
``spectrum_to_srgb``. ``docs/polarization-camera.md`` explains it for users.

The result is a :class:`StokesImage` with one (image) band named ``<λ0>nm`` (e.g.
``632.8nm``) and no colour preview; ``pbrdf polcam`` reads it as a monochrome
camera behind that filter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..stokes.image import StokesImage

__all__ = ["Passband", "parse_wavelength", "require_spectral", "passband_response",
           "PassbandResponse", "passband_srf", "passband_image", "LINE_WIDTH"]

#: Width (nm) of the passband a laser line (no WIDTH) is rendered with; the
#: materials' spectra do not change over it.
LINE_WIDTH = 0.01
#: Mitsuba's CIE 1931 tables cover 360-830 nm.
CIE_RANGE = (360.0, 830.0)
#: Largest spacing (nm) of the tabulated spectral response.
SPACING = 0.5


@dataclass(frozen=True)
class Passband:
    """A passband of wavelengths: *centre* and full *width* in nm (0: a
    line). Rendered, it is one band of the Stokes image, :attr:`name`."""

    centre: float
    width: float = 0.0

    @property
    def name(self) -> str:
        """The name of the Stokes image's band, e.g. ``632.8nm``."""
        return f"{self.centre:g}nm"

    @property
    def limits(self):
        """(low, high) in nm of the passband that is rendered."""
        half = max(self.width, LINE_WIDTH) / 2
        return self.centre - half, self.centre + half

    def describe(self) -> str:
        return f"{self.centre:g} nm" + (f" (band {self.width:g} nm wide)" if self.width
                                        else " (line)")


def parse_wavelength(text) -> Passband:
    """``NM`` or ``NM:WIDTH`` (nm) as a :class:`Passband`, or a Passband
    unchanged; :class:`~mitsuba_pbrdf.errors.ParameterError` naming
    ``wavelength`` for anything else or a passband outside 360-830 nm."""
    if isinstance(text, Passband):
        return text
    centre, _, width = str(text).partition(":")
    try:
        passband = Passband(float(centre), float(width) if width.strip() else 0.0)
    except ValueError:
        raise ParameterError("wavelength", "expects NM or NM:WIDTH in nanometres (e.g. 632.8 "
                             f"or 550:10), got {text!r}") from None
    if not (math.isfinite(passband.centre) and math.isfinite(passband.width)) \
            or passband.width < 0:
        raise ParameterError("wavelength", "the wavelength and width must be finite and the "
                             f"width >= 0, got {text!r}")
    low, high = passband.limits
    if low < CIE_RANGE[0] or high > CIE_RANGE[1]:
        raise ParameterError("wavelength", f"the band {low:g}-{high:g} nm must lie within "
                             f"{CIE_RANGE[0]:g}-{CIE_RANGE[1]:g} nm (Mitsuba's colour tables)")
    return passband


@dataclass
class PassbandResponse:
    """The sensor response of a passband: the colour channel of the ``stokes``
    integrator it is read from (0, 1, 2 for R, G, B), the tabulated response
    (``wavelengths``, ``values``) and the factor taking that channel to the
    passband-averaged Stokes vector."""

    passband: Passband
    channel: int
    wavelengths: np.ndarray
    values: np.ndarray
    scale: float


def require_spectral(variant: str):
    """:class:`~mitsuba_pbrdf.errors.ParameterError` (``wavelength``) unless
    *variant* is spectral: only those render a passband."""
    if "_spectral" not in variant:
        raise ParameterError("wavelength", f"needs a spectral variant, not {variant}")


def rgb_response(wavelengths) -> np.ndarray:
    """K_c(λ) of the ``stokes`` integrator, shape (3, n) (a spectral Mitsuba
    variant must be set)."""
    import mitsuba as mi

    require_spectral(mi.variant())
    lam = mi.Float(np.asarray(wavelengths, dtype=np.float32))
    w = mi.UnpolarizedSpectrum(lam, lam, lam, lam)  # the 4 lanes at the same wavelength
    pdf = mi.pdf_rgb_spectrum(w)
    return np.array(mi.spectrum_to_srgb(mi.UnpolarizedSpectrum(1.0) / pdf, w), dtype=np.float64)


def passband_response(passband: Passband) -> PassbandResponse:
    """The tabulated sensor response of *passband* (see the module docstring)."""
    low, high = passband.limits
    n = max(3, int(math.ceil((high - low) / SPACING)) + 1)
    lam = np.linspace(low, high, n)
    k = rgb_response(lam)
    same_sign = np.all(k > 0, axis=1) | np.all(k < 0, axis=1)
    strength = np.where(same_sign, np.abs(k).min(axis=1), 0.0)
    channel = int(np.argmax(strength))
    if strength[channel] <= 1e-6 * np.abs(rgb_response([555.0])).max():
        raise ParameterError("wavelength", f"the band {low:g}-{high:g} nm is too wide: no "
                             "colour channel of the stokes integrator keeps one sign over it")
    values = 1.0 / np.abs(k[channel])
    # the integral of the linear interpolation Mitsuba samples from (trapezoid rule)
    z = float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(lam)))
    scale = float(np.sign(k[channel, 0])) * z / (high - low)
    return PassbandResponse(passband, channel, lam, values / values.max(), scale)


def passband_srf(response: PassbandResponse) -> tuple:
    """The sensor's spectral response of *response* as
    :class:`~.scene_setup.SceneSetup` takes it: ``(wavelength_min,
    wavelength_max, values)``, nm, a ``regular`` spectrum."""
    lam = response.wavelengths
    return float(lam[0]), float(lam[-1]), tuple(float(v) for v in response.values)


def passband_image(image: StokesImage, response: PassbandResponse) -> StokesImage:
    """The passband's Stokes image (one band, :attr:`Passband.name`) from
    the R, G, B Stokes image of a render with the passband's response."""
    channel = image.bands.index("RGB"[response.channel])
    stokes = image.stokes[..., channel:channel + 1] * np.float32(response.scale)
    passband = response.passband
    metadata = dict(image.metadata, wavelength_nm=f"{passband.centre:g}",
                    band_width_nm=f"{passband.width:g}", band_channel="RGB"[response.channel])
    return StokesImage(stokes, [passband.name], None, metadata)
