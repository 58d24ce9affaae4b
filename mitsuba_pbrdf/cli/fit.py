"""``pbrdf fit``: fit the three- and two-component models to measurements in a
CSV file (format: :mod:`mitsuba_pbrdf.measured.measurements`). ``pbrdf-fit``
is the same command."""

from __future__ import annotations

import os
import sys
from typing import Optional, Sequence

from ..options import DD_DISTRIBUTIONS, DEFAULTS, SHADOWING
from ..outputs import atomic_path, write_json
from .common import CliError, check_outputs, one_line


def run(args) -> int:
    """``pbrdf fit``."""
    from ..fitting import fit_models, plot_fit, report
    from ..measured import MeasurementError, read_measurements

    check_outputs(args.plot, args.json)
    try:
        data = read_measurements(args.csv)
        models = ("three", "two") if args.model == "both" else (args.model,)
        results = fit_models(data, models, backend=args.backend, shadowing=args.shadowing,
                             dd_distribution=args.dd_distribution, material=args.material,
                             init=args.init, fix=args.fix, starts=args.starts,
                             rel_uncertainty=args.rel_uncertainty,
                             abs_uncertainty=args.abs_uncertainty)
    except (MeasurementError, ValueError) as e:
        raise CliError(one_line(e)) from e
    print(report(data, results), end="")
    if args.plot:
        with atomic_path(args.plot) as tmp:
            plot_fit(data, results, tmp, title=os.path.basename(args.csv))
        print(f"\nplot: {args.plot}")
    if args.json:
        write_json(args.json, {m: r.as_dict() for m, r in results.items()})
        print(f"results: {args.json}")
    return 0


def add_parser(subparsers):
    p = subparsers.add_parser(
        "fit", help="fit the model to measurements (CSV)",
        description="Fit the three-component pBRDF (and the two-component one) to "
                    "measurements in a CSV file: theta_i, phi_i, theta_r, phi_r (deg), "
                    "wavelength (nm), m00..m33 and/or dolp, optional <quantity>_err.")
    p.add_argument("csv", help="measurements: theta_i, phi_i, theta_r, phi_r (deg), "
                               "wavelength (nm), m00..m33 and/or dolp, optional <q>_err")
    p.add_argument("--model", choices=("three", "two", "both"), default="both")
    p.add_argument("--backend", choices=("reference", "drjit"), default="reference",
                   help="reference: NumPy float64 with scipy (default); drjit: the plugin")
    p.add_argument("--material", help="start n, k from this tabulated conductor (e.g. Al, Cu)")
    p.add_argument("--init", default="", help="starting values, e.g. sigma=0.1,n=1.2")
    p.add_argument("--fix", default="", help="fixed values, e.g. n=1.2,k=7 or kid=0")
    p.add_argument("--shadowing", choices=SHADOWING, default=DEFAULTS["shadowing"])
    p.add_argument("--dd-distribution", choices=DD_DISTRIBUTIONS,
                   default=DEFAULTS["dd_distribution"])
    p.add_argument("--starts", type=int, default=3, help="number of starting points (default 3)")
    p.add_argument("--rel-uncertainty", type=float, default=0.05)
    p.add_argument("--abs-uncertainty", type=float, default=0.005)
    p.add_argument("--plot", help="write a PNG of fit versus data")
    p.add_argument("--json", help="write the results as JSON")
    p.set_defaults(func=run)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``pbrdf-fit ...``: the same as ``pbrdf fit ...``."""
    from . import main as pbrdf_main

    return pbrdf_main(["fit"] + list(sys.argv[1:] if argv is None else argv))
