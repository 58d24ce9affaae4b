"""``pbrdf fit``: fit the three- and two-component models to measurements in a
CSV file (format: :mod:`mitsuba_pbrdf.measured.measurements`) or to a
``.pbsdf`` table (the KAIST database's format: :mod:`mitsuba_pbrdf.measured.pbsdf`;
the entries used: :mod:`mitsuba_pbrdf.measured.table_sampling`). The file's
kind is told by its first bytes. ``pbrdf-fit`` is the same command."""

from __future__ import annotations

import math
import os
import sys
from typing import Optional, Sequence

from ..choices import (AUTO, BOTH, LAYOUT_CHOICES, LAYOUTS, MODELS, PLOT_FORMATS, model_names,
                       preferred)
from ..interrupts import release
from ..schema import DD_DISTRIBUTIONS as DISTRIBUTIONS
from ..errors import one_line
from .arguments import check_outputs, float_list, positive_int, require_file
from .errors import CliError, option_message
from .fit_progress import FitProgressDisplay
from .model_options import add_model_arguments


def _check_options(args):
    from ..fitting.vector import parse_assignments

    from ..fitting.objectives import OBJECTIVES

    if args.objective not in ("auto",) + tuple(OBJECTIVES):
        raise CliError(f"--objective must be auto or one of {', '.join(OBJECTIVES)}, "
                       f"not {args.objective!r}")
    positive_int("--starts", args.starts)
    if args.log_floor is not None and not (math.isfinite(args.log_floor) and args.log_floor > 0):
        raise CliError(f"--log-floor must be a finite number > 0 (1/sr), got {args.log_floor:g}")
    if args.nk is not None and args.material is not None:
        raise CliError("give --material or --nk, not both")
    positive_int("--cells", args.cells)
    for option, v in (("--rel-uncertainty", args.rel_uncertainty),
                      ("--abs-uncertainty", args.abs_uncertainty)):
        if not (math.isfinite(v) and v >= 0):
            raise CliError(f"{option} must be a finite number >= 0, got {v:g}")
    if not 0 < args.max_angle < 90:
        raise CliError(f"--max-angle must be in (0, 90) degrees, got {args.max_angle:g}")
    try:
        init = parse_assignments(args.init, "--init")
        fix = parse_assignments(args.fix, "--fix")
    except ValueError as e:
        raise CliError(one_line(e)) from e
    check_outputs(("--plot", args.plot, PLOT_FORMATS), ("--json", args.json),
                  ("--scene-out", args.scene_out, ("xml",)),
                  inputs=[("FILE", args.data), ("--nk", args.nk)], create_folders=False)
    return init, fix


def _index_table(args):
    from ..measured import IndexTableError, read_index_table

    if args.nk is None:
        return None
    if not os.path.exists(args.nk):
        raise CliError(f"--nk: index table not found: {args.nk}")
    try:
        return read_index_table(args.nk)
    except IndexTableError as e:
        raise CliError(f"--nk: {one_line(e)}") from e


def _wavelengths(args):
    wavelengths = float_list(args.wavelength, "--wavelength") if args.wavelength else None
    if wavelengths and not all(math.isfinite(w) and w > 0 for w in wavelengths):
        raise CliError(f"--wavelength takes wavelengths in nm, > 0, got {args.wavelength!r}")
    return wavelengths


