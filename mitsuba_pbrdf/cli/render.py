"""``pbrdf render``: a scene to a Stokes EXR and a PNG.

Everything that can be checked is checked before rendering: the scene file
(or a packaged scene of that name), the ``-D`` values against what the scene
does with them, the variant (polarized), ``--size``, the scene's integrator
(wrapped in ``stokes`` where it has none, with a line on stderr, unless
``--no-auto-stokes``), the picture options, and that both outputs can be written. The outputs are written atomically and replace
existing files (as Mitsuba does; the command says so)."""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager
from typing import Optional

from .arguments import (check_outputs, chosen_variant, parse_defines, progress_options,
                        scene_file, show_progress, variant_help)
from .errors import PROG, CliError
from .pictures import (picture_kwargs, picture_options, warn_quality,
                       warn_unused_picture_options)


def _out_stem(out: Optional[str], scene_path: str) -> str:
    stem = os.path.splitext(os.path.basename(scene_path))[0]
    if out is None:
        return os.path.join("out", stem)
    if out.endswith(("/", os.sep)) or os.path.isdir(out):
        return os.path.join(out, stem)
    base, ext = os.path.splitext(out)
    return base if ext.lower() in (".exr", ".png") else out


@contextmanager
def _loading(scene: str):
    """Mitsuba's loader errors as ``cannot load SCENE: ...``."""
    from ..rendering.render import SceneLoadError

    try:
        yield
    except SceneLoadError as e:
        raise CliError(f"cannot load {scene}: {e}") from e


def _wrote(path: str, existed: bool, detail: str = "") -> str:
    return f"{'replaced' if existed else 'wrote'} {path}{detail}"


def run(args) -> int:
    """``pbrdf render``."""
    from ..rendering.render import check_render
    from ..rendering.scene_params import scene_inputs
    from ..stokes.quality import UnusableImageError
    from ..visualization.render_files import render_files

    scene = scene_file(args.scene, "render", "rendering")
    params = parse_defines(args.define)
    picture = picture_kwargs(args)
    warn_unused_picture_options(args, picture["panels"], "render")
    # the library's checks, once (errors name the parameter; run_command names the option)
    with _loading(scene):  # Mitsuba's parser reads the scene for the checks
        request = check_render(scene, spp=args.spp, variant=chosen_variant(args), params=params,
                               passes=args.passes, wavelength=args.wavelength, bands=args.bands,
                               size=args.size, auto_stokes=args.auto_stokes)
    written = request.mode.band_names  # the Stokes bands the render writes
    if picture["band"] not in (None, *written):
        raise CliError(f"no band {picture['band']!r} in a render; bands are {', '.join(written)}")
    stem = _out_stem(args.out, scene)
    exr_path, png_path = stem + ".exr", stem + ".png"
    check_outputs(("--out", exr_path, ("exr",)), ("--out", png_path, ("png",)),
                  inputs=[("SCENE.xml", scene)]
                  + [("a file the scene reads", path) for path in scene_inputs(scene, params)])
    existed = [os.path.exists(exr_path), os.path.exists(png_path)]
    if request.notice:
        print(f"{PROG} render: {request.notice} (--no-auto-stokes refuses instead)",
              file=sys.stderr)

    try:
        with _loading(scene):
            done = render_files(request, exr_path, png_path, seed=args.seed,
                                progress=show_progress(args), **picture)
    except UnusableImageError as e:
        raise CliError(str(e)) from None
    warn_quality(done.quality, f"the render of {scene}", "render")
    image = done.image
    print(_wrote(done.exr, existed[0],
                 f" ({image.width}x{image.height}, Stokes bands {','.join(image.bands)})"))
    print(_wrote(done.png, existed[1]))
    print(f"timings: {done.timings.summary()}")
    return 0


def add_parser(subparsers):
    r = subparsers.add_parser("render", help="render a scene to <out>.exr (Stokes) and <out>.png",
                              description="Render a Mitsuba scene to a Stokes EXR and an overview "
                                          "PNG. SCENE.xml may also name a packaged scene "
                                          "(default, analytic_plane, gallery/sphere, "
                                          "gallery/polarizer), so the examples run from any "
                                          "directory.")
    r.add_argument("scene", metavar="SCENE.xml", help="Mitsuba scene file, or a packaged scene")
    r.add_argument("--spp", type=int, default=None, help="samples per pixel (default: the scene's)")
    r.add_argument("--variant", default=None, help=variant_help())
    r.add_argument("--seed", type=int, default=0, help="sampler seed (default: 0)")
    r.add_argument("--passes", type=int, default=None,
                   help="split the samples into N passes with different seeds, averaged "
                        "(default: automatic, passes of about a second each, one pass for "
                        "short renders; see docs/cli.md)")
    r.add_argument("--out", metavar="DIR_OR_STEM", default=None,
                   help="output stem (writes STEM.exr and STEM.png, replacing existing files) or "
                        "existing directory / path ending in '/' (default: out/<scene stem>)")
    r.add_argument("--wavelength", metavar="NM[:WIDTH]", default=None,
                   help="render the Stokes image at one wavelength in nm (a laser line, e.g. "
                        "632.8) or averaged over a band WIDTH nm wide (e.g. 550:10), as one "
                        "Stokes band named after it; spectral variants only (see "
                        "docs/polarization-camera.md)")
    r.add_argument("--bands", metavar="LIST", default=None,
                   help="render a Stokes cube: S0-S3 averaged over each of several wavelength "
                        "bands in one render, e.g. 450:650:20 (10 bands of 20 nm) or "
                        "450:470,532:533,600:650 (LOW:HIGH bands); up to 64 bands within "
                        "360-830 nm, EXR channels S0.460nm ...; spectral variants only (see "
                        "docs/spectral-cube.md)")
    r.add_argument("--size", metavar="WIDTHxHEIGHT", default=None,
                   help="image size in pixels for any scene, e.g. 320x240, set on the scene's "
                        "film wherever it is (default: the scene's)")
    r.add_argument("--no-auto-stokes", dest="auto_stokes", action="store_false",
                   help="refuse a scene whose integrator is not inside <integrator "
                        "type=\"stokes\"> (default: render it wrapped in stokes, and say so)")
    r.add_argument("-D", dest="define", action="append", metavar="key=value",
                   help="override a scene <default> parameter (repeatable)")
    picture_options(r, "intensity,dolp")
    progress_options(r)
    r.set_defaults(func=run)
