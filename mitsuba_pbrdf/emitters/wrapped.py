"""The base class of the three polarized emitters, :func:`emitter_base`.
Each wraps one emitter, ``self.inner`` (``polarized_sky``'s intensity,
``stokes_envmap``'s ``envmap``, ``polarized_emitter``'s lamp), keeps its
radiance, sampling and pdf, and changes only what it returns through
``self.light(value, w, wavelengths)``: ``value`` the inner emitter's
radiance or sample weight, ``w`` the world-space direction the light
propagates in (the Stokes basis of :func:`mitsuba_pbrdf.mueller.basis`).

The base is built on the active variant's ``mi.Emitter`` each time a
plugin's ``build_class()`` runs, as :func:`mitsuba_pbrdf.bsdfs.perturbed.wrapper_base`
is for the BSDFs: nanobind takes one base, so no mix-in beside ``mi.Emitter``.

**No** ``set_scene``: Mitsuba 3.9.1 never calls a Python emitter's
``set_scene`` (measured: an override that prints is never reached), so an
inner infinite emitter (``sunsky``, ``constant``, ``envmap``) keeps the unit
bounding sphere it starts with. Its ``sample_direction`` then puts the
sampled point 2 units away (``ds.p``), and the shadow ray that
``Scene.sample_emitter_direction`` traces to that point misses every
occluder farther away: light leaked through the ground of a scene 20 units
wide (``tests/emitters/test_polarized_sky_texture.py``). :func:`sample_direction` puts
the point :data:`FAR` away instead. ``sample_ray`` (light tracing) still
starts its rays on that unit sphere (docs/polarized-light.md).

**No** ``set_shape`` either (measured: a shape holding a Python emitter sets
the emitter's shape in C++, ``get_shape()``, and never calls the Python
override): an inner ``area`` lamp of ``polarized_emitter`` kept no shape, and
its ``sample_direction`` returned zero weights, so emitter sampling lit
nothing and only BSDF-sampled paths found the lamp. :func:`nested` hands the
wrapper's shape on before each call.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

#: How far (scene units) an infinite emitter's direction sample puts its
#: point: shadow rays test occluders up to that distance. Float32 rounding of
#: a point that far moves the direction of the shadow ray by about 1e-7 rad.
FAR = 1e7


def nested(self):
    """``self.inner``, given this emitter's shape first if it has none
    (module docstring)."""
    inner = self.inner
    if inner.get_shape() is None:
        shape = self.get_shape()
        if shape is not None:
            inner.set_shape(shape)
    return inner


def emitter_base(configure):
    """The active variant's ``mi.Emitter`` with what the three emitters share:
    a constructor that sets the attributes ``configure(props)`` returns (a
    dict; everything read and checked first), and the Emitter methods that
    hand the call to ``self.inner`` and its value to ``self.light``."""

    class WrappedEmitter(mi.Emitter):
        def __init__(self, props):
            # Checked before the base class registers the instance with Dr.Jit:
            # a half-built emitter left registered after an error would break
            # every later render of the session.
            config = configure(props)
            super().__init__(props)
            for key, value in config.items():
                setattr(self, key, value)

        def eval(self, si, active=True):
            """An infinite emitter seen along ``-si.wi``: its light propagates
            along ``si.wi`` (world space)."""
            return self.light(nested(self).eval(si, active), si.wi, si.wavelengths)

        def eval_direction(self, it, ds, active=True):
            return self.light(nested(self).eval_direction(it, ds, active), -ds.d, it.wavelengths)

        def sample_direction(self, it, sample, active=True):
            """The inner emitter's sample, named as this emitter's (an adjoint
            pass that re-evaluates ``ds.emitter`` then sees the polarization);
            an infinite one's point :data:`FAR` away (module docstring)."""
            ds, weight = nested(self).sample_direction(it, sample, active)
            ds.emitter = mi.EmitterPtr(self)
            if nested(self).is_environment():
                ds.p = dr.fma(ds.d, FAR, it.p)
                ds.dist = FAR
            return ds, self.light(weight, -ds.d, it.wavelengths)

        def pdf_direction(self, it, ds, active=True):
            return nested(self).pdf_direction(it, ds, active)

        def sample_ray(self, time, sample1, sample2, sample3, active=True):
            ray, weight = nested(self).sample_ray(time, sample1, sample2, sample3, active)
            return ray, self.light(weight, ray.d, ray.wavelengths)

        def sample_position(self, time, sample, active=True):
            return nested(self).sample_position(time, sample, active)

        def bbox(self):
            return self.inner.bbox()

        def is_environment(self):
            return self.inner.is_environment()

    return WrappedEmitter


def max_dop(emitter, n=64):
    """The largest degree of polarization of an infinite ``emitter``'s light
    over ``n`` directions spread over the sphere (a Fibonacci lattice) at
    four wavelengths: 0 for Mitsuba's own emitters (depolarizers) and in
    unpolarized variants. A load-time check (plain floats)."""
    import numpy as np

    if not mi.is_polarized:
        return 0.0
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = np.pi * (3.0 - np.sqrt(5.0)) * k
    r = np.sqrt(1.0 - z * z)
    w = np.stack([r * np.cos(phi), r * np.sin(phi), z], -1)
    scalar = mi.variant().startswith("scalar")
    worst = 0.0
    for rows in ([[*v] for v in w] if scalar else [w.T]):
        si = dr.zeros(mi.SurfaceInteraction3f) if scalar else dr.zeros(mi.SurfaceInteraction3f, n)
        si.wi = mi.Vector3f(*rows)
        if mi.is_spectral:
            si.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
        value = emitter.eval(si)
        s = [np.asarray(value[i, 0], np.float64) for i in range(4)]
        dop = np.sqrt(s[1] ** 2 + s[2] ** 2 + s[3] ** 2) / np.maximum(np.abs(s[0]), 1e-30)
        worst = max(worst, float(np.max(np.where(np.abs(s[0]) > 0, dop, 0.0))))
    return worst
