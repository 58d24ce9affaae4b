"""Render a Stokes image from your own script, save it, and measure a region.

Shows how to:

* render a Mitsuba scene file that uses ``<bsdf type="pbrdf">`` from Python
  (``mitsuba_pbrdf.rendering.render_scene``: sets the variant, registers the
  plugin, renders in passes), overriding the scene's ``<default>`` values;
* write the Stokes image to an OpenEXR file (named channels ``S0.R ... S3.B``)
  and a picture (intensity, DoLP, AoLP);
* compute the DoLP and AoLP of a rectangular region of the image.

The region's polarization is that of all the light it receives: its Stokes
vectors are summed first (Stokes vectors add; averaging angles would not), using
the luminance combination of the R, G, B bands, as a panchromatic polarimeter
would measure. The mean of the per-pixel DoLP is printed beside it: it weighs
dim and bright pixels alike, and it is not lowered by AoLP changing across the
region, so the two differ. AoLP is counter-clockwise from the image's
horizontal (``docs/conventions.md``).

Run from the repository root::

    python examples/render_stokes_image.py             # 320x240, 64 spp: ~20 s on 2 cores
    python examples/render_stokes_image.py --quick     # 80x60, 8 spp: ~10 s (CI)
    python examples/render_stokes_image.py -D material=Au --region 0.1,0.3,0.3,0.7

Writes the EXR and the PNG into ``out/examples/``, named after the scene
(``--out STEM`` writes ``STEM.exr`` and ``STEM.png``). The default region is
the chromium sphere's reflection of the back light in ``scenes/default.xml``,
seen at 55-60 degrees of incidence, hence strongly polarized (DoLP about 0.25: the
large soft box is reflected over a range of angles and the diffuse lobes dilute it).
"""

import argparse
import os

import numpy as np

from mitsuba_pbrdf.rendering import render_scene
from mitsuba_pbrdf.stokes import write_stokes_exr
from mitsuba_pbrdf.visualization.panels import save_overview_png
from mitsuba_pbrdf.stokes.image import aolp, dolp, luminance_stokes

#: x0, y0, x1, y1 as fractions of the image width and height (y downwards).
DEFAULT_REGION = "0.74,0.16,0.82,0.26"


def region_slices(text, height, width):
    """Pixel slices (rows, columns) of a region given as fractions ``x0,y0,x1,y1``."""
    x0, y0, x1, y1 = (float(v) for v in text.split(","))
    if not (0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1):
        raise SystemExit(f"--region: expected 0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1, "
                         f"got {text}")
    rows = slice(int(y0 * height), max(int(np.ceil(y1 * height)), int(y0 * height) + 1))
    cols = slice(int(x0 * width), max(int(np.ceil(x1 * width)), int(x0 * width) + 1))
    return rows, cols


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="scenes/default.xml", help="Mitsuba scene file")
    parser.add_argument("--quick", action="store_true", help="80x60 pixels, 8 spp (a smoke run)")
    parser.add_argument("--spp", type=int, default=None,
                        help="samples per pixel (default: the scene's)")
    parser.add_argument("-D", dest="define", action="append", default=[], metavar="key=value",
                        help="override a <default> of the scene (repeatable)")
    parser.add_argument("--region", default=DEFAULT_REGION, metavar="x0,y0,x1,y1",
                        help="region to measure, fractions of width and height "
                             f"(default: {DEFAULT_REGION})")
    parser.add_argument("--out", default=None, metavar="STEM",
                        help="writes STEM.exr and STEM.png (default: out/examples/<scene name>)")
    args = parser.parse_args(argv)

    params = dict(item.split("=", 1) for item in args.define)
    spp = args.spp
    if args.quick:
        params.update(width=80, height=60)
        spp = spp or 8

    # Sets the variant (CUDA if usable, else llvm_ad_spectral_polarized),
    # registers pbrdf, loads the scene with the overrides and renders it.
    image = render_scene(args.scene, spp=spp, params=params, seed=0)
    print(f"rendered {args.scene}: {image.width}x{image.height}, {image.metadata['spp']} spp, "
          f"variant {image.metadata['variant']}, bands {','.join(image.bands)}, "
          f"{float(image.metadata['time_render_s']):.2f} s")

    name = os.path.splitext(os.path.basename(args.scene))[0]
    stem = args.out or os.path.join("out", "examples", name)
    os.makedirs(os.path.dirname(os.path.abspath(stem)), exist_ok=True)
    exr = write_stokes_exr(stem + ".exr", image)
    png = save_overview_png(stem + ".png", image, panels=("intensity", "dolp", "aolp"))
    print(f"wrote {exr}")
    print(f"wrote {png}")

    # image.stokes is (H, W, 4, bands); luminance_stokes gives one Stokes vector per pixel.
    stokes = luminance_stokes(image)                                  # (H, W, 4)
    rows, cols = region_slices(args.region, image.height, image.width)
    patch = stokes[rows, cols]                                        # (h, w, 4)
    total = patch.reshape(-1, 4).sum(axis=0)                          # the region's light
    print(f"region x {cols.start}:{cols.stop}, y {rows.start}:{rows.stop} "
          f"({patch.shape[0] * patch.shape[1]} pixels)")
    print(f"DoLP of the region's light: {float(dolp(total, axis=-1)):.4f}")
    print(f"AoLP of the region's light: {np.degrees(float(aolp(total, axis=-1))):.2f} deg")
    print(f"mean per-pixel DoLP: {float(dolp(patch, axis=-1).mean()):.4f}")


if __name__ == "__main__":
    main()
