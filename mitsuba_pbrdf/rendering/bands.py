"""The passbands of a Stokes cube (``pbrdf render --bands``): parsing and
checking the list (:class:`PassbandList`), in nm. Each passband becomes one
band of the cube's Stokes image.

Syntax (the list syntax of ``pbrdf export``'s bands, with passbands instead of
single wavelengths): comma-separated items, each

* ``START:STOP:STEP``: contiguous passbands STEP nm wide from START to STOP
  (``450:650:20`` is 10 bands, 450-470 ... 630-650; STOP - START must be a
  whole number of steps), or
* ``LOW:HIGH``: one passband from LOW to HIGH nm (``532:533``).

Passbands must be increasing, must not overlap (they may touch), must lie
within 360-830 nm (Mitsuba's CIE tables) and number at most :data:`MAX_BANDS`.
The image band of each is named after its centre, ``f"{centre:g}nm"``
(``460nm``, ``532.5nm``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..numbers import range_count
from .narrowband import CIE_RANGE

__all__ = ["PassbandList", "parse_bands", "require_spectral_bands", "MAX_BANDS"]

#: Most passbands in one cube (each is a band of 4 float32 planes of the image in memory
#: and in the EXR; 64 bands of 5 nm cover the visible range).
MAX_BANDS = 64
#: Narrowest passband, nm (float32 wavelengths resolve ~1e-4 nm at 800 nm).
MIN_WIDTH = 0.01


@dataclass(frozen=True)
class PassbandList:
    """Non-overlapping increasing passbands: ``edges`` is a tuple of (low, high) in nm."""

    edges: tuple

    @property
    def lows(self) -> np.ndarray:
        return np.array([e[0] for e in self.edges])

    @property
    def highs(self) -> np.ndarray:
        return np.array([e[1] for e in self.edges])

    @property
    def widths(self) -> np.ndarray:
        return self.highs - self.lows

    @property
    def centres(self) -> np.ndarray:
        return (self.lows + self.highs) / 2

    @property
    def names(self) -> list:
        """The names of the image's bands, e.g. ``460nm`` (no trailing ``.0``)."""
        return [f"{c:g}nm" for c in self.centres]

    @property
    def total_width(self) -> float:
        """Length (nm) of the union of the passbands."""
        return float(self.widths.sum())

    def header(self) -> str:
        """The passbands' edges for a file header: ``450-470,470-490,...`` (nm)."""
        return ",".join(f"{lo:g}-{hi:g}" for lo, hi in self.edges)

    def describe(self) -> str:
        return (f"{len(self.edges)} band{'s' * (len(self.edges) > 1)} over "
                f"{self.edges[0][0]:g}-{self.edges[-1][1]:g} nm")


def _number(text: str, whole: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ParameterError("bands", f"expects START:STOP:STEP ranges and LOW:HIGH bands in nm, "
                             f"comma-separated (e.g. 450:650:20 or 450:470,532:533), got "
                             f"{whole!r}") from None
    if not math.isfinite(value):
        raise ParameterError("bands", f"wavelengths must be finite, got {whole!r}")
    return value


def _item_edges(item: str, whole: str) -> list:
    parts = [p.strip() for p in item.split(":")]
    if len(parts) not in (2, 3) or not all(parts):
        raise ParameterError("bands", f"each item is START:STOP:STEP or LOW:HIGH (nm), got "
                             f"{item!r} in {whole!r}")
    values = [_number(p, whole) for p in parts]
    if len(values) == 2:
        low, high = values
        if high <= low:
            raise ParameterError("bands", f"the band {item!r} is reversed or empty: LOW < HIGH")
        return [(low, high)]
    start, stop, step = values
    if step <= 0 or stop <= start:
        raise ParameterError("bands", f"the range {item!r} needs START < STOP and STEP > 0")
    # bounded before rounding: a denormal STEP (1e-320) makes the quotient infinite
    count = range_count(start, stop, step, "bands", MAX_BANDS, item, "bands")
    n = int(round(count))
    if abs(count - n) > 1e-6 * max(1.0, count):
        raise ParameterError("bands", f"the range {item!r}: STOP - START is not a whole number "
                             f"of {step:g} nm steps")
    return [(start + i * step, start + (i + 1) * step) for i in range(n)]


def parse_bands(text) -> PassbandList:
    """The passbands of *text* (see the module docstring), or a PassbandList
    unchanged; :class:`~mitsuba_pbrdf.errors.ParameterError` naming ``bands``
    for anything else: bad syntax, a reversed or empty band, overlapping or
    decreasing bands, a band outside 360-830 nm, more than 64 bands."""
    if isinstance(text, PassbandList):
        return text
    whole = str(text)
    items = [item.strip() for item in whole.split(",")]
    if not whole.strip() or not all(items):
        raise ParameterError("bands", f"expects a comma-separated list of bands, got {whole!r}")
    edges = []
    for item in items:
        edges += _item_edges(item, whole)
        if len(edges) > MAX_BANDS:
            raise ParameterError("bands", f"{whole!r} has more than {MAX_BANDS} bands")
    for (lo0, hi0), (lo1, hi1) in zip(edges, edges[1:]):
        if lo1 < hi0 - 1e-9:
            raise ParameterError("bands", f"the bands {lo0:g}-{hi0:g} and {lo1:g}-{hi1:g} nm "
                                 "overlap or are out of order (list them increasing)")
    for low, high in edges:
        if high - low < MIN_WIDTH:
            raise ParameterError("bands", f"the band {low:g}-{high:g} nm is narrower than "
                                 f"{MIN_WIDTH:g} nm")
        if low < CIE_RANGE[0] or high > CIE_RANGE[1]:
            raise ParameterError("bands", f"the band {low:g}-{high:g} nm must lie within "
                                 f"{CIE_RANGE[0]:g}-{CIE_RANGE[1]:g} nm (Mitsuba's colour tables)")
    return PassbandList(tuple(edges))


def require_spectral_bands(variant: str):
    """:class:`~mitsuba_pbrdf.errors.ParameterError` (``bands``) unless
    *variant* is spectral."""
    if "_spectral" not in variant:
        raise ParameterError("bands", f"needs a spectral variant, not {variant}")
