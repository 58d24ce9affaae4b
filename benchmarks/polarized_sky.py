"""Render time of a scene lit by ``polarized_sky`` against the same scene lit
by Mitsuba's ``sunsky`` at the same sun (goal: ratio <= 1.2;
docs/polarized-light.md quotes the figures).

    python benchmarks/polarized_sky.py                  # 256 x 192, 32 spp, 7 pairs
    python benchmarks/polarized_sky.py --reps 3 --spp 8 --res 128
    python benchmarks/polarized_sky.py --report benchmarks/polarized_sky.md

Scene (``llvm_ad_spectral_polarized``, ``stokes`` around ``path``, max depth
4): a copper ``pbrdf`` sphere on a rough aluminium ``roughconductor`` ground,
seen with the sky behind, so that both the sky seen directly (``eval``) and
its sampling (``sample_direction``, ``pdf_direction``) are exercised. Models
``rayleigh`` and ``berry``. Each pair is compiled first, then rendered
``--reps`` times in alternation (A B A B ...); printed are the medians of the
CPU seconds (all of this process's threads) of each side and the median of
the per-pair ratios.
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import benchmark  # noqa: E402

SUN = [0.55, 0.45, 0.70]


def scene(mi, sky, res):
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "stokes", "inner": {"type": "path", "max_depth": 4}},
        "sensor": {"type": "perspective", "fov": 45,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, -4, 1.5],
                                                              target=[0, 0, 0.7], up=[0, 0, 1]),
                   "film": {"type": "hdrfilm", "width": res, "height": res * 3 // 4,
                            "pixel_format": "rgb"},
                   "sampler": {"type": "independent"}},
        "sky": sky,
        "sphere": {"type": "sphere", "center": [0, 0, 0.8], "radius": 0.8,
                   "bsdf": {"type": "pbrdf", "material": "Cu", "sigma": 0.05, "kdd": 0.05}},
        "ground": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(20),
                   "bsdf": {"type": "roughconductor", "material": "Al", "alpha": 0.2}},
    })


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--res", type=int, default=256)
    parser.add_argument("--spp", type=int, default=32)
    parser.add_argument("--reps", type=int, default=7)
    parser.add_argument("--report", help="also write the table to this Markdown file")
    args = parser.parse_args(argv)

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")
    import mitsuba as mi

    sunsky = scene(mi, {"type": "sunsky", "sun_direction": SUN}, args.res)
    setting = (f"{args.res} x {args.res * 3 // 4}, {args.spp} spp, {args.reps} pairs, "
               f"CPU seconds (medians)")
    print(setting)
    rows = []
    for model in ("rayleigh", "berry"):
        polarized = scene(mi, {"type": "polarized_sky", "sun_direction": SUN, "model": model},
                          args.res)
        for s in (polarized, sunsky):          # compile both first
            benchmark.timed_render(mi, s, args.spp)
        ta, tb = [], []
        for rep in range(args.reps):
            ta.append(benchmark.cpu_render_time(mi, polarized, args.spp, seed=rep))
            tb.append(benchmark.cpu_render_time(mi, sunsky, args.spp, seed=rep))
        row = (model, np.median(ta), np.median(tb), np.median(np.divide(ta, tb)))
        rows.append(row)
        print(f"polarized_sky ({model}): {row[1]:.3f} s, sunsky: {row[2]:.3f} s, "
              f"ratio {row[3]:.3f}")
    if args.report:
        with open(args.report, "w") as f:
            f.write("# polarized_sky against sunsky: render time\n\n"
                    "Written by `python benchmarks/polarized_sky.py --report "
                    "benchmarks/polarized_sky.md` (the scene is in its docstring; goal: "
                    "ratio <= 1.2).\n\n"
                    f"{setting}, `llvm_ad_spectral_polarized`, {os.cpu_count()} cores.\n\n"
                    "| sky | polarized_sky (s) | sunsky (s) | ratio (median of pairs) |\n"
                    "|---|---|---|---|\n")
            for model, a, b, r in rows:
                f.write(f"| {model} | {a:.3f} | {b:.3f} | {r:.3f} |\n")


if __name__ == "__main__":
    main()
