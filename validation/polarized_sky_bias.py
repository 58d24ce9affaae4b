"""How much the unpolarized-sky assumption biases the DoLP and AoLP of metals
outdoors: the same scene under ``polarized_sky`` and under Mitsuba's
(unpolarized) ``sunsky`` of the same intensity.

    python validation/polarized_sky_bias.py            # 160 x 120, 128 spp
    python validation/polarized_sky_bias.py --quick    # 96 x 72, 32 spp

Writes ``validation/polarized_sky_bias.md``. Scene (``llvm_ad_spectral_polarized``,
``stokes`` around ``path``, max depth 4, +Z up): a copper and an aluminium
``pbrdf`` sphere (sigma 0.05, kdd 0.05) on a grey diffuse ground, seen from
1.6 m height, the sun 120° of azimuth from the viewing direction at three
elevations; the sky ``rayleigh`` with ``dolp_max`` 0.8. Per sphere (pixels
whose centre ray hits it, luminance Stokes vector): the median and 90th
percentile of |DoLP(polarized sky) - DoLP(unpolarized sky)| and of the AoLP
difference (pixels with DoLP > 0.05 under both), and the same statistics
between two renders of the unpolarized sky with different seeds (the Monte
Carlo noise floor). Also writes ``validation/figures/polarized_sky_gallery.png``:
per sun elevation, intensity, DoLP and AoLP under the polarized sky beside the
same under the unpolarized sky of equal intensity.
"""

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from common import pyplot, save_figure, table, use_variant, write_markdown  # noqa: E402

ELEVATIONS = (15.0, 35.0, 60.0)
SPHERES = {"Cu": [-0.55, 0.0, 0.5], "Al": [0.55, 0.0, 0.5]}
RADIUS = 0.5


def scene(mi, sky, width, height):
    from proof import polarized_light as pl

    cam = pl.camera([0, -4, 1.6], [0, 0, 0.5], [0, 0, 1], fov=32, width=width, height=height)
    cam["sampler"] = {"type": "independent"}
    shapes = {f"sphere_{m}": {"type": "sphere", "center": c, "radius": RADIUS,
                              "bsdf": {"type": "pbrdf", "material": m, "sigma": 0.05,
                                       "kdd": 0.05}} for m, c in SPHERES.items()}
    shapes["ground"] = {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(30),
                        "bsdf": {"type": "diffuse", "reflectance": 0.3}}
    return pl.scene(sky, cam, shapes, max_depth=4)


def masks(loaded):
    """{material: (H, W) bool}: pixels whose centre ray hits that sphere first."""
    from proof import polarized_light as pl

    o, d = pl.pixel_rays(loaded)
    hits = {}
    for m, c in SPHERES.items():
        oc = o - np.asarray(c)
        b = np.sum(oc * d, -1)
        disc = b * b - (np.sum(oc * oc, -1) - RADIUS ** 2)
        t = np.where(disc > 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)
        hits[m] = np.where(t > 0, t, np.inf)
    first = {m: np.isfinite(t) & np.all([t <= hits[n] for n in hits], 0) for m, t in hits.items()}
    return first


def luminance_stokes(image):
    from mitsuba_pbrdf.stokes import luminance_stokes as lum

    return lum(image).astype(np.float64)


def dolp_aolp(image):
    from mitsuba_pbrdf.stokes import aolp, dolp, luminance_stokes

    s = luminance_stokes(image).astype(np.float64)
    return dolp(s, axis=-1), np.degrees(aolp(s, axis=-1))


def differences(a, b, mask):
    (da, aa), (db, ab) = a, b
    ddolp = np.abs(da - db)[mask]
    both = mask & (da > 0.05) & (db > 0.05)
    daolp = np.abs((aa - ab + 90.0) % 180.0 - 90.0)[both]
    stats = lambda x: (float(np.median(x)), float(np.percentile(x, 90))) if x.size else (0.0, 0.0)
    return (*stats(ddolp), *stats(daolp), int(mask.sum()), int(both.sum()))


