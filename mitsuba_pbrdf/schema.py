"""Every plugin's parameters, each declared once: name, kind, default, bounds,
flags and a one-line doc (:class:`Parameter`). ``pbrdf``'s are
:data:`PARAMETERS`; the other plugins' are in :data:`PLUGIN_PARAMETERS`.

Pure Python, no imports beyond the standard library. Everything that takes a
model parameter reads it from here:

* the plugin (:mod:`mitsuba_pbrdf.bsdfs.pbrdf`): which properties it reads and
  checks, what ``traverse`` exposes with which flags, the lobe records and the
  parameter table of its docstring;
* the reference evaluator's parameter record
  (:class:`mitsuba_pbrdf.reference.PBRDFParams`) and its checks;
* the model options of ``pbrdf plot``, ``pbrdf export`` and ``pbrdf fit``
  (:mod:`mitsuba_pbrdf.cli.model_options`);
* the fitted parameters, their starting values and bounds
  (:mod:`mitsuba_pbrdf.fitting.vector`);
* the parameter table of ``docs/plugin.md`` and every plugin's docstring
  rows of its declared parameters (:mod:`mitsuba_pbrdf.schema_tables`, which
  ``python -m mitsuba_pbrdf.schema_tables`` rewrites; tests/test_schema.py checks
  them);
* the reads of :func:`mitsuba_pbrdf.properties.declared`.

The plugin and the reference still compute the model independently: only the
names, defaults and bounds are shared. Adding a parameter means a line here and
its physics in ``bsdfs/`` and ``reference/``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Optional, Tuple

__all__ = ["Parameter", "Fit", "Alias", "ALIASES", "PARAMETERS", "MIN_SIGMA", "LOBES", "DEFAULTS", "SHADOWING",
           "REFERENCE_SHADOWING", "DD_DISTRIBUTIONS", "DISTRIBUTIONS", "SAMPLING",
           "REFINEMENTS", "ANISOTROPIC_WIDTHS", "exposed_widths", "parameter", "names",
           "PLUGIN_PARAMETERS", "bounds_doc"]

#: Smallest accepted RMS slope (``sigma``, ``sigma_dd``): Mitsuba's microfacet
#: distributions clamp the Beckmann/GGX width alpha = sqrt(2) sigma to 1e-4.
MIN_SIGMA = 1e-4 / math.sqrt(2.0)

#: Mitsuba's roughness ``alpha`` per RMS slope ``sigma``: Beckmann's width
#: alpha = sqrt(2) sigma (paper Eq. 3); the plugin's GGX takes the same alpha.
ALPHA_PER_SIGMA = math.sqrt(2.0)


@dataclass(frozen=True)
class Fit:
    """How a parameter is fitted to measurements: starting value, bounds, and
    the scale below which its relative uncertainty is not meaningful."""

    initial: float
    lower: float
    upper: float
    name: Optional[str] = None        # its name in fits, if not the parameter's (n for eta)
    per_wavelength: bool = False      # one value per measured wavelength (n, k)
    scale_floor: float = 0.0          # uncertainty is judged against max(|value|, scale_floor)


@dataclass(frozen=True)
class Alias:
    """Another name a parameter is given under, in other units: a value given
    as ``name`` is ``scale`` times the parameter's (Mitsuba's ``alpha`` is
    sqrt(2) times the paper's ``sigma``). Only the plugin takes aliases."""

    name: str
    scale: float
    doc: str


@dataclass(frozen=True)
class Parameter:
    """One parameter of a plugin.

    ``kind``: ``"spectrum"`` (a number, spectrum or texture; may vary with
    wavelength), ``"float"`` (a number or texture, one value per point),
    ``"number"`` (a plain number), ``"integer"``, ``"boolean"``, ``"choice"`` (a string from
    ``choices``) or ``"material"`` (a conductor name). ``lower``/``upper``/
    ``positive``: the value must be >= ``lower``, <= ``upper`` (> 0 where
    ``positive``); ``floor``: the smallest value the plugin takes (Mitsuba's
    limit). ``flags_doc``: the docs' Flags cell where ``differentiable`` does
    not say it all (exposed under another key, or exposed and not
    differentiable). ``lobe``/``role``: the lobe it weights (``"weight"``) or shapes
    (``"width"``; ``"width_u"``/``"width_v"``: its width along the shading
    frame's s and t axes). ``refines``: the parameter it refines (``sigma_u``
    and ``sigma_v`` refine ``sigma``): it defaults to that parameter's value,
    and where any refinement of a parameter is given, the refinements replace
    it (in ``traverse``, in fits); where none is, the parameter stands alone
    and the refinements are None. ``plugin``/``reference``/``cli``: whether
    the plugin, the reference evaluator, the model options of the commands
    take it. ``smooth_at_zero``: the plugin also takes exactly 0 (a constant
    0, not a texture that is 0 somewhere) as the smooth limit, a delta lobe;
    the reference does not. ``alias``: the :class:`Alias` the plugin also takes it under
    (one of the two names, never both); ``parameter(alias.name)`` is the
    declaration as given under that name, whose ``stands_for`` names the
    parameter and whose values are ``scale`` times the parameter's.
    """

    name: str
    kind: str
    default: object
    doc: str
    lower: Optional[float] = None
    upper: Optional[float] = None
    positive: bool = False
    floor: Optional[float] = None
    choices: Tuple[str, ...] = ()
    reference_choices: Tuple[str, ...] = ()   # choices only the reference evaluator offers
    differentiable: bool = False
    discontinuous: bool = False
    lobe: Optional[str] = None
    role: Optional[str] = None
    refines: Optional[str] = None
    fit: Optional[Fit] = None
    plugin: bool = True
    reference: bool = True
    cli: bool = True
    default_doc: Optional[str] = None         # the default as the docs state it
    unit: str = "dimensionless"
    typical: str = ""                         # typical values, for the docs
    smooth_at_zero: bool = False
    alias: Optional[Alias] = None
    stands_for: Optional[str] = None          # an alias's parameter (``sigma`` for ``alpha``)
    scale: float = 1.0                        # an alias's values per the parameter's
    flags_doc: Optional[str] = None

    @property
    def option(self) -> str:
        """The command-line option: ``--sigma-dd`` for ``sigma_dd``."""
        return "--" + self.name.replace("_", "-")

    @property
    def bound_doc(self) -> str:
        if self.kind == "choice":
            return " or ".join(f"``{c}``" for c in self.choices)
        if self.floor is not None:
            return (f"0 (smooth: a mirror) or >= {self.floor:.3g}" if self.smooth_at_zero
                    else f">= {self.floor:.3g}")
        if self.positive:
            return "> 0"
        if self.lower is not None or self.upper is not None:
            return bounds_doc(self.lower, self.upper)
        return ""


def bounds_doc(low: Optional[float], high: Optional[float]) -> str:
    """``in [low, high]``, ``>= low`` or ``<= high``, as the docs and the
    errors word a range (either bound None: open)."""
    return (f"in [{low:g}, {high:g}]" if low is not None and high is not None
            else f">= {low:g}" if low is not None else f"<= {high:g}")


