"""``stokes_prb``: polarization-aware path replay, Stokes images and their
gradients at the memory of a primal render.

.. list-table::
   :header-rows: 1

   * - Parameter
     - Type
     - Description
     - Default
     - Flags
   * - ``max_depth``
     - integer
     - Longest path, as in ``path`` (1: emitters seen directly, 2: direct illumination, ...); the replay stores each vertex of a sample in local memory, so the depth must be finite. Valid: in [0, 64].
     - 6
     - --
   * - ``rr_depth``
     - integer
     - Depth at which Russian roulette starts, as in ``path``. Valid: > 0.
     - 5
     - --
   * - ``hide_emitters``
     - boolean
     - Hide directly visible emitters, as in ``path``.
     - false
     - --

``<integrator type="stokes_prb"/>`` renders what
``<integrator type="stokes"><integrator type="path"/></integrator>`` renders,
with the same random numbers: the film channels R, G, B, then S0.R ... S3.B
(the Stokes vector in the camera's frame, as ``stokes`` writes it), so Stokes
files, losses and pictures work unchanged. ``mi.render(scene, params, ...)``
followed by ``dr.backward`` or ``dr.forward`` gives the gradients of ``path``
differentiated by AD (detached sampling, as Mitsuba's ``prb``), with the memory
of a primal render whatever the number of samples, the depth or the number of
parameters (textures included).

How (docs/path-replay.md): a first loop traces each path as ``path`` does and
keeps, per sample and per vertex, in Dr.Jit local memory, the intersection,
the random numbers and the adjoint ``delta_k`` (the loss gradient carried
from the camera as a row Stokes vector); a second loop walks the vertices
backwards, differentiates ``delta_k . (E_k + T_k L_{k+1})`` one vertex at a
time and rebuilds the radiance ``L_{k+1}`` arriving from the rest of the path
by ``L_k = E_k + W_k L_{k+1}``, the sampled weight ``W_k`` being ``T_k``'s
value (no inverse of a Mueller matrix: depolarizing lobes make those
singular).

Not handled (as Mitsuba's ``prb``): derivatives from visibility
discontinuities (moving geometry, silhouettes: use a projective integrator
without polarization) and from the motion of surfaces; participating media;
films other than RGB films (``hdrfilm`` with ``pixel_format`` rgb or rgba).
Derivatives with respect to the parameters of a delta or null BSDF (a
``polarizer``'s angle, a smooth ``conductor``) are those of its sampled
weight, as ``path`` AD gives them; a delta lobe chosen with a
parameter-dependent probability gets no derivative of that probability
(``path`` neither).

XML::

    <integrator type="stokes_prb">
        <integer name="max_depth" value="4"/>
    </integrator>
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

from ..schema import parameter
from .film import develop_stokes, has_nonsmooth_bsdf, sensor_and_film
from .support import MAX_DEPTH_LIMIT, STOKES_CHANNELS, usable_variant
from .replay import VertexStore, replay, trace


def build_class():
    """``StokesPRBIntegrator`` on the active variant's base class (registry.plugin_class)."""
    # mi.ad is the active variant's; ``from mitsuba.ad... import`` would give
    # the ADIntegrator of the variant that first imported it.
    ADIntegrator = mi.ad.integrators.common.ADIntegrator
    variant = mi.variant()

    class StokesPRBIntegrator(ADIntegrator):
        __doc__ = __doc__

        def __init__(self, props):
            if not usable_variant(variant):
                raise RuntimeError(
                    f"stokes_prb needs a polarized JIT variant such as llvm_ad_spectral_polarized, "
                    f"not {variant!r}")
            max_depth = props.get("max_depth", parameter("max_depth", "stokes_prb").default)
            if not 0 <= max_depth <= MAX_DEPTH_LIMIT:
                raise ValueError(
                    f"stokes_prb: max_depth must be between 0 and {MAX_DEPTH_LIMIT} (path replay "
                    f"stores every vertex of a sample), got {max_depth}")
            super().__init__(props)

        def aov_names(self):
            return list(STOKES_CHANNELS)

        def to_string(self):
            return (f"StokesPRBIntegrator[max_depth = {self.max_depth}, "
                    f"rr_depth = {self.rr_depth}, hide_emitters = {self.hide_emitters}]")

        # ---------------------------------------------------------- rendering

        def render(self, scene, sensor=0, seed=0, spp=0, develop=True, evaluate=True):
            if not develop:
                raise RuntimeError("stokes_prb: develop=True must be specified (as for "
                                   "Mitsuba's AD integrators)")
            sensor, film = sensor_and_film(scene, sensor)
            with dr.suspend_grad():
                sampler, spp = self.prepare(sensor, seed, spp, self.aov_names())
                ray, weight, pos = self.sample_rays(scene, sensor, sampler)
                stokes, valid, _ = trace(self, scene, sampler, ray)
                return develop_stokes(film, sensor, spp, pos, ray, weight, stokes,
                                alpha=dr.select(valid, 1.0, 0.0))

        def render_forward(self, scene, params=None, sensor=0, seed=0, spp=0):
            sensor, film = sensor_and_film(scene, sensor)
            with dr.suspend_grad():
                sampler, spp = self.prepare(sensor, seed, spp, self.aov_names())
                ray, weight, pos = self.sample_rays(scene, sensor, sampler)
                store = VertexStore(max(self.max_depth, 1), "forward")
                _, valid, count = trace(self, scene, sampler, ray, store=store)
                tangent = replay(self, scene, ray, store, count, valid,
                                 differentiate_delta=has_nonsmooth_bsdf(scene))
                return develop_stokes(film, sensor, spp, pos, ray, weight, tangent, alpha=0.0)

        def render_backward(self, scene, params, grad_in, sensor=0, seed=0, spp=0):
            sensor, film = sensor_and_film(scene, sensor)
            with dr.suspend_grad():
                sampler, spp = self.prepare(sensor, seed, spp, self.aov_names())
                ray, weight, pos = self.sample_rays(scene, sensor, sampler)
                # Adjoint Stokes vector of each sample: the image gradient
                # pulled back through the film (rotation to the camera frame,
                # spectrum to RGB, splatting, division by the pixel weight).
                with dr.resume_grad():
                    stokes = dr.zeros(mi.SpectrumEntry, dr.width(ray))
                    dr.enable_grad(stokes)
                    image = develop_stokes(film, sensor, spp, pos, ray, weight, stokes, alpha=1.0)
                    dr.set_grad(image, grad_in)
                    dr.enqueue(dr.ADMode.Backward, image)
                    dr.traverse(dr.ADMode.Backward)
                    delta0 = dr.grad(stokes)
                film.clear()
                store = VertexStore(max(self.max_depth, 1), "reverse")
                _, valid, count = trace(self, scene, sampler, ray, store=store, delta0=delta0)
                replay(self, scene, ray, store, count, valid,
                       differentiate_delta=has_nonsmooth_bsdf(scene))
                del sampler, ray, weight, pos, stokes, delta0, store
                dr.eval()

    return StokesPRBIntegrator
