"""Saving matplotlib figures as PNG files: atomically
(:mod:`mitsuba_pbrdf.outputs`), optionally palette-quantized."""

from __future__ import annotations

import os
from typing import Optional

from ..outputs import atomic_path

__all__ = ["save_png"]


def save_png(fig, path, dpi: int = 150, colors: Optional[int] = None) -> str:
    """Save a matplotlib figure as PNG, atomically (:mod:`mitsuba_pbrdf.outputs`:
    the folder is created, a failure leaves any previous file untouched). With
    *colors* (e.g. 256) the PNG is palette-quantized with dithering: for
    pictures of noisy renders, committed to the repository, 2-3x smaller.
    Returns the path."""
    path = os.fspath(path)
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
            palette = rgb.quantize(colors=colors, method=Image.Quantize.MAXCOVERAGE)
            # dithered against that palette, so smooth colour ramps do not band
            rgb.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG).save(
                tmp, format="PNG", optimize=True)
    return path
