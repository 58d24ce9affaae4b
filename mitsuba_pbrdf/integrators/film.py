"""The film side of ``stokes_prb``: splatting per-sample Stokes vectors as
``stokes`` around ``path`` does (camera frame, RGB bands), and the scene
checks the integrator makes before it renders. Variant-independent: every
``mi`` name is looked up when a function runs."""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

__all__ = ["sensor_and_film", "develop_stokes", "has_nonsmooth_bsdf"]


def sensor_and_film(scene, sensor):
    if isinstance(sensor, int):
        sensor = scene.sensors()[sensor]
    film = sensor.film()
    if mi.has_flag(film.flags(), mi.FilmFlags.Special):
        raise RuntimeError(f"stokes_prb writes RGB films (hdrfilm with pixel_format rgb or rgba), "
                           f"not {film.class_name()}")
    return sensor, film


def camera_stokes(sensor, ray, stokes):
    """The Stokes vector in the camera's frame, as ``stokes`` rotates it: the
    reference axis is ray.d x (the sensor's up vector)."""
    vertical = sensor.world_transform() @ mi.Vector3f(0.0, 1.0, 0.0)
    rotation = mi.mueller.rotate_stokes_basis(-ray.d, mi.mueller.stokes_basis(-ray.d),
                                              dr.cross(ray.d, vertical))
    return [dr.fma(rotation[i][0], stokes[0], dr.fma(rotation[i][1], stokes[1],
                   dr.fma(rotation[i][2], stokes[2], rotation[i][3] * stokes[3])))
            for i in range(4)]


def develop_stokes(film, sensor, spp, pos, ray, weight, stokes, alpha):
    """Splat each sample's Stokes vector as ``stokes`` + ``path`` would (R, G,
    B from the sensor-weighted S0; S0.R ... S3.B), develop, return the image."""
    s = camera_stokes(sensor, ray, stokes)
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


def has_nonsmooth_bsdf(scene):
    """Whether a shape's BSDF has delta or null components (their weights are
    re-sampled with derivatives in the replay)."""
    non_smooth = mi.BSDFFlags.Delta | mi.BSDFFlags.Delta1D | mi.BSDFFlags.Null
    for shape in scene.shapes():
        bsdf = shape.bsdf()
        if bsdf is not None and (int(bsdf.flags()) & int(non_smooth)):
            return True
    return False
