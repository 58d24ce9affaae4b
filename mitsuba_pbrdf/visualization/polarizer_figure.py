"""The gallery's polarizer picture (``polarizer.png``, ``pbrdf gallery``):
renders through an ideal linear polarizer at each of the camera's angles
(:data:`~mitsuba_pbrdf.camera.polcam.ANGLES`) beside the Stokes render
without a filter, and the check of Malus's law between them."""

from __future__ import annotations

from typing import Dict, Optional

import numpy as np

from ..camera.polcam import ANGLES, stokes_from_intensities
from ..stokes.image import StokesImage
from .panels import plot_aolp, plot_dolp, plot_intensity
from .tonemap import linear_rgb, shared_exposure, tonemap

__all__ = ["polarizer_check", "polarizer_figure"]


def polarizer_check(filtered: Dict[int, StokesImage], clear: StokesImage) -> dict:
    """Malus's law on the renders: for each relation, the largest per-pixel
    error divided by the largest S0 of the clear (unfiltered) render.

    ``sum_0_90``: I0 + I90 vs S0; ``sum_45_135``: I45 + I135 vs S0;
    ``s1``: I0 − I90 vs S1; ``s2``: I45 − I135 vs S2 (all bands)."""
    i = {a: filtered[a].s0.astype(np.float64) for a in ANGLES}
    s = clear.stokes.astype(np.float64)
    scale = float(np.abs(s[:, :, 0]).max()) or 1.0
    return {
        "sum_0_90": float(np.abs(i[0] + i[90] - s[:, :, 0]).max() / scale),
        "sum_45_135": float(np.abs(i[45] + i[135] - s[:, :, 0]).max() / scale),
        "s1": float(np.abs(i[0] - i[90] - s[:, :, 1]).max() / scale),
        "s2": float(np.abs(i[45] - i[135] - s[:, :, 2]).max() / scale),
    }


def polarizer_figure(filtered: Dict[int, StokesImage], clear: StokesImage,
                     title: Optional[str] = None, dolp_limit: float = 0.5,
                     min_dolp: float = 0.02):
    """The polarizer picture: row 1, the four filtered intensities (one
    exposure); row 2, the unfiltered intensity and the DoLP and AoLP a
    polarization camera computes from the four, next to the DoLP of the
    Stokes render."""
    import matplotlib.cm
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    exposure = 2.0 * shared_exposure([clear])  # the filtered images are ~S0/2
    camera = StokesImage(
        stokes_from_intensities({a: filtered[a].s0 for a in ANGLES}, axis=-2),
        bands=filtered[0].bands)
    aspect = clear.height / clear.width
    fig = Figure(figsize=(4 * 2.9 + 0.6, 2 * 2.9 * aspect + 1.1), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 4)

    for ax, a in zip(axes[0], ANGLES):
        ax.imshow(tonemap(linear_rgb(filtered[a]), exposure)[0], interpolation="nearest")
        ax.set_title(f"through a polarizer at {a}°", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
        # an invisible colour bar, so that the columns line up with the row below
        fig.colorbar(matplotlib.cm.ScalarMappable(), ax=ax, fraction=0.046,
                     pad=0.03).ax.set_visible(False)
    plot_intensity(axes[1, 0], clear, exposure=exposure / 2.0,
                   title=f"no filter (S0, {np.log2(exposure / 2.0):+.1f} EV)")
    fig.colorbar(matplotlib.cm.ScalarMappable(), ax=axes[1, 0], fraction=0.046,
                 pad=0.03).ax.set_visible(False)
    plot_dolp(axes[1, 1], camera, dolp_limit=dolp_limit)
    axes[1, 1].set_title("DoLP from the four pictures", fontsize=9)
    plot_aolp(axes[1, 2], camera, min_dolp=min_dolp)
    axes[1, 2].set_title("AoLP from the four pictures", fontsize=9)
    plot_dolp(axes[1, 3], clear, dolp_limit=dolp_limit)
    axes[1, 3].set_title("DoLP of the Stokes render (no filter)", fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig
