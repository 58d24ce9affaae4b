"""Reading and checking the ``pbrdf`` plugin's textures and widths (the
general readers are :mod:`mitsuba_pbrdf.properties`).

Every check raises ``ValueError`` (bad value) or ``TypeError`` (bad type) whose
message starts with ``pbrdf:`` and names the offending parameter, so a bad scene
fails at load time instead of rendering black or NaN pixels.
"""

import math
from typing import NamedTuple

import drjit as dr
import mitsuba as mi
import numpy as np

from .. import schema

# Texture parameters holding values (as opposed to wavelengths or UV transforms).
_VALUE_KEYS = ("value", "values", "data", "color")

_TEXTURE_TYPES = (mi.Properties.Type.Float, mi.Properties.Type.Integer, mi.Properties.Type.Color,
                  mi.Properties.Type.Spectrum, mi.Properties.Type.Object)


def declared(props, parameter, default=None):
    """Parameter *parameter* (a :class:`mitsuba_pbrdf.schema.Parameter` of kind
    ``float`` or ``spectrum``) read from *props* and checked against its
    declared bounds; *default* replaces the declared default."""
    return texture(props, parameter.name, parameter.default if default is None else default,
                   spectral=parameter.kind == "spectrum", positive=parameter.positive,
                   minimum=parameter.floor, smooth_at_zero=parameter.smooth_at_zero)


class Width(NamedTuple):
    """A lobe's width as the scene gives it: a float ``texture``, the ``name``
    it is given (and exposed) under, ``sigma_u`` or Mitsuba's ``alpha_u``, and
    ``to_alpha``, the distribution's alpha per value (sqrt(2) for a slope
    sigma, 1 for an alpha)."""

    texture: object
    name: str
    to_alpha: float

    def alpha(self, si, active):
        """The distribution's width alpha at ``si``."""
        return self.to_alpha * self.texture.eval_1(si, active)

    def __str__(self):  # an alias's value is not the slope: say so
        if self.to_alpha == schema.ALPHA_PER_SIGMA:
            return str(self.texture)
        return f"{self.texture} (given as {self.name})"


def read_width(props, name):
    """Width parameter *name* (``sigma``, ``sigma_u`` ...) as a :class:`Width`,
    given under its name or its alias (Mitsuba's ``alpha``, ``alpha_u`` ...),
    checked against the declaration of the name it is given under; None
    where neither is given. Both refused, naming both."""
    p = schema.parameter(name)
    given = [n for n in _names(name) if n in props]
    if len(given) == 2:
        a = p.alias
        factor = "sqrt(2)" if a.scale == schema.ALPHA_PER_SIGMA else f"{a.scale:g}"
        raise ValueError(f"pbrdf: give either '{name}' or '{a.name}' "
                         f"({a.name} = {factor} {name}), not both")
    as_given = schema.parameter(given[0] if given else name)
    if not given and as_given.default is None:
        return None
    return Width(declared(props, as_given), as_given.name, schema.ALPHA_PER_SIGMA / as_given.scale)


def _names(name):
    """The names parameter *name* may be given under: its own, its alias."""
    alias = schema.parameter(name).alias
    return (name, alias.name) if alias else (name,)


def read_refinement(props, name, refined):
    """A refinement (``sigma_u``) as given, else the *refined* parameter's
    :class:`Width` (``sigma``) where any of its refinements is given, else
    None (the lobe is isotropic). Given under an alias, a refinement is
    exposed under its alias (a defaulted one under the alias of its own name
    where *refined* was given as an alias: ``alpha_u`` takes ``alpha``)."""
    own = read_width(props, name)
    if own is not None:
        return own
    refinements = schema.REFINEMENTS[schema.parameter(name).refines]
    if not any(n in props for r in refinements for n in _names(r)):
        return None
    exposed = name if refined.name == schema.parameter(name).refines \
        else schema.parameter(name).alias.name
    return Width(refined.texture, exposed, refined.to_alpha)


def is_smooth(width_u, width_v):
    """Whether a lobe of widths ``width_u``, ``width_v`` (None: isotropic) is
    the smooth limit, a delta lobe: every width exactly 0. A lobe smooth
    along one axis only is refused (a delta in one direction, a microfacet
    spread in the other, is no lobe Mitsuba can sample)."""
    widths = [w for w in (width_u, width_v) if w is not None]
    zero = [is_constant_zero(w.texture) for w in widths]
    if any(zero) and not all(zero):
        flat = widths[zero.index(True)].name
        rough = widths[zero.index(False)].name
        raise ValueError(f"pbrdf: '{flat}' is 0 (smooth) but '{rough}' is not: a lobe is "
                         f"smooth only where both widths are 0; give '{flat}' >= "
                         f"{schema.parameter(flat).floor:.3g} for a nearly smooth axis")
    return all(zero)


