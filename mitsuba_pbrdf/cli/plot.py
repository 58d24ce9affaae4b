"""``pbrdf plot``: the model's pBRDF from the reference evaluator (no variant)."""

from __future__ import annotations

import math

from ..errors import one_line
from ..interrupts import release
from .arguments import check_outputs, float_list
from .errors import CliError
from .model_options import add_model_arguments, params_from_args


def run(args) -> int:
    """``pbrdf plot``."""
    from ..visualization.pbrdf_plots import save_pbrdf_plot
    from ..reference.params import check_theta_i

    params = params_from_args(args)
    wavelengths = float_list(args.wavelengths, "--wavelengths")
    check_outputs(("--out", args.out, ("png",)))
    if not all(math.isfinite(w) and 0 < w < 1e5 for w in wavelengths):
        raise CliError(f"--wavelengths takes wavelengths in nm, finite and > 0, got "
                       f"{args.wavelengths!r}")
    release()  # checked: the plot is NumPy and matplotlib (mitsuba_pbrdf.interrupts)
    try:
        params.validate()
        check_theta_i(args.theta_i)
        if not (-360.0 <= args.phi_i <= 360.0):
            raise ValueError(f"--phi-i must be in [-360, 360] degrees, got {args.phi_i:g}")
        path = save_pbrdf_plot(args.out, params, args.theta_i, wavelengths, phi_i=args.phi_i)
    except ValueError as e:
        raise CliError(one_line(e)) from e
    print(f"wrote {path} ({params.label()}, θi = {args.theta_i:g}°; "
          "computed with the NumPy reference evaluator)")
    return 0


def add_parser(subparsers):
    p = subparsers.add_parser("plot", help="plot the model's pBRDF (lobes, Mueller elements, DoP)",
                              description="Plot the pBRDF for given parameters: polar lobe, M00, "
                                          "normalized Mueller elements and DoP in the plane of "
                                          "incidence, M00 and DoP over the hemisphere. Computed with "
                                          "the NumPy float64 reference evaluator (no Mitsuba variant).")
    add_model_arguments(p)
    p.add_argument("--theta-i", type=float, default=45.0,
                   help="incidence angle in degrees, in [0, 90) (default: 45)")
    p.add_argument("--phi-i", type=float, default=0.0,
                   help="azimuth of the light in degrees from the surface's s axis (dp_du): "
                        "it matters for anisotropic surfaces (--sigma-u != --sigma-v), which "
                        "also get maps with the light turned by 90 degrees (default: 0)")
    p.add_argument("--wavelengths", default="550,450,650",
                   help="wavelengths in nm; the first is used for single-wavelength panels "
                        "(default: 550,450,650)")
    p.add_argument("--out", default="out/pbrdf_plot.png", metavar="PNG",
                   help="output PNG (default: out/pbrdf_plot.png)")
    p.set_defaults(func=run)
