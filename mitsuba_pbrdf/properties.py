"""Reading and checking Mitsuba ``Properties``: the one reader of every
plugin's parameters, with one-line errors that name the plugin and the
parameter (``ValueError`` for a bad value,
``TypeError`` for a bad type), raised in the constructor so that a bad scene
fails at load time. Plain functions: ``mi.*`` is looked up when called, so
this module serves every variant without a reload.

Mitsuba refuses a scene whose plugin leaves a property unread; every helper
here reads what it checks.
"""

from __future__ import annotations

import math

import mitsuba as mi

from .schema import bounds_doc, parameter

_NUMBER = (mi.Properties.Type.Float, mi.Properties.Type.Integer)


def number(props, plugin, name, default=None, low=None, high=None, what=""):
    """A finite float parameter in [low, high] (either bound optional);
    ``default`` where absent (None: required)."""
    if name not in props:
        if default is None:
            raise ValueError(f"{plugin}: parameter '{name}' is required{what}")
        return float(default)
    if props.type(name) not in _NUMBER:
        raise TypeError(f"{plugin}: parameter '{name}' must be a number, "
                        f"got {props.type(name).name.lower()} {props.as_string(name)!r}")
    value = float(props[name])
    if not math.isfinite(value):
        raise ValueError(f"{plugin}: parameter '{name}' must be finite, got {value}")
    if (low is not None and value < low) or (high is not None and value > high):
        raise ValueError(f"{plugin}: parameter '{name}' must be {bounds_doc(low, high)}{what}, "
                         f"got {value:g}")
    return value


def declared(props, plugin, name):
    """Plugin *plugin*'s parameter *name* read and checked against its
    declaration (:data:`mitsuba_pbrdf.schema.PLUGIN_PARAMETERS`): a choice, a
    boolean, a bounded number or integer; its declared default where absent."""
    p = parameter(name, plugin)
    if p.kind == "choice":
        return choice(props, plugin, name, p.choices, p.default)
    if p.kind == "boolean":
        return flag(props, plugin, name, p.default)
    value = number(props, plugin, name, p.default, p.lower, p.upper)
    if p.positive and not value > 0:
        raise ValueError(f"{plugin}: parameter '{name}' must be > 0, got {value:g}")
    if p.kind == "integer":
        if value != int(value):
            raise ValueError(f"{plugin}: parameter '{name}' must be a whole number, got {value:g}")
        return int(value)
    return value


def direction(props, plugin, name):
    """A required non-zero, finite 3-vector, normalized (a tuple of floats)."""
    if name not in props:
        raise ValueError(f"{plugin}: parameter '{name}' is required (a direction, e.g. "
                         f"<vector name=\"{name}\" x=\"0\" y=\"0.5\" z=\"1\"/>)")
    if props.type(name) not in (mi.Properties.Type.Vector, mi.Properties.Type.Color):
        raise TypeError(f"{plugin}: parameter '{name}' must be a vector, "
                        f"got {props.type(name).name.lower()} {props.as_string(name)!r}")
    value = [float(c) for c in props[name]]
    return unit_vector(plugin, name, value)


def unit_vector(plugin, name, value):
    """``value`` (3 numbers) normalized; a one-line error if it has no direction."""
    value = [float(c) for c in value]
    if len(value) != 3 or not all(math.isfinite(c) for c in value):
        raise ValueError(f"{plugin}: parameter '{name}' must be 3 finite numbers, got {value}")
    length = math.sqrt(sum(c * c for c in value))
    if length < 1e-12:
        raise ValueError(f"{plugin}: parameter '{name}' has zero length: it must point "
                         "somewhere")
    return tuple(c / length for c in value)


def choice(props, plugin, name, options, default):
    """A string parameter restricted to ``options`` (case-insensitive)."""
    if name not in props:
        return default
    if props.type(name) != mi.Properties.Type.String:
        raise TypeError(f"{plugin}: parameter '{name}' must be a string, one of "
                        f"{', '.join(options)}")
    value = props[name].lower()
    if value not in options:
        raise ValueError(f"{plugin}: parameter '{name}' is {props[name]!r}; valid values: "
                         f"{', '.join(options)}")
    return value


def string(props, plugin, name, default=None):
    """A string parameter; ``default`` where absent (None: required)."""
    if name not in props:
        if default is None:
            raise ValueError(f"{plugin}: parameter '{name}' is required")
        return default
    if props.type(name) != mi.Properties.Type.String:
        raise TypeError(f"{plugin}: parameter '{name}' must be a string")
    return props[name]


def flag(props, plugin, name, default):
    """A boolean parameter; ``default`` where absent."""
    if name not in props:
        return default
    if props.type(name) != mi.Properties.Type.Bool:
        raise TypeError(f"{plugin}: parameter '{name}' must be a boolean")
    return bool(props[name])


def nested_objects(props, kinds):
    """``{key: object}`` of the nested objects of ``props`` that are instances
    of ``kinds`` (read, so Mitsuba counts them as used)."""
    return {key: props[key] for key in props.keys()
            if props.type(key) == mi.Properties.Type.Object and isinstance(props[key], kinds)}