#: Every model parameter, in the order of the docs' table.
PARAMETERS: Tuple[Parameter, ...] = (
    Parameter("material", "material", "Al",
              "Named conductor from Mitsuba's tabulated spectra; mutually exclusive with "
              "eta and k.", unit="–", typical="71 names (Al, Cu, Au, Ag, Cr, ...)"),
    Parameter("eta", "spectrum", None,
              "Real part n of the metal's complex index of refraction N = n + ik.",
              positive=True, differentiable=True, discontinuous=True,
              fit=Fit(1.5, 0.01, 20.0, name="n", per_wavelength=True, scale_floor=0.1),
              default_doc="from material", typical="metals in the visible: 0.05–3.5"),
    Parameter("k", "spectrum", None,
              "Imaginary part k (extinction coefficient) of the complex index N = n + ik.",
              lower=0.0, differentiable=True, discontinuous=True,
              fit=Fit(5.0, 0.0, 40.0, per_wavelength=True, scale_floor=0.1),
              default_doc="from material", typical="metals in the visible: 1.8–8"),
    Parameter("sigma", "float", 0.1,
              "RMS microfacet slope per axis of the specular lobe (paper Eq. 3); Beckmann "
              "width alpha = sqrt(2) sigma (Mitsuba clamps alpha >= 1e-4, hence the floor). "
              "0 is the smooth limit: a delta lobe, Mitsuba's conductor.",
              positive=True, floor=MIN_SIGMA, smooth_at_zero=True, differentiable=True, discontinuous=True,
              lobe="specular", role="width", fit=Fit(0.15, 1e-3, 2.0, scale_floor=1e-3),
              unit="dimensionless (slope)", typical="0.02 polished – 0.5 rough",
              alias=Alias("alpha", ALPHA_PER_SIGMA,
                          "Mitsuba's roughness (roughconductor's alpha, Beckmann or GGX as "
                          "distribution says): the specular lobe's width alpha = sqrt(2) "
                          "sigma, given instead of sigma.")),
    Parameter("sigma_u", "float", None,
              "RMS slope of the specular lobe along the shading frame's s axis (dp_du); "
              "alpha_u = sqrt(2) sigma_u. Giving sigma_u or sigma_v makes the lobe anisotropic.",
              positive=True, floor=MIN_SIGMA, smooth_at_zero=True, differentiable=True, discontinuous=True,
              lobe="specular", role="width_u", refines="sigma",
              fit=Fit(0.15, 1e-3, 2.0, scale_floor=1e-3), default_doc="sigma",
              unit="dimensionless (slope)", typical="brushed metal: sigma_u / sigma_v 2–10",
              alias=Alias("alpha_u", ALPHA_PER_SIGMA,
                          "Mitsuba's alpha_u: the specular lobe's width along s, "
                          "alpha_u = sqrt(2) sigma_u, given instead of sigma_u.")),
    Parameter("sigma_v", "float", None,
              "RMS slope of the specular lobe along the shading frame's t axis "
              "(n x dp_du); alpha_v = sqrt(2) sigma_v. 0 only with sigma_u = 0 (smooth).",
              positive=True, floor=MIN_SIGMA, smooth_at_zero=True, differentiable=True, discontinuous=True,
              lobe="specular", role="width_v", refines="sigma",
              fit=Fit(0.15, 1e-3, 2.0, scale_floor=1e-3), default_doc="sigma",
              unit="dimensionless (slope)", typical="as sigma_u",
              alias=Alias("alpha_v", ALPHA_PER_SIGMA,
                          "Mitsuba's alpha_v: the specular lobe's width along t, "
                          "alpha_v = sqrt(2) sigma_v, given instead of sigma_v.")),
    Parameter("distribution", "choice", "beckmann",
              "Normal distribution of the specular lobe: beckmann (the paper's Gaussian "
              "slopes) or ggx (Trowbridge-Reitz), both of width alpha = sqrt(2) sigma.",
              choices=("beckmann", "ggx"), lobe="specular", unit="–"),
    Parameter("ks", "spectrum", 1.0, "Weight k_s of the specular (polarizing) lobe (paper Eq. 2).",
              lower=0.0, differentiable=True, lobe="specular", role="weight",
              fit=Fit(1.0, 0.0, 20.0), typical="0–1"),
    Parameter("kdd", "spectrum", 0.0,
              "Weight k_dd of the directional diffuse (depolarized) lobe (paper Eq. 2).",
              lower=0.0, differentiable=True, lobe="directional_diffuse", role="weight",
              fit=Fit(0.1, 0.0, 20.0), typical="0–1"),
    Parameter("sigma_dd", "float", 0.5,
              "RMS slope of the directional diffuse lobe (alpha_dd = sqrt(2) sigma_dd).",
              positive=True, floor=MIN_SIGMA, differentiable=True, discontinuous=True,
              lobe="directional_diffuse", role="width",
              fit=Fit(0.5, 1e-3, 5.0, scale_floor=1e-3), unit="dimensionless (slope)",
              typical="wider than sigma"),
    Parameter("sigma_dd_u", "float", None,
              "RMS slope of the directional diffuse lobe along the s axis; giving sigma_dd_u "
              "or sigma_dd_v makes that lobe anisotropic.",
              positive=True, floor=MIN_SIGMA, differentiable=True, discontinuous=True,
              lobe="directional_diffuse", role="width_u", refines="sigma_dd",
              default_doc="sigma_dd", unit="dimensionless (slope)", typical="as sigma_dd"),
    Parameter("sigma_dd_v", "float", None,
              "RMS slope of the directional diffuse lobe along the t axis.",
              positive=True, floor=MIN_SIGMA, differentiable=True, discontinuous=True,
              lobe="directional_diffuse", role="width_v", refines="sigma_dd",
              default_doc="sigma_dd", unit="dimensionless (slope)", typical="as sigma_dd"),
    Parameter("kid", "spectrum", 0.0,
              "Weight k_id of the ideal (Lambertian, depolarized) diffuse lobe (paper Eq. 2).",
              lower=0.0, differentiable=True, lobe="ideal_diffuse", role="weight",
              fit=Fit(0.01, 0.0, 10.0), typical="0–1"),
    Parameter("shadowing", "choice", "vgroove",
              "Shadowing-masking G: vgroove (Torrance-Sparrow/Blinn, the paper's) or smith "
              "(Smith's, as Mitsuba's roughconductor).",
              choices=("vgroove", "smith"), reference_choices=("none",), unit="–"),
    Parameter("dd_distribution", "choice", "beckmann",
              "Normal distribution of the directional diffuse lobe.",
              choices=("beckmann", "ggx"), unit="–"),
    Parameter("sampling", "choice", "mixture",
              "mixture (lobes chosen by estimated albedo) or cosine (cosine-weighted "
              "hemisphere only: the benchmarks' baseline).",
              choices=("mixture", "cosine"), reference=False, cli=False, unit="–"),
)