def projected(width_u, width_v):
    """Whether a lobe of widths ``width_u``, ``width_v`` (None: isotropic)
    needs Smith's G1 projected on the azimuth: anisotropic, unless both are
    the same number. Decided from the textures at load time, as
    roughconductor decides ``Anisotropic``: their values may be traced."""
    if width_v is None:
        return False
    u, v = constant(width_u.texture), constant(width_v.texture)
    return u is None or v is None or u * width_u.to_alpha != v * width_v.to_alpha


def texture(props, name, default, *, spectral, positive=False, minimum=None,
            smooth_at_zero=False):
    """A float/spectrum/texture parameter, checked to be finite and >= 0
    (> 0 when ``positive``, >= ``minimum`` when given) everywhere; where
    ``smooth_at_zero``, a texture that is 0 everywhere passes too.

    ``spectral`` parameters may exceed 1 (unbounded textures); float parameters
    are evaluated with ``eval_1``.
    """
    if name in props:
        kind = props.type(name)
        if kind not in _TEXTURE_TYPES:
            raise TypeError(f"pbrdf: parameter '{name}' must be a float, spectrum or texture, "
                            f"got {kind.name.lower()} {props.as_string(name)!r}")
        if kind == mi.Properties.Type.Object and not isinstance(props[name], mi.Texture):
            raise TypeError(f"pbrdf: parameter '{name}' must be a texture, "
                            f"got {type(props[name]).__name__}")
        if kind in (mi.Properties.Type.Float, mi.Properties.Type.Integer) \
                and not (smooth_at_zero and props[name] == 0):
            _check_number(name, props[name], positive, minimum)
        elif kind == mi.Properties.Type.Color:  # <rgb>: check the colour as written
            colour = [float(c) for c in props[name]]
            for component in colour:
                _check_number(name, component, positive, minimum)
            if spectral and mi.is_spectral and max(colour) > 1.0:
                raise ValueError(_RGB_ABOVE_ONE.format(
                    name=name, colour=", ".join(f"{c:g}" for c in colour)))
    try:
        get = props.get_unbounded_texture if spectral else props.get_texture
        tex = get(name) if default is None else get(name, default)
    except RuntimeError as error:  # e.g. an inline spectrum Mitsuba refuses
        reason = str(error).strip().splitlines()[-1]
        raise ValueError(f"pbrdf: parameter '{name}' is invalid: {reason}") from None
    if smooth_at_zero and is_constant_zero(tex):
        return tex
    check_texture_values(name, tex, positive, minimum, spectral=spectral)
    return tex


#: Mitsuba 3.9.1's spectral variants upsample every ``<rgb>`` colour as a
#: reflectance (values in [0, 1]), also where an unbounded texture is asked for:
#: grey 1.5 evaluates to 1.0 and (1.2, 0.3, 0.3) to another colour. Refused
#: rather than silently changed.
_RGB_ABOVE_ONE = ("pbrdf: parameter '{name}' is an RGB colour above 1 ({colour}), which "
                  "Mitsuba's spectral variants clip to a reflectance <= 1; give a number, "
                  "a <spectrum> of wavelength:value pairs over 360-830 nm "
                  "(e.g. value=\"360:1.5, 550:1.2, 830:2.0\") or a material")


def check_texture_values(name, tex, positive=False, minimum=None, spectral=True):
    """Raise if texture ``tex`` holds or evaluates to a NaN, infinite or
    negative value (zero when ``positive``, below ``minimum`` when given).

    Values stored as they are (uniform, tabulated spectra, one-channel bitmaps,
    RGB in non-spectral variants) are checked exactly. Spectral variants store
    RGB colours and three-channel bitmaps as spectral-upsampling coefficients;
    those, and tabulated spectra (zero outside their wavelength range), are
    also evaluated at every texel centre and at wavelengths spanning Mitsuba's
    spectral range. A float parameter (``spectral`` false) is also evaluated
    the way the kernel evaluates it, with ``eval_1``: a texture that cannot
    give one value per point (an RGB bitmap in a spectral variant, such as an
    ordinary 8-bit PNG) is refused naming the parameter.
    """
    evaluated = [] if spectral else [_eval_1_values(name, tex)]
    for values in texture_values(tex) + evaluated:
        if values.size == 0:
            continue
        if not np.all(np.isfinite(values)):
            raise ValueError(f"pbrdf: parameter '{name}' contains NaN or infinite values")
        low = float(values.min())
        # textures hold float32: a floor given in Python (1e-4) is as stored
        if minimum is not None and low < float(np.float32(minimum)):
            raise ValueError(f"pbrdf: parameter '{name}' must be >= {minimum:.3g} everywhere, "
                             f"found {low:g}")
        if low < 0 or (positive and low <= 0):
            bound = "> 0" if positive else ">= 0"
            raise ValueError(f"pbrdf: parameter '{name}' must be {bound} everywhere "
                             f"(over the whole spectral range), found {low:g}")


