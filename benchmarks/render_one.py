"""One render of a benchmark scene, for timing whole processes against each other.

    python benchmarks/render_one.py pbrdf            # specular-only pbrdf (Cu, Smith)
    python benchmarks/render_one.py roughconductor   # Mitsuba's built-in equivalent
    python benchmarks/render_one.py pbrdf3           # all three lobes

Options: ``--scene plane_small_light|sphere_environment`` (benchmark.py's
scenes), ``--res`` (width in pixels), ``--spp``, ``--variant``. It renders
once to compile (kernels are cached on disk across processes), then
``--reps`` times, and prints the CPU seconds of each timed render. Pair two
of them with any process timer (``/usr/bin/time``, hyperfine) in alternation,
or compare the printed CPU times: the render-time ratio of pbrdf against
roughconductor at equal spp is the quantity ``docs/performance.md``
quotes.
"""

import argparse
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import benchmark  # noqa: E402

BSDFS = {
    "roughconductor": {"type": "roughconductor", "material": "Cu", "alpha": benchmark.ALPHA},
    "pbrdf": {"type": "pbrdf", "material": "Cu", "sigma": benchmark.ALPHA / math.sqrt(2),
              "shadowing": "smith"},
    "pbrdf3": {"type": "pbrdf", "material": "Cu", "sigma": benchmark.ALPHA / math.sqrt(2),
               "shadowing": "smith", "kdd": 0.2, "sigma_dd": 0.5, "kid": 0.05},
}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("bsdf", choices=sorted(BSDFS))
    p.add_argument("--scene", default="sphere_environment",
                   choices=("plane_small_light", "sphere_environment"))
    p.add_argument("--res", type=int, default=256)
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--reps", type=int, default=1)
    p.add_argument("--variant", default=benchmark.POLARIZED)
    args = p.parse_args(argv)
    mi = benchmark.set_variant(args.variant)
    scene = mi.load_dict(benchmark.scene_dict(mi, args.scene, BSDFS[args.bsdf], args.res))
    benchmark.timed_render(mi, scene, args.spp)  # compile (or load kernels from the cache)
    for rep in range(args.reps):
        print(f"{args.bsdf} {args.scene}: {benchmark.cpu_render_time(mi, scene, args.spp, rep):.3f} "
              "CPU s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