def _as_alias(p: Parameter) -> Parameter:
    """Parameter *p* as given under its alias: its name, doc, bounds in the
    alias's units; the plugin's only."""
    a = p.alias

    def scaled(x):
        return None if x is None else x * a.scale

    return replace(p, name=a.name, doc=a.doc, lower=scaled(p.lower), floor=scaled(p.floor),
                   alias=None, stands_for=p.name, scale=a.scale, fit=None, reference=False,
                   cli=False, typical="", unit="dimensionless (width)")


#: The declarations as given under an alias, by alias name (``alpha`` ...).
ALIASES = {p.alias.name: _as_alias(p) for p in PARAMETERS if p.alias}

_BY_NAME = {**{p.name: p for p in PARAMETERS}, **ALIASES}


def parameter(name: str, plugin: str = "pbrdf") -> Parameter:
    """The declaration of plugin *plugin*'s parameter *name*, or of an alias
    of ``pbrdf``'s (``alpha``) as given under that name."""
    if plugin == "pbrdf":
        return _BY_NAME[name]
    return next(p for p in PLUGIN_PARAMETERS[plugin] if p.name == name)


def names(**flags) -> Tuple[str, ...]:
    """Names of the parameters whose attributes equal *flags*, in table order
    (``names(reference=True)``, ``names(kind="choice")``)."""
    return tuple(p.name for p in PARAMETERS
                 if all(getattr(p, key) == value for key, value in flags.items()))


#: Lobes in component order, each with its weight and width parameter
#: (None: the lobe has no width).
LOBES = {
    lobe: (next(p.name for p in PARAMETERS if p.lobe == lobe and p.role == "weight"),
           next((p.name for p in PARAMETERS if p.lobe == lobe and p.role == "width"), None))
    for lobe in dict.fromkeys(p.lobe for p in PARAMETERS if p.lobe)
}

#: The refinements of each refined parameter, in table order:
#: ``{"sigma": ("sigma_u", "sigma_v"), "sigma_dd": ("sigma_dd_u", "sigma_dd_v")}``.
REFINEMENTS = {
    base: tuple(p.name for p in PARAMETERS if p.refines == base)
    for base in dict.fromkeys(p.refines for p in PARAMETERS if p.refines)
}

