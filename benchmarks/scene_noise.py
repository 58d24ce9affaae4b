"""Monte Carlo noise of a scene's render: the relative error of the luminance S0
and the error of the DoLP at a given spp, against a high-spp reference of the
same scene. How scenes/default.xml's lighting was chosen (docs/cli.md).

    python benchmarks/scene_noise.py scenes/default.xml
    git show 1d2f22e:scenes/default.xml > /tmp/old_default.xml   # small bright soft boxes
    python benchmarks/scene_noise.py /tmp/old_default.xml

Prints, averaged over --seeds renders: the RMS and the largest per-pixel
relative error of S0 (S0 below 1e-3 counts as 1e-3), the share of pixels off
by more than 50 % (fireflies), the RMS error of the DoLP where S0 > 0.05, and
the render time. The reference has --ref-spp samples (its own error is
sqrt(spp / ref_spp) of the figures, 25 % at the defaults: ratios between
scenes are what to read).
"""

import argparse
import time

import numpy as np

from mitsuba_pbrdf.rendering import render_scene_timed
from mitsuba_pbrdf.stokes.image import dolp, luminance_stokes


def noise(scene, spp=64, ref_spp=1024, width=160, height=120, seeds=2):
    """The figures of the module docstring, as a dict."""
    size = {"width": width, "height": height}
    reference, _ = render_scene_timed(scene, spp=ref_spp, params=size, seed=100)
    ref = luminance_stokes(reference).astype(np.float64)
    s0, ref_dolp = ref[..., 0], dolp(ref, axis=-1)
    rows = []
    for seed in range(1, seeds + 1):
        start = time.perf_counter()
        image, timings = render_scene_timed(scene, spp=spp, params=size, seed=seed, passes=1)
        seconds = time.perf_counter() - start
        lum = luminance_stokes(image).astype(np.float64)
        rel = (lum[..., 0] - s0) / np.maximum(s0, 1e-3)
        d = dolp(lum, axis=-1) - ref_dolp
        rows.append((np.sqrt(np.mean(rel ** 2)), np.abs(rel).max(), np.mean(np.abs(rel) > 0.5),
                     np.sqrt(np.mean(d[s0 > 0.05] ** 2)), timings.kernel_run, seconds))
    keys = ("s0_rel_rms", "s0_rel_max", "firefly_share", "dolp_rms", "kernel_s", "render_s")
    return dict(zip(keys, np.mean(rows, axis=0)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene")
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--ref-spp", type=int, default=1024)
    parser.add_argument("--width", type=int, default=160)
    parser.add_argument("--height", type=int, default=120)
    parser.add_argument("--seeds", type=int, default=2)
    args = parser.parse_args(argv)
    r = noise(args.scene, args.spp, args.ref_spp, args.width, args.height, args.seeds)
    print(f"{args.scene} at {args.width}x{args.height}, {args.spp} spp (reference "
          f"{args.ref_spp} spp): S0 relative error RMS {r['s0_rel_rms']:.3f}, largest "
          f"{r['s0_rel_max']:.2f}, pixels off by > 50 % {100 * r['firefly_share']:.2f} %; "
          f"DoLP RMS error {r['dolp_rms']:.4f}; kernels {r['kernel_s']:.1f} s, "
          f"render {r['render_s']:.1f} s")


if __name__ == "__main__":
    main()
