"""``pbrdf polcam``: a polarization camera's images of a Stokes EXR.

Writes ``DIR/<stem>_I0.exr``, ``_I45.exr``, ``_I90.exr``, ``_I135.exr`` (the
images behind ideal linear polarizers, same bands as the input) and the raw
sensor frame ``DIR/<stem>_mosaic.exr`` (monochrome sensor) or
``_mosaic_rgb.exr`` (colour sensor), one channel ``Y``; with ``--bits`` also
the ADC counts as a 16-bit PNG; and always an 8-bit picture of the raw frame to
look at, ``_mosaic_preview.png`` (full scale white;
:mod:`mitsuba_pbrdf.camera.raw_frames`). ``pbrdf view`` draws the Stokes image
of the mosaic (demosaiced) or of the four polarizer images. Everything is checked and computed before the
first file is written, and each file is written atomically
(:mod:`mitsuba_pbrdf.camera.polcam`, ``docs/polarization-camera.md``)."""

from __future__ import annotations

import os

from ..errors import ParameterError, one_line
from ..interrupts import release
from .arguments import check_outputs, finite_float, require_file
from .errors import CliError, option_message


def sensor_model(args):
    """The :class:`~mitsuba_pbrdf.camera.polcam.SensorModel` of the options (checked)."""
    from ..camera.polcam import SensorModel

    finite_float("--exposure", args.exposure, low=0.0, low_open=True)
    finite_float("--full-well", args.full_well, low=0.0, low_open=True)
    finite_float("--read-noise", args.read_noise, low=0.0)
    if args.read_noise and args.full_well is None:
        raise CliError("--read-noise (electrons) needs --full-well")
    if args.exposure is not None and args.full_well is None and args.bits is None:
        # without shot noise or an ADC nothing would use the exposure
        raise CliError("--exposure (the radiance at full well) needs --full-well or --bits")
    if args.seed is not None and args.full_well is None:
        raise CliError("--seed (of the shot and read noise) needs --full-well")
    if args.bits is not None and not 1 <= args.bits <= 16:
        raise CliError(f"--bits must be in 1..16, got {args.bits}")
    return SensorModel(exposure=args.exposure, full_well=args.full_well,
                       read_noise=args.read_noise or 0.0, bits=args.bits, seed=args.seed or 0)


def run(args) -> int:
    """``pbrdf polcam``."""
    from ..visualization.polcam_files import polcam_files
    from ..stokes.image import StokesChannelError

    require_file(args.exr, "EXR file")
    model = sensor_model(args)
    if args.sensor == "colour" and args.band is not None:
        raise CliError("--band is for the mono sensor; the colour sensor sees R, G, B")
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise CliError(f"--out: {args.out} is not a folder")
    release()  # checked: what follows is NumPy, Ctrl-C stops it at once (mitsuba_pbrdf.interrupts)
    try:
        files = polcam_files(args.exr, args.out, sensor=args.sensor, band=args.band, model=model)
    except ParameterError as e:  # of an option (sensor -> --sensor), not of the file
        raise CliError(option_message(e, args)) from e
    except (StokesChannelError, ValueError, KeyError) as e:
        raise CliError(f"{args.exr}: {one_line(e).removeprefix(args.exr + ': ')}") from e
    check_outputs(*[("--out", p) for p in files.paths], inputs=[("STOKES.exr", args.exr)])
    written = files.write()  # all the files or none
    print(f"wrote {len(written)} files in {args.out}: "
          + ", ".join(os.path.basename(p) for p in written))
    return 0


def add_parser(subparsers):
    p = subparsers.add_parser(
        "polcam", help="a polarization camera's four polarizer images and raw mosaic of a "
                       "Stokes EXR",
        description="From a Stokes EXR, the images behind ideal linear polarizers at 0, 45, 90 "
                    "and 135 degrees (from the image's horizontal, counter-clockwise in the "
                    "picture) and the raw frame of a Sony IMX250MZR (mono) or IMX250MYR "
                    "(colour) polarization sensor, optionally with shot noise, read noise and "
                    "ADC quantization. See docs/polarization-camera.md.")
    p.add_argument("exr", metavar="STOKES.exr",
                   help="EXR with Stokes channels S0.<band> ... S3.<band>")
    p.add_argument("--out", metavar="DIR", required=True,
                   help="output folder (created if missing; files are replaced)")
    p.add_argument("--sensor", choices=["mono", "colour"], default="mono",
                   help="monochrome (IMX250MZR) or colour (IMX250MYR) sensor (default: mono)")
    p.add_argument("--band", default=None,
                   help="Stokes band the mono sensor sees (default: the luminance combination "
                        "of R, G, B; the only band of a one-band image)")
    g = p.add_argument_group(
        "sensor model (on with --full-well or --bits; the other options need one of them)")
    g.add_argument("--exposure", type=float, default=None, metavar="RADIANCE",
                   help="radiance that fills the full well (default: the frame's maximum); needs "
                        "--full-well or --bits")
    g.add_argument("--full-well", type=float, default=None, metavar="ELECTRONS",
                   help="full-well capacity in electrons; adds photon shot noise")
    g.add_argument("--read-noise", type=float, default=None, metavar="ELECTRONS",
                   help="read noise, standard deviation in electrons (needs --full-well)")
    g.add_argument("--bits", type=int, default=None, metavar="N",
                   help="ADC bits (1-16): quantize, and also write the counts as a 16-bit PNG "
                        "(values in the low N bits)")
    g.add_argument("--seed", type=int, default=None,
                   help="seed of the shot and read noise (default: 0; needs --full-well)")
    p.set_defaults(func=run)