#: Lobes with anisotropic widths: ``lobe -> (width_u, width_v)`` parameter names.
ANISOTROPIC_WIDTHS = {
    lobe: tuple(next(p.name for p in PARAMETERS if p.lobe == lobe and p.role == role)
                for role in ("width_u", "width_v"))
    for lobe in LOBES
    if any(p.lobe == lobe and p.role == "width_u" for p in PARAMETERS)
}


def exposed_widths(lobe: str, anisotropic: bool) -> Tuple[str, ...]:
    """The width parameters lobe *lobe* exposes: its ``width`` alone, or where
    it is *anisotropic* its ``width_u`` and ``width_v`` (empty: no width)."""
    if anisotropic:
        return ANISOTROPIC_WIDTHS[lobe]
    width = LOBES[lobe][1]
    return (width,) if width else ()


#: Default values by name (eta and k: None, meaning "from the material").
DEFAULTS = {p.name: p.default for p in PARAMETERS}


def _other(name: str, kind: str, default, doc: str, **flags) -> Parameter:
    """A parameter of a plugin other than ``pbrdf``: neither the reference
    evaluator nor the model options take it."""
    return Parameter(name, kind, default, doc, reference=False, cli=False, **flags)


_FLIP = _other("flip_invalid_normals", "boolean", True,
               "Mirror the perturbed normal's tangential part where it faces away from the "
               "viewer (Schüssler et al. 2017), as Mitsuba's ``normalmap`` and ``bumpmap`` do.")
_SHADOWING_FUNCTION = _other(
    "use_shadowing_function", "boolean", True,
    "Multiply by Estevez et al. 2019's shadowing term of the perturbed normal (softens the "
    "bump-terminator edge), as Mitsuba's ``normalmap`` and ``bumpmap`` do.")


def _sunsky(name: str, default, doc: str, kind: str = "number",
            flags_doc: str = "``intensity.*``", **bounds) -> Parameter:
    """A parameter that ``polarized_sky`` hands to its internal ``sunsky``,
    whose default (Mitsuba 3.9.1's) applies where it is not given."""
    return _other(name, kind, default, doc, default_doc=f"``sunsky``'s: {default:.7g}",
                  flags_doc=flags_doc, **bounds)


_DATE = "``intensity.*`` (not differentiable)"   # the sun's position is read-only