def run(args) -> int:
    """``pbrdf fit``."""
    from ..fitting import fit_file, report
    from ..measured import MeasurementError, PbsdfError
    from ..fitting.report import undetermined_warning

    init, fix = _check_options(args)
    nk = _index_table(args)
    require_file(args.data, "measurement file")
    wavelengths = _wavelengths(args)
    models = model_names(args.model)
    fits = len(models) * (2 if args.distribution == "auto" else 1)
    try:
        with FitProgressDisplay(fits) as shown:
            # on_read=release: read and checked, Ctrl-C from here on stops the
            # fit (mitsuba_pbrdf.interrupts)
            fitted = fit_file(args.data, models, layout=args.layout, wavelengths=wavelengths,
                              observables=args.observables.split(",") if args.observables
                              else None, cells=args.cells, max_angle=args.max_angle,
                              seed=args.seed, on_read=release, backend=args.backend,
                              shadowing=args.shadowing, dd_distribution=args.dd_distribution,
                              material=args.material, nk=nk, distribution=args.distribution,
                              init=init, fix=fix, starts=args.starts,
                              rel_uncertainty=args.rel_uncertainty,
                              abs_uncertainty=args.abs_uncertainty,
                              anisotropic=args.anisotropic, objective=args.objective,
                              log_floor=args.log_floor, progress=shown)
    except (MeasurementError, PbsdfError, ValueError) as e:
        raise CliError(option_message(e, args)) from e
    table, data, results = fitted.table, fitted.data, fitted.results
    if table is not None:
        print(f"table: {table.describe()}; fitted {len(data)} cell-wavelength entries "
              f"({len(data) // max(data.wavelengths.size, 1)} cells at "
              f"{data.wavelengths.size} of its wavelengths, both directions within "
              f"{args.max_angle:g} deg of the normal)")
    print(report(data, results), end="")
    for r in results.values():
        if r.undetermined:
            print(undetermined_warning(r), file=sys.stderr)
        for warning in r.warnings:
            print(warning, file=sys.stderr)
    fitted.save(plot=args.plot, json=args.json, scene=args.scene_out, material=args.material)
    if args.plot:
        print(f"\nplot: {args.plot}")
    if args.json:
        print(f"results: {args.json}")
    if args.scene_out:
        print(f"scene: {args.scene_out} (the {preferred(results).model}-component fit as a "
              f"pbrdf BSDF)")
    return 0


def add_parser(subparsers):
    p = subparsers.add_parser(
        "fit", help="fit the model to measurements (CSV) or a .pbsdf table",
        description="Fit the three-component pBRDF (and the two-component one) to "
                    "measurements in a CSV file (theta_i, phi_i, theta_r, phi_r (deg), "
                    "wavelength (nm), m00..m33 and/or dolp, optional <quantity>_err), to a "
                    "file in NIST's Mueller BRDF layout (see docs/fitting.md) or to a "
                    ".pbsdf table (KAIST database format; see docs/measured-data.md).")
    for group in (_file_arguments, _model_arguments, _objective_arguments, _shape_arguments,
                  _solver_arguments, _table_arguments, _output_arguments):
        group(p)
    p.set_defaults(func=run)


def _file_arguments(p):
    """The file, and what of it to read (:func:`mitsuba_pbrdf.measured.read`)."""
    p.add_argument("data", metavar="FILE", help="measurements (.csv) or a pBRDF table (.pbsdf)")
    p.add_argument("--layout", choices=LAYOUT_CHOICES, default=AUTO,
                   help="CSV layout: " + ", ".join(f"{lay.name} ({lay.summary})"
                                                   for lay in LAYOUTS.values())
                        + f" or {AUTO} (told by the header; default)")
    p.add_argument("--wavelength", default="",
                   help="fit only the rows at these wavelengths (nm, comma-separated, "
                        "within 0.5 nm), e.g. 532")


def _model_arguments(p):
    """Which models, evaluated how, and where n, k come from."""
    p.add_argument("--model", choices=tuple(MODELS) + (BOTH,), default=BOTH)
    p.add_argument("--backend", choices=("reference", "drjit"), default="reference",
                   help="reference: NumPy float64 with scipy (default); drjit: the plugin")
    p.add_argument("--material", help="take n, k from this tabulated conductor (e.g. Al, Cu) "
                                      "at the data's wavelengths: the start of a polarized fit, "
                                      "fixed in a fit of unpolarized data (m00 alone)")
    p.add_argument("--nk", metavar="FILE",
                   help="take n, k from this table instead (columns wavelength,n,k in nm, or "
                        "refractiveindex.info's CSV export: wl,n and wl,k blocks in um)")


