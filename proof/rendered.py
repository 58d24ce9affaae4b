"""Rendered Stokes images of aluminium and copper measured against physics:
:func:`measure` renders a scene in passes and compares each pixel with the
geometry of reflection and with the float64 reference evaluator.

Scenes (``llvm_ad_spectral_polarized``, ``stokes`` + ``direct`` integrators,
box pixel filter): a plate and a sphere of ``pbrdf`` with the metal's tabulated
n, k (``material="Al"`` / ``"Cu"``, three lobes), lit by an unpolarized
directional light whose spectrum is a narrow band (628-638 nm) so that every
wavelength carried by a pixel sees nearly the same n + ik.

Checks per pixel:

* **Angle of linear polarization from geometry alone.** Unpolarized light
  reflected by the specular lobe from wi to wr is reflected by the facets with
  normal h = normalize(wi + wr); it leaves s-polarized with respect to that
  facet's plane of incidence (R_s >= R_p for every metal), i.e. polarized along
  ``wi x wr``, perpendicular to the plane containing the incident and the
  reflected ray. The depolarized lobes do not change the angle. So the expected
  AoLP of every pixel is the angle of ``wi x wr`` in the camera's Stokes frame
  (x = cross(ray direction, camera up)) - for the pixels whose ray lies in the
  plane of incidence (the plate's middle column), the direction perpendicular to
  the plane of incidence. No BRDF evaluation is involved.
* **Degree of linear polarization against the reference evaluator**: the
  footprint average (8 x 8 rays per pixel) of the reference's Stokes vector for
  unpolarized light, integrated over the light's band with the sensor's
  response (``band_weights``), rotated into the camera frame.

Noise: ``passes`` independent renders with different seeds; per pixel the
standard error of the mean DoLP (AoLP) over passes. Pixels compared: every ray
of the footprint hits the object, the light is more than ~3 deg above the local
horizon for the whole footprint (the terminator is a discontinuity the
footprint quadrature cannot resolve) and, for AoLP, the reference DoLP is at
least 10 standard errors (where the angle is defined).

Units and frames: Stokes vectors in the camera's Stokes frame (x =
cross(ray direction, camera up), Mitsuba's ``stokes_basis`` convention), S0 in
arbitrary units (a least-squares scale is fitted), angles in radians unless a
name ends in ``_deg``, wavelengths in nm.
"""

import time

import numpy as np

from mitsuba_pbrdf import reference

BAND = (628.0, 638.0)                        # nm, the light's spectrum (plus 1 nm ramps)
BAND_NODES = np.linspace(BAND[0], BAND[1], 6)   # the reference's wavelengths in the band
LOBES = dict(kdd=0.15, sigma_dd=0.5, kid=0.03)
SIGMA = {"Al": 0.12, "Cu": 0.18}
SUBPIXELS = 8

SCENES = {
    # The plate of scenes/analytic_plane.xml, the light in the x-z plane so that
    # the middle column (odd width) sees the plane of incidence.
    "plate": dict(width=65, height=48, fov=40.0, origin=(2.4, 0.0, 1.2), target=(0.2, 0.0, 0.0),
                  up=(0.0, 0.0, 1.0), light=(0.85, 0.0, -0.45)),
    # A unit sphere seen from +z, lit from the right, slightly behind (phase angle ~96 deg).
    "sphere": dict(width=64, height=64, fov=34.0, origin=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0),
                   up=(0.0, 1.0, 0.0), light=(-0.95, -0.25, 0.1)),
}


def light_spectrum():
    """A 10 nm wide band (linear ramps of 1 nm at the edges)."""
    lo, hi = BAND
    return {"type": "irregular", "wavelengths": f"{lo - 1}, {lo}, {hi}, {hi + 1}",
            "values": "0, 1, 1, 0"}