#: The declared parameters of each plugin, by the name scene files give it
#: (``pbrdf``: :data:`PARAMETERS`). A plugin's other rows (nested objects,
#: files, directions, transforms) are read and documented in its module.
PLUGIN_PARAMETERS = {
    "pbrdf": tuple(p for p in PARAMETERS if p.plugin),
    "polarized_normalmap": (_FLIP, _SHADOWING_FUNCTION),
    "polarized_twosided": (),   # its two nested BSDFs only
    "polarized_bumpmap": (
        _other("scale", "number", 1.0, "Multiplier of the height gradient; a finite number "
               "(not a boolean), re-checked at ``parameters_changed``.", flags_doc="|exposed|"),
        _FLIP, _SHADOWING_FUNCTION),
    "polarized_sky": (
        _other("model", "choice", "rayleigh",
               "``rayleigh``: single scattering, DoLP = ``dolp_max`` sin²γ/(1 + cos²γ) (γ: "
               "angle between the viewing direction and the sun), polarized perpendicular to "
               "the plane through the sun and the viewing direction. ``berry``: the neutral "
               "points of the real sky (Babinet, Brewster, Arago and the fourth), Berry, "
               "Dennis and Lee, New J. Phys. 6 (2004) 162.", choices=("rayleigh", "berry")),
        _other("dolp_max", "number", 0.8,
               "Degree of linear polarization at 90° from the sun (Rayleigh); clear skies "
               "reach 0.7-0.8.", lower=0.0, upper=1.0, differentiable=True,
               flags_doc="|exposed|, |differentiable| (JIT variants)"),
        _other("neutral_point_separation", "number", 35.0,
               "``berry`` only: the angle in degrees between the Babinet point (above the "
               "sun) and the Brewster point (below it); each lies half of it from the sun. "
               "The Babinet point is typically observed 15-20° above the sun.",
               lower=0.0, upper=90.0),
        _sunsky("turbidity", 3.0, "Turbidity of the ``sunsky`` intensity (Hosek-Wilkie sky "
                "and sun), handed to the internal ``sunsky`` as the rows below.",
                lower=1.0, upper=10.0),
        _sunsky("sun_scale", 1.0, "Factor on the ``sunsky`` intensity's sun.", lower=0.0),
        _sunsky("sky_scale", 1.0, "Factor on the ``sunsky`` intensity's sky.", lower=0.0),
        _sunsky("sun_aperture", 0.5358, "Apparent diameter of the ``sunsky`` intensity's sun, "
                "degrees.", lower=1e-3, upper=179.9),
        _sunsky("albedo", 0.3, "Ground albedo of the ``sunsky`` intensity: a number, or a "
                "spectrum as ``sunsky`` takes it.", lower=0.0, upper=1.0),
        _sunsky("year", 2010, "Instead of ``sun_direction``, with the rest of the date, the "
                "time and the place: the sun ``sunsky`` puts there (+X south, +Y west in its "
                "frame, measured), which must be above the horizon. Only with the ``sunsky`` "
                "intensity.", kind="integer", flags_doc=_DATE),
        _sunsky("month", 7, "Month of the date.", kind="integer", lower=1, upper=12,
                flags_doc=_DATE),
        _sunsky("day", 10, "Day of the month.", kind="integer", lower=1, upper=31,
                flags_doc=_DATE),
        _sunsky("hour", 15.0, "Local time: hours.", lower=0.0, upper=24.0, flags_doc=_DATE),
        _sunsky("minute", 0.0, "Local time: minutes.", lower=0.0, upper=60.0, flags_doc=_DATE),
        _sunsky("second", 0.0, "Local time: seconds.", lower=0.0, upper=60.0, flags_doc=_DATE),
        _sunsky("latitude", 35.6894, "Latitude of the place, degrees north.", lower=-90.0,
                upper=90.0, flags_doc=_DATE),
        _sunsky("longitude", 139.6917, "Longitude of the place, degrees east.", lower=-180.0,
                upper=180.0, flags_doc=_DATE),
        _sunsky("timezone", 9.0, "Time zone of the local time, hours from UTC.", lower=-12.0,
                upper=14.0, flags_doc=_DATE)),
    "polarized_emitter": (
        _other("angle", "number", 0.0,
               "The polarizer's transmission axis in degrees, from the local x axis towards "
               "the local y axis of ``to_world``."),
        _other("degree", "number", 1.0,
               "Degree of linear polarization the filter gives unpolarized light (1: an ideal "
               "polarizer; less: a leaky one).", lower=0.0, upper=1.0),
        _other("transmittance", "number", 1.0,
               "Fraction of an unpolarized lamp's radiance the filter passes. An ideal "
               "polarizer passes 0.5; the default keeps the lamp's radiance and polarizes it "
               "(and so doubles light already polarized along its axis, see below).",
               lower=0.0, upper=1.0)),
    "stokes_prb": (   # Mitsuba's ADIntegrator reads them too, with the same defaults
        _other("max_depth", "integer", 6, "Longest path, as in ``path`` (1: emitters seen "
               "directly, 2: direct illumination, ...); the replay stores each vertex of a "
               "sample in local memory, so the depth must be finite.", lower=0, upper=64),
        _other("rr_depth", "integer", 5, "Depth at which Russian roulette starts, as in "
               "``path``.", positive=True),
        _other("hide_emitters", "boolean", False, "Hide directly visible emitters, as in "
               "``path``.")),
    "stokes_envmap": (
        _other("scale", "number", 1.0, "Factor on the radiance.", lower=0.0,
               flags_doc="``intensity.scale``"),),
}

SHADOWING = parameter("shadowing").choices
#: The reference evaluator also offers ``"none"`` (G = 1: the original
#: Priest-Germer model, unbounded at grazing; for validation plots only).
REFERENCE_SHADOWING = SHADOWING + parameter("shadowing").reference_choices
DD_DISTRIBUTIONS = parameter("dd_distribution").choices
DISTRIBUTIONS = parameter("distribution").choices
SAMPLING = parameter("sampling").choices
