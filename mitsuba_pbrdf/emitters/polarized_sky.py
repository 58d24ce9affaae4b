"""``polarized_sky``: a clear sky whose light is partially linearly polarized.

.. list-table::
   :header-rows: 1

   * - Parameter
     - Type
     - Description
     - Default
     - Flags
   * - ``sun_direction``
     - vector
     - Direction towards the sun, in world space, as Mitsuba's ``sunsky``
       takes it (its local frame has +Z up; ``to_world`` turns it). Must not
       be zero; with the ``sunsky`` intensity the sun must be above the
       horizon. Required unless a date, time and place are given.
       Differentiable: the polarization pattern's derivative, with the
       intensity held (a ``sunsky`` intensity gets the new direction without
       its gradient: its own misses the moving sun disk).
     - (required)
     - |exposed|, |differentiable| (JIT variants); read-only with a date
   * - ``model``
     - string
     - ``rayleigh``: single scattering, DoLP = ``dolp_max`` sin²γ/(1 + cos²γ) (γ: angle between the viewing direction and the sun), polarized perpendicular to the plane through the sun and the viewing direction. ``berry``: the neutral points of the real sky (Babinet, Brewster, Arago and the fourth), Berry, Dennis and Lee, New J. Phys. 6 (2004) 162. Valid: ``rayleigh`` or ``berry``.
     - ``rayleigh``
     - --
   * - ``dolp_max``
     - float
     - Degree of linear polarization at 90° from the sun (Rayleigh); clear skies reach 0.7-0.8. Valid: in [0, 1].
     - 0.8
     - |exposed|, |differentiable| (JIT variants)
   * - ``neutral_point_separation``
     - float
     - ``berry`` only: the angle in degrees between the Babinet point (above the sun) and the Brewster point (below it); each lies half of it from the sun. The Babinet point is typically observed 15-20° above the sun. Valid: in [0, 90].
     - 35
     - --
   * - ``turbidity``
     - float
     - Turbidity of the ``sunsky`` intensity (Hosek-Wilkie sky and sun), handed to the internal ``sunsky`` as the rows below. Valid: in [1, 10].
     - ``sunsky``'s: 3
     - ``intensity.*``
   * - ``sun_scale``
     - float
     - Factor on the ``sunsky`` intensity's sun. Valid: >= 0.
     - ``sunsky``'s: 1
     - ``intensity.*``
   * - ``sky_scale``
     - float
     - Factor on the ``sunsky`` intensity's sky. Valid: >= 0.
     - ``sunsky``'s: 1
     - ``intensity.*``
   * - ``sun_aperture``
     - float
     - Apparent diameter of the ``sunsky`` intensity's sun, degrees. Valid: in [0.001, 179.9].
     - ``sunsky``'s: 0.5358
     - ``intensity.*``
   * - ``albedo``
     - float
     - Ground albedo of the ``sunsky`` intensity: a number, or a spectrum as ``sunsky`` takes it. Valid: in [0, 1].
     - ``sunsky``'s: 0.3
     - ``intensity.*``
   * - ``year``
     - integer
     - Instead of ``sun_direction``, with the rest of the date, the time and the place: the sun ``sunsky`` puts there (+X south, +Y west in its frame, measured), which must be above the horizon. Only with the ``sunsky`` intensity.
     - ``sunsky``'s: 2010
     - ``intensity.*`` (not differentiable)
   * - ``month``
     - integer
     - Month of the date. Valid: in [1, 12].
     - ``sunsky``'s: 7
     - ``intensity.*`` (not differentiable)
   * - ``day``
     - integer
     - Day of the month. Valid: in [1, 31].
     - ``sunsky``'s: 10
     - ``intensity.*`` (not differentiable)
   * - ``hour``
     - float
     - Local time: hours. Valid: in [0, 24].
     - ``sunsky``'s: 15
     - ``intensity.*`` (not differentiable)
   * - ``minute``
     - float
     - Local time: minutes. Valid: in [0, 60].
     - ``sunsky``'s: 0
     - ``intensity.*`` (not differentiable)
   * - ``second``
     - float
     - Local time: seconds. Valid: in [0, 60].
     - ``sunsky``'s: 0
     - ``intensity.*`` (not differentiable)
   * - ``latitude``
     - float
     - Latitude of the place, degrees north. Valid: in [-90, 90].
     - ``sunsky``'s: 35.6894
     - ``intensity.*`` (not differentiable)
   * - ``longitude``
     - float
     - Longitude of the place, degrees east. Valid: in [-180, 180].
     - ``sunsky``'s: 139.6917
     - ``intensity.*`` (not differentiable)
   * - ``timezone``
     - float
     - Time zone of the local time, hours from UTC. Valid: in [-12, 14].
     - ``sunsky``'s: 9
     - ``intensity.*`` (not differentiable)
   * - ``radiance``
     - spectrum or texture
     - A sky radiance replacing the ``sunsky`` intensity, sampled uniformly
       over the sphere, no sun. A spectrum: an internal ``constant``
       emitter. A spatially varying texture (a ``bitmap``...): looked up by
       direction at texture coordinates (u, v) = (azimuth from local +Y
       towards +X / 2 pi, zenith angle from local +Z / pi), the lat-long
       layout of Mitsuba's ``envmap`` turned +Y to +Z
       (``<rotate x="1" angle="90"/>``). Refused at load time if negative,
       NaN or infinite (``properties.nonnegative_texels``).
     - --
     - ``intensity.*`` (a spectrum), ``radiance.*`` (a texture)
   * - (nested emitter)
     - emitter
     - An infinite emitter (``envmap``, ``constant``, ``sunsky``...) whose
       radiance and sampling replace the ``sunsky`` intensity. A polarized
       one (``stokes_envmap``, a ``polarized_emitter``...) is refused at
       load time: the sky would replace its polarization.
     - --
     - ``intensity.*``
   * - ``to_world``
     - transform
     - Local-to-world transform of the sky (``sunsky``'s: its local +Z is up):
       a rotation (a uniform scale and a translation change nothing); refused
       at load time if singular, not finite, mirroring, shearing or scaling
       unevenly.
     - identity
     - --

The emitted light, seen in direction ``d`` (propagating along ``w = -d``),
has the intensity's radiance ``L(d)`` and the Stokes vector
``L (1, q, u, 0)`` of :mod:`.sky_models` in Mitsuba's Stokes basis of ``w``
(``mi.mueller.stokes_basis(w)``; :mod:`mitsuba_pbrdf.mueller`); the sun disk of a
``sunsky`` intensity (within half of ``sun_aperture`` of the sun) is
unpolarized. ``eval``, ``eval_direction``, ``sample_direction``,
``sample_ray`` and ``sample_wavelengths`` take the intensity emitter's value
and its sampling (``sunsky``'s sky and sun sampling, ``envmap``'s
importance sampling) and polarize it in place: the pdf is the intensity's,
which the polarization does not change. In unpolarized variants the emitter
is the intensity emitter. Color/spectral variants only where the intensity
is ``sunsky`` (Mitsuba's ``sunsky`` refuses monochrome variants).

XML::

    <emitter type="polarized_sky">
        <vector name="sun_direction" x="0.5" y="0.2" z="0.6"/>
        <string name="model" value="berry"/>
        <float name="dolp_max" value="0.75"/>
        <float name="turbidity" value="3"/>
    </emitter>

    <emitter type="polarized_sky">   <!-- the sun of 21 June 2024, 09:30 in Paris -->
        <integer name="year" value="2024"/>
        <integer name="month" value="6"/>
        <integer name="day" value="21"/>
        <float name="hour" value="9.5"/>
        <float name="latitude" value="48.86"/>
        <float name="longitude" value="2.35"/>
        <float name="timezone" value="2"/>
    </emitter>

:func:`build_class` defines the class on the active variant's Mitsuba base
class; :func:`mitsuba_pbrdf.registry.plugin_class` calls it once per variant.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi

from . import wrapped
from .. import properties as read
from ..schema import parameter
from .sky_models import berry, neutral_points, rayleigh
from ..mueller import emitted, intensity


_NAME = "polarized_sky"
#: Parameters handed to the internal ``sunsky`` (declared in schema.py).
SUNSKY_PARAMETERS = ("turbidity", "sun_scale", "sky_scale", "sun_aperture", "albedo")
#: The date, time and place that Mitsuba 3.9.1's ``sunsky`` takes instead of a
#: sun direction (declared in schema.py).
SUN_POSITION = ("year", "month", "day", "hour", "minute", "second", "latitude", "longitude",
                "timezone")


def _sun_position(props):
    """``{key: value}`` of the date, time and place keys given, checked."""
    return {key: read.declared(props, _NAME, key) for key in SUN_POSITION if key in props}


def _texture(props):
    """``radiance`` as a texture, checked: ``(texture, spatially varying)``."""
    if props.type("radiance") == mi.Properties.Type.Color:   # <rgb>: as written
        read.nonnegative_values(_NAME, "radiance", [float(c) for c in props["radiance"]])
    try:
        texture = props.get_unbounded_texture("radiance")
    except RuntimeError as error:
        raise ValueError(f"{_NAME}: parameter 'radiance' is invalid: "
                         f"{read.mitsuba_reason(error)}") from None
    varying = texture.is_spatially_varying()
    if varying:
        read.nonnegative_texels(_NAME, "radiance", texture)
    else:
        read.nonnegative_texture(_NAME, "radiance", texture)
    return texture, varying


def _elevation(sun, up):
    """The sun's elevation above the horizon, degrees."""
    return math.degrees(math.asin(max(-1.0, min(1.0, sum(a * b for a, b in zip(sun, up))))))


