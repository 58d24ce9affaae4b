"""Render time of ``polarized_normalmap`` / ``polarized_bumpmap`` against
Mitsuba's ``normalmap`` / ``bumpmap`` around the same nested BSDF (goal:
ratio <= 1.05; docs/normal-maps.md quotes the figures).

    python benchmarks/normalmap_speed.py                 # 256 x 192, 64 spp, 7 pairs
    python benchmarks/normalmap_speed.py --reps 3 --spp 16 --res 128

Scenes: the gallery's hammered plate (``scenes/gallery/plate.xml``: pbrdf in
the normal map, environment light, max depth 4), and benchmark.py's
``sphere_environment`` with ``roughconductor`` inside the wrapper (the plate's
normal map, or a height field made from it). Each pair is compiled first, then
rendered ``--reps`` times in alternation (A B A B ...); the figure is the
median of the per-pair ratios of CPU seconds (all of this process's threads),
with the medians of each side.
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import benchmark  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PLATE = os.path.join(ROOT, "scenes", "gallery", "plate.xml")
NORMALS = os.path.join(ROOT, "scenes", "gallery", "plate_normals.exr")


def wrapped(kind, nested):
    """A wrapper dict around ``nested``: the plate's normal map, or its x
    component as a height field (bump map)."""
    if kind.endswith("normalmap"):
        return {"type": kind, "bsdf": nested,
                "normalmap": {"type": "bitmap", "filename": NORMALS, "raw": True}}
    return {"type": kind, "bsdf": nested, "scale": 0.05,
            "height": {"type": "bitmap", "filename": NORMALS, "raw": True}}


def interleaved(mi, scene_a, scene_b, spp, reps):
    """Median CPU seconds of A, of B, and the median of the ratios A/B of
    renders taken in alternation."""
    for scene in (scene_a, scene_b):  # compile both first
        benchmark.timed_render(mi, scene, spp)
    ta, tb = [], []
    for rep in range(reps):
        ta.append(benchmark.cpu_render_time(mi, scene_a, spp, seed=rep))
        tb.append(benchmark.cpu_render_time(mi, scene_b, spp, seed=rep))
    return float(np.median(ta)), float(np.median(tb)), float(np.median(np.divide(ta, tb)))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--res", type=int, default=256, help="width in pixels (height 3/4 of it)")
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--reps", type=int, default=7)
    p.add_argument("--variant", default=benchmark.POLARIZED)
    args = p.parse_args(argv)
    mi = benchmark.set_variant(args.variant)
    size = {"width": str(args.res), "height": str(args.res * 3 // 4), "spp": str(args.spp)}

    def plate(wrapper):
        return mi.load_file(PLATE, wrapper=wrapper, **size)

    def sphere(wrapper):
        nested = {"type": "roughconductor", "material": "Cu", "alpha": benchmark.ALPHA}
        return mi.load_dict(benchmark.scene_dict(mi, "sphere_environment",
                                                 wrapped(wrapper, nested), args.res))

    print(f"{args.variant}, {args.res} px wide, {args.spp} spp, {args.reps} interleaved pairs; "
          "CPU seconds per render (medians)")
    print("| scene | ours | Mitsuba's | ours (s) | Mitsuba's (s) | ratio (median of pairs) |")
    print("|---|---|---|---|---|---|")
    for label, load, kind in (("hammered plate (pbrdf)", plate, "normalmap"),
                              ("sphere (roughconductor)", sphere, "normalmap"),
                              ("sphere (roughconductor)", sphere, "bumpmap")):
        ta, tb, ratio = interleaved(mi, load("polarized_" + kind), load(kind), args.spp,
                                    args.reps)
        print(f"| {label} | polarized_{kind} | {kind} | {ta:.3f} | {tb:.3f} | {ratio:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
