"""Tabulate the model into a ``.pbsdf`` table that Mitsuba's
``measured_polarized`` renders (``pbrdf export``).

Every table cell is the float64 reference evaluator's pBRDF (1/sr, no cosine
factor) at the cell's Rusinkiewicz angles, rotated from the reference's
global s/p frames into the table's facet frames
(:mod:`mitsuba_pbrdf.measured.rusinkiewicz`). Cells where the light or the
viewer is on or below the horizon (theta_d + theta_h at or beyond 90 deg,
depending on phi_d; a cosine below :data:`HORIZON`) hold the model's value
there, 0: in floating point cos(90 deg) = 6e-17 > 0, and the model's 1/cos
would put values up to 1e29 on horizon nodes. Computed in slabs of ``phi_d`` (NumPy,
no loop over cells) and written as it goes, so a full KAIST-size table
(about 1 GB) never sits in memory.

Grids (:class:`Grid`): ``phi_d`` uniform on [-pi, pi], ``theta_d`` uniform on
[0, pi/2], ``theta_h`` on [0, pi/2] either uniform or ``square``-spaced
(``theta_h = pi/2 (i/(N-1))^2``, dense near the specular peak, the spacing of
the MERL database). :data:`DEFAULT_GRID` renders the model's default roughness
accurately in 96 MB (``validation/measured_oracle.md`` gives its
interpolation error); :data:`KAIST_GRID` is the database's 361 x 91 x 91 grid
(1-degree steps, uniform, about 1 GB with 5 wavelengths).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..numbers import range_count
from ..reference.params import PBRDFParams
from .pbsdf import write_pbsdf
from .rusinkiewicz import angles, directions, global_to_facet

__all__ = ["Grid", "DEFAULT_GRID", "KAIST_GRID", "KAIST_WAVELENGTHS", "MAX_BANDS", "parse_grid",
           "parse_bands", "tabulate", "export_pbsdf"]

#: Cells with the light or the viewer closer to the horizon than this cosine
#: (0.06 mrad) hold 0, the model's value at and below the horizon.
HORIZON = 1e-6

#: The KAIST database's five bands (nm).
KAIST_WAVELENGTHS = (450, 500, 550, 600, 650)

#: The most wavelengths a table may have (a hyperspectral camera's 400-1000 nm
#: in 1-nm steps is 601).
MAX_BANDS = 2048

#: Wavelengths evaluated at once by :func:`tabulate` (bounds its float64
#: intermediates for hyperspectral tables).
BAND_CHUNK = 8


@dataclass(frozen=True)
class Grid:
    """Sizes of the table's angle grids and the spacing of ``theta_h``."""
    phi_d: int
    theta_d: int
    theta_h: int
    theta_h_spacing: str = "square"

    def __post_init__(self):
        for name in ("phi_d", "theta_d", "theta_h"):
            if not 2 <= getattr(self, name) <= 4096:
                raise ParameterError("grid", f"{name} needs 2 to 4096 points, "
                                             f"got {getattr(self, name)}")
        if self.theta_h_spacing not in ("square", "uniform"):
            raise ParameterError("grid", f"theta_h spacing must be square or uniform, "
                                         f"got {self.theta_h_spacing!r}")

    def axes(self):
        """``(phi_d, theta_d, theta_h)`` in radians (float64)."""
        u = np.linspace(0.0, 1.0, self.theta_h)
        theta_h = 0.5 * np.pi * (u * u if self.theta_h_spacing == "square" else u)
        return (np.linspace(-np.pi, np.pi, self.phi_d), np.linspace(0.0, 0.5 * np.pi, self.theta_d),
                theta_h)

    def nbytes(self, wavelengths=5):
        return self.phi_d * self.theta_d * self.theta_h * wavelengths * 16 * 4

    def __str__(self):
        return f"{self.phi_d}x{self.theta_d}x{self.theta_h}" + (
            "" if self.theta_h_spacing == "square" else "-uniform")


DEFAULT_GRID = Grid(49, 80, 80, "square")
KAIST_GRID = Grid(361, 91, 91, "uniform")