def gallery(frames):
    """Gallery-style figure: one row per sun elevation, intensity, DoLP and AoLP
    (hue, brightness by DoLP) under the polarized sky, then under the unpolarized
    sky of the same intensity; returns the path relative to validation/."""
    from mitsuba_pbrdf.visualization.colours import aolp_rgb

    plt = pyplot()
    fig, axes = plt.subplots(len(frames), 6, figsize=(13.5, 1.9 * len(frames) + 0.4))
    axes = np.atleast_2d(axes)
    titles = ("intensity", "DoLP", "AoLP (hue),\ndark where DoLP is low")
    for i, (elevation, images) in enumerate(frames):
        scale = np.percentile(images[0][0][..., 0], 99.5)      # one exposure per row
        for j, (label, (s, d, a)) in enumerate(zip(("polarized sky", "unpolarized sky"), images)):
            tone = np.clip(s[..., 0] / scale, 0, 1) ** (1 / 2.2)
            axes[i, 3 * j].imshow(tone, cmap="gray", vmin=0, vmax=1)
            im = axes[i, 3 * j + 1].imshow(d, cmap="viridis", vmin=0, vmax=0.8)
            axes[i, 3 * j + 2].imshow(aolp_rgb(a) * np.clip(d / 0.5, 0, 1)[..., None])
            for k in range(3):
                axes[i, 3 * j + k].set_title(f"{label}:\n{titles[k]}" if i == 0 else "")
        axes[i, 0].set_ylabel(f"sun {elevation:g}°")
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
        ax.grid(False)
    fig.subplots_adjust(right=0.92, wspace=0.05, hspace=0.08)
    fig.colorbar(im, cax=fig.add_axes([0.935, 0.2, 0.01, 0.6]), label="DoLP")
    return save_figure(fig, "polarized_sky_gallery")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    args = p.parse_args(argv)
    mi = use_variant()
    from proof import polarized_light as pl

    width, height, spp = (96, 72, 32) if args.quick else (160, 120, 128)
    rows, noise_rows, frames = [], [], []
    for elevation in ELEVATIONS:
        sun = pl.sun_vector(elevation, 120.0 + 90.0).tolist()   # view along +Y (azimuth 90)
        polarized = {"type": "polarized_sky", "sun_direction": sun, "dolp_max": 0.8}
        plain = {"type": "sunsky", "sun_direction": sun}
        img_p, loaded = pl.render_stokes(scene(mi, polarized, width, height), spp=spp, seed=1)
        img_u, _ = pl.render_stokes(scene(mi, plain, width, height), spp=spp, seed=1)
        img_u2, _ = pl.render_stokes(scene(mi, plain, width, height), spp=spp, seed=2)
        m = masks(loaded)
        a_p, a_u, a_u2 = dolp_aolp(img_p), dolp_aolp(img_u), dolp_aolp(img_u2)
        frames.append((elevation, [(luminance_stokes(img_p), *a_p),
                                   (luminance_stokes(img_u), *a_u)]))
        for material, mask in m.items():
            rows.append([f"{elevation:g}°", material, *differences(a_p, a_u, mask)])
            noise_rows.append([f"{elevation:g}°", material, *differences(a_u2, a_u, mask)])
    figure = gallery(frames)
    headers = ["sun elevation", "sphere", "median |ΔDoLP|", "p90 |ΔDoLP|", "median |ΔAoLP| (°)",
               "p90 |ΔAoLP| (°)", "pixels", "pixels with DoLP > 0.05"]
    text = f"""# The unpolarized-sky assumption on metals

`python validation/polarized_sky_bias.py{' --quick' if args.quick else ''}`
(llvm_ad_spectral_polarized; {width} x {height}, {spp} spp; a copper and an aluminium `pbrdf`
sphere, sigma 0.05, kdd 0.05, on a grey diffuse ground; the sun 120° of azimuth from the viewing
direction; `polarized_sky` `rayleigh`, `dolp_max` 0.8, against `sunsky` at the same sun).

Differences of the luminance DoLP and AoLP per sphere pixel, polarized sky against unpolarized
sky:

{table(headers, rows)}

Monte Carlo noise floor (the unpolarized sky against itself, another seed):

{table(headers, noise_rows)}

Both skies are rendered with the same seed (common random numbers), so their differences
carry less noise than the floor above, which compares two seeds.

Reading: a metal reflects the sky's polarization through its Fresnel matrix, so under a real
(polarized) sky the polarization of its reflection is not the one an unpolarized sky model
predicts. The lower half of each sphere reflects the depolarizing ground, where both skies give
the same answer: hence small medians. The upper half reflects the sky, and where the reflected
direction is far from the sun (up to 90°, where the sky's DoLP is highest) the sky's
polarization either adds to the s-polarization of reflection or, crossed with it, cancels part
of it and turns the AoLP: the 90th percentiles. Wherever the rows exceed the noise floor, an
analysis that assumes an unpolarized sky (shape from polarization outdoors, in particular)
misreads the DoLP and AoLP by that much. (Recovering normals under both assumptions, the
issue's second question, is in [validation/sky_normals.md](sky_normals.md).)

![copper and aluminium spheres under the polarized and the unpolarized sky]({figure})

The figure (copper on the left, aluminium on the right): one row per sun elevation;
intensity (the luminance S0, one exposure per row, gamma 2.2), DoLP, and AoLP as hue darkened
where the DoLP is low, under `polarized_sky`, then under `sunsky` of the same intensity. The intensities are nearly the same; the DoLP and AoLP of the
upper halves of the spheres, which reflect the sky, are not.
"""
    write_markdown("polarized_sky_bias", text)


if __name__ == "__main__":
    main()
