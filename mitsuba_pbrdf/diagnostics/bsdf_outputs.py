"""Everything a Mitsuba BSDF returns for a batch of direction pairs, as NumPy.

:func:`bsdf_outputs` calls ``eval``, ``pdf``, ``eval_pdf`` and ``sample`` of any
BSDF of a polarized spectral JIT variant (``llvm_ad_*``/``cuda_ad_*``) in one
transport mode, and also returns the value rotated into the reference's global
s/p frames with the cosine divided out (as :func:`mitsuba_pbrdf.frames.eval_global`
does, here from the same ``eval_pdf`` call). Directions are the *physical* ones,
unit vectors (n, 3) in the surface's local frame (z = the normal): ``wi``
towards the viewer, ``wo`` towards the light; wavelengths in nm (4).
"""

import numpy as np

def _mueller(value, n):
    """(n, 4 wavelengths, 4, 4) from a Dr.Jit Mueller matrix; a result of width 1
    (e.g. the zero weight of a BSDF without lobes) is broadcast to n lanes."""
    a = np.asarray(value, dtype=np.float64)
    a = a.reshape(4, 4, 4, -1)
    return np.transpose(np.broadcast_to(a, (4, 4, 4, n)), (3, 2, 0, 1))


def _lanes(value, n):
    """A Dr.Jit Float as (n,) float64 (width 1 broadcast)."""
    return np.broadcast_to(np.asarray(value, dtype=np.float64).reshape(-1), (n,))


def bsdf_outputs(bsdf, wi, wo, wavelengths, mode, rng, textures=None, uv=None):
    """Everything ``bsdf`` returns for these pairs in one transport mode.

    ``wi``/``wo`` are the *physical* directions (viewer, light); in Importance
    mode Mitsuba's si.wi is the light and its wo argument the viewer. ``mode``:
    "radiance" or "importance". ``rng`` (a NumPy Generator) draws the sample()
    inputs. ``uv`` (2, n) selects each lane's texel of textured parameters;
    ``textures`` ({name: texture}) are evaluated there.

    Returns a dict of NumPy float64 arrays, Mueller matrices as (n, 4, 4, 4)
    (lane, wavelength, row, column), in Mitsuba's own Stokes bases unless said:
    ``value``, ``pdf`` (``eval``, ``pdf``), ``value_ep``, ``pdf_ep``
    (``eval_pdf``), ``weight``, ``bs_pdf``, ``bs_wo`` (``sample``: weight,
    pdf, sampled direction (n, 3) in si's convention), ``value_bs``,
    ``pdf_bs`` (``eval_pdf`` at the sampled direction), ``brdf`` (``value_ep``
    in the global s/p frames, cosine divided out: 1/sr) and ``lanes``
    ({name: (n, 4)} per-lane texture values)."""
    import drjit as dr
    import mitsuba as mi

    from ..frames import _global_basis

    n = len(wi)
    radiance = mode == "radiance"
    si_wi, wo_arg = (wi, wo) if radiance else (wo, wi)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(*[mi.Float(np.ascontiguousarray(si_wi[:, j])) for j in range(3)])
    si.n = mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    if uv is not None:
        si.uv = mi.Point2f(*np.asarray(uv, dtype=np.float32))
    si.wavelengths = mi.UnpolarizedSpectrum(*wavelengths)
    w = mi.Vector3f(*[mi.Float(np.ascontiguousarray(wo_arg[:, j])) for j in range(3)])
    ctx = mi.BSDFContext(mi.TransportMode.Radiance if radiance else mi.TransportMode.Importance)

    value_ep, pdf_ep = bsdf.eval_pdf(ctx, si, w)
    value = bsdf.eval(ctx, si, w)
    pdf = bsdf.pdf(ctx, si, w)
    bs, weight = bsdf.sample(ctx, si, mi.Float(rng.random(n, dtype=np.float32)),
                             mi.Point2f(*rng.random((2, n), dtype=np.float32)))
    value_bs, pdf_bs = bsdf.eval_pdf(ctx, si, bs.wo)          # at the sampled direction

    # into the reference's global s/p frames (light arrives along -wo_hat, leaves along wi_hat)
    wo_h, wi_h = (w, si.wi) if radiance else (si.wi, w)
    rotated = mi.mueller.rotate_mueller_basis(
        value_ep, -wo_h, mi.mueller.stokes_basis(-wo_h), _global_basis(-wo_h),
        wi_h, mi.mueller.stokes_basis(wi_h), _global_basis(wi_h))
    cos_wo = np.abs(wo_arg[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        brdf = np.where(cos_wo[:, None, None, None] > 0,
                        _mueller(rotated, n) / cos_wo[:, None, None, None], 0.0)
    lanes = {}                             # per-lane values of textured parameters
    for name, texture in (textures or {}).items():
        lanes[name] = np.asarray(texture.eval(si), dtype=np.float64).reshape(4, n).T
    bs_wo = np.asarray(bs.wo, dtype=np.float64).reshape(3, -1).T
    return dict(value=_mueller(value, n), value_ep=_mueller(value_ep, n),
                pdf=_lanes(pdf, n), pdf_ep=_lanes(pdf_ep, n),
                weight=_mueller(weight, n), bs_pdf=_lanes(bs.pdf, n),
                bs_wo=np.broadcast_to(bs_wo, (n, 3)), brdf=brdf, lanes=lanes,
                value_bs=_mueller(value_bs, n), pdf_bs=_lanes(pdf_bs, n))
