"""Stokes cubes (``pbrdf render --bands``): S0..S3 in many narrow passbands
(:class:`~.bands.PassbandList`), one band of the image each, from one render,
one scene load and one set of kernels.

Mitsuba's ``stokes`` integrator writes R, G, B only (and its ``specfilm``
does not work inside ``stokes``), so the cube has its own render loop, in
Dr.Jit, over the scene's integrator *inside* ``stokes`` (``path``, ``direct``
or ``volpath``; the scene file is loaded with that integrator in place of
``stokes``, or with its own ``path`` ... where it has no ``stokes``, found
through ``<include>`` s and ``<ref>`` s: :mod:`.scene_setup`):

1. a sample per (pixel, spp) at a uniform position in its pixel, splatted
   with the film's reconstruction filter as Mitsuba's film does (weight
   f(x) f(y) on each pixel of the filter's footprint, pixel values divided by
   the sum of the weights they received; a box filter splats into the
   sample's own pixel only);
2. its 4 wavelengths drawn one per band in turn: the m-th wavelength of a
   pixel (m = 4 k + j for its k-th sample, lane j, counted across passes)
   lies in band m mod B (B bands), uniformly within it (position
   (u + j/4) mod 1 of the band, u one random number per sample). So every band
   gets the same number of wavelengths however narrow it is, n_b =
   #{m < 4 spp : m mod B = b} in every pixel, a fixed count: a random count
   (bands drawn at random) would add its own Poisson noise, about
   1/sqrt(4 spp / B) of the band's value even where the spectrum is smooth;
3. the Stokes vector (column 0 of the integrator's Mueller-matrix result)
   rotated into the camera frame as ``stokes`` does
   (:func:`mitsuba_pbrdf.integrators.film.camera_stokes`);
4. each lane's Stokes vector, times the filter weight and spp / n_b,
   scatter-added into the band that contains its wavelength; dividing by the
   pixel's filter weight gives the band's mean over the wavelengths drawn
   uniformly in it (with a box filter exactly the sum over the band's n_b
   wavelengths / n_b).

The expectation of band b is then (1/W_b) ∫_b S(λ) dλ, the band average of the
Stokes vector: what ``pbrdf render --wavelength c:W_b`` gives for that band
(:mod:`mitsuba_pbrdf.rendering.narrowband`). Each band gets about
4 spp / B wavelength samples per pixel; a cube needs 4 spp >= B
(:func:`band_counts`). Units: those of the scene's
radiance (the band average of the spectral radiance); frames: the camera's
(reference axis ray.d x the sensor's up vector).

The sensor's camera weight is taken as 1 (pinhole perspective, orthographic
and thin-lens cameras); scenes with a spectral response (``srf``) or a
``specfilm`` are refused (:mod:`.scene_setup`).
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..stokes.image import StokesImage
from .bands import PassbandList

__all__ = ["band_counts", "check_cube_spp", "cube_pass", "cube_image"]


def band_counts(n_bands: int, total_spp: int) -> np.ndarray:
    """Wavelengths per pixel in each band of a render of *total_spp* samples
    per pixel (4 wavelengths each, band m mod B for the m-th)."""
    return np.bincount(np.arange(4 * total_spp) % n_bands, minlength=n_bands)


def check_cube_spp(passbands: PassbandList, total_spp: int):
    """:class:`ParameterError` (``bands``) unless every passband gets a wavelength."""
    n = len(passbands.edges)
    if 4 * int(total_spp) < n:
        raise ParameterError("bands", f"{n} bands need at least {-(-n // 4)} samples per pixel "
                             f"(4 wavelengths each), got {total_spp}")


def _footprint(rfilter):
    """Pixel offsets (dx, dy) a sample can reach with *rfilter*; None for a box
    filter of radius <= 0.5 (the sample's own pixel only)."""
    radius = float(rfilter.radius())
    if rfilter.class_name() == "BoxFilter" and radius <= 0.5:
        return None
    r = int(np.ceil(radius))
    return [(dx, dy) for dy in range(-r, r + 1) for dx in range(-r, r + 1)]


def cube_pass(scene, passbands: PassbandList, spp: int, seed: int, first: int,
              total_spp: int) -> np.ndarray:
    """One pass of *spp* samples per pixel, the pixel's samples *first* ..
    *first* + spp - 1 of *total_spp*: its filter-weighted sums, float64 array
    (H, W, 4 n_bands + 1): the Stokes sums per (component, band) times
    spp / n_b, then the sum of the filter weights. The passes' arrays add up;
    :func:`cube_image` divides. Camera frame (see the module docstring)."""
    import drjit as dr
    import mitsuba as mi

    from ..integrators.film import camera_stokes

    sensor = scene.sensors()[0]
    film = sensor.film()
    width, height = (int(v) for v in film.crop_size())
    n_bands = len(passbands.edges)
    lows = mi.Float(passbands.lows.astype(np.float32))
    widths = mi.Float(passbands.widths.astype(np.float32))
    counts = band_counts(n_bands, total_spp)
    lane_scale = mi.Float((total_spp / counts).astype(np.float32))

    n = width * height * spp
    sampler = sensor.sampler().clone()
    sampler.set_sample_count(spp)
    sampler.set_samples_per_wavefront(spp)
    sampler.seed(seed, n)
    idx = dr.arange(mi.UInt32, n)
    pixel = idx // spp
    sample = idx % spp + first  # the sample's index in its pixel, across passes
    pos = mi.Vector2f(mi.Float(pixel % width), mi.Float(pixel // width)) + sampler.next_2d()
    time = sensor.shutter_open() + sensor.shutter_open_time() * sampler.next_1d()
    # the position within the crop window, as mi.render gives it (the sensor maps the crop)
    ray, _ = sensor.sample_ray(time, 0.5, pos / mi.Vector2f(width, height), sampler.next_2d())
    u = sampler.next_1d()
    lanes, band_index = [], []
    for j in range(4):  # the 4 wavelength lanes of a spectral variant (fixed, not data)
        shifted = u + j / 4.0
        within = shifted - dr.floor(shifted)
        b = (4 * sample + j) % n_bands
        band_index.append(b)
        lanes.append(dr.fma(within, dr.gather(mi.Float, widths, b), dr.gather(mi.Float, lows, b)))
    ray.wavelengths = mi.UnpolarizedSpectrum(*lanes)
    spec, _, _ = scene.integrator().sample(scene, sampler, ray, None, True)
    stokes = camera_stokes(sensor, ray, [spec[i][0] for i in range(4)])

    cube = dr.zeros(mi.Float, width * height * n_bands * 4)
    weights = dr.zeros(mi.Float, width * height)
    scales = [dr.gather(mi.Float, lane_scale, band_index[j]) for j in range(4)]
    rfilter = film.rfilter()
    footprint = _footprint(rfilter)
    corner = mi.Vector2i(dr.floor(pos))
    # the filter's footprint: a few pixel offsets (fixed by the filter, not the image)
    for dx, dy in footprint or [(0, 0)]:
        if footprint is None:
            target, weight, ok = pixel, mi.Float(1.0), mi.Bool(True)
        else:
            px, py = corner.x + dx, corner.y + dy
            weight = (rfilter.eval(mi.Float(px) + 0.5 - pos.x)
                      * rfilter.eval(mi.Float(py) + 0.5 - pos.y))
            ok = (px >= 0) & (px < width) & (py >= 0) & (py < height) & (weight != 0)
            target = mi.UInt32(dr.select(ok, py * width + px, 0))
        dr.scatter_reduce(dr.ReduceOp.Add, weights, weight, target, ok)
        for j in range(4):
            base = (target * n_bands + band_index[j]) * 4
            for i in range(4):
                dr.scatter_reduce(dr.ReduceOp.Add, cube, stokes[i][j] * (weight * scales[j]),
                                  base + i, ok)
    sums = np.array(cube, dtype=np.float64).reshape(height, width, n_bands, 4)
    sums = np.moveaxis(sums, 3, 2).reshape(height, width, 4 * n_bands)
    return np.concatenate([sums, np.array(weights, dtype=np.float64).reshape(height, width, 1)],
                          axis=2)


def cube_image(stokes: np.ndarray, passbands: PassbandList, metadata=None) -> StokesImage:
    """The cube as a :class:`StokesImage`: one band per passband, named after
    its centre, the passbands' edges in ``metadata['band_edges_nm']``.
    *stokes* is the cube (H, W, 4, n_bands), or the sum of :func:`cube_pass`'s
    arrays (H, W, 4 n_bands + 1), divided here by its filter weights."""
    n = len(passbands.edges)
    if stokes.ndim == 3:
        weights = stokes[..., -1:]
        safe = np.where(weights > 0, weights, 1.0)
        stokes = (stokes[..., :-1] / safe).reshape(stokes.shape[0], stokes.shape[1], 4, n)
    metadata = dict(metadata or {}, band_edges_nm=passbands.header(), spectral_cube="1")
    return StokesImage(stokes.astype(np.float32), passbands.names, None, metadata)