def _intensity_emitter(props, up, sun, when):
    """``(emitter, kind, sun_half_aperture or None, texture or None, sun)``:
    the emitter giving the sky's intensity and sampling, built from *props*
    (checked), and the sun (a unit tuple: the given one, or where ``sunsky``
    puts it at the given date, time and place)."""
    nested = read.nested_objects(props, mi.Emitter)
    sunsky_keys = [k for k in (*SUNSKY_PARAMETERS, *when) if k in props]
    given = [what for what, present in (("a nested emitter", bool(nested)),
                                        ("'radiance'", "radiance" in props)) if present]
    if len(nested) > 1 or len(given) > 1:
        raise ValueError(f"{_NAME}: give at most one intensity: 'radiance' or one nested "
                         f"emitter, found {len(nested)} nested emitter(s)"
                         f"{' and radiance' if 'radiance' in props else ''}")
    if given and sunsky_keys:
        raise ValueError(f"{_NAME}: parameter '{sunsky_keys[0]}' belongs to the sunsky "
                         f"intensity, which {given[0]} replaces")
    if nested:
        emitter = next(iter(nested.values()))
        if not emitter.is_environment():
            raise ValueError(f"{_NAME}: the nested emitter must be an infinite emitter "
                             f"(envmap, constant, sunsky), got {emitter.class_name()}")
        dop = wrapped.max_dop(emitter)
        if dop > 1e-6:
            # the sky's pattern would replace that polarization, silently
            raise ValueError(f"{_NAME}: the nested emitter is polarized (degree up to "
                             f"{dop:.3g}), and the sky replaces the polarization of its "
                             "intensity: nest an unpolarized emitter (envmap, constant, "
                             "sunsky), or put a polarized_emitter around the sky to filter it")
        return emitter, "nested", None, None, sun
    if "radiance" in props:
        texture, varying = _texture(props)
        if varying:   # unit radiance, uniform sampling; the texture scales it by direction
            unit = read.create("constant", radiance=read.create("uniform", value=1.0))
            return unit, "texture", None, texture, sun
        return read.create("constant", radiance=texture), "constant", None, None, sun

    if not (mi.is_rgb or mi.is_spectral):
        raise ValueError(f"{_NAME}: the default sunsky intensity needs an RGB or spectral "
                         f"variant, not {mi.variant()!r}; give 'radiance' or a nested emitter")
    if not when and _elevation(sun, up) <= 0.0:
        raise ValueError(f"{_NAME}: parameter 'sun_direction' puts the sun "
                         f"{-_elevation(sun, up):.3g}° below the horizon, where sunsky's sky "
                         "is black; raise it or give 'radiance'")
    config = dict(when) if when else {"sun_direction": mi.ScalarVector3f(sun)}
    for key in SUNSKY_PARAMETERS:
        if key == "albedo" and key in props and props.type(key) not in (
                mi.Properties.Type.Float, mi.Properties.Type.Integer):
            config[key] = props[key]    # a spectrum: sunsky checks it
        elif key in props:
            config[key] = read.declared(props, _NAME, key)
    if "to_world" in props:
        config["to_world"] = read.as_transform(read.rotation(props, _NAME, "to_world"))
    try:
        emitter = read.create("sunsky", **config)
    except RuntimeError as error:
        raise ValueError(f"{_NAME}: the sunsky intensity refused its parameters: "
                         f"{read.mitsuba_reason(error)}") from None
    if when:
        sun = read.unit_vector(_NAME, "sun_direction",
                               _floats(mi.traverse(emitter)["sun_direction"]))
        if _elevation(sun, up) <= 0.0:
            raise ValueError(f"{_NAME}: the date, time and place ({', '.join(when)}) put the "
                             f"sun {-_elevation(sun, up):.3g}° below the horizon, where "
                             "sunsky's sky is black")
    given = {key: config.get(key, parameter(key, _NAME).default)
             for key in ("sun_aperture", "sun_scale")}
    half = math.radians(given["sun_aperture"]) / 2.0
    return emitter, "sunsky", half if given["sun_scale"] > 0 else None, None, sun


