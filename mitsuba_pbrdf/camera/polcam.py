"""What a division-of-focal-plane polarization camera records of a Stokes image.

* :func:`polarizer_images`: the four images behind an ideal linear polarizer at
  0°, 45°, 90° and 135° (Malus's law, per band):
  ``I_θ = (S0 + S1 cos 2θ + S2 sin 2θ) / 2``;
* :func:`mono_mosaic`: the raw frame of a monochrome polarization sensor (Sony
  IMX250MZR): 2 x 2 super-pixels of polarizer angles ``90, 45 / 135, 0`` from
  the top-left (:data:`MONO_LAYOUT`);
* :func:`colour_mosaic`: the raw frame of the colour one (IMX250MYR): each
  2 x 2 polarization super-pixel lies under one colour filter, and the
  super-pixels form an RGGB Bayer pattern, so the pattern repeats every 4 x 4
  pixels (:func:`colour_layout`), the layout polanalyser's ``COLOR_PolarRGB``
  demosaics;
* :class:`SensorModel`: optional photon shot noise, read noise and ADC
  quantization of a mosaic (off unless asked for), and :func:`write_png16`.

Frame: θ is measured from the image's horizontal (its right), counter-clockwise
in the picture, in the Stokes frame of Mitsuba's ``stokes`` integrator (x-axis
the image's right, y-axis its up; :mod:`mitsuba_pbrdf.stokes.image`). Light
with AoLP = θ passes the θ polarizer best. Rows of the arrays run top to
bottom, as in the picture. ``docs/polarization-camera.md`` has the details.

::

    images = polarizer_images(stokes)              # {0: (H, W, n_bands), 45: ..., 90:, 135:}
    raw = mono_mosaic(stokes, band="R")            # (H, W); band=None: luminance
    raw = colour_mosaic(stokes)                    # (H, W), needs bands R, G, B
    noisy, counts = SensorModel(full_well=10500, read_noise=2.5, bits=12, seed=1).apply(raw)
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from typing import Dict, Optional

import numpy as np

from ..errors import ParameterError
from ..outputs import atomic_path
from ..stokes.image import StokesImage, luminance_stokes
from ..stokes.quality import require_usable

__all__ = ["ANGLES", "MONO_LAYOUT", "BAYER_LAYOUT", "COLOUR_CUBE_REFUSAL", "polarizer_images",
           "stokes_from_intensities",
           "malus", "mono_layout", "colour_layout", "mono_mosaic", "colour_mosaic", "SensorModel",
           "write_png16", "is_cube", "polcam_outputs", "polcam_file_names", "write_polcam_files"]

#: Polarizer angles of the four channels, degrees.
ANGLES = (0, 45, 90, 135)
#: Polarizer angle (degrees) of each pixel of a 2 x 2 super-pixel, [row][column] from top-left.
MONO_LAYOUT = ((90, 45), (135, 0))
#: Colour filter of each 2 x 2 super-pixel of a 2 x 2 block of super-pixels (RGGB Bayer).
BAYER_LAYOUT = (("R", "G"), ("G", "B"))


def malus(stokes: np.ndarray, angle_deg: float, axis: int = -1) -> np.ndarray:
    """Intensity behind an ideal linear polarizer at *angle_deg* of Stokes
    vectors whose components lie on *axis* (-2 for ``StokesImage.stokes``)."""
    a = np.asarray(stokes)
    s0, s1, s2 = (np.take(a, i, axis=axis) for i in range(3))
    t = math.radians(angle_deg)
    # exact at the multiples of 45 degrees (cos 90° is 6e-17 in floating point)
    c, s = (round(math.cos(2 * t), 15), round(math.sin(2 * t), 15))
    return 0.5 * (s0 + c * s1 + s * s2)


def polarizer_images(image: StokesImage) -> Dict[int, np.ndarray]:
    """The four polarizer images ``{θ: (H, W, n_bands) float32}`` of a Stokes
    image, θ in :data:`ANGLES` (per band, bands as in ``image.bands``)."""
    return {a: malus(image.stokes, a, axis=-2).astype(np.float32) for a in ANGLES}


def stokes_from_intensities(intensities: Dict[int, np.ndarray], axis: int = -1) -> np.ndarray:
    """Linear Stokes vectors from the intensities behind a polarizer at each
    of :data:`ANGLES` (what a division-of-focal-plane camera computes; the
    inverse of :func:`malus` at those angles): S0 = (I0 + I45 + I90 + I135) / 2,
    S1 = I0 − I90, S2 = I45 − I135, S3 = 0, float64, the four components on
    a new *axis* (-2 for ``StokesImage.stokes`` from (H, W, bands) intensities)."""
    i0, i45, i90, i135 = (np.asarray(intensities[a], dtype=np.float64) for a in ANGLES)
    return np.stack([(i0 + i45 + i90 + i135) / 2, i0 - i90, i45 - i135,
                     np.zeros_like(i0)], axis=axis)


def mono_layout(height: int, width: int) -> np.ndarray:
    """Polarizer angle (degrees) of each pixel of a monochrome sensor, (H, W) int."""
    tile = np.array(MONO_LAYOUT)
    return np.tile(tile, (height // 2 + 1, width // 2 + 1))[:height, :width]


def colour_layout(height: int, width: int):
    """``(angles, colours)`` of each pixel of the colour sensor: the polarizer
    angle (degrees, (H, W) int) and the colour filter (index into R, G, B,
    (H, W) int). The pattern repeats every 4 x 4 pixels::

        90R  45R  90G  45G
        135R  0R 135G   0G
        90G  45G  90B  45B
        135G  0G 135B   0B
    """
    angles = mono_layout(height, width)
    bayer = np.array([["RGB".index(c) for c in row] for row in BAYER_LAYOUT])
    colours = np.repeat(np.repeat(bayer, 2, axis=0), 2, axis=1)
    colours = np.tile(colours, (height // 4 + 1, width // 4 + 1))[:height, :width]
    return angles, colours


def _check_even(image: StokesImage, what: str):
    if image.height % 2 or image.width % 2:
        raise ValueError(f"the {what} sensor's 2 x 2 polarization super-pixels need an even "
                         f"image width and height, got {image.width}x{image.height}")


def _pick(images: Dict[int, np.ndarray], angles: np.ndarray) -> np.ndarray:
    out = np.zeros(angles.shape, dtype=np.float32)
    for a in ANGLES:
        mask = angles == a
        out[mask] = images[a][mask]
    return out


def mono_mosaic(image: StokesImage, band: Optional[str] = None) -> np.ndarray:
    """The monochrome sensor's raw frame, (H, W) float32 in the image's units.
    *band*: the Stokes band it sees (None: the Rec. 709 luminance combination
    of R, G, B, or the mean of other bands, :func:`luminance_stokes`; the one
    band of a one-band image). Needs an even width and height."""
    _check_even(image, "monochrome")
    if band is None:
        stokes = image.stokes[..., 0] if len(image.bands) == 1 else luminance_stokes(image)
    else:
        stokes = image.band(band)
    images = {a: malus(stokes, a) for a in ANGLES}
    return _pick(images, mono_layout(image.height, image.width))


def colour_mosaic(image: StokesImage) -> np.ndarray:
    """The colour sensor's raw frame, (H, W) float32 (:func:`colour_layout`);
    the image needs bands R, G, B and an even width and height."""
    missing = [b for b in "RGB" if b not in image.bands]
    if missing:
        raise ValueError(f"the colour sensor needs Stokes bands R, G, B; the image has "
                         f"{', '.join(image.bands)}")
    _check_even(image, "colour")
    angles, colours = colour_layout(image.height, image.width)
    out = np.zeros(angles.shape, dtype=np.float32)
    for c, name in enumerate("RGB"):
        stokes = image.band(name)
        for a in ANGLES:
            mask = (angles == a) & (colours == c)
            out[mask] = malus(stokes[mask], a)
    return out


@dataclass
class SensorModel:
    """Photon shot noise, read noise and ADC quantization of a raw frame.

    Attributes
    ----------
    exposure : float, optional
        The radiance (in the image's units) that fills the full well; brighter
        pixels saturate. None: the frame's maximum (nothing saturates).
    full_well : float, optional
        Electrons at full well. With it, the electron count of a pixel is
        Poisson distributed (shot noise); None: no shot noise.
    read_noise : float
        Standard deviation of the read noise, electrons (needs *full_well*).
    bits : int, optional
        ADC bits (1-16): the frame is quantized to integers 0 .. 2^bits - 1
        (full well = 2^bits - 1). None: not quantized.
    seed : int
        Seed of the NumPy random generator (``numpy.random.default_rng``).
    """

    exposure: Optional[float] = None
    full_well: Optional[float] = None
    read_noise: float = 0.0
    bits: Optional[int] = None
    seed: int = 0

    def __post_init__(self):
        for name in ("exposure", "full_well"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value}")
        if not (math.isfinite(self.read_noise) and self.read_noise >= 0):
            raise ValueError(f"read_noise must be a finite number >= 0, got {self.read_noise}")
        if self.read_noise > 0 and self.full_well is None:
            raise ValueError("read_noise (electrons) needs full_well")
        if self.bits is not None and not 1 <= int(self.bits) <= 16:
            raise ValueError(f"bits must be in 1..16, got {self.bits}")

    @property
    def enabled(self) -> bool:
        """Whether the model changes a frame at all."""
        return self.full_well is not None or self.bits is not None

    def apply(self, raw: np.ndarray):
        """``(frame, counts)``: the recorded frame in the input's units (float32;
        ``counts * exposure / (2^bits - 1)`` when quantized) and the ADC counts
        (uint16, or None without *bits*)."""
        raw = np.asarray(raw, dtype=np.float64)
        exposure = self.exposure if self.exposure is not None else float(raw.max())
        if not exposure > 0:
            exposure = 1.0  # a black frame stays black
        signal = np.clip(raw / exposure, 0.0, None)  # fraction of full well
        if self.full_well is not None:
            rng = np.random.default_rng(self.seed)
            electrons = rng.poisson(np.minimum(signal, 1.0) * self.full_well).astype(np.float64)
            if self.read_noise > 0:
                electrons += rng.normal(0.0, self.read_noise, electrons.shape)
            signal = np.clip(electrons / self.full_well, 0.0, 1.0)
        else:
            signal = np.minimum(signal, 1.0)
        if self.bits is None:
            return (signal * exposure).astype(np.float32), None
        top = 2 ** int(self.bits) - 1
        counts = np.rint(signal * top).astype(np.uint16)
        return (counts * (exposure / top)).astype(np.float32), counts


def write_png16(path, counts: np.ndarray) -> str:
    """Write ADC counts (H, W) as a 16-bit greyscale PNG, values as they are
    (a 12-bit frame uses the low 12 bits), atomically. Returns the path."""
    from PIL import Image

    counts = np.ascontiguousarray(counts, dtype=np.uint16)
    path = os.fspath(path)
    with atomic_path(path) as tmp:
        Image.fromarray(counts).save(tmp, format="PNG")
    return path


#: Why the colour sensor does not take a Stokes cube (``pbrdf polcam``, a sweep's
#: ``[polcam]``): its R, G, B are integrals over the whole visible spectrum
#: against the filters' responses, which a cube's band averages cannot give
#: (docs/spectral-cube.md#tools).
COLOUR_CUBE_REFUSAL = (
    "the colour sensor's R, G, B filters each integrate the whole visible spectrum "
    "(360-830 nm), and a Stokes cube holds only the averages of its own bands; render "
    "the scene without bands (in R, G, B) for the colour sensor, or let the mono sensor "
    "see each band of the cube")


def polcam_outputs(image: StokesImage, sensor: str = "mono", band: Optional[str] = None,
                   model: Optional[SensorModel] = None) -> dict:
    """Everything ``pbrdf polcam`` writes, computed before anything is written:
    ``{suffix: value}`` with suffixes ``I0, I45, I90, I135`` (``{band: (H, W)}``
    channels), ``mosaic`` or ``mosaic_rgb`` (``{"Y": (H, W)}``) and, with
    ``model.bits``, ``mosaic.png`` / ``mosaic_rgb.png`` (uint16 counts).

    A Stokes cube (:func:`is_cube`) seen by the mono sensor without a *band*
    gives one mosaic per band, as a monochrome polarization camera behind each
    band's filter in turn: ``mosaic`` has one channel per band (named as the
    bands), each with the sensor model applied on its own (its own exposure
    when none is given, noise seed ``model.seed + band index``), and with
    ``model.bits`` one ``mosaic_<band>.png`` per band. The colour sensor refuses
    a cube (:class:`~mitsuba_pbrdf.errors.ParameterError` ``sensor``,
    :data:`COLOUR_CUBE_REFUSAL`)."""
    if sensor not in ("mono", "colour"):
        raise ValueError(f"sensor must be 'mono' or 'colour', got {sensor!r}")
    if sensor == "colour" and is_cube(image):
        raise ParameterError("sensor", f"'colour' cannot see a Stokes cube: "
                                       f"{COLOUR_CUBE_REFUSAL}")
    if band is not None and band not in image.bands:
        raise ValueError(f"no band {band!r}; bands are {', '.join(image.bands)}")
    bad = int(np.count_nonzero(~np.isfinite(image.stokes)))
    if bad:
        raise ValueError(f"{bad} non-finite Stokes values (NaN or infinite); a camera image "
                         "needs finite ones")
    # the unusable-pixel rule of every reader (all-negative S0 is no camera image)
    if sensor == "colour":
        require_usable(image, bands=("R", "G", "B")
                       if all(b in image.bands for b in "RGB") else None)
    elif band is not None or len(image.bands) == 1:
        require_usable(image, band=band or image.bands[0])
    else:
        require_usable(image, bands=image.bands if is_cube(image) else None)
    if sensor == "mono" and band is None and is_cube(image):
        return _cube_outputs(image, model)
    if sensor == "mono":
        raw, name = mono_mosaic(image, band), "mosaic"
    else:
        if band is not None:
            raise ValueError("band is for the monochrome sensor; the colour sensor sees R, G, B")
        raw, name = colour_mosaic(image), "mosaic_rgb"
    result = {f"I{a}": {b: plane[:, :, i] for i, b in enumerate(image.bands)}
              for a, plane in polarizer_images(image).items()}
    counts = None
    if model is not None and model.enabled:
        raw, counts = model.apply(raw)
    result[name] = {"Y": raw}
    if counts is not None:
        result[name + ".png"] = counts
    return result


def is_cube(image: StokesImage) -> bool:
    """Whether *image* is a Stokes cube (``pbrdf render --bands``: band edges
    in its metadata, more than one band)."""
    return "band_edges_nm" in image.metadata and len(image.bands) > 1


def _cube_outputs(image: StokesImage, model: Optional[SensorModel]) -> dict:
    result = {f"I{a}": {b: plane[:, :, i] for i, b in enumerate(image.bands)}
              for a, plane in polarizer_images(image).items()}
    mosaics, counts = {}, {}
    for i, name in enumerate(image.bands):
        raw = mono_mosaic(image, name)
        if model is not None and model.enabled:
            raw, counts[name] = replace(model, seed=model.seed + i).apply(raw)
        mosaics[name] = raw
    result["mosaic"] = mosaics
    for name, value in counts.items():
        if value is not None:
            result[f"mosaic_{name}.png"] = value
    return result


def polcam_file_names(outputs: dict, stem: str) -> Dict[str, str]:
    """``{suffix: file name}`` of :func:`polcam_outputs`' results:
    ``<stem>_<suffix>.exr``, or ``<stem>_mosaic.png`` for the ADC counts."""
    return {suffix: f"{stem}_{suffix}" + ("" if suffix.endswith(".png") else ".exr")
            for suffix in outputs}


def write_polcam_files(outputs: dict, folder, stem: str, metadata=None) -> list:
    """Write :func:`polcam_outputs`' results in *folder* (each file atomically:
    EXRs with *metadata* and a ``polcam`` attribute, counts as 16-bit PNGs);
    returns the file names, in the order of *outputs*."""
    from ..stokes.exr import write_exr

    names = polcam_file_names(outputs, stem)
    for suffix, value in outputs.items():
        path = os.path.join(os.fspath(folder), names[suffix])
        if suffix.endswith(".png"):
            write_png16(path, value)
        else:
            write_exr(path, value, dict(metadata or {}, polcam=suffix))
    return list(names.values())

