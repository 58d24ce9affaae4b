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
       horizon.
     - (required)
     - |exposed|
   * - ``model``
     - string
     - ``rayleigh``: single scattering, DoLP = ``dolp_max`` sin²γ/(1 + cos²γ)
       (γ: angle between the viewing direction and the sun), polarized
       perpendicular to the plane through the sun and the viewing direction.
       ``berry``: the neutral points of the real sky (Babinet, Brewster,
       Arago and the fourth), Berry, Dennis and Lee, New J. Phys. 6 (2004) 162.
     - ``rayleigh``
     - --
   * - ``dolp_max``
     - float
     - Degree of linear polarization at 90° from the sun (Rayleigh), in
       [0, 1]; clear skies reach 0.7-0.8.
     - 0.8
     - |exposed|, |differentiable| (JIT variants)
   * - ``neutral_point_separation``
     - float
     - ``berry`` only: the angle in degrees, in [0, 90], between the Babinet
       point (above the sun) and the Brewster point (below it); each lies
       half of it from the sun. The Babinet point is typically observed
       15-20° above the sun.
     - 35
     - --
   * - ``turbidity``, ``albedo``, ``sun_scale``, ``sky_scale``, ``sun_aperture``
     - float, spectrum
     - The intensity's ``sunsky`` parameters (Hosek-Wilkie sky and sun),
       handed to an internal ``sunsky`` at the same sun direction; turbidity
       in [1, 10], albedo in [0, 1].
     - ``sunsky``'s: 3, 0.3, 1, 1, 0.5338
     - ``intensity.*``
   * - ``radiance``
     - spectrum
     - A constant sky radiance replacing the ``sunsky`` intensity (an
       internal ``constant`` emitter: uniform sampling, no sun).
     - --
     - ``intensity.*``
   * - (nested emitter)
     - emitter
     - An infinite emitter (``envmap``, ``constant``, ``sunsky``...) whose
       radiance and sampling replace the ``sunsky`` intensity.
     - --
     - ``intensity.*``
   * - ``to_world``
     - transform
     - Local-to-world transform of the sky (``sunsky``'s: its local +Z is up).
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

This module defines the class for the Mitsuba variant active when it is
imported; :func:`mitsuba_pbrdf.registry.variant_module` reloads it for another.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi

from . import params as read
from .sky_models import MODELS, berry, neutral_points, rayleigh
from ..mueller import emitted, intensity

#: The Mitsuba variant this module's class was built for (registry.variant_module).
VARIANT = mi.variant()

_NAME = "polarized_sky"
#: Parameters handed to the internal ``sunsky``, with their bounds.
SUNSKY_PARAMETERS = {"turbidity": (1.0, 10.0), "sun_scale": (0.0, None),
                     "sky_scale": (0.0, None), "sun_aperture": (1e-3, 179.9)}
#: sunsky's default sun aperture (degrees).
SUN_APERTURE = 0.5338


def _intensity_emitter(props, up, sun):
    """``(emitter, kind, sun_half_aperture or None)``: the emitter giving the
    sky's intensity and sampling, built from *props* (checked)."""
    nested = read.nested_objects(props, mi.Emitter)
    sunsky_keys = [k for k in (*SUNSKY_PARAMETERS, "albedo") if k in props]
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
        return emitter, "nested", None
    if "radiance" in props:
        if props.type("radiance") == mi.Properties.Type.Color:   # <rgb>: as written
            read.nonnegative_values(_NAME, "radiance", [float(c) for c in props["radiance"]])
        try:
            radiance = props.get_unbounded_texture("radiance")
        except RuntimeError as error:
            raise ValueError(f"{_NAME}: parameter 'radiance' is invalid: "
                             f"{read.mitsuba_reason(error)}") from None
        read.nonnegative_texture(_NAME, "radiance", radiance)
        return mi.load_dict({"type": "constant", "radiance": radiance}), "constant", None

    if not (mi.is_rgb or mi.is_spectral):
        raise ValueError(f"{_NAME}: the default sunsky intensity needs an RGB or spectral "
                         f"variant, not {mi.variant()!r}; give 'radiance' or a nested emitter")
    elevation = math.degrees(math.asin(max(-1.0, min(1.0, sum(a * b for a, b in zip(sun, up))))))
    if elevation <= 0.0:
        raise ValueError(f"{_NAME}: parameter 'sun_direction' puts the sun {-elevation:.3g}° "
                         "below the horizon, where sunsky's sky is black; raise it or give "
                         "'radiance'")
    config = {"type": "sunsky", "sun_direction": mi.ScalarVector3f(sun)}
    for key, (low, high) in SUNSKY_PARAMETERS.items():
        if key in props:
            config[key] = read.number(props, _NAME, key, low=low, high=high)
    if "albedo" in props:
        if props.type("albedo") in (mi.Properties.Type.Float, mi.Properties.Type.Integer):
            config["albedo"] = read.number(props, _NAME, "albedo", low=0.0, high=1.0)
        else:
            config["albedo"] = props["albedo"]
    if "to_world" in props:
        config["to_world"] = props["to_world"]
    try:
        emitter = mi.load_dict(config)
    except RuntimeError as error:
        raise ValueError(f"{_NAME}: the sunsky intensity refused its parameters: "
                         f"{read.mitsuba_reason(error)}") from None
    half = math.radians(config.get("sun_aperture", SUN_APERTURE)) / 2.0
    return emitter, "sunsky", half if config.get("sun_scale", 1.0) > 0 else None


def _floats(value):
    """The values of a Float, a Vector3f or a Python float, as a list of floats."""
    value = dr.detach(value) if not isinstance(value, float) else value
    return [float(c) for c in dr.ravel(value)] if not isinstance(value, float) else [value]


def _configure(props):
    """The checked parameters of a ``polarized_sky``, as attributes."""
    model = read.choice(props, _NAME, "model", MODELS, "rayleigh")
    dolp_max = read.number(props, _NAME, "dolp_max", 0.8, 0.0, 1.0)
    separation = read.number(props, _NAME, "neutral_point_separation", 35.0, 0.0, 90.0)
    if model != "berry" and "neutral_point_separation" in props:
        raise ValueError(f"{_NAME}: parameter 'neutral_point_separation' applies to "
                         "model 'berry' only")
    to_world = read.transform(props, "to_world")
    up = read.unit_vector(_NAME, "to_world", [to_world[i][2] for i in range(3)])
    horizontal = read.unit_vector(_NAME, "to_world", [to_world[i][0] for i in range(3)])
    sun = read.direction(props, _NAME, "sun_direction")
    emitter, kind, half_aperture = _intensity_emitter(props, up, sun)
    return {"model": model, "dolp_max": mi.Float(dolp_max), "separation": separation,
            "up": up, "horizontal": horizontal, "sun": sun, "intensity": emitter,
            "kind": kind, "sun_half_aperture": half_aperture}


class PolarizedSky(mi.Emitter):
    """A sky whose light carries the polarization of :mod:`.sky_models`
    (module docstring)."""

    def __init__(self, props):
        # Everything is read and checked before the base class registers the
        # instance with Dr.Jit: a half-built emitter left registered after an
        # error would break every later render of the session.
        config = _configure(props)
        super().__init__(props)
        for key, value in config.items():
            setattr(self, key, value)
        self._set_sun(config["sun"])
        self.m_flags = mi.EmitterFlags.Infinite | mi.EmitterFlags.SpatiallyVarying

    def _set_sun(self, sun):
        """The sun's direction and the neutral points (plain Python, float64)."""
        self.sun = sun
        self.sun_direction = mi.Vector3f(sun)
        self.babinet, self.brewster = neutral_points(sun, self.up, self.separation,
                                                     self.horizontal)

    # -------------------------------------------------------------- polarization

    def _ratios(self, w):
        """``(q, u)`` of the light propagating along ``w`` (world, unit)."""
        if self.model == "rayleigh":
            q, u = rayleigh(w, mi.Vector3f(self.sun), self.dolp_max)
        else:
            q, u = berry(w, mi.Vector3f(self.babinet), mi.Vector3f(self.brewster),
                         self.dolp_max)
        if self.sun_half_aperture is not None:   # the sun disk is unpolarized
            in_sun = -dr.dot(w, mi.Vector3f(self.sun)) >= math.cos(self.sun_half_aperture)
            q, u = dr.select(in_sun, 0.0, q), dr.select(in_sun, 0.0, u)
        return q, u

    def _polarized(self, value, w):
        """The intensity emitter's ``value`` for light propagating along ``w``,
        polarized (unchanged in unpolarized variants)."""
        if not mi.is_polarized:
            return value
        q, u = self._ratios(w)
        return emitted(intensity(value), q, u)

    # -------------------------------------------------------------- Emitter API

    def eval(self, si, active=True):
        return self._polarized(self.intensity.eval(si, active), si.wi)

    def eval_direction(self, it, ds, active=True):
        return self._polarized(self.intensity.eval_direction(it, ds, active), -ds.d)

    def sample_direction(self, it, sample, active=True):
        ds, weight = self.intensity.sample_direction(it, sample, active)
        ds.emitter = mi.EmitterPtr(self)
        return ds, self._polarized(weight, -ds.d)

    def pdf_direction(self, it, ds, active=True):
        return self.intensity.pdf_direction(it, ds, active)

    def sample_ray(self, time, sample1, sample2, sample3, active=True):
        ray, weight = self.intensity.sample_ray(time, sample1, sample2, sample3, active)
        return ray, self._polarized(weight, ray.d)

    def sample_wavelengths(self, si, sample, active=True):
        wavelengths, weight = self.intensity.sample_wavelengths(si, sample, active)
        return wavelengths, self._polarized(weight, si.wi)

    def sample_position(self, time, sample, active=True):
        return self.intensity.sample_position(time, sample, active)

    def set_scene(self, scene):
        self.intensity.set_scene(scene)

    def bbox(self):
        return self.intensity.bbox()

    def is_environment(self):
        return True

    # -------------------------------------------------------------- parameters

    def traverse(self, callback):
        if not isinstance(self.dolp_max, float):   # scalar variants: a plain float
            callback.put("dolp_max", self.dolp_max, mi.ParamFlags.Differentiable)
        callback.put("sun_direction", self.sun_direction, mi.ParamFlags.NonDifferentiable)
        callback.put("intensity", self.intensity, mi.ParamFlags.Differentiable)

    def parameters_changed(self, keys):
        if not keys or "dolp_max" in keys:
            value = _floats(self.dolp_max)
            if len(value) != 1 or not (0.0 <= value[0] <= 1.0):
                raise ValueError(f"{_NAME}: parameter 'dolp_max' must be in [0, 1], got "
                                 f"{value if len(value) != 1 else value[0]}")
        sun = self.sun
        if self.kind == "sunsky" and any(k == "intensity" or k.startswith("intensity.")
                                         for k in keys):
            # the nested sunsky's own sun_direction was changed: follow it
            sun = read.unit_vector(_NAME, "sun_direction", _floats(
                mi.traverse(self.intensity)["sun_direction"]))
        if not keys or "sun_direction" in keys:
            sun = read.unit_vector(_NAME, "sun_direction", _floats(self.sun_direction))
            if sun != self.sun and self.kind == "sunsky":
                params = mi.traverse(self.intensity)
                params["sun_direction"] = mi.Vector3f(sun)
                params.update()
        if sun != self.sun:
            self._set_sun(sun)

    def to_string(self):
        extra = (f",\n  neutral_point_separation = {self.separation}"
                 if self.model == "berry" else "")
        return (f"PolarizedSky[\n  model = {self.model!r},\n  sun_direction = {self.sun},\n"
                f"  dolp_max = {self.dolp_max}{extra},\n  intensity = {self.kind}\n]")
