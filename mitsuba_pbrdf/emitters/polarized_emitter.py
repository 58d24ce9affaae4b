"""``polarized_emitter``: any emitter seen through a linear polarizer.

.. list-table::
   :header-rows: 1

   * - Parameter
     - Type
     - Description
     - Default
     - Flags
   * - (nested emitter)
     - emitter
     - The lamp: ``area`` (nest this plugin in the shape instead of the
       ``area`` emitter), ``spot``, ``point``, ``directional``, ``projector``,
       ``constant``, ``envmap``...
     - (required)
     - ``emitter.*``
   * - ``angle``
     - float
     - The polarizer's transmission axis in degrees, from the local x axis towards the local y axis of ``to_world``.
     - 0
     - --
   * - ``degree``
     - float
     - Degree of linear polarization the filter gives unpolarized light (1: an ideal polarizer; less: a leaky one). Valid: in [0, 1].
     - 1
     - --
   * - ``transmittance``
     - float
     - Fraction of an unpolarized lamp's radiance the filter passes. An ideal polarizer passes 0.5; the default keeps the lamp's radiance and polarizes it (and so doubles light already polarized along its axis, see below). Valid: in [0, 1].
     - 1
     - --
   * - ``to_world``
     - transform
     - The polarizer's frame: its sheet is the local xy plane. Give a spot
       light's or a rectangle's own ``to_world`` to turn the axis with it.
       Refused at load time if singular or not finite.
     - identity
     - --

The filter is a linear diattenuator (Chipman's homogeneous one) with
principal transmittances ``T (1 + p)`` along its axis and ``T (1 - p)``
across it: T the transmittance, p the degree, the axis ``a`` projected across
the ray, ``a - (a.w) w`` (the tilted-polarizer approximation: exact for rays
along the local z axis, the axis's projection for oblique ones), chi its angle
in Mitsuba's Stokes basis of the propagation direction ``w``
(:func:`mitsuba_pbrdf.mueller.linear_diattenuator`). Its Mueller matrix
multiplies the lamp's whole Mueller matrix, so an unpolarized lamp of
radiance L leaves with ``T L (1, p cos 2chi, p sin 2chi, 0)``, and a lamp
that is itself polarized (a nested ``polarized_emitter``, a
``stokes_envmap``...) is filtered: two ideal filters at theta1 (inner) and
theta2 pass ``2 T1 T2 L cos²(theta1 - theta2)`` (Malus's law), polarized
along the outer axis. A physical (passive) filter has ``T (1 + p) <= 1``;
the default T = 1 is a filter with gain. Rays along the axis itself (``a``
parallel to ``w``: the polarizer seen edge-on) pass unchanged, times T. An
analyzer at angle theta to the axis passes ``T L (1 + p cos 2theta) / 2`` of
an unpolarized lamp.

Everything else is the lamp's: its flags, sampling (``sample_direction``,
``sample_ray``, ``sample_position``, ``pdf_direction``) and spectrum
(``sample_wavelengths``, which has no direction, scales by T only). In
unpolarized variants it is the lamp times the transmittance.

What Mitsuba's plugin system does not allow: the wrapper cannot sit *between*
a lamp and a shape (a shape takes one emitter, which must be this plugin,
nesting the ``area`` emitter); it cannot polarize the light of emissive media
or of a ``sunsky``'s sun separately from its sky (use ``polarized_sky``); and
Mitsuba's C++ ``mitsuba`` executable cannot load it (Python plugins only run
from Python: ``pbrdf render`` or ``mi.load_file`` after
``import mitsuba_pbrdf``).

XML::

    <shape type="rectangle">
        <emitter type="polarized_emitter">
            <float name="angle" value="30"/>
            <emitter type="area">
                <rgb name="radiance" value="5"/>
            </emitter>
        </emitter>
    </shape>

:func:`build_class` defines the class on the active variant's Mitsuba base
class; :func:`mitsuba_pbrdf.registry.plugin_class` calls it once per variant.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi

from . import wrapped
from .. import properties as read
from ..mueller import basis, linear_diattenuator, times


_NAME = "polarized_emitter"


def _configure(props):
    """The checked parameters of a ``polarized_emitter``, as attributes."""
    nested = read.nested_objects(props, mi.Emitter)
    if len(nested) != 1:
        raise ValueError(f"{_NAME}: exactly one nested emitter (the lamp) must be given, "
                         f"found {len(nested)}")
    lamp = next(iter(nested.values()))
    angle = math.radians(read.declared(props, _NAME, "angle"))
    degree = read.declared(props, _NAME, "degree")
    transmittance = read.declared(props, _NAME, "transmittance")
    m = read.transform(props, _NAME, "to_world")
    local = (math.cos(angle), math.sin(angle), 0.0)
    axis = read.unit_vector(_NAME, "to_world",
                            [sum(m[i][j] * local[j] for j in range(3)) for i in range(3)])
    surface = bool(lamp.flags() & mi.EmitterFlags.Surface)
    return {"inner": lamp, "axis": axis, "degree": degree, "transmittance": transmittance,
            "surface": surface, "angle_deg": math.degrees(angle)}


def build_class():
    """``PolarizedEmitter`` on the active variant's base class (registry.plugin_class)."""
    class PolarizedEmitter(wrapped.emitter_base(_configure)):
        """A lamp behind a linear polarizer (module docstring)."""

        def __init__(self, props):
            super().__init__(props)
            self.m_flags = self.inner.flags()
            self.m_needs_sample_2 = self.inner.needs_sample_2()
            self.m_needs_sample_3 = self.inner.needs_sample_3()

        def light(self, value, w, wavelengths=None):
            """The lamp's ``value`` for light propagating along ``w`` (world),
            through the polarizer."""
            if not mi.is_polarized:
                return value * self.transmittance
            x, y = basis(w)
            a = mi.Vector3f(self.axis)
            # the filter's Mueller matrix times the lamp's whole matrix: a lamp
            # that is itself polarized (another polarized_emitter, a
            # stokes_envmap...) is filtered as Malus's law says
            return times(linear_diattenuator(dr.dot(a, x), dr.dot(a, y), self.degree,
                                             self.transmittance), value)

        def eval(self, si, active=True):
            w = si.to_world(si.wi) if self.surface else si.wi
            return self.light(wrapped.nested(self).eval(si, active), w)

        def pdf_position(self, ps, active=True):
            return wrapped.nested(self).pdf_position(ps, active)

        def sample_wavelengths(self, si, sample, active=True):
            wavelengths, weight = wrapped.nested(self).sample_wavelengths(si, sample, active)
            return wavelengths, weight * self.transmittance

        def set_shape(self, shape):
            super().set_shape(shape)
            self.inner.set_shape(shape)

        def traverse(self, callback):
            callback.put("emitter", self.inner, mi.ParamFlags.Differentiable)

        def to_string(self):
            return (f"PolarizedEmitter[\n  angle = {self.angle_deg:g},\n  degree = {self.degree:g},\n"
                    f"  transmittance = {self.transmittance:g},\n  lamp = {self.inner.class_name()}\n]")

    return PolarizedEmitter
