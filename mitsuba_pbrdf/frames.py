"""The bridge between Mitsuba and the reference evaluator's frames: evaluate
any Mitsuba BSDF as a BRDF Mueller matrix in the global s/p frames.

``mitsuba_pbrdf.reference.pbrdf`` returns BRDF Mueller matrices (1/sr, no
cosine) in the *global s/p frames* (see its module docstring): the incident
light propagates along ``d_in = -wi`` with Stokes x-axis
``normalize(z x d_in)``, the reflected light along ``d_out = wr`` with x-axis
``normalize(z x d_out)``; ``(1, 0, 0)`` at normal incidence.

Mitsuba's ``bsdf.eval(ctx, si, wo)`` returns instead (polarized variants):

* the BRDF times ``|cos theta|`` of its ``wo`` argument;
* light arriving along ``-wo_hat`` and leaving along ``wi_hat``, where
  ``wo_hat, wi_hat = wo, si.wi`` in ``TransportMode.Radiance`` and
  ``si.wi, wo`` in ``TransportMode.Importance``;
* input Stokes basis ``mi.mueller.stokes_basis(-wo_hat)``, output basis
  ``mi.mueller.stokes_basis(wi_hat)``.

So the reference's ``wi`` (towards the light) is ``wo_hat`` and its ``wr``
(towards the viewer) is ``wi_hat``. :func:`eval_global` takes the directions in
these *physical* roles, sets ``si.wi`` and ``wo`` for the requested mode, divides
the cosine out and rotates the matrix into the global s/p frames with
``mi.mueller.rotate_mueller_basis``. It returns NumPy float64 arrays;
:func:`mueller_brdf` does the same in Dr.Jit and keeps derivatives (for
gradients and the ``drjit`` fitting backend).

Variants: JIT variants (``llvm_ad_*``, ``cuda_ad_*``) evaluate all directions in
one call; scalar variants loop in Python (slow: keep n small). Spectral variants
evaluate at the given wavelengths (4 of them, one per spectral channel). Mono and
RGB variants have no wavelengths: textures return their single band (for a
``material`` conductor Mitsuba uses the luminance, resp. the sRGB colour, of the
tabulated spectrum), and ``wavelengths_nm`` is ignored. Unpolarized variants
return intensities, shape ``(n, n_bands)``, instead of ``(n, n_bands, 4, 4)``.
"""

import numpy as np

import drjit as dr
import mitsuba as mi

from .variant import require_variant


# ---------------------------------------------------------------------------
# Directions
# ---------------------------------------------------------------------------

def _float32_exact(v):
    """Unit vectors rounded to float32 (what Mitsuba will see), as float64."""
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return v.astype(np.float32).astype(np.float64)


def _uniform_cosine(n, rng, min_cos):
    """Directions with cos(theta) uniform in [min_cos, 1] and uniform azimuth."""
    cos_t = rng.uniform(min_cos, 1.0, n)
    sin_t = np.sqrt(1.0 - cos_t**2)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    return np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=-1)


def random_directions(n, rng, near_specular=0.5, min_cos=0.02, spread=(1e-3, 0.5)):
    """``n`` pairs ``(wi_hat, wo_hat)`` of local unit directions above the surface.

    ``wo_hat`` points towards the light and ``wi_hat`` towards the viewer (the
    physical roles of :func:`eval_global`). A share ``near_specular`` of the
    pairs puts ``wi_hat`` within an angle drawn log-uniformly from ``spread``
    (radians) of the mirror direction of ``wo_hat``, so that the specular lobe
    is exercised; the rest are independent (cos theta uniform). ``min_cos``
    keeps both directions off grazing, where float32 cosines lose relative
    precision. Both arrays have shape (n, 3), float64, exactly representable in
    float32.
    """
    n_spec = int(round(near_specular * n))
    wo = _uniform_cosine(n, rng, min_cos)
    wi = _uniform_cosine(n, rng, min_cos)

    todo = np.arange(n_spec)
    while todo.size:
        mirror = wo[todo] * np.array([-1.0, -1.0, 1.0])
        axis = np.cross(mirror, rng.normal(size=(todo.size, 3)))
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        angle = np.exp(rng.uniform(np.log(spread[0]), np.log(spread[1]), todo.size))[:, None]
        candidate = mirror * np.cos(angle) + np.cross(axis, mirror) * np.sin(angle)
        ok = candidate[:, 2] >= min_cos
        wi[todo[ok]] = candidate[ok]
        todo = todo[~ok]
        wo[todo] = _uniform_cosine(todo.size, rng, min_cos)  # retry with a new light direction
    return _float32_exact(wi), _float32_exact(wo)