def parse_grid(text) -> Grid:
    """``default``, ``kaist`` or ``PxDxH`` (phi_d x theta_d x theta_h sizes),
    optionally ``-uniform`` for a uniform theta_h (default: square-spaced)."""
    text = str(text).strip().lower()
    if text == "default":
        return DEFAULT_GRID
    if text == "kaist":
        return KAIST_GRID
    m = re.fullmatch(r"(\d+)x(\d+)x(\d+)(-uniform|-square)?", text)
    if not m:
        raise ParameterError("grid", f"must be default, kaist or PxDxH (e.g. 49x80x80), "
                                     f"got {text!r}")
    return Grid(int(m[1]), int(m[2]), int(m[3]), (m[4] or "-square")[1:])


def parse_bands(text, what="bands"):
    """Wavelengths (whole nm, strictly increasing, 1 to :data:`MAX_BANDS` of
    them) from comma-separated items, each a wavelength or ``START:STOP:STEP``
    (STOP included when on the grid), e.g. ``400:700:10`` or ``450,550,650``.
    :class:`~mitsuba_pbrdf.errors.ParameterError` of the parameter ``what`` otherwise."""
    text = str(text).strip()
    items = [i.strip() for i in text.split(",")]
    if not text or any(not i for i in items):
        raise ParameterError(what, f"expected comma-separated wavelengths in nm or "
                             f"START:STOP:STEP, got {text!r}")
    out = []
    for item in items:
        parts = item.split(":")
        try:
            numbers = [float(p) for p in parts]
        except ValueError:
            raise ParameterError(what, f"{item!r} is not a wavelength (nm) or "
                                 f"START:STOP:STEP") from None
        if len(parts) not in (1, 3) or not all(math.isfinite(v) and v == round(v)
                                               for v in numbers):
            raise ParameterError(what, f"{item!r} must be a whole number of nm or "
                                 f"START:STOP:STEP of whole nm")
        if len(parts) == 1:
            out.append(int(numbers[0]))
            continue
        start, stop, step = (int(v) for v in numbers)
        if step <= 0 or stop < start:
            raise ParameterError(what, f"{item!r} needs STEP > 0 and STOP >= START")
        if stop > start and range_count(start, stop, step, what, MAX_BANDS, item,
                                        "steps") + 1 > MAX_BANDS:
            raise ParameterError(what, f"{item!r} gives more than {MAX_BANDS} wavelengths")
        out.extend(range(start, stop + 1, step))
    if len(out) > MAX_BANDS:
        raise ParameterError(what, f"{len(out)} wavelengths; at most {MAX_BANDS}")
    if any(not 1 <= w <= 65535 for w in out):
        raise ParameterError(what, f"wavelengths must lie in 1..65535 nm (stored as uint16), "
                             f"got {text!r}")
    if any(b <= a for a, b in zip(out, out[1:])):
        raise ParameterError(what, f"wavelengths must be strictly increasing, got {text!r}")
    return out


def tabulate(params: PBRDFParams, phi_d, theta_d, theta_h, wavelengths):
    """The table ``(len(phi_d), len(theta_d), len(theta_h), W, 4, 4)`` (float64)
    of the model at these grid values (radians) and wavelengths (nm)."""
    pd, td, th = np.meshgrid(phi_d, theta_d, theta_h, indexing="ij")
    L, V = directions(pd, td, th)
    ti, pi_, tr, pr = angles(L, V)
    wavelengths = np.asarray(wavelengths, dtype=np.float64)
    # a few wavelengths at a time: a hyperspectral table's float64 intermediates
    # would otherwise grow with its hundreds of bands
    M = np.concatenate([params.evaluate(ti, pi_, tr, pr, wavelengths[w:w + BAND_CHUNK])
                        for w in range(0, len(wavelengths), BAND_CHUNK)], axis=-3)
    # on the horizon (cos 90 deg = 6e-17 in floating point) the model's 1/cos
    # gives up to 1e29: such a node would leak into every lookup near the horizon
    # (fireflies). The model's value at and below the horizon is 0.
    on_horizon = np.minimum(L[..., 2], V[..., 2]) < HORIZON
    M[on_horizon] = 0.0
    return global_to_facet(M, L, V)


def export_pbsdf(path, params: PBRDFParams, grid: Grid = DEFAULT_GRID,
                 wavelengths=KAIST_WAVELENGTHS):
    """Write the model with ``params`` as a ``.pbsdf`` table (atomically)."""
    params.validate()
    phi_d, theta_d, theta_h = grid.axes()
    slab = lambda p0, p1: tabulate(params, phi_d[p0:p1], theta_d, theta_h,
                                   wavelengths).astype(np.float32)
    return write_pbsdf(path, slab, phi_d, theta_d, theta_h, wavelengths, slab_bytes=4 << 20)
