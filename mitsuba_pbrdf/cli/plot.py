"""``pbrdf plot``: the model's pBRDF from the reference evaluator (no variant)."""

from __future__ import annotations

from ..options import DD_DISTRIBUTIONS, DEFAULTS, SHADOWING
from .common import CliError, check_outputs, float_list, one_line


def run(args) -> int:
    """``pbrdf plot``."""
    from ..figures.pbrdf_plots import save_pbrdf_plot
    from ..reference.params import PBRDFParams

    material = args.material
    if (args.eta is not None or args.k is not None) and args.material is not None:
        raise CliError("give --material or --eta and --k, not both")
    if args.eta is None and args.k is None and material is None:
        material = "Al"
    params = PBRDFParams(material=material, eta=args.eta, k=args.k, sigma=args.sigma,
                         ks=args.ks, kdd=args.kdd, sigma_dd=args.sigma_dd, kid=args.kid,
                         shadowing=args.shadowing, dd_distribution=args.dd_distribution)
    wavelengths = float_list(args.wavelengths, "--wavelengths")
    check_outputs(("--out", args.out))
    try:
        params.validate()
        path = save_pbrdf_plot(args.out, params, args.theta_i, wavelengths)
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
    p.add_argument("--material", default=None,
                   help="Mitsuba conductor name (Al, Cu, Au, Ag, Cr, ...; default: Al)")
    p.add_argument("--eta", type=float, default=None, help="real part n of the complex index "
                                                            "(with --k; constant over wavelength)")
    p.add_argument("--k", type=float, default=None, help="imaginary part k of the complex index")
    p.add_argument("--sigma", type=float, default=0.1, help="RMS facet slope, > 0 (default: 0.1)")
    p.add_argument("--ks", type=float, default=1.0, help="specular weight (default: 1)")
    p.add_argument("--kdd", type=float, default=0.0, help="directional diffuse weight (default: 0)")
    p.add_argument("--sigma-dd", type=float, default=0.5,
                   help="directional diffuse RMS slope, > 0 (default: 0.5)")
    p.add_argument("--kid", type=float, default=0.0, help="ideal diffuse weight (default: 0)")
    p.add_argument("--shadowing", default=DEFAULTS["shadowing"], choices=SHADOWING,
                   help="shadowing-masking G (default: vgroove)")
    p.add_argument("--dd-distribution", default=DEFAULTS["dd_distribution"],
                   choices=DD_DISTRIBUTIONS,
                   help="directional diffuse distribution (default: beckmann)")
    p.add_argument("--theta-i", type=float, default=45.0,
                   help="incidence angle in degrees, in [0, 90) (default: 45)")
    p.add_argument("--wavelengths", default="550,450,650",
                   help="wavelengths in nm; the first is used for single-wavelength panels "
                        "(default: 550,450,650)")
    p.add_argument("--out", default="out/pbrdf_plot.png", metavar="PNG",
                   help="output PNG (default: out/pbrdf_plot.png)")
    p.set_defaults(func=run)
