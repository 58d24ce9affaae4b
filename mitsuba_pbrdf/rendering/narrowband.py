"""Narrow-band Stokes images (``pbrdf render --wavelength NM[:WIDTH]``): the
Stokes image at one wavelength (a laser line) or averaged over a band (a
bandpass filter), from Mitsuba's ``stokes`` integrator in a spectral variant.

Why it needs care: the ``stokes`` integrator writes each Stokes component as

    S_i.c = mean over the ray's 4 wavelengths λ of  K_c(λ) S_i(λ),
    K_c(λ) = sRGB_c(CIE xyz(λ)) / p_rgb(λ),

whatever the sensor samples (it divides by ``pdf_rgb_spectrum``, the pdf
Mitsuba samples wavelengths with by default, and converts to sRGB). This
module gives the sensor a spectral response (``srf``) that Mitsuba samples the
wavelengths from: zero outside the band [λ0 - W/2, λ0 + W/2], and inside it
proportional to 1 / |K_c(λ)| for the colour channel c with the largest
response (R at 632.8 nm), tabulated at :func:`band_response`'s points (spacing
at most 0.5 nm; K_c is smooth on that scale) and interpolated linearly, as
Mitsuba's ``regular`` spectrum does. With that sampling pdf p(λ) = srf(λ) / Z,

    E[S_i.c] = ∫ p K_c S_i dλ = sign(K_c) / Z ∫_band S_i dλ,

so the band average of S_i is ``sign(K_c) Z / W * S_i.c`` (:func:`band_image`);
for a line (W = 0, rendered as a band of :data:`LINE_WIDTH`) it is
``S_i.c / K_c(λ0)``. K_c is computed with Mitsuba's own ``pdf_rgb_spectrum`` and
``spectrum_to_srgb``. ``docs/polarization-camera.md`` explains it for users.

The result is a :class:`StokesImage` with one band named ``<λ0>nm`` (e.g.
``632.8nm``) and no colour preview; ``pbrdf polcam`` reads it as a monochrome
camera behind that filter.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..stokes.image import StokesImage
from .scene_loading import load_scene_text

__all__ = ["WavelengthBand", "parse_wavelength", "require_spectral", "band_response", "BandResponse",
           "scene_with_band", "band_image", "LINE_WIDTH"]

#: Width (nm) of the band a laser line (no WIDTH) is rendered with; the
#: materials' spectra do not change over it.
LINE_WIDTH = 0.01
#: Mitsuba's CIE 1931 tables cover 360-830 nm.
CIE_RANGE = (360.0, 830.0)
#: Largest spacing (nm) of the tabulated spectral response.
SPACING = 0.5


@dataclass(frozen=True)
class WavelengthBand:
    """A wavelength band: *centre* and full *width* in nm (0: a line)."""

    centre: float
    width: float = 0.0

    @property
    def name(self) -> str:
        """The Stokes band's name, e.g. ``632.8nm``."""
        return f"{self.centre:g}nm"

    @property
    def limits(self):
        """(low, high) in nm of the band that is rendered."""
        half = max(self.width, LINE_WIDTH) / 2
        return self.centre - half, self.centre + half

    def describe(self) -> str:
        return f"{self.centre:g} nm" + (f" (band {self.width:g} nm wide)" if self.width
                                        else " (line)")


