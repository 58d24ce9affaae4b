"""``pbrdf export``: tabulate the model into a ``.pbsdf`` table that Mitsuba's
``measured_polarized`` renders (format and conventions:
:mod:`mitsuba_pbrdf.measured.pbsdf`, :mod:`mitsuba_pbrdf.measured.rusinkiewicz`).
Computed with the NumPy float64 reference evaluator (no variant needed)."""

from __future__ import annotations

import os
import shutil
import time

from ..interrupts import release
from .arguments import check_outputs, float_list
from .errors import CliError, option_message
from .model_options import add_model_arguments, params_from_args


def run(args) -> int:
    """``pbrdf export``."""
    from ..measured.export import KAIST_WAVELENGTHS, export_pbsdf, parse_bands, parse_grid
    from ..measured.pbsdf import PbsdfError

    params = params_from_args(args)
    folder = os.path.dirname(os.path.abspath(args.out))
    check_outputs(("--out", args.out, ("pbsdf",)), create_folders=False)
    if args.bands is not None and args.wavelengths is not None:
        raise CliError("give --wavelengths (the 5 bands measured_polarized renders) or "
                       "--bands (any number), not both")
    if args.bands is not None:
        try:
            wavelengths = parse_bands(args.bands)
        except ValueError as e:
            raise CliError(option_message(e, args)) from e
    else:
        text = args.wavelengths or ",".join(map(str, KAIST_WAVELENGTHS))
        wavelengths = float_list(text, "--wavelengths")
        if len(wavelengths) != 5:
            raise CliError(f"--wavelengths: measured_polarized reads exactly 5 wavelengths, "
                           f"got {len(wavelengths)} (--bands takes any number)")
        if any(w != round(w) or not 1 <= w <= 65535 for w in wavelengths) or sorted(set(wavelengths)) != wavelengths:
            raise CliError(f"--wavelengths must be increasing whole nm, got {text!r}")
    try:
        grid = parse_grid(args.grid)
        params.validate()
        need, free = grid.nbytes(len(wavelengths)), shutil.disk_usage(folder).free
        if need > free:
            raise CliError(f"--out: the table needs {need / 2**30:.2f} GiB and {folder} has "
                           f"{free / 2**30:.2f} GiB free")
        release()  # checked: Ctrl-C from here on stops the export (mitsuba_pbrdf.interrupts)
        t0 = time.perf_counter()
        export_pbsdf(args.out, params, grid, [int(w) for w in wavelengths])
    except (ValueError, PbsdfError) as e:  # parameter -> option (grid -> --grid)
        raise CliError(option_message(e, args)) from e
    size = os.path.getsize(args.out)
    shown = (", ".join(f"{w:g}" for w in wavelengths) if len(wavelengths) <= 8 else
             f"{len(wavelengths)} from {wavelengths[0]:g} to {wavelengths[-1]:g}")
    print(f"wrote {args.out} ({params.label()}; grid phi_d x theta_d x theta_h = {grid}, "
          f"wavelengths {shown} nm; {size / 2**20:.1f} MiB, "
          f"{time.perf_counter() - t0:.1f} s)")
    if len(wavelengths) != 5:
        print(f"note: {len(wavelengths)} wavelengths: pbrdf fit and read_pbsdf read the table; "
              "Mitsuba's measured_polarized renders only tables of exactly 5 "
              "(docs/measured-data.md)")
    return 0


def add_parser(subparsers):
    p = subparsers.add_parser(
        "export", help="tabulate the model into a .pbsdf file (measured_polarized's format)",
        description="Tabulate the pBRDF (NumPy float64 reference evaluator) into a .pbsdf "
                    "table in the exact conventions of Mitsuba's measured_polarized plugin "
                    "(Rusinkiewicz angles, Stokes frames of the facet, BRDF without cosine). "
                    "See docs/measured-data.md.")
    add_model_arguments(p)
    p.add_argument("--grid", default="default",
                   help="default (49x80x80, square-spaced theta_h, 96 MB), kaist (361x91x91, "
                        "1-degree steps, about 1 GB) or PxDxH[-uniform]")
    p.add_argument("--wavelengths", default=None,
                   help="the 5 wavelengths in nm (default: KAIST's 450,500,550,600,650)")
    p.add_argument("--bands", default=None, metavar="LIST",
                   help="any number of wavelengths (whole nm): a list and/or START:STOP:STEP "
                        "ranges, e.g. 400:700:10 (a hyperspectral table; measured_polarized "
                        "renders only 5)")
    p.add_argument("--out", required=True, metavar="FILE.pbsdf", help="output table")
    p.set_defaults(func=run)
