"""Scaffolding for the polarized-light tests (tests/test_polarized_light.py)
and benchmarks/polarized_sky.py: small scenes around the package's emitters,
their Stokes renders, the rays through pixel centres, and an independent
NumPy float64 statement of the sky models and of Mitsuba's camera Stokes
basis.

The reference statements are deliberately in a different form from the
plugin's (:mod:`mitsuba_pbrdf.emitters.sky_models`): the Rayleigh pattern from
the scattering plane's normal ``sun x view`` and the angles of the Stokes
parameters, Berry, Dennis and Lee's pattern in the paper's own stereographic
form (complex ``w(zeta)``, the polarization direction at ``arg(w)/2`` from the
sun's meridian, mapped back to the sphere by a small step in the plane).
"""

from __future__ import annotations

import numpy as np


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def sun_vector(elevation_deg, azimuth_deg):
    """Direction towards the sun, +Z up, azimuth from +X towards +Y."""
    e, a = np.radians(elevation_deg), np.radians(azimuth_deg)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


# ---------------------------------------------------------------- Stokes bases

def camera_basis(d, up):
    """The ``stokes`` integrator's basis for a pixel whose ray goes along
    ``d``: x = normalize(d x up), y = w x x with w = -d (the light's
    propagation), angles counter-clockwise about w."""
    d = unit(d)
    x = unit(np.cross(d, np.broadcast_to(up, d.shape)))
    return x, np.cross(-d, x)


def linear_stokes(degree, e, x, y):
    """(q, u) of light linearly polarized to ``degree`` along ``e`` (3-vectors
    perpendicular to the propagation), in the basis (x, y)."""
    chi = np.arctan2(np.sum(e * y, -1), np.sum(e * x, -1))
    return degree * np.cos(2 * chi), degree * np.sin(2 * chi)


# ---------------------------------------------------------------- sky models

def rayleigh(view, sun, dolp_max):
    """(degree, E direction) of single-scattering skylight seen in direction
    ``view``: dolp_max sin²γ / (1 + cos²γ), E along sun x view."""
    view = unit(view)
    cos_g = np.clip(view @ sun, -1, 1)
    degree = dolp_max * (1 - cos_g ** 2) / (1 + cos_g ** 2)
    e = np.cross(np.broadcast_to(sun, view.shape), view)
    n = np.linalg.norm(e, axis=-1, keepdims=True)
    return degree, np.where(n > 1e-12, e / np.maximum(n, 1e-300), 0.0)


def _zeta(v):
    """Stereographic coordinate tan(theta/2) exp(i phi) of unit vectors (+Z up)."""
    theta = np.arccos(np.clip(v[..., 2], -1, 1))
    return np.tan(theta / 2) * np.exp(1j * np.arctan2(v[..., 1], v[..., 0]))


def _from_zeta(z):
    theta = 2 * np.arctan(np.abs(z))
    phi = np.angle(z)
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                     np.cos(theta)], -1)


def berry_stereographic(view, sun_elevation_deg, sun_azimuth_deg, separation_deg, dolp_max):
    """(degree, E direction) of Berry, Dennis and Lee's (2004) sky in its
    stereographic form: neutral points separation/2 above (Babinet) and below
    (Brewster) the sun, Arago and the fourth point antipodal to them,
    ``w = -4 (z-Ba)(z-Br)(z-Ar)(z-Fo) / ((1+|z|²)² |Ba-Fo| |Br-Ar|)``,
    degree dolp_max |w|/(2-|w|), E at arg(w)/2 - phi_sun from the real axis
    of the plane. +Z up; valid while the Babinet point is on the sun's side
    of the zenith."""
    view = unit(view)
    theta_s = np.radians(90.0 - sun_elevation_deg)
    phi_s = np.radians(sun_azimuth_deg)
    half = np.radians(separation_deg) / 2
    ba = np.tan((theta_s - half) / 2) * np.exp(1j * phi_s)
    br = np.tan((theta_s + half) / 2) * np.exp(1j * phi_s)
    ar, fo = -1 / np.conj(br), -1 / np.conj(ba)
    z = _zeta(view)
    w = (-4 * (z - ba) * (z - br) * (z - ar) * (z - fo)
         / ((1 + np.abs(z) ** 2) ** 2 * np.abs(ba - fo) * np.abs(br - ar)))
    degree = dolp_max * np.abs(w) / (2 - np.abs(w))
    chi = 0.5 * np.angle(w * np.exp(-2j * phi_s))
    step = 1e-6 * (1 + np.abs(z) ** 2)
    e = _from_zeta(z + step * np.exp(1j * chi)) - _from_zeta(z)
    e -= np.sum(e * view, -1, keepdims=True) * view
    return degree, unit(e)


