"""The polarization-camera picture (README, ``pbrdf gallery --only polcam``):
the four polarizer images of a Stokes image with one exposure, the colour and
monochrome sensors' raw frames, and close-ups of both mosaics with each
pixel's polarizer angle (and colour filter) written on it
(:mod:`mitsuba_pbrdf.camera.polcam`)."""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

from ..camera.polcam import (ANGLES, colour_layout, colour_mosaic, mono_layout, mono_mosaic,
                             polarizer_images)
from ..stokes.image import StokesImage
from .tonemap import auto_exposure, linear_rgb, tonemap

__all__ = ["polcam_figure"]

_TINTS = np.array([[1.0, 0.35, 0.35], [0.45, 1.0, 0.45], [0.45, 0.6, 1.0]])


def _close_up(ax, raw, angles, corner, size, colours=None, title=""):
    """Pixels of *raw* from *corner*, exposed so that the brightest is white."""
    y, x = corner
    crop = raw[y:y + size, x:x + size]
    crop = crop / max(float(crop.max()), 1e-30)
    grey = tonemap(np.repeat(crop[..., None], 3, axis=-1), 1.0)[0]
    if colours is not None:
        grey = grey * _TINTS[colours[y:y + size, x:x + size]]
    ax.imshow(grey, interpolation="nearest")
    for r in range(size):
        for c in range(size):
            ax.text(c, r, str(angles[y + r, x + c]), ha="center", va="center", fontsize=5.5,
                    color="black" if grey[r, c].mean() > 0.45 else "white")
    ax.set_title(title, fontsize=8)


def _most_polarized_block(image: StokesImage, size: int):
    """Top-left pixel (multiples of 4) of the size x size block with the most
    linearly polarized light (the mosaic's pattern shows best there)."""
    from ..stokes.image import luminance_stokes

    s = luminance_stokes(image)
    linear = np.hypot(s[..., 1], s[..., 2])
    best, corner = -1.0, (0, 0)
    for y in range(0, image.height - size + 1, 4):
        for x in range(0, image.width - size + 1, 4):
            value = float(linear[y:y + size, x:x + size].mean())
            if value > best:
                best, corner = value, (y, x)
    return corner


def polcam_figure(image: StokesImage, title: Optional[str] = None,
                  close_up: Tuple[int, int] = None, size: int = 8):
    """A matplotlib figure (2 x 4 panels); *close_up* is the (row, column) of
    the close-ups' top-left pixel (default: the image centre, even)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    images = polarizer_images(image)
    exposure = 2.0 * auto_exposure(linear_rgb(image))  # a polarizer passes about half
    h, w = image.height, image.width
    fig = Figure(figsize=(10.0, 2 * 2.4 * h / w + 0.9), dpi=100)
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 4)
    for ax, a in zip(axes[0], ANGLES):
        ax.imshow(tonemap(images[a], exposure)[0])
        ax.set_title(f"I{a}: polarizer at {a}°", fontsize=9)
    colour, mono = colour_mosaic(image), mono_mosaic(image)
    grey = lambda raw: tonemap(np.repeat(raw[..., None], 3, axis=-1), exposure)[0]  # noqa: E731
    axes[1, 0].imshow(grey(mono), interpolation="nearest")
    axes[1, 0].set_title("mono sensor frame (IMX250MZR)", fontsize=8)
    axes[1, 2].imshow(grey(colour), interpolation="nearest")
    axes[1, 2].set_title("colour sensor frame (IMX250MYR)", fontsize=8)
    corner = close_up or _most_polarized_block(image, size)
    _close_up(axes[1, 1], mono, mono_layout(h, w), corner, size,
              title=f"mono, {size}x{size} pixels: angles")
    angles, filters = colour_layout(h, w)
    _close_up(axes[1, 3], colour, angles, corner, size, filters,
              title=f"colour, {size}x{size}: angles, filters")
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    if title:
        fig.suptitle(title, fontsize=10)
    fig.subplots_adjust(left=0.01, right=0.99, bottom=0.01, top=0.86 if title else 0.93,
                        wspace=0.04, hspace=0.15)
    return fig
