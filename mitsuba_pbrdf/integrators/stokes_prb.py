"""``stokes_prb``: polarization-aware path replay, Stokes images and their
gradients at the memory of a primal render.

.. list-table::
   :header-rows: 1

   * - Parameter
     - Type
     - Description
     - Default
   * - ``max_depth``
     - integer
     - Longest path, as in ``path`` (1: emitters seen directly, 2: direct
       illumination, ...). Between 0 and 64: the replay stores each vertex of
       a sample in local memory, so the depth must be finite.
     - 6
   * - ``rr_depth``
     - integer
     - Depth at which Russian roulette starts, as in ``path``.
     - 5
   * - ``hide_emitters``
     - boolean
     - Hide directly visible emitters, as in ``path``.
     - false

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
keeps, per sample and per vertex, in Dr.Jit local memory, the sampled Mueller
weight ``W_k``, the random numbers and the adjoint ``delta_k`` (the loss
gradient carried from the camera as a row Stokes vector); a second loop walks
the vertices backwards, rebuilds the radiance ``L_{k+1}`` arriving from the
rest of the path by ``L_k = E_k + W_k L_{k+1}`` (no inverse of a Mueller
matrix: depolarizing lobes make those singular) and differentiates
``delta_k . (E_k + T_k L_{k+1})`` one vertex at a time.

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

from .replay import VertexStore, replay, trace

__all__ = ["STOKES_CHANNELS", "MAX_DEPTH_LIMIT", "integrator_class", "register",
           "supports_scene", "from_path"]

#: The Stokes channels ``stokes`` adds after R, G, B (and A).
STOKES_CHANNELS = [f"S{i}.{c}" for i in range(4) for c in "RGB"]
#: Largest ``max_depth``: each vertex costs ~0.5 kB of local memory per lane.
MAX_DEPTH_LIMIT = 64

_classes = {}


def integrator_class():
    """The ``stokes_prb`` class for the active variant (one per variant, as
    Mitsuba's base classes differ between variants)."""
    variant = mi.variant()
    if variant not in _classes:
        _classes[variant] = _define_class()
    return _classes[variant]


def _usable_variant():
    variant = mi.variant() or ""
    return "polarized" in variant and not variant.startswith("scalar")


def _create(props):
    if not _usable_variant():
        raise RuntimeError(
            f"stokes_prb needs a polarized JIT variant such as llvm_ad_spectral_polarized, "
            f"not {mi.variant()!r}")
    return integrator_class()(props)


def register():
    """Register ``stokes_prb`` in the active variant (in the others, loading
    it says which variant to use)."""
    mi.register_integrator("stokes_prb", _create)


def _define_class():
    from mitsuba.ad.integrators.common import ADIntegrator

    class StokesPRBIntegrator(ADIntegrator):
        __doc__ = __doc__

        def __init__(self, props):
            max_depth = props.get("max_depth", 6)
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
            sensor, film = _sensor_and_film(scene, sensor)
            with dr.suspend_grad():
                sampler, spp = self.prepare(sensor, seed, spp, self.aov_names())
                ray, weight, pos = self.sample_rays(scene, sensor, sampler)
                stokes, valid, _ = trace(self, scene, sampler, ray)
                return _develop(film, sensor, spp, pos, ray, weight, stokes,
                                alpha=dr.select(valid, 1.0, 0.0))

        def render_forward(self, scene, params=None, sensor=0, seed=0, spp=0):
            sensor, film = _sensor_and_film(scene, sensor)
            with dr.suspend_grad():
                sampler, spp = self.prepare(sensor, seed, spp, self.aov_names())
                ray, weight, pos = self.sample_rays(scene, sensor, sampler)
                store = VertexStore(max(self.max_depth, 1), "forward")
                _, valid, count = trace(self, scene, sampler, ray, store=store)
                tangent = replay(self, scene, ray, store, count, valid,
                                 differentiate_delta=_has_nonsmooth_bsdf(scene))
                return _develop(film, sensor, spp, pos, ray, weight, tangent, alpha=0.0)

        def render_backward(self, scene, params, grad_in, sensor=0, seed=0, spp=0):
            sensor, film = _sensor_and_film(scene, sensor)
            with dr.suspend_grad():
                sampler, spp = self.prepare(sensor, seed, spp, self.aov_names())
                ray, weight, pos = self.sample_rays(scene, sensor, sampler)
                # Adjoint Stokes vector of each sample: the image gradient
                # pulled back through the film (rotation to the camera frame,
                # spectrum to RGB, splatting, division by the pixel weight).
                with dr.resume_grad():
                    stokes = dr.zeros(mi.SpectrumEntry, dr.width(ray))
                    dr.enable_grad(stokes)
                    image = _develop(film, sensor, spp, pos, ray, weight, stokes, alpha=1.0)
                    dr.set_grad(image, grad_in)
                    dr.enqueue(dr.ADMode.Backward, image)
                    dr.traverse(dr.ADMode.Backward)
                    delta0 = dr.grad(stokes)
                film.clear()
                store = VertexStore(max(self.max_depth, 1), "reverse")
                _, valid, count = trace(self, scene, sampler, ray, store=store, delta0=delta0)
                replay(self, scene, ray, store, count, valid,
                       differentiate_delta=_has_nonsmooth_bsdf(scene))
                del sampler, ray, weight, pos, stokes, delta0, store
                dr.eval()

    return StokesPRBIntegrator


# ------------------------------------------------------------------ film

def _sensor_and_film(scene, sensor):
    if isinstance(sensor, int):
        sensor = scene.sensors()[sensor]
    film = sensor.film()
    if mi.has_flag(film.flags(), mi.FilmFlags.Special):
        raise RuntimeError(f"stokes_prb writes RGB films (hdrfilm with pixel_format rgb or rgba), "
                           f"not {film.class_name()}")
    return sensor, film


def _camera_stokes(sensor, ray, stokes):
    """The Stokes vector in the camera's frame, as ``stokes`` rotates it: the
    reference axis is ray.d x (the sensor's up vector)."""
    vertical = sensor.world_transform() @ mi.Vector3f(0.0, 1.0, 0.0)
    rotation = mi.mueller.rotate_stokes_basis(-ray.d, mi.mueller.stokes_basis(-ray.d),
                                              dr.cross(ray.d, vertical))
    return [dr.fma(rotation[i][0], stokes[0], dr.fma(rotation[i][1], stokes[1],
                   dr.fma(rotation[i][2], stokes[2], rotation[i][3] * stokes[3])))
            for i in range(4)]


def _develop(film, sensor, spp, pos, ray, weight, stokes, alpha):
    """Splat each sample's Stokes vector as ``stokes`` + ``path`` would (R, G,
    B from the sensor-weighted S0; S0.R ... S3.B), develop, return the image."""
    s = _camera_stokes(sensor, ray, stokes)
    wavelengths = ray.wavelengths
    pdf = mi.pdf_rgb_spectrum(wavelengths)
    inv_pdf = dr.select(pdf != 0, dr.rcp(pdf), 0.0)
    channels = []
    for i in range(4):
        rgb = mi.spectrum_to_srgb(s[i] * inv_pdf, wavelengths)
        channels += [rgb.x, rgb.y, rgb.z]
    # R, G, B: unpolarized part of (sensor weight x Stokes)
    radiance = mi.spectrum_to_srgb(
        dr.fma(weight[0][0], s[0], dr.fma(weight[0][1], s[1],
               dr.fma(weight[0][2], s[2], weight[0][3] * s[3]))), wavelengths)
    block = film.create_block()
    block.set_coalesce(block.coalesce() and spp >= 4)
    head = [radiance.x, radiance.y, radiance.z]
    if mi.has_flag(film.flags(), mi.FilmFlags.Alpha):
        head.append(mi.Float(alpha))
    block.put(pos, head + [mi.Float(1.0)] + channels)
    film.put_block(block)
    return film.develop()


def _has_nonsmooth_bsdf(scene):
    """Whether a shape's BSDF has delta or null components (their weights are
    re-sampled with derivatives in the replay)."""
    non_smooth = mi.BSDFFlags.Delta | mi.BSDFFlags.Delta1D | mi.BSDFFlags.Null
    for shape in scene.shapes():
        bsdf = shape.bsdf()
        if bsdf is not None and (int(bsdf.flags()) & int(non_smooth)):
            return True
    return False


# ------------------------------------------------------------------ scenes

def supports_scene(scene):
    """``(True, "")`` if ``scene``'s integrator is ``stokes`` around ``path``
    (or already ``stokes_prb``) with a depth path replay can store, in a
    polarized JIT variant; else ``(False, why)``."""
    if not _usable_variant():
        return False, f"variant {mi.variant()!r} is not a polarized JIT variant"
    integrator = scene.integrator()
    if isinstance(integrator, integrator_class()):
        return True, ""
    nested = _nested_path(integrator)
    if nested is None:
        return False, f"the integrator is not stokes around path: {integrator.class_name()}"
    depth, _ = _path_depths(nested)
    if depth < 0 or depth > MAX_DEPTH_LIMIT:
        return False, f"path max_depth {depth} is not in [0, {MAX_DEPTH_LIMIT}]"
    film = scene.sensors()[0].film()
    if mi.has_flag(film.flags(), mi.FilmFlags.Special):
        return False, f"film {film.class_name()} is not an RGB film"
    return True, ""


def from_path(scene):
    """A ``stokes_prb`` integrator with the ``max_depth``, ``rr_depth`` and
    ``hide_emitters`` of ``scene``'s ``stokes``/``path`` integrator (check
    with :func:`supports_scene` first); the scene's own if it is one."""
    integrator = scene.integrator()
    if isinstance(integrator, integrator_class()):
        return integrator
    nested = _nested_path(integrator)
    depth, rr_depth = _path_depths(nested)
    return mi.load_dict({"type": "stokes_prb", "max_depth": depth, "rr_depth": rr_depth,
                         "hide_emitters": bool(nested.hide_emitters)})


def _nested_path(integrator):
    if integrator is None or integrator.class_name() != "StokesIntegrator":
        return None
    found = []

    class Callback(mi.TraversalCallback):
        def put(self, name, value, flags, *args):
            if isinstance(value, mi.Object):
                found.append(value)

    integrator.traverse(Callback())
    nested = [x for x in found if x.class_name() == "PathIntegrator"]
    return nested[0] if nested else None


def _path_depths(path):
    """``(max_depth, rr_depth)`` of a ``path`` integrator, read from its
    description (-1 for an unbounded depth)."""
    import re

    text = str(path)
    depth = int(re.search(r"max_depth = (\d+)", text).group(1))
    rr_depth = int(re.search(r"rr_depth = (\d+)", text).group(1))
    return (-1 if depth == 0xFFFFFFFF else depth), rr_depth