def single_nested(props, plugin, kind):
    """The one nested object of type *kind* (``mi.BSDF``); a one-line error
    otherwise."""
    found = nested_objects(props, kind)
    if len(found) != 1:
        raise ValueError(f"{plugin}: exactly one nested {kind.__name__} must be given, "
                         f"found {len(found)}")
    return next(iter(found.values()))


#: A transform whose 3 x 3 part has |det| below this fraction of the product
#: of its column lengths (the largest |det| such columns allow) is singular:
#: it squeezes local directions into a plane, and no direction maps back.
SINGULAR = 1e-6


def _det3(m):
    """The determinant of a 3 x 3 list of rows."""
    return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))


def transform(props, plugin, name):
    """The transform *name* (``"to_world"``) as a 4 x 4 list of rows (identity
    if absent): finite, with an invertible 3 x 3 part (see :data:`SINGULAR`),
    which the emitters invert to map world directions back."""
    if name not in props:
        return [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]
    if props.type(name) != mi.Properties.Type.Transform:
        raise TypeError(f"{plugin}: parameter '{name}' must be a transform, got "
                        f"{props.type(name).name.lower()} {props.as_string(name)!r}")
    matrix = props[name].matrix
    rows = [[float(matrix[i][j]) for j in range(4)] for i in range(4)]
    if not all(math.isfinite(c) for row in rows for c in row):
        raise ValueError(f"{plugin}: parameter '{name}' contains NaN or infinite values")
    m = [row[:3] for row in rows[:3]]
    det = _det3(m)
    bound = math.prod(math.sqrt(sum(m[i][j] ** 2 for i in range(3))) for j in range(3))
    if not abs(det) > SINGULAR * bound:
        raise ValueError(f"{plugin}: parameter '{name}' is singular (its 3 x 3 part has "
                         f"determinant {det:.3g}): it must map local directions one to one, "
                         "e.g. a rotation")
    return rows


def rotation(props, plugin, name):
    """The rotation (3 x 3 rows) of the transform *name* (:func:`transform`,
    checked): its 3 x 3 part divided by its uniform scale. For infinite
    emitters: Mitsuba's ``envmap`` and ``sunsky`` look their texels up at the
    un-normalized ``to_world⁻¹ w``, right for rotations only (a scale of 2
    moved an envmap's S0 by up to 48 % of its maximum, a sunsky's by 8 %),
    and a mirror would flip a Stokes basis's handedness: any other transform
    is refused."""
    m = [row[:3] for row in transform(props, plugin, name)[:3]]
    det = _det3(m)
    r = [[c / math.copysign(abs(det) ** (1.0 / 3.0), det) for c in row] for row in m]
    error = max(abs(sum(r[i][k] * r[j][k] for k in range(3)) - (i == j))
                for i in range(3) for j in range(3))
    if det <= 0 or error > 1e-4:
        raise ValueError(f"{plugin}: parameter '{name}' must be a rotation (times a uniform "
                         "scale, which changes nothing); it mirrors, shears or scales unevenly")
    return r


def as_transform(rows):
    """A ``mi.ScalarTransform4f`` of the 3 x 3 ``rows`` (no translation)."""
    m = [[float(c) for c in row] + [0.0] for row in rows] + [[0.0, 0.0, 0.0, 1.0]]
    return mi.ScalarTransform4f(m)


def leftover(props, plugin, allowed=()):
    """Raise naming the first property the plugin did not expect."""
    for key in props.keys():
        if key not in allowed:
            raise ValueError(f"{plugin}: unknown parameter '{key}'")


def nonnegative_texture(plugin, name, texture):
    """Raise if ``texture`` evaluates to a negative, NaN or infinite value at
    any of 256 wavelengths spanning 360-830 nm (spectral variants) or in any
    channel; uniform and spectral textures have no spatial variation to
    check (``radiance`` of an infinite emitter is evaluated without uv)."""
    import drjit as dr
    import numpy as np

    n = 64
    lam = np.linspace(360.0, 830.0, 4 * n).reshape(4, n)
    if mi.variant().startswith("scalar"):    # one lane per call (load time only)
        values = []
        for k in range(n):
            si = dr.zeros(mi.SurfaceInteraction3f)
            if mi.is_spectral:
                si.wavelengths = mi.UnpolarizedSpectrum(*lam[:, k])
            values.append(np.array(texture.eval(si), dtype=np.float64).ravel())
        values = np.concatenate(values)
    else:
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        if mi.is_spectral:
            si.wavelengths = mi.UnpolarizedSpectrum(*[mi.Float(row) for row in lam])
        values = np.array(texture.eval(si), dtype=np.float64)
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{plugin}: parameter '{name}' contains NaN or infinite values")
    if values.min() < 0:
        raise ValueError(f"{plugin}: parameter '{name}' must be >= 0 everywhere (over the "
                         f"whole spectral range), found {values.min():g}")


