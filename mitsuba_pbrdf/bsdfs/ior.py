"""Named conductors' complex index of refraction as Mitsuba textures.

Mitsuba ships tabulated spectra ``data/ior/<Name>.eta.spd`` and ``<Name>.k.spd``
(wavelength in nm, dimensionless n and k). This module turns them into textures
for the active variant the way Mitsuba's own ``roughconductor`` does: an
``irregular`` spectrum in spectral variants, the spectrum's unbounded sRGB
projection in RGB variants and its luminance in monochromatic variants.
"""

import os

import mitsuba as mi

from ..properties import create


def ior_directory():
    """Folder holding Mitsuba's tabulated conductor spectra."""
    return os.path.join(os.path.dirname(mi.__file__), "data", "ior")


def available_materials():
    """Names accepted by the ``material`` parameter (e.g. ``Al``, ``Cu``, ``Au``)."""
    names = {f[: -len(".eta.spd")] for f in os.listdir(ior_directory()) if f.endswith(".eta.spd")}
    return sorted(n for n in names if os.path.exists(os.path.join(ior_directory(), n + ".k.spd")))


def complex_ior_textures(material):
    """``(eta, k)`` textures of the named conductor for the active variant.

    Raises ``ValueError`` naming the parameter and listing valid names when the
    material is unknown.
    """
    if not isinstance(material, str) or material not in available_materials():
        raise ValueError(
            f"pbrdf: unknown material {material!r} (parameter 'material'); "
            f"valid names: {', '.join(available_materials())}"
        )
    return tuple(_spectrum_texture(os.path.join(ior_directory(), f"{material}.{part}.spd"))
                 for part in ("eta", "k"))


def _spectrum_texture(filename):
    wavelengths, values = _cover_spectral_range(*mi.spectrum_from_file(filename))
    if mi.is_spectral:
        return create("irregular",
                      wavelengths=", ".join(f"{w:.9g}" for w in wavelengths),
                      values=", ".join(f"{v:.9g}" for v in values))
    # Non-spectral variants: the same projection as Mitsuba's ior_from_file.
    r, g, b = mi.spectrum_list_to_srgb(wavelengths, values, bounded=False)
    if mi.is_monochromatic:
        luminance = 0.212671 * r + 0.715160 * g + 0.072169 * b  # Mitsuba's luminance()
        return create("uniform", value=float(luminance))
    return create("srgb", color=mi.ScalarColor3f(r, g, b), unbounded=True)


def _cover_spectral_range(wavelengths, values):
    """Hold the end values out to Mitsuba's spectral range (360-830 nm): 27 of
    the 71 tables stop short of it (e.g. Se at 689 nm), and an irregular
    spectrum is zero outside its table, which would make n = k = 0 there.
    (Mitsuba's roughconductor does not extend them.)"""
    wavelengths, values = list(wavelengths), list(values)
    if wavelengths[0] > mi.MI_CIE_MIN:
        wavelengths.insert(0, mi.MI_CIE_MIN)
        values.insert(0, values[0])
    if wavelengths[-1] < mi.MI_CIE_MAX:
        wavelengths.append(mi.MI_CIE_MAX)
        values.append(values[-1])
    return wavelengths, values