def _floats(value):
    """The values of a Float, a Vector3f or a Python float, as a list of floats."""
    value = dr.detach(value) if not isinstance(value, float) else value
    return [float(c) for c in dr.ravel(value)] if not isinstance(value, float) else [value]


def _configure(props):
    """The checked parameters of a ``polarized_sky``, as attributes."""
    model = read.declared(props, _NAME, "model")
    dolp_max = read.declared(props, _NAME, "dolp_max")
    separation = read.declared(props, _NAME, "neutral_point_separation")
    if model != "berry" and "neutral_point_separation" in props:
        raise ValueError(f"{_NAME}: parameter 'neutral_point_separation' applies to "
                         "model 'berry' only")
    to_world = read.rotation(props, _NAME, "to_world")
    up = read.unit_vector(_NAME, "to_world", [to_world[i][2] for i in range(3)])
    horizontal = read.unit_vector(_NAME, "to_world", [to_world[i][0] for i in range(3)])
    when = _sun_position(props)
    if when and "sun_direction" in props:
        raise ValueError(f"{_NAME}: give 'sun_direction' or a date, time and place "
                         f"({', '.join(SUN_POSITION)}), not both")
    if not when and "sun_direction" not in props:
        raise ValueError(f"{_NAME}: parameter 'sun_direction' is required (a direction, "
                         "e.g. <vector name=\"sun_direction\" x=\"0\" y=\"0.5\" z=\"1\"/>), "
                         "or a date, time and place for the sunsky intensity "
                         f"({', '.join(SUN_POSITION)})")
    sun = None if when else read.direction(props, _NAME, "sun_direction")
    emitter, kind, half_aperture, texture, sun = _intensity_emitter(props, up, sun, when)
    return {"model": model, "dolp_max": mi.Float(dolp_max), "separation": separation,
            "up": up, "horizontal": horizontal,
            "to_local": [list(column) for column in zip(*to_world)],   # R⁻¹ = Rᵀ
            "sun": sun, "when": when, "inner": emitter, "kind": kind,
            "sun_half_aperture": half_aperture, "texture": texture}