def to_angles(v):
    """Zenith and azimuth angles (radians) of directions (..., 3)."""
    v = np.asarray(v, dtype=np.float64)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return np.arccos(np.clip(v[..., 2], -1.0, 1.0)), np.arctan2(v[..., 1], v[..., 0])


# ---------------------------------------------------------------------------
# Evaluation in the global s/p frames
# ---------------------------------------------------------------------------

def _mode(mode):
    if isinstance(mode, str):
        return {"radiance": mi.TransportMode.Radiance,
                "importance": mi.TransportMode.Importance}[mode.lower()]
    return mode


def _global_basis(d):
    """normalize(z x d), or the surface x-axis where d is parallel to z (Dr.Jit)."""
    s = dr.cross(mi.Vector3f(0, 0, 1), d)
    degenerate = dr.squared_norm(s) == 0
    return dr.select(degenerate, mi.Vector3f(1, 0, 0), dr.normalize(s))


def _evaluate(bsdf, wi_hat, wo_hat, wavelengths_nm, mode, with_pdf):
    """One vectorized call (JIT variants) or a Python loop (scalar variants).

    Returns (value array, pdf array or None, cos of the ``wo`` argument)."""
    wi_hat = np.asarray(wi_hat, dtype=np.float64).reshape(-1, 3)
    wo_hat = np.asarray(wo_hat, dtype=np.float64).reshape(-1, 3)
    n = wi_hat.shape[0]
    mode = _mode(mode)
    radiance = mode == mi.TransportMode.Radiance
    si_wi, wo_arg = (wi_hat, wo_hat) if radiance else (wo_hat, wi_hat)
    scalar = mi.variant().startswith("scalar")
    wavelengths = None
    if mi.is_spectral:
        wavelengths = np.asarray(wavelengths_nm, dtype=np.float64).reshape(-1)
        if wavelengths.size != dr.size_v(mi.UnpolarizedSpectrum):
            raise ValueError(f"{mi.variant()} evaluates {dr.size_v(mi.UnpolarizedSpectrum)} "
                             f"wavelengths at a time, got {wavelengths.size}")

    def one_call(wi_np, wo_np, size):
        if scalar:
            si = mi.SurfaceInteraction3f()
            vec = lambda a: mi.Vector3f(*[float(x) for x in a])
        else:
            si = dr.zeros(mi.SurfaceInteraction3f, size)
            vec = lambda a: mi.Vector3f(*[mi.Float(np.ascontiguousarray(a[:, j])) for j in range(3)])
        si.wi = vec(wi_np)
        wo = vec(wo_np)
        si.n = mi.Normal3f(0, 0, 1)
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))        # local frame = identity
        if wavelengths is not None:
            si.wavelengths = type(si.wavelengths)(*[float(w) for w in wavelengths])
        ctx = mi.BSDFContext(mode)
        if with_pdf:
            value, pdf = bsdf.eval_pdf(ctx, si, wo)
        else:
            value, pdf = bsdf.eval(ctx, si, wo), None

        if mi.is_polarized:
            wo_h, wi_h = (wo, si.wi) if radiance else (si.wi, wo)
            value = mi.mueller.rotate_mueller_basis(
                value,
                -wo_h, mi.mueller.stokes_basis(-wo_h), _global_basis(-wo_h),
                wi_h, mi.mueller.stokes_basis(wi_h), _global_basis(wi_h))
            if scalar:
                arr = np.array([[np.asarray(value[i, j], dtype=np.float64).reshape(-1)
                                 for j in range(4)] for i in range(4)])       # (4, 4, bands)
                arr = np.moveaxis(arr, -1, 0)[None]                           # (1, bands, 4, 4)
            else:
                arr = np.asarray(value, dtype=np.float64).reshape(4, 4, -1, size)
                arr = np.transpose(arr, (3, 2, 0, 1))                         # (n, bands, 4, 4)
        else:
            arr = np.asarray(value, dtype=np.float64).reshape(-1, 1 if scalar else size).T
        pdf_np = None if pdf is None else np.asarray(pdf, dtype=np.float64).reshape(-1)
        return arr, pdf_np

    if scalar:
        parts = [one_call(si_wi[i], wo_arg[i], 1) for i in range(n)]
        arr = np.concatenate([p[0] for p in parts])
        pdf = None if not with_pdf else np.concatenate([p[1] for p in parts])
    else:
        arr, pdf = one_call(si_wi, wo_arg, n)
    cos_wo = np.abs(wo_arg[:, 2] / np.linalg.norm(wo_arg, axis=-1))
    return arr, pdf, cos_wo


