"""Colours of the Stokes pictures: the AoLP hue wheel, scales chosen from the
data, and the marker colours of unusable pixels.

Conventions, as the ``polanalyser`` package and polarization cameras draw them:

* AoLP: hue = AoLP / 180° around the HSV wheel at full saturation and value
  (0° red, 45° yellow-green, ±90° cyan, −45° violet), so every angle is bright
  and −90° meets +90°; ``polanalyser.applyColorToAoLP`` uses the same hues.
  Pixels whose DoLP is too low for the angle to mean anything are neutral grey.
* DoLP, DoCP: a sequential map from 0 to a stated maximum (``auto``: the data's
  99.5th percentile rounded up to 1, 2, 2.5 or 5 x 10^k).
* S1/S0, S2/S0, S3/S0: a diverging map (red positive, blue negative, white 0;
  ``polanalyser.plotMueller`` defaults to the reverse, red negative), with one
  symmetric scale shared by the three by default, so they compare by eye.

Unusable pixels (:mod:`mitsuba_pbrdf.stokes.quality`) are painted in a colour
that the panel's map never produces (:data:`MARKERS`), named in its legend.
"""

from __future__ import annotations

import math
from typing import Optional, Union

import numpy as np

__all__ = ["MARKERS", "MASKED_GREY", "nice_ceiling", "auto_limit", "resolve_limit", "aolp_rgb",
           "aolp_colormap", "colour_image", "paint"]

#: Marker colour of unusable pixels, by panel, with its name for the legend.
MARKERS = {
    "intensity": ((1.0, 0.0, 1.0), "magenta"),
    "dolp": ((1.0, 0.0, 0.0), "red"),
    "docp": ((1.0, 0.0, 0.0), "red"),
    "aolp": ((0.0, 0.0, 0.0), "black"),
    "hsv": ((1.0, 1.0, 1.0), "white"),
    "stokes": ((0.0, 0.85, 0.0), "green"),
}
#: Colour of AoLP pixels whose DoLP is below the threshold.
MASKED_GREY = (0.55, 0.55, 0.55)

_STEPS = (1.0, 2.0, 2.5, 5.0, 10.0)


def nice_ceiling(x: float) -> float:
    """The smallest of 1, 2, 2.5, 5 x 10^k that is >= *x* (> 0)."""
    k = math.floor(math.log10(x))
    for step in _STEPS:
        value = step * 10.0 ** k
        if value >= x * (1 - 1e-9):
            return float(f"{value:.6g}")
    return 10.0 ** (k + 1)


def auto_limit(values: np.ndarray, percentile: float = 99.5, floor: float = 1e-3,
               cap: float = 1.0) -> float:
    """A scale's top for *values* (finite ones): the *percentile*-th
    percentile rounded up by :func:`nice_ceiling`, within [floor, cap]."""
    values = np.asarray(values, dtype=np.float64)
    values = values[np.isfinite(values)]
    top = float(np.percentile(values, percentile)) if values.size else 0.0
    return min(cap, nice_ceiling(max(top, floor)))


def resolve_limit(limit: Union[float, str, None], values: np.ndarray, **auto) -> tuple:
    """``(top, automatic)``: *limit* itself when it is a number, else
    (``"auto"`` or None) :func:`auto_limit` of *values*."""
    if limit is None or (isinstance(limit, str) and limit.strip().lower() == "auto"):
        return auto_limit(values, **auto), True
    limit = float(limit)
    if not (math.isfinite(limit) and limit > 0):
        raise ValueError(f"a scale's top must be a finite number > 0 or 'auto', got {limit}")
    return limit, False


def aolp_rgb(angle_deg: np.ndarray) -> np.ndarray:
    """RGB in [0, 1] of AoLP angles in degrees: hue = (angle mod 180°) / 180°,
    full saturation and value (shape (..., 3))."""
    from matplotlib.colors import hsv_to_rgb

    hue = (np.asarray(angle_deg, dtype=np.float64) % 180.0) / 180.0
    ones = np.ones_like(hue)
    return hsv_to_rgb(np.stack([hue, ones, ones], axis=-1))


def aolp_colormap():
    """The AoLP hue wheel as a colour map over [-90°, 90°], for colour bars."""
    from matplotlib.colors import ListedColormap

    return ListedColormap(aolp_rgb(np.linspace(-90.0, 90.0, 256)), name="aolp_hue")


def colour_image(values: np.ndarray, cmap, vmin: float, vmax: float) -> np.ndarray:
    """RGB (..., 3) of *values* through the matplotlib colour map *cmap*
    (a name or a Colormap), clipped to [vmin, vmax]; non-finite values take
    the colour of *vmin* (callers paint them with :func:`paint`)."""
    import matplotlib

    cmap = matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap
    values = np.nan_to_num(np.asarray(values, dtype=np.float64), nan=vmin, posinf=vmax,
                           neginf=vmin)
    t = np.clip((values - vmin) / (vmax - vmin), 0.0, 1.0)
    return cmap(t)[..., :3]


def paint(rgb: np.ndarray, mask: Optional[np.ndarray], colour) -> np.ndarray:
    """*rgb* with the pixels of *mask* set to *colour* (in place; returns it)."""
    if mask is not None and mask.any():
        rgb[mask] = colour
    return rgb