def parse_wavelength(text: str) -> WavelengthBand:
    """``NM`` or ``NM:WIDTH`` (nm) as a :class:`WavelengthBand`;
    :class:`~mitsuba_pbrdf.errors.ParameterError` naming ``wavelength`` for
    anything else or a band outside 360-830 nm."""
    centre, _, width = str(text).partition(":")
    try:
        band = WavelengthBand(float(centre), float(width) if width.strip() else 0.0)
    except ValueError:
        raise ParameterError("wavelength", "expects NM or NM:WIDTH in nanometres (e.g. 632.8 "
                             f"or 550:10), got {text!r}") from None
    if not (math.isfinite(band.centre) and math.isfinite(band.width)) or band.width < 0:
        raise ParameterError("wavelength", "the wavelength and width must be finite and the "
                             f"width >= 0, got {text!r}")
    low, high = band.limits
    if low < CIE_RANGE[0] or high > CIE_RANGE[1]:
        raise ParameterError("wavelength", f"the band {low:g}-{high:g} nm must lie within "
                             f"{CIE_RANGE[0]:g}-{CIE_RANGE[1]:g} nm (Mitsuba's colour tables)")
    return band


@dataclass
class BandResponse:
    """The sensor response of a band: the colour channel the band is read from
    (0, 1, 2 for R, G, B), the tabulated response (``wavelengths``, ``values``)
    and the factor taking that channel to the band-averaged Stokes vector."""

    band: WavelengthBand
    channel: int
    wavelengths: np.ndarray
    values: np.ndarray
    scale: float


def require_spectral(variant: str):
    """:class:`~mitsuba_pbrdf.errors.ParameterError` (``wavelength``) unless
    *variant* is spectral: only those render a wavelength band."""
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


def band_response(band: WavelengthBand) -> BandResponse:
    """The tabulated sensor response of *band* (see the module docstring)."""
    low, high = band.limits
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
    return BandResponse(band, channel, lam, values / values.max(), scale)


def scene_with_band(scene_path, response: BandResponse) -> str:
    """The scene file's XML with the band's response as its sensor's ``srf``
    (a ``regular`` spectrum). ``ValueError`` if the file has no ``<sensor>``
    (one in an included file is not supported), or one with an ``srf`` or a
    spectral film of its own."""
    path = os.fspath(scene_path)
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as e:
        raise ValueError(f"{path}: not readable XML ({e})") from None
    sensors = root.findall("sensor")
    if not sensors:
        raise ParameterError("wavelength", f"{path} has no <sensor> of its own (one in an "
                             "included file is not supported)")
    sensor = sensors[0]
    if any(child.get("name") == "srf" for child in sensor):
        raise ParameterError("wavelength", f"the sensor of {path} has a spectral response "
                             "(srf) already")
    if any(child.tag == "film" and child.get("type") == "specfilm" for child in sensor):
        raise ParameterError("wavelength", "the scene's film is a specfilm; use hdrfilm")
    srf = ET.SubElement(sensor, "spectrum", {"name": "srf", "type": "regular"})
    lam = response.wavelengths
    ET.SubElement(srf, "float", {"name": "wavelength_min", "value": repr(float(lam[0]))})
    ET.SubElement(srf, "float", {"name": "wavelength_max", "value": repr(float(lam[-1]))})
    ET.SubElement(srf, "string", {"name": "values",
                                  "value": ", ".join(f"{v:.9g}" for v in response.values)})
    return ET.tostring(root, encoding="unicode")


def load_band_scene(scene_path, params, response: BandResponse):
    """``mi.load_string`` of :func:`scene_with_band`, resolving the scene's
    relative paths (includes, textures) from its folder, as ``mi.load_file``
    does. Raises what :func:`~mitsuba_pbrdf.rendering.render.load_scene` raises."""
    return load_scene_text(scene_with_band(scene_path, response), scene_path, params)


def band_image(image: StokesImage, response: BandResponse) -> StokesImage:
    """The band's Stokes image (one band, :attr:`WavelengthBand.name`) from
    the R, G, B Stokes image of a render with the band's response."""
    channel = image.bands.index("RGB"[response.channel])
    stokes = image.stokes[..., channel:channel + 1] * np.float32(response.scale)
    band = response.band
    metadata = dict(image.metadata, wavelength_nm=f"{band.centre:g}",
                    band_width_nm=f"{band.width:g}", band_channel="RGB"[response.channel])
    return StokesImage(stokes, [band.name], None, metadata)