def _objective_arguments(p):
    """What the fit minimizes, from where, with what held fixed."""
    p.add_argument("--objective", default="auto",
                   help="the residual minimized for m00 (other quantities: linear): auto "
                        "(default: linear when the file gives uncertainties, log when m00 "
                        "spans more than two decades, else linear), linear, log, relative, "
                        "cosine (Ngan et al. 2005), log-cosine (Loew et al. 2012); see "
                        "docs/fitting.md")
    p.add_argument("--log-floor", type=float, default=None, metavar="F",
                   help="floor f of the log and relative objectives, 1/sr (default: 1 %% of "
                        "the median positive m00)")
    p.add_argument("--init", default="", help="starting values, e.g. sigma=0.1,n=1.2")
    p.add_argument("--fix", default="", help="fixed values, e.g. n=1.2,k=7 or kid=0")


def _shape_arguments(p):
    """The lobes' shadowing and distributions, and anisotropy."""
    add_model_arguments(p, kinds=("choice",), skip=("distribution", "dd_distribution"))
    p.add_argument("--distribution", choices=("auto",) + DISTRIBUTIONS, default="auto",
                   help="normal distribution of the microfacet lobes: auto (default: fit "
                        "beckmann and ggx, keep the better and say so), beckmann or ggx")
    p.add_argument("--dd-distribution", choices=DISTRIBUTIONS, default=None,
                   help="the directional diffuse lobe's distribution (default: the same as "
                        "the specular lobe's)")
    p.add_argument("--anisotropic", action="store_true",
                   help="fit sigma_u and sigma_v (the RMS slopes along the surface's x and y "
                        "axes, azimuth 0 and 90 deg) instead of sigma; the report says whether "
                        "the measurements resolve them")


def _solver_arguments(p):
    """The starts, and the uncertainties assumed where the file gives none."""
    p.add_argument("--starts", type=int, default=None,
                   help="number of starting points (default: the initial values and a grid "
                        "of roughness scales per lobe, 7 for the three-component model)")
    p.add_argument("--rel-uncertainty", type=float, default=0.05,
                   help="assumed relative uncertainty of each value (default 0.05)")
    p.add_argument("--abs-uncertainty", type=float, default=0.005,
                   help="assumed absolute floor, times the column's largest value (CSV) or "
                        "the entry's M00 (.pbsdf, NIST layout) (default 0.005)")


def _table_arguments(p):
    """What of a .pbsdf table is fitted (:func:`mitsuba_pbrdf.measured.read`)."""
    p.add_argument("--cells", type=int, default=3000,
                   help=".pbsdf: number of table cells to fit (default 3000)")
    p.add_argument("--max-angle", type=float, default=80.0,
                   help=".pbsdf: leave out cells with the light or viewer further than this "
                        "from the normal (degrees, default 80)")
    p.add_argument("--observables", default="",
                   help="quantities to fit, e.g. m00,m11,dolp (default: a .pbsdf table's "
                        "m00..m33, a CSV file's columns; dolp is derived from m00, m10, m20 "
                        "when the file has no dolp column)")
    p.add_argument("--seed", type=int, default=0, help=".pbsdf: seed of the cell sample")


def _output_arguments(p):
    """The files the command writes besides its report."""
    p.add_argument("--plot", help="write a picture of fit versus data ("
                                  + ", ".join(f".{f}" for f in PLOT_FORMATS[:-1])
                                  + f" or .{PLOT_FORMATS[-1]})")
    p.add_argument("--json", help="write the results as JSON")
    p.add_argument("--scene-out", metavar="FILE.xml",
                   help="write a Mitsuba scene with the fitted pbrdf BSDF (the three-component "
                        "fit, else the one fitted), ready to render in a polarized variant")


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``pbrdf-fit ...``: the same as ``pbrdf fit ...``."""
    from . import main as pbrdf_main

    return pbrdf_main(["fit"] + list(sys.argv[1:] if argv is None else argv))
