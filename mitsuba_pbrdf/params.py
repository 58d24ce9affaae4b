"""Reading and checking the ``pbrdf`` plugin's parameters.

Every check raises ``ValueError`` (bad value) or ``TypeError`` (bad type) whose
message starts with ``pbrdf:`` and names the offending parameter, so a bad scene
fails at load time instead of rendering black or NaN pixels.
"""

import math

import drjit as dr
import mitsuba as mi
import numpy as np

# Texture parameters holding values (as opposed to wavelengths or UV transforms).
_VALUE_KEYS = ("value", "values", "data", "color")

_TEXTURE_TYPES = (mi.Properties.Type.Float, mi.Properties.Type.Integer, mi.Properties.Type.Color,
                  mi.Properties.Type.Spectrum, mi.Properties.Type.Object)


def choice(props, name, options, default):
    """A string parameter restricted to ``options`` (case-insensitive)."""
    if name not in props:
        return default
    if props.type(name) != mi.Properties.Type.String:
        raise TypeError(f"pbrdf: parameter '{name}' must be a string, one of {', '.join(options)}")
    value = props[name].lower()
    if value not in options:
        raise ValueError(f"pbrdf: parameter '{name}' is {props[name]!r}; "
                         f"valid values: {', '.join(options)}")
    return value


def texture(props, name, default, *, spectral, positive=False):
    """A float/spectrum/texture parameter, checked to be finite and >= 0
    (> 0 when ``positive``) everywhere.

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
        if kind in (mi.Properties.Type.Float, mi.Properties.Type.Integer):
            _check_number(name, props[name], positive)
        elif kind == mi.Properties.Type.Color:  # <rgb>: check the colour as written
            for component in props[name]:
                _check_number(name, float(component), positive)
    tex = props.get_unbounded_texture(name, default) if spectral else props.get_texture(name, default)
    check_texture_values(name, tex, positive)
    return tex


def check_texture_values(name, tex, positive=False):
    """Raise if texture ``tex`` holds or evaluates to a NaN, infinite or
    negative value (or zero when ``positive``).

    Values stored as they are (uniform, tabulated spectra, RGB in non-spectral
    variants) are checked exactly. Spectral variants store RGB colours and
    bitmaps as spectral-upsampling coefficients, so such textures are checked
    by evaluating them over a grid of UV positions and wavelengths instead.
    """
    stored, coefficients = _stored_values(tex)
    arrays = list(stored)
    if coefficients:
        arrays.append(_evaluated_values(tex))
    for values in arrays:
        if values.size == 0:
            continue
        if not np.all(np.isfinite(values)):
            raise ValueError(f"pbrdf: parameter '{name}' contains NaN or infinite values")
        low = float(values.min())
        if low < 0 or (positive and low <= 0):
            bound = "> 0" if positive else ">= 0"
            raise ValueError(f"pbrdf: parameter '{name}' must be {bound} everywhere, "
                             f"found {low:g}")


def texture_values(tex):
    """The values a texture holds or evaluates to, as float64 arrays."""
    stored, coefficients = _stored_values(tex)
    return stored + ([_evaluated_values(tex)] if coefficients else [])


def _stored_values(tex):
    """(arrays of values stored as they are, whether some leaves hold
    spectral-upsampling coefficients instead)."""
    params = mi.traverse(tex)
    stored, coefficients = [], False
    for key in params.keys():
        if key.split(".")[-1] not in _VALUE_KEYS:
            continue
        node = params.properties[key][2]
        if mi.is_spectral and node.class_name().startswith(_COEFFICIENT_CLASSES):
            coefficients = True
            continue
        value = params[key]
        stored.append(np.asarray(dr.detach(value).numpy() if hasattr(value, "numpy")
                                 else value, dtype=np.float64).ravel())
    return stored, coefficients


# Texture classes whose values are spectral-upsampling coefficients in spectral variants.
_COEFFICIENT_CLASSES = ("SRGBReflectanceSpectrum", "BitmapTexture")


def _evaluated_values(tex, resolution=64, wavelengths=(360.0, 830.0, 24)):
    """The texture evaluated on a ``resolution``^2 grid of UV positions (texel
    centres of a grid that fine) at wavelengths spanning the visible range."""
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
        value = tex.eval(si)
        out.append(np.asarray(value, dtype=np.float64).ravel())
    return np.concatenate(out)


def is_constant_zero(tex):
    """True when the texture holds only zeros (its lobe can be skipped)."""
    values = texture_values(tex)
    return bool(values) and all(v.size > 0 and not np.any(v) for v in values)


def _check_number(name, value, positive):
    if not math.isfinite(value):
        raise ValueError(f"pbrdf: parameter '{name}' is {value}; it must be a finite number")
    if value < 0 or (positive and value <= 0):
        bound = "> 0" if positive else ">= 0"
        raise ValueError(f"pbrdf: parameter '{name}' is {value:g}; it must be {bound}")