def _divide_cosine(arr, cos_wo):
    cos = cos_wo.reshape((-1,) + (1,) * (arr.ndim - 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(cos > 0, arr / cos, 0.0)


def eval_global(bsdf, wi_hat, wo_hat, wavelengths_nm=(450.0, 550.0, 650.0, 750.0),
                mode="radiance"):
    """BRDF of a Mitsuba BSDF in the reference's global s/p frames, float64.

    ``wo_hat`` (towards the light, the reference's ``wi``) and ``wi_hat``
    (towards the viewer, the reference's ``wr``) are arrays (n, 3) of local
    directions; ``mode`` is ``"radiance"``, ``"importance"`` or a
    ``mi.TransportMode``. Returns (n, n_bands, 4, 4) in polarized variants and
    (n, n_bands) in unpolarized ones, with the cosine factor of Mitsuba's
    ``eval`` divided out.
    """
    require_variant()
    arr, _, cos_wo = _evaluate(bsdf, wi_hat, wo_hat, wavelengths_nm, mode, with_pdf=False)
    return _divide_cosine(arr, cos_wo)


def eval_pdf_global(bsdf, wi_hat, wo_hat, wavelengths_nm=(450.0, 550.0, 650.0, 750.0),
                    mode="radiance"):
    """Like :func:`eval_global` through ``bsdf.eval_pdf``; returns ``(value, pdf)``,
    ``pdf`` (n,) being Mitsuba's solid-angle density of sampling ``wo`` given ``si.wi``."""
    require_variant()
    arr, pdf, cos_wo = _evaluate(bsdf, wi_hat, wo_hat, wavelengths_nm, mode, with_pdf=True)
    return _divide_cosine(arr, cos_wo), pdf


def _vector(v):
    if isinstance(v, mi.Vector3f):
        return v
    v = np.asarray(v, dtype=np.float32).reshape(-1, 3)
    return mi.Vector3f(*(mi.Float(np.ascontiguousarray(v[:, j])) for j in range(3)))


def mueller_brdf(bsdf, wi_hat, wo_hat, wavelengths=(450.0, 520.0, 600.0, 690.0),
                 mode="radiance", uv=None):
    """BRDF Mueller matrices of ``bsdf`` (1/sr, no cosine) in the global s/p
    frames of :mod:`mitsuba_pbrdf.reference`, as a Dr.Jit ``mi.Spectrum`` that
    keeps derivatives (JIT polarized variants).

    ``wo_hat`` points towards the light (the reference's ``wi``), ``wi_hat``
    towards the viewer (its ``wr``): arrays (n, 3) or ``mi.Vector3f``, local
    frame. ``wavelengths``: 4 values (nm) for every lane, or a
    ``mi.UnpolarizedSpectrum`` with one wavelength set per lane. ``uv``:
    texture coordinates (``mi.Point2f``) for textured parameters. Same frames
    and conventions as :func:`eval_global`, which returns
    NumPy arrays without derivatives.
    """
    require_variant()
    if not mi.is_polarized:
        raise RuntimeError(f"mueller_brdf needs a polarized variant, not {mi.variant()}")
    wi_hat, wo_hat = _vector(wi_hat), _vector(wo_hat)
    radiance = str(mode).lower().endswith("radiance")
    si = dr.zeros(mi.SurfaceInteraction3f, dr.width(wi_hat))
    si.n = mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.wi, wo = (wi_hat, wo_hat) if radiance else (wo_hat, wi_hat)
    if uv is not None:
        si.uv = uv
    if mi.is_spectral:
        si.wavelengths = (wavelengths if isinstance(wavelengths, mi.UnpolarizedSpectrum)
                          else mi.UnpolarizedSpectrum(*(float(w) for w in wavelengths)))
    ctx = mi.BSDFContext(mi.TransportMode.Radiance if radiance else mi.TransportMode.Importance)
    value = bsdf.eval(ctx, si, wo)
    value = mi.mueller.rotate_mueller_basis(
        value,
        -wo_hat, mi.mueller.stokes_basis(-wo_hat), _global_basis(-wo_hat),
        wi_hat, mi.mueller.stokes_basis(wi_hat), _global_basis(wi_hat))
    cos = mi.Frame3f.cos_theta(wo)
    return value * dr.select(cos > 0, dr.rcp(cos), 0.0)
