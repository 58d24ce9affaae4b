"""``pbrdf recover-normals``: shape from polarization, a thin layer over
:func:`mitsuba_pbrdf.inverse.normals.recover_from_files`, which reads the
scene (one shape's BSDF a ``polarized_normalmap``) and one target per sensor: Stokes EXRs (``pbrdf render``) for ``--observables intensity`` or
``stokes``, raw mono mosaic EXRs (``pbrdf polcam``'s ``_mosaic.exr``, channel
``Y``) for ``polcam``. Writes ``DIR/normals.exr`` (channels X, Y, Z: unit
normals in the shape's tangent frame), ``DIR/normals.png`` (the usual
(n + 1) / 2 colour encoding, one pixel per texel: a texture),
``DIR/recovery.png`` (the picture to look at: true and recovered normals, the
angular error map, the loss curve; :mod:`mitsuba_pbrdf.visualization.normal_recovery`)
and ``DIR/recovery.json`` (loss per iteration, options, angular errors with
``--truth``, which takes ``normals.exr`` or a normal-map texture such as
``write_plate_files``' ``plate_normals.exr``), all four or none
(:meth:`~mitsuba_pbrdf.inverse.normals.NormalRecovery.save`), after
checking every input and that the folder can take them."""

from __future__ import annotations

import os

from .arguments import (check_outputs, chosen_variant, progress_options, require_file,
                        show_progress, variant_help)
from .errors import CliError


def run(args) -> int:
    """``pbrdf recover-normals``."""
    from ..inverse.driver import LR_END
    from ..inverse.normals import recover
    from ..inverse.normals.inputs import check_options
    from ..inverse.normals.result import recovery_paths
    from ..registry import use_variant
    from ..rendering.progress import progress_reporter
    from ..rendering.render import require_polarized
    from ..rendering.scene_params import scene_inputs

    require_file(args.scene, "scene")
    for path in args.targets:
        require_file(path, "--targets: target")
    if args.truth:
        require_file(args.truth, "--truth file")
    if args.lr_end is None:
        args.lr_end = LR_END
    check_options(args.observables, args.parametrization, args.iterations, args.spp,
                  args.smoothness, args.lr, args.lr_end, seed=args.seed)
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise CliError(f"--out: {args.out} is not a folder")
    paths = recovery_paths(args.out)
    check_outputs(*[("--out", p) for p in paths.values()],
                  inputs=[("SCENE.xml", args.scene), *[("--targets", t) for t in args.targets],
                          ("--truth", args.truth)]
                  + [("a file the scene reads", p) for p in scene_inputs(args.scene)])
    variant = chosen_variant(args)
    require_polarized(variant)
    use_variant(variant)

    with progress_reporter(args.iterations, "recover-normals", show_progress(args),
                           steps=args.iterations, unit="it") as bar:
        result = recover.recover_from_files(
            args.scene, args.targets, truth=args.truth or None, observables=args.observables,
            parametrization=args.parametrization, smoothness=args.smoothness,
            iterations=args.iterations, spp=args.spp, lr=args.lr, lr_end=args.lr_end,
            fit_roughness=args.fit_roughness, seed=args.seed,
            callback=lambda it, loss: bar.update(1))

    result.save(paths)  # the four outputs, or none
    print(f"wrote {', '.join(paths.values())}")
    errors = result.error_stats()
    print(f"loss {result.loss[0]:.4g} -> {result.loss[-1]:.4g} in {result.seconds:.1f} s"
          + (f"; angular error median {errors['median']:.2f} deg "
             f"(start {result.error_stats('start_error')['median']:.2f})" if errors else ""))
    return 0


def add_parser(subparsers):
    p = subparsers.add_parser(
        "recover-normals", help="recover a polarized_normalmap's normals from target images",
        description="Shape from polarization: fit the normal map of the scene's one "
                    "polarized_normalmap to one target image per sensor by polarized path "
                    "replay (stokes_prb) and Adam. See docs/inverse-rendering.md.")
    p.add_argument("scene", metavar="SCENE.xml",
                   help="Mitsuba scene; one shape's BSDF a polarized_normalmap over a raw bitmap")
    p.add_argument("--targets", nargs="+", required=True, metavar="EXR",
                   help="one target per sensor, in sensor order: Stokes EXRs (intensity, stokes) "
                        "or raw mosaic EXRs from pbrdf polcam (polcam)")
    p.add_argument("--out", metavar="DIR", required=True,
                   help="output folder (created if missing): normals.exr, normals.png, "
                        "recovery.png, recovery.json (replaced)")
    p.add_argument("--observables", default="stokes", metavar="intensity|stokes|polcam",
                   help="what the fit compares: S0, S0..S2, or the raw IMX250MZR mosaic "
                        "(default: stokes)")
    p.add_argument("--parametrization", default="normals", metavar="normals|height",
                   help="a free unit normal per texel, or a height field (integrable) "
                        "(default: normals)")
    p.add_argument("--smoothness", type=float, default=0.0,
                   help="weight of the neighbouring-normal difference penalty (default: 0)")
    p.add_argument("--iterations", type=int, default=100, help="Adam steps (default: 100)")
    p.add_argument("--spp", type=int, default=16,
                   help="samples per pixel of each iteration's render (default: 16)")
    p.add_argument("--lr", type=float, default=0.02,
                   help="Adam learning rate of the first iteration (default: 0.02)")
    p.add_argument("--lr-end", type=float, default=None,
                   help="learning rate of the last iteration as a fraction of --lr, reached by a "
                        "geometric decay (default: recover_normals's LR_END, 0.1)")
    p.add_argument("--fit-roughness", action="store_true",
                   help="also fit the wrapped pbrdf's sigma map (must be a bitmap)")
    p.add_argument("--truth", metavar="NORMALS.exr", default=None,
                   help="true normals for the angular error: channels X, Y, Z (as normals.exr) "
                        "or a normal-map texture's R, G, B = (n + 1) / 2 (as plate_normals.exr)")
    p.add_argument("--seed", type=int, default=0, help="seed of the iterations' renders")
    p.add_argument("--variant", default=None, help=variant_help())
    progress_options(p)
    p.set_defaults(func=run)