def band_weights():
    """Quadrature weights of BAND_NODES for what a pixel records: the integral
    over wavelength of S(lambda) E(lambda) (r + g + b)(lambda), with E the
    light's spectrum and r, g, b Mitsuba's linear sRGB responses (CIE 1931 XYZ
    -> sRGB); S is interpolated linearly between the nodes and held constant
    over the 1 nm ramps. Normalized to sum 1 (a common factor cancels in DoLP
    and AoLP and is fitted for S0)."""
    import mitsuba as mi

    lam = np.linspace(BAND[0] - 1.0, BAND[1] + 1.0, 2401)
    emission = np.interp(lam, [BAND[0] - 1, BAND[0], BAND[1], BAND[1] + 1], [0.0, 1.0, 1.0, 0.0])
    xyz = mi.cie1931_xyz(mi.Float(lam.astype(np.float32)))
    rgb = np.asarray(mi.xyz_to_srgb(mi.Color3f(xyz)), dtype=np.float64)
    response = emission * rgb.sum(axis=0)
    hats = np.stack([np.interp(lam, BAND_NODES, np.eye(len(BAND_NODES))[j])
                     for j in range(len(BAND_NODES))])       # constant beyond the end nodes
    w = (hats * response).sum(axis=1)
    return w / w.sum()


def scene_dict(name, metal):
    import mitsuba as mi

    s = SCENES[name]
    bsdf = dict({"type": "pbrdf", "material": metal, "sigma": SIGMA[metal]}, **LOBES)
    if name == "plate":
        shape = {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(10), "bsdf": bsdf}
    else:
        shape = {"type": "sphere", "bsdf": bsdf}
    return {
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": {"type": "direct"}},
        "sensor": {"type": "perspective", "fov": s["fov"],
                   "to_world": mi.ScalarTransform4f().look_at(origin=s["origin"], target=s["target"],
                                                              up=s["up"]),
                   "sampler": {"type": "independent"},
                   "film": {"type": "hdrfilm", "width": s["width"], "height": s["height"],
                            "pixel_format": "rgb", "rfilter": {"type": "box"}}},
        "light": {"type": "directional", "direction": s["light"],
                  "irradiance": light_spectrum()},
        "object": shape,
    }


def render(scene, spp, passes, seed=0):
    """(passes, H, W, 4) Stokes vectors, the colour channels summed (the light is
    narrowband: every channel carries the same Stokes vector up to a factor)."""
    import mitsuba as mi

    out = []
    for p in range(passes):
        img = np.array(mi.render(scene, spp=spp, seed=seed + 1000 * p), dtype=np.float64)
        out.append(img[..., 3:15].reshape(img.shape[:-1] + (4, 3)).sum(axis=-1))
    return np.stack(out)


# ---------------------------------------------------------------------------
# Expected values
# ---------------------------------------------------------------------------

