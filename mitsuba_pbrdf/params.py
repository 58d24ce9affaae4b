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
    if name in props and props.type(name) not in _TEXTURE_TYPES:
        raise TypeError(f"pbrdf: parameter '{name}' must be a float, spectrum or texture, "
                        f"got {props.type(name).name.lower()} {props.as_string(name)!r}")
    if name in props and props.type(name) == mi.Properties.Type.Object and \
            not isinstance(props[name], mi.Texture):
        raise TypeError(f"pbrdf: parameter '{name}' must be a texture, "
                        f"got {type(props[name]).__name__}")
    if name in props and props.type(name) in (mi.Properties.Type.Float, mi.Properties.Type.Integer):
        _check_number(name, props[name], positive)
    tex = props.get_unbounded_texture(name, default) if spectral else props.get_texture(name, default)
    check_texture_values(name, tex, positive)
    return tex


def check_texture_values(name, tex, positive=False):
    """Raise if any value stored in texture ``tex`` is NaN, infinite or negative
    (or zero when ``positive``)."""
    for values in texture_values(tex):
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
    """The arrays of values held by a texture (its traversable value leaves)."""
    params = mi.traverse(tex)
    out = []
    for key in params.keys():
        if key.split(".")[-1] in _VALUE_KEYS:
            value = params[key]
            out.append(np.asarray(dr.detach(value).numpy() if hasattr(value, "numpy")
                                  else value, dtype=np.float64).ravel())
    return out


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
