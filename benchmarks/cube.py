"""Stokes cubes (``pbrdf render --bands``, docs/spectral-cube.md): validation
figures and cost against narrow-band renders.

1. Validation: a 4-band cube over 600-680 nm of scenes/analytic_plane.xml with
   the steep index of tests/rendering/test_narrowband.py, against the float64 reference
   averaged over each band (largest error / tolerance, tolerance as in
   tests/rendering/test_cube.py), the neighbouring bands' references (which must fail),
   and per-band ``--wavelength c:20`` renders.
2. Cost: the cube of B bands in one render against B narrow-band renders
   (``render_scene(..., wavelength="c:W")`` one after the other in one
   process: B scene loads, B sets of kernels), interleaved rounds with new
   seeds, medians. The narrow renders take S spp and the cube S B / 4, so each
   band gets S path samples in both; the noise of each band is measured (the
   relative standard deviation of a pixel over the rounds, pooled over pixels
   and bands) and the cube's time is also given scaled to the narrow renders'
   noise (time x variance ratio: Monte Carlo time to a given noise goes as
   1/variance). With ``--commands`` also whole commands (``pbrdf render
   --bands`` once against B ``pbrdf render --wavelength``; each a new Python
   process: import, load, JIT, render, write).

    python benchmarks/cube.py [--rounds 5] [--commands] [--report benchmarks/cube.md]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from mitsuba_pbrdf import use_variant  # noqa: E402
from mitsuba_pbrdf.rendering import render_scene  # noqa: E402
from mitsuba_pbrdf.rendering.bands import parse_bands  # noqa: E402

VARIANT = "llvm_ad_spectral_polarized"
SCENE = str(ROOT / "scenes" / "analytic_plane.xml")
SPHERE = str(ROOT / "scenes" / "gallery" / "sphere.xml")


def validation(lines):
    from test_narrowband import params, reference_image

    bands = parse_bands("600:680:20")
    spp, runs = 256, 4
    stacks = np.stack([render_scene(SCENE, spp=spp, seed=11 + 100 * i, params=params(),
                                    passes=2, variant=VARIANT, bands=bands).stokes
                       for i in range(runs)]).astype(np.float64)
    mean = stacks.mean(axis=0)
    stderr = stacks[:, :, :, 0].std(axis=0, ddof=1) / np.sqrt(runs)
    pooled = np.sqrt(np.mean((stderr / mean[:, :, 0]) ** 2, axis=(0, 1)))
    refs = [reference_image(list(lo + (np.arange(5) + 0.5) * (hi - lo) / 5))
            for lo, hi in bands.edges]
    lines += ["## Validation: cube against the float64 reference", "",
              f"scenes/analytic_plane.xml, 32x24, index n 0.3 -> 1.5, k 3 -> 6 over 600-670 nm; "
              f"cube `600:680:20`, {spp} spp x {runs} independent renders (2 passes each); "
              "tolerance 5 pooled standard errors + 2e-3 of S0 (tests/rendering/test_cube.py).", "",
              "| band | pooled rel. std. error of S0 | largest error / tolerance | "
              "image-mean S0 cube / reference - 1 | against the lower neighbour's reference | "
              "against the upper neighbour's reference |",
              "|---|---|---|---|---|---|"]
    for b, name in enumerate(bands.names):
        s0 = refs[b][..., :1]
        bound = (5 * pooled[b] + 2e-3) * s0
        worst = float((np.abs(mean[..., b] - refs[b]) / bound).max())
        bias = float(mean[..., 0, b].mean() / refs[b][..., 0].mean() - 1)
        others = []
        for o in (b - 1, b + 1):
            if 0 <= o < len(refs):
                ob = (5 * pooled[b] + 2e-3) * refs[o][..., :1]
                others.append(f"{float((np.abs(mean[..., b] - refs[o]) / ob).max()):.2f}")
            else:
                others.append("-")
        lines.append(f"| {name} | {pooled[b]:.2e} | {worst:.2f} | {bias:+.2e} | {others[0]} | "
                     f"{others[1]} |")
    lines += ["", "A largest error / tolerance below 1 passes; against a neighbour's reference "
              "it must exceed 1 (the test tells the bands apart).", ""]

    narrow = {}
    for c in (630, 660):
        runs_n = np.stack([render_scene(SCENE, spp=spp, seed=11 + 100 * i, params=params(),
                                        passes=1, variant=VARIANT, wavelength=f"{c}:20").stokes
                           for i in range(runs)]).astype(np.float64)[..., 0]
        narrow[c] = runs_n
    cube = np.stack([render_scene(SCENE, spp=spp, seed=7 + 100 * i, params=params(), passes=1,
                                  variant=VARIANT, bands="620:640,650:670").stokes
                     for i in range(runs)]).astype(np.float64)
    lines += ["## Validation: cube bands against `--wavelength c:20` renders", "",
              f"Same scene; cube `620:640,650:670` and narrow renders, {spp} spp x {runs} each; "
              "tolerance 5 combined standard errors + 1e-3 of S0.", "",
              "| band | largest difference / tolerance | image-mean S0 cube / narrow - 1 |",
              "|---|---|---|"]
    for b, c in enumerate((630, 660)):
        cm, nm = cube[..., b].mean(axis=0), narrow[c].mean(axis=0)
        ce = np.sqrt(np.mean((cube[..., 0, b].std(axis=0, ddof=1) / np.sqrt(runs)
                              / cm[..., 0]) ** 2))
        ne = np.sqrt(np.mean((narrow[c][..., 0].std(axis=0, ddof=1) / np.sqrt(runs)
                              / nm[..., 0]) ** 2))
        bound = (5 * np.hypot(ce, ne) + 1e-3) * nm[..., :1]
        lines.append(f"| {c}nm | {float((np.abs(cm - nm) / bound).max()):.2f} | "
                     f"{float(cm[..., 0].mean() / nm[..., 0].mean() - 1):+.2e} |")
    lines.append("")


def relative_noise(images):
    """Relative std of S0 over the rounds, pooled over pixels and bands."""
    a = np.stack(images).astype(np.float64)[:, :, :, 0, :]
    mean = a.mean(axis=0)
    ok = mean > 1e-6 * mean.max()
    return float(np.sqrt(np.mean((a.std(axis=0, ddof=1)[ok] / mean[ok]) ** 2)))


def cost(lines, scene, label, params, bands_text, narrow_spp, rounds):
    bands = parse_bands(bands_text)
    n = len(bands.edges)
    cube_spp = narrow_spp * n // 4
    cube_t, narrow_t, cube_img, narrow_img = [], [], [], []
    for r in range(rounds):
        def run_cube():
            t = time.perf_counter()
            img = render_scene(scene, spp=cube_spp, seed=r, params=params, variant=VARIANT,
                               bands=bands)
            cube_t.append(time.perf_counter() - t)
            cube_img.append(img.stokes)

        def run_narrow():
            t = time.perf_counter()
            planes = [render_scene(scene, spp=narrow_spp, seed=r, params=params,
                                   variant=VARIANT,
                                   wavelength=f"{c:g}:{w:g}").stokes[..., 0]
                      for c, w in zip(bands.centres, bands.widths)]
            narrow_t.append(time.perf_counter() - t)
            narrow_img.append(np.stack(planes, axis=-1))

        for step in ((run_cube, run_narrow) if r % 2 == 0 else (run_narrow, run_cube)):
            step()
    noise_c, noise_n = relative_noise(cube_img), relative_noise(narrow_img)
    tc, tn = statistics.median(cube_t), statistics.median(narrow_t)
    equal = tc * (noise_c / noise_n) ** 2
    lines.append(f"| {label} | {n} x {bands.widths[0]:g} nm | {cube_spp} | {tc:.2f} | "
                 f"{narrow_spp} | {tn:.2f} | {noise_c:.3g} | {noise_n:.3g} | {equal:.2f} | "
                 f"{tn / equal:.1f} |")
    return tn / equal


def commands(lines, rounds, bands_text="450:650:20", narrow_spp=16):
    bands = parse_bands(bands_text)
    n = len(bands.edges)
    base = [sys.executable, "-m", "mitsuba_pbrdf", "render", SCENE, "--variant", VARIANT,
            "--no-progress", "-D", "width=64", "-D", "height=48"]
    cube_t, narrow_t = [], []
    with tempfile.TemporaryDirectory() as tmp:
        def run(argv):
            t = time.perf_counter()
            subprocess.run(argv, check=True, cwd=ROOT, capture_output=True)
            return time.perf_counter() - t

        for r in range(rounds):
            cube = lambda: cube_t.append(run(base + ["--bands", bands_text, "--spp",  # noqa
                                                     str(narrow_spp * n // 4), "--out",
                                                     f"{tmp}/cube"]))
            narrow = lambda: narrow_t.append(sum(  # noqa: E731
                run(base + ["--wavelength", f"{c:g}:{w:g}", "--spp", str(narrow_spp),
                            "--out", f"{tmp}/n{i}"])
                for i, (c, w) in enumerate(zip(bands.centres, bands.widths))))
            for step in ((cube, narrow) if r % 2 == 0 else (narrow, cube)):
                step()
    tc, tn = statistics.median(cube_t), statistics.median(narrow_t)
    lines += ["## Whole commands", "",
              f"`pbrdf render scenes/analytic_plane.xml --bands {bands_text} --spp "
              f"{narrow_spp * n // 4}` once against {n} `pbrdf render --wavelength c:20 --spp "
              f"{narrow_spp}`, 64x48, each a new process (import, load, JIT, render, write), "
              f"{rounds} interleaved rounds, medians.", "",
              "| | seconds |", "|---|---|",
              f"| cube, one command | {tc:.1f} |", f"| {n} narrow-band commands | {tn:.1f} |",
              f"| ratio | {tn / tc:.1f} |", ""]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="small sizes (a smoke test)")
    parser.add_argument("--commands", action="store_true", help="also time whole commands")
    parser.add_argument("--no-validation", action="store_true")
    parser.add_argument("--report", default=None)
    args = parser.parse_args(argv)
    use_variant(VARIANT)
    command = "python benchmarks/cube.py " + " ".join(argv if argv is not None else sys.argv[1:])
    lines = ["# Stokes cubes: validation and cost", "",
             f"`{command}`, variant `{VARIANT}`, on this project's 2-core machine "
             "(docs/spectral-cube.md quotes it).", ""]
    if not args.no_validation and not args.quick:
        validation(lines)
    lines += ["## Cost: one cube against narrow-band renders (in one process)", "",
              f"{args.rounds} interleaved rounds (new seed each), medians of wall seconds "
              "(scene loads, kernel compiles and renders; Dr.Jit's kernel cache warm after the "
              "first round). Noise: relative standard deviation of a pixel's S0 over the "
              "rounds, pooled over pixels and bands. Equal-noise time: the cube's time x "
              "(its noise / the narrow renders' noise)^2.", "",
              "| scene | bands | cube spp | cube s | narrow spp | B narrow renders s | "
              "cube noise | narrow noise | cube s at narrow noise | speed-up |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    size = (16, 12) if args.quick else (64, 48)
    plane = dict(width=size[0], height=size[1])
    cost(lines, SCENE, f"analytic_plane {size[0]}x{size[1]} (direct)", plane, "450:650:20",
         4 if args.quick else 16, args.rounds)
    if not args.quick:
        cost(lines, SCENE, f"analytic_plane {size[0]}x{size[1]} (direct)", plane, "400:720:5",
             4, args.rounds)
        cost(lines, SPHERE, "gallery/sphere 120x90 (path, depth 6)",
             dict(width=120, height=90), "450:650:20", 16, args.rounds)
    lines.append("")
    if args.commands:
        commands(lines, max(1, min(args.rounds, 3)))
    text = "\n".join(lines) + "\n"
    print(text)
    if args.report:
        from mitsuba_pbrdf.outputs import atomic_path

        with atomic_path(args.report) as tmp:
            Path(tmp).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
