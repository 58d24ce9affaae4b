"""The model's parameters as command-line options (``--sigma``, ``--sigma-dd``,
``--shadowing`` ...), made from :mod:`mitsuba_pbrdf.schema` for ``pbrdf plot``,
``pbrdf export`` and ``pbrdf fit``, and the parameter record they give."""

from __future__ import annotations

from .. import schema
from .errors import CliError

__all__ = ["add_model_arguments", "params_from_args"]


def _help(p) -> str:
    bound = f"; {p.bound_doc.replace('``', '')}" if p.bound_doc and p.kind != "choice" else ""
    if p.kind == "material":
        return f"{p.doc} (default: {p.default})"
    if p.refines:
        return f"{p.doc} (default: {p.refines}{bound})"
    if p.default is None:
        return f"{p.doc} Give eta and k together; constant over wavelength{bound}."
    return f"{p.doc} (default: {p.default}{bound})"


def add_model_arguments(parser, kinds=("material", "spectrum", "float", "choice"), skip=()):
    """Add one option per model parameter of the given *kinds* (the schema's
    ``cli`` parameters, less those named in *skip*) to *parser*."""
    for p in schema.PARAMETERS:
        if not p.cli or p.kind not in kinds or p.name in skip:
            continue
        if p.kind == "material":
            parser.add_argument(p.option, default=None, help=_help(p))
        elif p.kind == "choice":
            parser.add_argument(p.option, default=p.default, choices=p.choices, help=_help(p))
        else:
            parser.add_argument(p.option, type=float, default=p.default, help=_help(p))


def params_from_args(args):
    """The reference's parameter record from the model options (material, or
    eta and k; the schema's default material when none is given); not yet
    validated."""
    from ..reference.params import PBRDFParams

    if (args.eta is not None or args.k is not None) and args.material is not None:
        raise CliError("give --material or --eta and --k, not both")
    values = {name: getattr(args, name) for name in schema.names(reference=True)}
    for p in schema.PARAMETERS:   # the plugin's floors (Mitsuba's), as load_dict has them
        value = values.get(p.name)
        if p.floor is not None and p.cli and isinstance(value, float) \
                and 0 < value < p.floor:
            raise CliError(f"{p.option}: must be >= {p.floor:.3g} (the plugin's floor: "
                           f"Mitsuba clamps narrower widths), got {value:g}")
    if args.eta is None and args.k is None and args.material is None:
        values["material"] = schema.DEFAULTS["material"]
    return PBRDFParams(**values)