# ---------------------------------------------------------------- scenes

def camera(origin, target, up, fov=50.0, width=32, height=24, kind="perspective"):
    """A camera whose single sample per pixel goes through the pixel centre
    (stratified sampler without jitter, box filter)."""
    import mitsuba as mi

    sensor = {"type": kind,
              "to_world": mi.ScalarTransform4f().look_at(origin=origin, target=target, up=up),
              "film": {"type": "hdrfilm", "width": width, "height": height,
                       "rfilter": {"type": "box"}, "pixel_format": "rgb"},
              "sampler": {"type": "stratified", "sample_count": 1, "jitter": False}}
    if kind == "perspective":
        sensor["fov"] = fov
    return sensor


def scene(emitter, sensor, shapes=None, max_depth=2):
    """A scene dict: ``stokes`` around ``path`` in polarized variants, ``path``
    alone otherwise."""
    import mitsuba as mi

    inner = {"type": "path", "max_depth": max_depth}
    out = {"type": "scene", "sensor": sensor, "sky": emitter,
           "integrator": {"type": "stokes", "inner": inner} if mi.is_polarized else inner}
    out.update(shapes or {})
    return out


def render_stokes(scene_dict, spp=1, seed=0):
    """(StokesImage, loaded scene); in unpolarized variants the image holds
    S0 only (S1 = S2 = S3 = 0)."""
    import mitsuba as mi

    from mitsuba_pbrdf.stokes import as_stokes_image, from_mitsuba

    loaded = mi.load_dict(scene_dict)
    image = mi.render(loaded, spp=spp, seed=seed)
    film = loaded.sensors()[0].film()
    if mi.is_polarized:
        return from_mitsuba(image, film), loaded
    rgb = np.array(image, dtype=np.float32)[..., :3]
    stokes = np.zeros(rgb.shape[:2] + (4, 3), np.float32)
    stokes[:, :, 0, :] = rgb
    return as_stokes_image(stokes, ["R", "G", "B"]), loaded


def pixel_rays(loaded):
    """(origins, directions), (H, W, 3) float64, of the rays through the pixel
    centres of the scene's sensor."""
    import drjit as dr
    import mitsuba as mi

    sensor = loaded.sensors()[0]
    width, height = sensor.film().crop_size()
    j, i = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    pos = mi.Point2f(mi.Float(((i + 0.5) / width).ravel()), mi.Float(((j + 0.5) / height).ravel()))
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    shape = (height, width, 3)
    o = np.stack([np.array(c, np.float64) for c in ray.o], -1).reshape(shape)
    d = np.stack([np.array(c, np.float64) for c in ray.d], -1).reshape(shape)
    dr.eval()
    return o, unit(d)


def camera_up(loaded):
    """The sensor's up vector in world space (its local +Y)."""
    import mitsuba as mi

    m = np.array(loaded.sensors()[0].world_transform().matrix, np.float64)
    m = m.reshape(4, 4) if m.size == 16 else m[..., 0].reshape(4, 4)
    return unit(m[:3, 1])


def normalized(image):
    """(q, u, v) = (S1, S2, S3) / S0 of the summed bands of a StokesImage (the
    ratios are band-independent where the light's polarization is), and S0."""
    s = image.stokes.sum(axis=-1).astype(np.float64)
    s0 = s[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        return s[..., 1] / s0, s[..., 2] / s0, s[..., 3] / s0, s0