def _normalize(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def hit(name, origin, direction):
    """(hit mask, surface normal) per ray for the scene's object."""
    if name == "plate":
        t = -origin[..., 2] / direction[..., 2]
        p = origin + t[..., None] * direction
        mask = (t > 0) & (np.abs(p[..., 0]) < 10) & (np.abs(p[..., 1]) < 10)
        return mask, np.broadcast_to([0.0, 0.0, 1.0], origin.shape)
    b = np.sum(origin * direction, axis=-1)
    c = np.sum(origin * origin, axis=-1) - 1.0
    disc = b * b - c
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    mask = (disc > 0) & (t > 0)
    return mask, _normalize(origin + t[..., None] * direction)


def angle_in_camera_frame(vector, direction, up):
    """Angle (rad) of a transverse ``vector`` from the camera's Stokes x axis
    cross(direction, up) (``direction``: the camera ray's), measured towards
    its y axis w x x_axis, where w = -direction is the direction in which the
    light propagates (right-handed (x, y, w), as Mitsuba's stokes_basis)."""
    x_axis = _normalize(np.cross(direction, up))
    y_axis = np.cross(-direction, x_axis)
    return np.arctan2(np.sum(vector * y_axis, -1), np.sum(vector * x_axis, -1))


def rotator_to_camera(forward, current, target):
    """Mueller rotator from Stokes basis ``current`` to ``target`` about
    ``forward`` (mitsuba.mueller.rotate_stokes_basis)."""
    theta = np.arccos(np.clip(np.sum(current * target, axis=-1), -1.0, 1.0))
    theta = np.where(np.sum(forward * np.cross(current, target), axis=-1) < 0, -theta, theta)
    return reference.rotator(theta)


def expected(name, metal, scene):
    """Per pixel: (valid mask, reference Stokes (H, W, 4) in the camera frame
    for unit irradiance, expected AoLP from geometry (H, W), and the same
    Stokes with 4 x 4 rays per pixel for the footprint-quadrature error)."""
    origin, direction, up = pixel_rays(scene.sensors()[0], SUBPIXELS)
    mask, normal = hit(name, origin, direction)
    w_i = _normalize(-np.asarray(SCENES[name]["light"], dtype=np.float64))   # towards the light
    w_r = -direction                                                         # towards the camera
    cos_i = np.sum(normal * w_i, -1)
    cos_r = np.sum(normal * w_r, -1)

    # Local frame per ray: z = normal, x = any tangent.
    helper = np.where(np.abs(normal[..., :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    e1 = _normalize(np.cross(helper, normal))
    e2 = np.cross(normal, e1)

    def angles(w):
        return (np.arccos(np.clip(np.sum(w * normal, -1), -1, 1)),
                np.arctan2(np.sum(w * e2, -1), np.sum(w * e1, -1)))

    ti, pi_ = angles(np.broadcast_to(w_i, w_r.shape))
    tr, pr = angles(w_r)
    n, k = reference.conductor_ior(metal, BAND_NODES)
    weights = band_weights()
    stokes = np.zeros(ti.shape + (4,))
    for row in range(ti.shape[0]):                   # one image row at a time: lean memory
        F = reference.pbrdf(ti[row, ..., None], pi_[row, ..., None], tr[row, ..., None],
                            pr[row, ..., None], n, k, SIGMA[metal], **LOBES)
        stokes[row] = np.einsum("...w,...wi->...i", np.broadcast_to(weights, F.shape[:-2]),
                                F[..., :, 0])
    stokes *= np.maximum(cos_i, 0)[..., None]
    stokes = np.where(mask[..., None], stokes, 0.0)
    # reference output frame: s = normalize(n x w_r) (surface x axis at normal exit)
    s_out = np.cross(normal, w_r)
    s_norm = np.linalg.norm(s_out, axis=-1, keepdims=True)
    s_out = np.where(s_norm > 1e-12, s_out / np.maximum(s_norm, 1e-300), e1)
    camera_x = _normalize(np.cross(direction, up))
    stokes = np.einsum("...ij,...j->...i", rotator_to_camera(w_r, s_out, camera_x), stokes)

    valid = np.all(mask, axis=-1) & np.all(cos_i > 0.05, axis=-1) & np.all(cos_r > 0.05, axis=-1)
    pixel = stokes.mean(axis=2)
    coarse = stokes.reshape(stokes.shape[:2] + (SUBPIXELS // 2, 2, SUBPIXELS // 2, 2, 4))
    coarse = coarse[:, :, :, 0, :, 0].reshape(stokes.shape[:2] + (-1, 4)).mean(axis=2)

    # geometry only: polarization along w_i x w_r (the pixel's mean ray direction)
    d = _normalize(direction.mean(axis=2))
    perpendicular = np.cross(np.broadcast_to(w_i, d.shape), -d)
    aolp_geometry = angle_in_camera_frame(perpendicular, d, up)
    return valid, pixel, aolp_geometry, coarse


def dolp(stokes):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.hypot(stokes[..., 1], stokes[..., 2]) / stokes[..., 0]


def aolp(stokes):
    return 0.5 * np.arctan2(stokes[..., 2], stokes[..., 1])


def wrap_half_pi(a):
    """Angle difference modulo pi, in [-pi/2, pi/2)."""
    return (a + 0.5 * np.pi) % np.pi - 0.5 * np.pi


# ---------------------------------------------------------------------------
# Study
# ---------------------------------------------------------------------------

def measure(name, metal, spp=256, passes=8):
    """Render and compare; returns a dict of figures of merit and images."""
    import mitsuba as mi

    scene = mi.load_dict(scene_dict(name, metal))
    start = time.perf_counter()
    images = render(scene, spp, passes)
    seconds = time.perf_counter() - start
    valid, ref, aolp_geo, coarse = expected(name, metal, scene)

    valid &= np.all(images[..., 0] > 0, axis=0)     # every pass saw light (narrow band)
    mean = images.mean(axis=0)
    # scale: least squares of rendered S0 on reference S0 over valid pixels
    # (irradiance x band x colour response: one constant per image)
    scale = np.sum(mean[..., 0] * ref[..., 0] * valid) / np.sum(ref[..., 0] ** 2 * valid)

    dolp_passes = dolp(images)
    dolp_mean = dolp(mean)
    dolp_se = dolp_passes.std(axis=0, ddof=1) / np.sqrt(passes)
    dolp_ref = dolp(ref)
    footprint = np.abs(dolp(coarse) - dolp_ref)          # 4x4 vs 8x8 rays: quadrature error
    d_dolp = dolp_mean - dolp_ref

    aolp_mean = aolp(mean)
    aolp_se = np.sqrt(np.mean(wrap_half_pi(aolp(images) - aolp_mean) ** 2, axis=0)
                      * passes / (passes - 1)) / np.sqrt(passes)
    polarized = valid & (dolp_ref > 10 * np.maximum(dolp_se, 1e-12))
    d_aolp_geo = wrap_half_pi(aolp_mean - aolp_geo)
    d_aolp_ref_geo = wrap_half_pi(aolp(ref) - aolp_geo)

    middle = np.zeros_like(valid)
    if name == "plate":
        middle[:, SCENES[name]["width"] // 2] = True      # rays in the plane of incidence
    in_plane = polarized & middle

    z = np.abs(d_dolp[valid]) / np.maximum(dolp_se[valid] + footprint[valid], 1e-12)
    z_aolp = np.abs(d_aolp_geo[polarized]) / np.maximum(aolp_se[polarized], 1e-12)
    # Aggregates robust to the heavy tails of per-pixel standard errors from
    # few passes: the image mean of the difference against its standard error
    # (a systematic error shows as a bias), and the RMS difference against the
    # RMS standard error (for pure noise they are equal in expectation).
    geometry_error = np.abs(d_aolp_ref_geo[polarized])    # single ray vs footprint average
    d_aolp_ref = wrap_half_pi(aolp_mean - aolp(ref))      # rendered vs reference evaluator
    aolp_footprint = np.abs(wrap_half_pi(aolp(coarse) - aolp(ref)))
    return {
        "scene": name, "metal": metal, "spp": spp, "passes": passes, "seconds": seconds,
        "pixels": int(valid.sum()), "polarized_pixels": int(polarized.sum()),
        "in_plane_pixels": int(in_plane.sum()),
        "scale": scale,
        "dolp_ref_max": float(dolp_ref[valid].max()),
        "dolp_mean_abs_error": float(np.abs(d_dolp[valid]).mean()),
        "dolp_max_abs_error": float(np.abs(d_dolp[valid]).max()),
        "dolp_bias": float(d_dolp[valid].mean()),
        "dolp_bias_se": float(np.sqrt(np.sum(dolp_se[valid] ** 2)) / valid.sum()),
        "dolp_median_se": float(np.median(dolp_se[valid])),
        "dolp_max_z": float(z.max()),
        "dolp_frac_3se": float(np.mean(np.abs(d_dolp[valid]) <= 3 * dolp_se[valid]
                                       + footprint[valid])),
        "footprint_max": float(footprint[valid].max()),
        "aolp_max_error_deg": float(np.degrees(np.abs(d_aolp_geo[polarized]).max())),
        "aolp_rms_error_deg": float(np.degrees(np.sqrt(np.mean(d_aolp_geo[polarized] ** 2)))),
        "aolp_median_se_deg": float(np.degrees(np.median(aolp_se[polarized]))),
        "aolp_max_z": float(z_aolp.max()),
        "aolp_ref_vs_geometry_deg": float(np.degrees(
            np.abs(d_aolp_ref_geo[valid & (dolp_ref > 1e-4)]).max())),
        "aolp_in_plane_max_deg": (float(np.degrees(np.abs(d_aolp_geo[in_plane]).max()))
                                  if in_plane.any() else np.nan),
        "aolp_in_plane_mean_deg": (float(np.degrees(d_aolp_geo[in_plane].mean()))
                                   if in_plane.any() else np.nan),
        "aolp_in_plane_mean_se_deg": (float(np.degrees(np.sqrt(np.sum(aolp_se[in_plane] ** 2))
                                                       / in_plane.sum()))
                                      if in_plane.any() else np.nan),
        "dolp_rms_error": float(np.sqrt(np.mean(d_dolp[valid] ** 2))),
        "dolp_rms_se": float(np.sqrt(np.mean(dolp_se[valid] ** 2))),
        "footprint_rms": float(np.sqrt(np.mean(footprint[valid] ** 2))),
        "aolp_mean_error_deg": float(np.degrees(d_aolp_geo[polarized].mean())),
        "aolp_mean_se_deg": float(np.degrees(np.sqrt(np.sum(aolp_se[polarized] ** 2))
                                             / max(polarized.sum(), 1))),
        "aolp_rms_se_deg": float(np.degrees(np.sqrt(np.mean(aolp_se[polarized] ** 2)))),
        "aolp_geometry_rms_deg": float(np.degrees(np.sqrt(np.mean(geometry_error ** 2)))),
        "aolp_ref_mean_error_deg": float(np.degrees(d_aolp_ref[polarized].mean())),
        "aolp_ref_rms_error_deg": float(np.degrees(np.sqrt(np.mean(d_aolp_ref[polarized] ** 2)))),
        "aolp_ref_max_error_deg": float(np.degrees(np.abs(d_aolp_ref[polarized]).max())),
        "aolp_footprint_rms_deg": float(np.degrees(np.sqrt(np.mean(aolp_footprint[polarized] ** 2)))),
        "images": dict(mean=mean, valid=valid, dolp=dolp_mean, dolp_ref=dolp_ref, d_dolp=d_dolp,
                       dolp_se=dolp_se, aolp=aolp_mean, aolp_geo=aolp_geo, polarized=polarized),
    }


def pixel_rays(sensor, subpixels):
    import mitsuba as mi

    """Rays of ``sensor`` through an S x S grid of points in every pixel (S =
    ``subpixels``): origins and directions (world), shape (H, W, S*S, 3), and
    the camera's up vector, which with the ray direction fixes the Stokes frame
    of Mitsuba's ``stokes`` integrator (x axis = cross(direction, up)). For
    comparing rendered pixels (box filter) with footprint averages of the
    reference."""
    import mitsuba as mi

    width, height = sensor.film().crop_size()
    u = (np.arange(subpixels) + 0.5) / subpixels
    px, py, su, sv = np.meshgrid(np.arange(width), np.arange(height), u, u, indexing="xy")
    x = ((px + su) / width).ravel()
    y = ((py + sv) / height).ravel()
    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(x, y), mi.Point2f(0.5, 0.5))
    shape = (height, width, subpixels * subpixels, 3)
    origin = np.array(ray.o, dtype=np.float64).T.reshape(shape)
    direction = np.array(ray.d, dtype=np.float64).T.reshape(shape)
    up = np.array(sensor.world_transform() @ mi.Vector3f(0, 1, 0), dtype=np.float64).ravel()
    return origin, direction, up