def build_class():
    """``PolarizedSky`` on the active variant's base class (registry.plugin_class)."""
    class PolarizedSky(wrapped.emitter_base(_configure)):
        """A sky whose light carries the polarization of :mod:`.sky_models`
        (module docstring)."""

        def __init__(self, props):
            super().__init__(props)
            self.sun_direction = mi.Vector3f(self.sun)
            self._set_sun_disk()
            self._set_pattern()
            self.m_flags = mi.EmitterFlags.Infinite | mi.EmitterFlags.SpatiallyVarying

        def _set_sun_disk(self):
            """Where the intensity's sun is (``self.sun``): its disk is unpolarized."""
            self.sun_disk = mi.Vector3f(self.sun)
            dr.make_opaque(self.sun_disk)

        def _set_pattern(self):
            """The pattern's sun and neutral points from ``sun_direction``, in
            Dr.Jit: differentiable with respect to it."""
            sun = dr.normalize(self.sun_direction)
            self.pattern_sun = sun
            if self.model == "berry":
                self.babinet, self.brewster = neutral_points(
                    sun, mi.Vector3f(self.up), self.separation, mi.Vector3f(self.horizontal))
                dr.make_opaque(self.babinet, self.brewster)
            dr.make_opaque(self.pattern_sun)

        # -------------------------------------------------------------- polarization

        def _ratios(self, w):
            """``(q, u)`` of the light propagating along ``w`` (world, unit)."""
            if self.model == "rayleigh":
                q, u = rayleigh(w, self.pattern_sun, self.dolp_max)
            else:
                q, u = berry(w, self.babinet, self.brewster, self.dolp_max)
            if self.sun_half_aperture is not None:   # the sun disk is unpolarized
                in_sun = -dr.dot(w, self.sun_disk) >= math.cos(self.sun_half_aperture)
                q, u = dr.select(in_sun, 0.0, q), dr.select(in_sun, 0.0, u)
            return q, u

        def _mapped(self, w, wavelengths):
            """The ``radiance`` texture seen along ``-w``: (u, v) = (azimuth from
            local +Y towards +X / 2 pi, zenith angle from local +Z / pi)."""
            d = mi.Vector3f(*(-dr.fma(r[0], w.x, dr.fma(r[1], w.y, r[2] * w.z)) for r in self.to_local))
            d = dr.normalize(d)
            u = dr.atan2(d.x, d.y) * (0.5 / math.pi)
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.uv = mi.Point2f(u - dr.floor(u), dr.safe_acos(d.z) * (1.0 / math.pi))
            si.wavelengths = wavelengths
            return self.texture.eval(si)

        def light(self, value, w, wavelengths):
            """The intensity emitter's ``value`` for light propagating along ``w``
            (times the ``radiance`` texture there), polarized in polarized variants."""
            radiance = intensity(value)
            if self.texture is not None:
                radiance = radiance * self._mapped(w, wavelengths)
            if not mi.is_polarized:
                return radiance
            q, u = self._ratios(w)
            return emitted(radiance, q, u)

        # -------------------------------------------------------------- Emitter API

        def sample_wavelengths(self, si, sample, active=True):
            wavelengths, weight = self.inner.sample_wavelengths(si, sample, active)
            return wavelengths, self.light(weight, si.wi, wavelengths)

        # -------------------------------------------------------------- parameters

        def traverse(self, callback):
            differentiable = dr.is_diff_v(mi.Float)
            if differentiable:   # scalar variants: plain floats
                callback.put("dolp_max", self.dolp_max, mi.ParamFlags.Differentiable)
            callback.put("sun_direction", self.sun_direction,
                         mi.ParamFlags.ReadOnly if self.when else
                         mi.ParamFlags.Differentiable if differentiable else
                         mi.ParamFlags.NonDifferentiable)
            callback.put("intensity", self.inner, mi.ParamFlags.Differentiable)
            if self.texture is not None:
                callback.put("radiance", self.texture, mi.ParamFlags.Differentiable)

        def parameters_changed(self, keys):
            if not keys or "dolp_max" in keys:
                value, declared = _floats(self.dolp_max), parameter("dolp_max", _NAME)
                if len(value) != 1 or not (declared.lower <= value[0] <= declared.upper):
                    raise ValueError(f"{_NAME}: parameter 'dolp_max' must be "
                                     f"{declared.bound_doc}, got "
                                     f"{value if len(value) != 1 else value[0]}")
            if not keys or "sun_direction" in keys:
                # a new sun: checked, handed to the sunsky intensity without its
                # gradient (the intensity is held; docs/polarized-light.md)
                sun = read.unit_vector(_NAME, "sun_direction", _floats(self.sun_direction))
                if self.kind == "sunsky":
                    if _elevation(sun, self.up) <= 0.0:
                        raise ValueError(f"{_NAME}: parameter 'sun_direction' puts the sun "
                                         f"{-_elevation(sun, self.up):.3g}° below the horizon, "
                                         "where sunsky's sky is black")
                    if sun != self.sun:
                        params = mi.traverse(self.inner)
                        params["sun_direction"] = mi.Vector3f(sun)
                        params.update()
                self.sun = sun
                self._set_sun_disk()
            elif self.kind == "sunsky" and any(k == "intensity" or k.startswith("intensity.")
                                               for k in keys):
                # the sunsky's own sun moved (its sun_direction, or its date and
                # time): the pattern follows, in place (mi.traverse holds the vector)
                self.sun = read.unit_vector(_NAME, "sun_direction", _floats(
                    mi.traverse(self.inner)["sun_direction"]))
                for i in range(3):
                    self.sun_direction[i] = mi.Float(self.sun[i])
                self._set_sun_disk()
            self._set_pattern()

        def to_string(self):
            extra = (f",\n  neutral_point_separation = {self.separation}"
                     if self.model == "berry" else "")
            when = (f",\n  date, time and place = {self.when}" if self.when else "")
            return (f"PolarizedSky[\n  model = {self.model!r},\n  sun_direction = {self.sun}{when},\n"
                    f"  dolp_max = {self.dolp_max}{extra},\n  intensity = {self.kind}\n]")

    return PolarizedSky
