"""Figures of the polarization-camera images (docs/polarization-camera.md):

1. polanalyser round trip: our mosaic (mono, colour) of a render, demosaiced
   by polanalyser (bilinear), its S0/S1/S2, DoLP and AoLP against ours, in the
   interior (the border that OpenCV's Bayer filter recomputes left out);
2. the frame convention: polcam's I_θ of a Stokes render against renders
   through Mitsuba's polarizer turned to θ (scenes/gallery/polarizer.xml);
3. the time of ``polcam_outputs`` on a 512 x 512 RGB Stokes image;
4. narrow-band renders (632.8 nm line, 632.8:20 band) against the reference
   evaluator, with the renders and tolerance of tests/rendering/test_narrowband.py.

    python benchmarks/polcam_figures.py [--spp 16] [--report benchmarks/polcam.md]

prints the figures as Markdown; ``--report`` also writes them, under a title
with the command, to a report the docs quote (docs/polarization-camera.md).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from mitsuba_pbrdf.visualization.gallery import _Settings, render_polarizer_images  # noqa: E402
from mitsuba_pbrdf.camera.polcam import (ANGLES, SensorModel, colour_mosaic,  # noqa: E402
                                         mono_mosaic, polarizer_images, polcam_outputs)
from mitsuba_pbrdf.stokes.image import StokesImage, aolp, dolp  # noqa: E402


def round_trip(image: StokesImage):
    import polanalyser as pa

    rows = []
    for sensor in ("mono", "colour"):
        if sensor == "mono":
            raw, border = mono_mosaic(image, band="G"), 2
            images = pa.demosaicing(raw.astype(np.float64), pa.COLOR_PolarMono)
            ours = image.band("G")[..., None, :]
            theirs = pa.calcLinearStokes(np.stack(images), np.radians(ANGLES))[..., None, :]
        else:
            raw, border = colour_mosaic(image), 4
            images = pa.demosaicing(raw.astype(np.float64), pa.COLOR_PolarRGB)
            ours = np.moveaxis(image.stokes, 2, 3)
            theirs = pa.calcLinearStokes(np.stack(images), np.radians(ANGLES))[..., ::-1, :]
        inner = (slice(border, -border), slice(border, -border))
        ours, theirs = ours[inner].astype(np.float64), theirs[inner]
        scale = ours[..., 0].max()
        s_err = np.abs(theirs[..., :3] - ours[..., :3]) / scale
        bright = ours[..., 0] > 0.05 * scale
        d_err = np.abs(pa.cvtStokesToDoLP(theirs) - dolp(ours, axis=-1))[bright]
        polarized = bright & (dolp(ours, axis=-1) > 0.1)
        a = (np.degrees(pa.cvtStokesToAoLP(theirs)) - np.degrees(aolp(ours, axis=-1)) + 90) % 180
        a_err = np.abs(a - 90)[polarized]
        rows.append((sensor, s_err.max(), np.sqrt(np.mean(s_err ** 2)), np.median(d_err),
                     np.percentile(d_err, 95), np.median(a_err), np.percentile(a_err, 95)))
    print("| sensor | S max err / max S0 | S RMS err / max S0 | DoLP err median | DoLP err p95 "
          "| AoLP err median (deg) | AoLP err p95 (deg) |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]:.3g} | {r[2]:.3g} | {r[3]:.3g} | {r[4]:.3g} | {r[5]:.3g} "
              f"| {r[6]:.3g} |")


def linear_image(h=180, w=240, seed=0) -> StokesImage:
    """S0, S1, S2 linear in the pixel position (bilinear demosaicing is exact
    on it: what remains is polanalyser's 16-bit quantization)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w] / max(h, w)
    c = rng.uniform(-0.3, 0.3, (3, 3, 3))
    s = [c[i, 0] + c[i, 1] * y[..., None] + c[i, 2] * x[..., None] for i in range(3)]
    stokes = np.stack([2.0 + s[0], s[1], s[2], np.zeros_like(s[0])], axis=2)
    return StokesImage(stokes, ["R", "G", "B"])


def narrowband():
    sys.path.insert(0, str(ROOT / "tests"))
    import test_narrowband as t

    from mitsuba_pbrdf import use_variant
    from mitsuba_pbrdf.rendering import render_scene
    from mitsuba_pbrdf.rendering.narrowband import parse_wavelength

    use_variant(t.VARIANT)

    def render(wavelength, seed):
        return render_scene(t.SCENE, spp=t.SPP, seed=seed, params=t.params(), passes=1,
                            variant=t.VARIANT, wavelength=wavelength).stokes[..., 0]

    print("\n## Narrow-band renders against the reference (scenes/analytic_plane.xml)\n")
    for wavelength in ("632.8", "632.8:20"):
        band = parse_wavelength(wavelength)
        passes = np.stack([render(wavelength, 11 + i) for i in range(t.PASSES)])
        mean = passes.mean(axis=0).astype(np.float64)
        low, high = band.limits
        lams = [band.centre] if band.width == 0 else list(
            low + (np.arange(21) + 0.5) * (high - low) / 21)
        expected = t.reference_image(lams)
        s0 = expected[..., :1]
        stderr = passes[..., 0].std(axis=0, ddof=1) / np.sqrt(t.PASSES) / mean[..., 0]
        bound = (5 * float(np.sqrt(np.mean(stderr ** 2))) + 2e-3) * s0
        error = np.abs(mean - expected)
        p_mean = np.hypot(mean[..., 1], mean[..., 2]) / mean[..., 0]
        p_ref = np.hypot(expected[..., 1], expected[..., 2]) / expected[..., 0]
        print(f"{wavelength}: image-mean S0 render / reference - 1 = "
              f"{mean[..., 0].mean() / expected[..., 0].mean() - 1:+.2e}; largest error / "
              f"tolerance {(error / bound).max():.2f}; DoLP within {np.abs(p_mean - p_ref).max():.1e}")
        if band.width == 0:
            other = render("600", 11)
            print(f"  600 nm render against the 632.8 nm reference: largest error / tolerance "
                  f"{(np.abs(other - expected) / bound).max():.2f}, image-mean S0 "
                  f"{other[..., 0].mean() / expected[..., 0].mean() - 1:+.2e}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--scale", type=float, default=1.0, help="of the 240 x 180 renders")
    parser.add_argument("--report", default=None, metavar="FILE.md",
                        help="also write the figures to this Markdown report")
    args = parser.parse_args(argv)
    if args.report is None:
        return figures(args)
    import contextlib
    import io

    from mitsuba_pbrdf.outputs import atomic_path

    command = "python benchmarks/polcam_figures.py " + " ".join(argv or sys.argv[1:])
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        status = figures(args)
    body = (f"# Polarization-camera figures\n\n`{command.strip()}` (this file), "
            "variant `llvm_ad_spectral_polarized`, on this project's 2-core machine.\n\n"
            + text.getvalue())
    print(body)
    with atomic_path(args.report) as tmp:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(body)
    return status


def figures(args) -> int:
    """Print every figure (Markdown)."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        settings = _Settings(scenes=ROOT / "scenes" / "gallery", out=Path(tmp), exr_dir=None,
                             spp=args.spp, scale=args.scale,
                             variant="llvm_ad_spectral_polarized", progress=False)
        filtered, clear = render_polarizer_images(settings)
    print(f"## polanalyser round trip (polarizer.xml unfiltered, {clear.width}x{clear.height}, "
          f"{args.spp} spp)\n")
    round_trip(clear)
    print("\n## polanalyser round trip, Stokes image linear in the pixel position (240x180)\n")
    round_trip(linear_image())

    ours = polarizer_images(clear)
    scale = float(clear.s0.max())
    h, w = clear.height, clear.width
    centre = (slice(h // 2 - 2, h // 2 + 2), slice(w // 2 - 2, w // 2 + 2))
    print("\n## polcam I_θ against renders through Mitsuba's polarizer (same seed)\n")
    print("| θ (deg) | max error / max S0 | centre 4x4 max error / max S0 |")
    print("|---|---|---|")
    for a in ANGLES:
        err = np.abs(ours[a] - filtered[a].s0)
        print(f"| {a} | {err.max() / scale:.2g} | {err[centre].max() / scale:.2g} |")

    rng = np.random.default_rng(0)
    big = StokesImage(rng.uniform(0, 1, (512, 512, 4, 3)).astype(np.float32), ["R", "G", "B"])
    model = SensorModel(full_well=10500, read_noise=2.5, bits=12, seed=1)
    for sensor in ("mono", "colour"):
        for m in (None, model):
            times = []
            for _ in range(5):
                t = time.perf_counter()
                polcam_outputs(big, sensor=sensor, model=m)
                times.append(time.perf_counter() - t)
            print(f"\npolcam_outputs 512x512 RGB, {sensor}, sensor model "
                  f"{'on' if m else 'off'}: {1e3 * min(times):.0f} ms (best of 5)")
    narrowband()
    return 0


if __name__ == "__main__":
    sys.exit(main())