def texture_values(tex):
    """The values a texture holds or evaluates to, as float64 arrays."""
    params = mi.traverse(tex)
    stored, evaluate, resolution = [], False, 1
    for key in params.keys():
        if key.split(".")[-1] not in _VALUE_KEYS:
            continue
        node = params.properties[key][2]
        value = params[key]
        array = np.asarray(dr.detach(value).numpy() if hasattr(value, "numpy") else value,
                           dtype=np.float64)
        cls = node.class_name()
        if cls.startswith("BitmapTexture"):
            resolution = min(max(resolution, *array.shape[:2]), _MAX_EVALUATED_RESOLUTION)
        if mi.is_spectral and cls.startswith(_EVALUATED_CLASSES):
            evaluate = True
            coefficients = cls.startswith("SRGB") or (cls.startswith("BitmapTexture")
                                                      and array.shape[-1] != 1)
            if coefficients:
                continue  # not values: only the evaluation tells
        stored.append(array.ravel())
    return stored + ([_evaluated_values(tex, resolution)] if evaluate else [])


# Bitmaps up to this size are evaluated at every texel centre, larger ones on
# a grid this fine (one-channel bitmaps are checked exactly whatever their size).
_MAX_EVALUATED_RESOLUTION = 1024

# Texture classes checked by evaluation in spectral variants: spectral-upsampling
# coefficients (RGB colours, bitmaps) and spectra that vanish outside their table.
_EVALUATED_CLASSES = ("SRGBReflectanceSpectrum", "BitmapTexture", "IrregularSpectrum",
                      "RegularSpectrum")


def _evaluated_values(tex, resolution, wavelengths=(360.0, 830.0, 24)):
    """The texture evaluated at the texel centres of a ``resolution``^2 grid
    (every texel of a bitmap up to that size) at wavelengths spanning
    Mitsuba's spectral range."""
    if mi.variant().startswith("scalar"):
        resolution = 1  # one lane per call: the centre only
    u = (np.arange(resolution) + 0.5) / resolution
    uu, vv = np.meshgrid(u, u)
    si = dr.zeros(mi.SurfaceInteraction3f, uu.size)
    si.uv = mi.Point2f(uu.ravel(), vv.ravel()) if resolution > 1 else mi.Point2f(0.5, 0.5)
    lambdas = np.linspace(*wavelengths)
    out = []
    for start in range(0, len(lambdas), 4):
        block = list(lambdas[start:start + 4]) + [lambdas[-1]] * (4 - len(lambdas[start:start + 4]))
        si.wavelengths = mi.UnpolarizedSpectrum(*(float(b) for b in block))
        out.append(np.asarray(tex.eval(si), dtype=np.float64).ravel())
    return np.concatenate(out)


def _eval_1_values(name, tex):
    """``tex.eval_1`` at the texel centres (as :func:`_evaluated_values`);
    ValueError naming *name* when the texture has no ``eval_1``."""
    resolution = 1
    params = mi.traverse(tex)
    for key in params.keys():
        if key.split(".")[-1] == "data" and hasattr(params[key], "shape"):
            resolution = min(max(resolution, *tuple(params[key].shape)[:2]),
                             _MAX_EVALUATED_RESOLUTION)
    if mi.variant().startswith("scalar"):
        resolution = 1
    u = (np.arange(resolution) + 0.5) / resolution
    uu, vv = np.meshgrid(u, u)
    si = dr.zeros(mi.SurfaceInteraction3f, uu.size)
    si.uv = mi.Point2f(uu.ravel(), vv.ravel()) if resolution > 1 else mi.Point2f(0.5, 0.5)
    try:
        with dr.suspend_grad():  # a check: no derivative graph (parameters_changed runs in AD)
            values = tex.eval_1(si)
            dr.eval(values)
        return np.asarray(values, dtype=np.float64).ravel()
    except Exception as e:  # noqa: BLE001 - Mitsuba's refusal, a RuntimeError today
        reason = " ".join(str(e).split("\n")[-1].split()) or type(e).__name__
        if "monochromatic" in str(e):
            reason = ("an RGB texture cannot give one value per point in a spectral variant "
                      "(e.g. an ordinary 8-bit RGB PNG)")
        raise ValueError(f"pbrdf: parameter '{name}' takes one value per point (eval_1): "
                         f"{reason}; give a number or a one-channel bitmap (raw = true)") from None


def constant(tex):
    """The texture's value where it holds one number (a float or uniform
    texture), else None."""
    values = texture_values(tex)
    return float(values[0][0]) if len(values) == 1 and values[0].size == 1 else None


def is_constant_zero(tex):
    """True when the texture holds only zeros (its lobe can be skipped)."""
    values = texture_values(tex)
    return bool(values) and all(v.size > 0 and not np.any(v) for v in values)


def _check_number(name, value, positive, minimum=None):
    if not math.isfinite(value):
        raise ValueError(f"pbrdf: parameter '{name}' is {value}; it must be a finite number")
    if minimum is not None and value < minimum:
        raise ValueError(f"pbrdf: parameter '{name}' is {value:g}; it must be >= {minimum:.3g}")
    if value < 0 or (positive and value <= 0):
        bound = "> 0" if positive else ">= 0"
        raise ValueError(f"pbrdf: parameter '{name}' is {value:g}; it must be {bound}")
