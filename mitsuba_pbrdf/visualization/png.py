"""Saving PNG files atomically (:mod:`mitsuba_pbrdf.outputs`): matplotlib
figures, optionally palette-quantized (:func:`save_png`), and plain pixel
arrays, one pixel per value (:func:`write_pixels_png`)."""

from __future__ import annotations

import os
from typing import Optional

import numpy as np

from ..outputs import atomic_path, escape_text

__all__ = ["save_png", "write_pixels_png"]


def _escape_texts(fig):
    """Every text of *fig* through :func:`mitsuba_pbrdf.outputs.escape_text`:
    titles hold file names, and one with bytes that are not UTF-8 (lone
    surrogates) makes matplotlib's font code raise."""
    from matplotlib.text import Text

    for artist in fig.findobj(Text):
        text = artist.get_text()
        if escape_text(text, "text") != text:
            artist.set_text(escape_text(text, "text"))


def save_png(fig, path, dpi: int = 150, colors: Optional[int] = None) -> str:
    """Save a matplotlib figure as PNG, atomically (:mod:`mitsuba_pbrdf.outputs`:
    the folder is created, a failure leaves any previous file untouched). With
    *colors* (e.g. 256) the PNG is palette-quantized with dithering (flat
    colours kept exact, :func:`_palette`): for pictures of noisy renders,
    committed to the repository, 2-3x smaller.
    Returns the path."""
    path = os.fspath(path)
    _escape_texts(fig)
    with atomic_path(path) as tmp:
        if colors is None:
            fig.savefig(tmp, dpi=dpi, format="png")
            return path
        import io

        from PIL import Image

        buffer = io.BytesIO()
        fig.savefig(buffer, dpi=dpi, format="png")
        buffer.seek(0)
        with Image.open(buffer) as picture:
            rgb = picture.convert("RGB")
            # dithered against the palette, so smooth colour ramps do not band
            rgb.quantize(palette=_palette(rgb, colors), dither=Image.Dither.FLOYDSTEINBERG).save(
                tmp, format="PNG", optimize=True)
    return path


def _palette(rgb, colors: int):
    """A palette image for *rgb*: its flat colours exactly (those covering at
    least 0.1 % of the picture: backgrounds, masks, markers; at most a quarter
    of the palette), the rest from Pillow's quantizer. Without the exact flat
    colours, dithering sprinkles a flat area with the nearest palette entries,
    which in a picture holding every hue (the AoLP wheel) can be far off."""
    import numpy as np
    from PIL import Image

    pixels = np.asarray(rgb, dtype=np.uint32).reshape(-1, 3)
    packed = (pixels[:, 0] << 16) | (pixels[:, 1] << 8) | pixels[:, 2]
    values, counts = np.unique(packed, return_counts=True)
    order = np.argsort(counts)[::-1][: colors // 4]
    flat = values[order][counts[order] >= 1e-3 * len(packed)]
    flat_rgb = np.stack([flat >> 16, (flat >> 8) & 255, flat & 255], axis=-1).astype(np.uint8)
    rest = colors - len(flat)
    quantized = rgb.quantize(colors=rest, method=Image.Quantize.MAXCOVERAGE).getpalette()
    palette = flat_rgb.ravel().tolist() + quantized[: 3 * rest]
    image = Image.new("P", (1, 1))
    image.putpalette(palette + [0] * (3 * colors - len(palette)))
    return image


def write_pixels_png(path, pixels: np.ndarray) -> str:
    """Write pixels as an 8-bit PNG, one pixel per value (no figure, no
    resampling), atomically: (H, W) greyscale or (H, W, 3) RGB, uint8 as they
    are, floats in [0, 1] scaled to 0-255. Returns the path."""
    from PIL import Image

    pixels = np.asarray(pixels)
    if pixels.dtype != np.uint8:
        pixels = np.rint(np.clip(np.nan_to_num(pixels.astype(np.float64)), 0, 1) * 255)
    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    path = os.fspath(path)
    with atomic_path(path) as tmp:
        Image.fromarray(pixels, mode="L" if pixels.ndim == 2 else "RGB").save(tmp, format="PNG")
    return path
