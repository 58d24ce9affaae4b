"""Scaffolding for the polarized-light tests (tests/emitters/test_polarized_light.py)
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


# ---------------------------------------------------------------- lat-long Stokes maps

def latlong_directions(width, height):
    """(H, W, 3) local directions of the texels of a lat-long map in Mitsuba's
    envmap layout, and the lat-long Stokes basis x (increasing azimuth)."""
    phi = 2 * np.pi * (np.arange(width) + 0.5) / width
    theta = np.pi * np.arange(height) / (height - 1)
    phi, theta = np.meshgrid(phi, theta)
    d = np.stack([np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)], -1)
    east = np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], -1)
    return d, east


def bilinear_latlong(values, d):
    """Bilinear interpolation of a lat-long map ``values`` (H, W, C) at local
    directions d (N, 3), on Mitsuba's envmap grid (float64)."""
    height, width = values.shape[:2]
    u = (np.arctan2(d[:, 0], -d[:, 2]) / (2 * np.pi)) % 1.0
    v = np.arccos(np.clip(d[:, 1], -1, 1)) / np.pi
    x = u * width - 0.5
    x = np.where(x < 0, x + width, x)
    y = np.clip(v * (height - 1), 0, height - 1)
    i0 = np.minimum(np.floor(x).astype(int), width - 1)
    j0 = np.minimum(np.floor(y).astype(int), height - 2)
    fx, fy = (x - i0)[:, None], (y - j0)[:, None]
    i1 = (i0 + 1) % width
    top = values[j0, i0] * (1 - fx) + values[j0, i1] * fx
    bottom = values[j0 + 1, i0] * (1 - fx) + values[j0 + 1, i1] * fx
    return top * (1 - fy) + bottom * fy


#: to_world of a lat-long map whose local +Y is the world's +Z (the sky's up)
Y_TO_Z = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])


def rayleigh_latlong(width, height, sun, dolp_max, rotation=Y_TO_Z):
    """(H, W, 4) Stokes map (S0 = 1) of the Rayleigh sky in the lat-long
    basis, for a map turned into the world by ``rotation``."""
    d, east = latlong_directions(width, height)
    d_world, east_world = d @ rotation.T, east @ rotation.T
    degree, e = rayleigh(d_world, sun, dolp_max)
    y = np.cross(-d_world, east_world)
    q, u = linear_stokes(degree, e, east_world, y)
    return np.stack([np.ones_like(q), q, u, np.zeros_like(q)], -1)


# ---------------------------------------------------------------- reflection

def rotate_stokes(stokes, x_from, x_to, w):
    """Stokes vectors (..., 4) in the basis with x axis ``x_from`` re-expressed
    in the basis with x axis ``x_to`` (both perpendicular to the propagation
    ``w``; y = w x x)."""
    y_to = np.cross(w, x_to)
    c, s = np.sum(x_from * x_to, -1), np.sum(x_from * y_to, -1)   # x_from = c x_to + s y_to
    cos2, sin2 = c * c - s * s, 2 * c * s
    out = stokes.copy()
    out[..., 1] = cos2 * stokes[..., 1] - sin2 * stokes[..., 2]
    out[..., 2] = sin2 * stokes[..., 1] + cos2 * stokes[..., 2]
    return out


def reflected(d, up, incident, eta, k, normal=(0.0, 0.0, 1.0)):
    """(q, u, v, F, stokes_in) of the light a camera ray ``d`` (H, W, 3) sees
    in a smooth plane of index eta + ik: ``incident(r)`` gives the Stokes
    vector (..., 4) of the light arriving from direction r and its basis x
    axis (propagation -r); the reference's Fresnel matrix in the s/p frames
    of reflection (x = normalize(n x propagation)); the result in the camera
    basis. ``stokes_in`` is the incident vector in the s/p frame."""
    from mitsuba_pbrdf.reference import fresnel_mueller

    n = np.asarray(normal, np.float64)
    r = d - 2 * (d @ n)[..., None] * n
    stokes, x_basis = incident(r)
    s_in = unit(np.cross(n, -r))
    stokes_in = rotate_stokes(stokes, x_basis, s_in, -r)
    F = fresnel_mueller(r @ n, eta, k)
    out = np.einsum("...ij,...j->...i", F, stokes_in)
    x, _ = camera_basis(d, up)
    out = rotate_stokes(out, unit(np.cross(n, -d)), x, -d)
    return out[..., 1] / out[..., 0], out[..., 2] / out[..., 0], out[..., 3] / out[..., 0], \
        F, stokes_in


def rayleigh_incident(sun, dolp_max):
    """``incident`` for :func:`reflected`: the Rayleigh sky."""
    def incident(r):
        degree, e = rayleigh(r, sun, dolp_max)
        x = unit(np.cross(np.broadcast_to([0.0, 0.0, 1.0], r.shape), -r))
        q, u = linear_stokes(degree, e, x, np.cross(-r, x))
        return np.stack([np.ones_like(q), q, u, np.zeros_like(q)], -1), x
    return incident


def latlong_incident(stokes_map, rotation=Y_TO_Z):
    """``incident`` for :func:`reflected`: a lat-long Stokes map turned into
    the world by ``rotation``, interpolated as ``stokes_envmap`` does."""
    def incident(r):
        shape = r.shape
        d_local = r.reshape(-1, 3) @ rotation          # rotation is orthogonal
        values = bilinear_latlong(stokes_map, d_local)
        east = np.stack([-d_local[:, 2], np.zeros(len(d_local)), d_local[:, 0]], -1)
        east = unit(east @ rotation.T)
        return values.reshape(shape[:-1] + (4,)), east.reshape(shape)
    return incident
