"""Recover a roughness (sigma) map and a directional-diffuse (kdd) map of a
textured metal sphere from Stokes images, with polarized path replay.

    python examples/svbrdf_recovery.py                 # S0, S1, S2 (default), ~1-2 min
    python examples/svbrdf_recovery.py --components 0  # S0 only, for comparison
    python examples/svbrdf_recovery.py --quick         # 16x16, 3 iterations (CI)

A ``pbrdf`` sphere whose ``sigma`` and ``kdd`` are single-channel bitmaps
(raw values, ``8 x 8`` texels; RGB upsampling in spectral variants assumes
reflectances in [0, 1], so the index n, k stays uniform) is seen by three
cameras under two area lights and a dim sky. Target images are rendered with
the true maps; the maps then start uniform and Adam fits their texels to the
targets through ``stokes_prb`` (``mi.render`` + ``dr.backward``: the memory of
a primal render whatever the number of texels): ``mitsuba_pbrdf.inverse.svbrdf``.
validation/svbrdf_recovery.py runs both variants and reports the error of each map.
"""

from __future__ import annotations

import argparse
import os
import sys


def main(argv=None):
    args = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args.add_argument("--components", default="012",
                      help="Stokes components in the loss, e.g. 0 or 012 (default)")
    args.add_argument("--iterations", type=int, default=60)
    args.add_argument("--quick", action="store_true", help="16x16 pixels, 3 iterations")
    args = args.parse_args(argv)
    import mitsuba_pbrdf
    from mitsuba_pbrdf.inverse.svbrdf import map_errors, recover

    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")
    settings = dict(iterations=3, size=16, spp=4, target_spp=16) if args.quick else \
        dict(iterations=args.iterations)
    result = recover(tuple(int(c) for c in args.components), **settings)
    for name, e in map_errors(result).items():
        print(f"{name}: RMS error {e['start']:.4f} (start) -> {e['recovered']:.4f}")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    sys.exit(main())