def nonnegative_texels(plugin, name, texture):
    """Raise if a spatially varying ``texture`` is negative, NaN or infinite.
    A bitmap whose texels are stored as values (every bitmap outside
    spectral variants; one-channel bitmaps in them) is checked texel by
    texel, naming the first bad one (column, row). Other textures are
    evaluated on a 512 x 256 grid of texture coordinates (64 x 32 in scalar
    variants), at 8 wavelengths spanning 360-830 nm in spectral variants,
    naming the first bad (u, v). A spectral variant's three-channel bitmap
    stores spectral-upsampling coefficients: Mitsuba's conversion has
    already mapped its NaN and negative texels to valid spectra, so only
    what the texture returns can be checked there."""
    import drjit as dr
    import numpy as np

    stored = mi.traverse(texture)
    if "data" in stored:
        data = np.array(stored["data"], np.float64)
        if data.ndim == 3 and (not mi.is_spectral or data.shape[2] == 1):
            for what, bad in (("NaN or infinite values", ~np.isfinite(data)),
                              ("negative values", data < 0)):
                texels = np.argwhere(bad.any(-1))
                if texels.size:
                    row, column = texels[0]
                    raise ValueError(f"{plugin}: parameter '{name}' has {len(texels)} "
                                     f"texel(s) with {what} (first at column {column}, row "
                                     f"{row}); it must be >= 0 everywhere")
            return
    width, height = (64, 32) if mi.variant().startswith("scalar") else (512, 256)
    j, i = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    u, v = ((i + 0.5) / width).ravel(), ((j + 0.5) / height).ravel()
    sets = np.linspace(360.0, 830.0, 8).reshape(2, 4) if mi.is_spectral else [None]
    columns = []      # per wavelength set: (points, channels)
    for lam in sets:
        if mi.variant().startswith("scalar"):      # one lane per call (load time only)
            rows = []
            for k in range(u.size):
                si = dr.zeros(mi.SurfaceInteraction3f)
                si.uv = mi.Point2f(u[k], v[k])
                if lam is not None:
                    si.wavelengths = mi.UnpolarizedSpectrum(*lam)
                rows.append(np.array(texture.eval(si), np.float64).ravel())
            columns.append(np.array(rows))
        else:
            si = dr.zeros(mi.SurfaceInteraction3f, u.size)
            si.uv = mi.Point2f(mi.Float(u), mi.Float(v))
            if lam is not None:
                si.wavelengths = mi.UnpolarizedSpectrum(*[float(x) for x in lam])
            columns.append(np.array(texture.eval(si), np.float64).reshape(-1, u.size).T)
    values = np.concatenate(columns, -1)
    for what, bad in (("NaN or infinite", ~np.isfinite(values)), ("negative", values < 0)):
        points = np.flatnonzero(bad.any(-1))
        if points.size:
            raise ValueError(f"{plugin}: parameter '{name}' is {what} at {points.size} of "
                             f"{u.size} texture coordinates (first at (u, v) = "
                             f"({u[points[0]]:.4g}, {v[points[0]]:.4g})); it must be >= 0 "
                             "everywhere")


def nonnegative_values(plugin, name, values):
    """Raise if any of ``values`` is negative, NaN or infinite."""
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{plugin}: parameter '{name}' contains NaN or infinite values")
    if min(values) < 0:
        raise ValueError(f"{plugin}: parameter '{name}' must be >= 0 everywhere, found "
                         f"{min(values):g}")


def mitsuba_reason(error):
    """The last line of a Mitsuba error without its source locations and its
    'At dictionary node ...: failed to instantiate ...:' preamble."""
    import re

    text = str(error).strip().splitlines()[-1]
    text = re.sub(r"\[[\w./-]+:\d+\]\s*", "", text)
    text = re.sub(r"At dictionary node \"[^\"]*\": failed to instantiate [^:]*:\s*", "", text)
    return " ".join(text.split())


def create(plugin_type: str, **params):
    """A new instance of Mitsuba plugin *plugin_type* (``"irregular"``,
    ``"sunsky"``, ...) of the active variant, with *params* as its properties,
    for a plugin's constructor to nest. Values are set as given, so give them
    the types the plugin reads: ``float``, ``int``, ``bool``, ``str``, Mitsuba
    objects (a texture, a bitmap), ``mi.ScalarColor3f`` for a colour,
    ``mi.ScalarVector3f`` for a vector, ``mi.ScalarTransform4f`` for a
    transform. Raises Mitsuba's ``RuntimeError`` when the plugin refuses its
    parameters.

    Through Mitsuba's plugin manager, never its scene parser: ``mi.load_dict``
    swaps the process-wide file resolver for a copy and frees the copy when
    done, while a parallel scene load runs other constructors on other threads
    that read it (``sunsky`` for its data files), so a ``load_dict`` inside a
    constructor can free what another thread reads (tests/test_properties.py).
    The plugin manager touches no resolver."""
    props = mi.Properties(plugin_type)
    for key, value in params.items():
        props[key] = value
    return mi.PluginManager.instance().create_object(props)
