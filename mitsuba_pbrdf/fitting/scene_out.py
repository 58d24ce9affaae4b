"""A fit as a scene: the fitted parameters written as a ``pbrdf`` BSDF into
the shipped ``scenes/_fitted.xml``: a sphere lit as the project's default
scene (two soft boxes and a dim sky over a matte floor), ready to render in a
polarized variant
(``pbrdf fit ... --scene-out fitted.xml``, then ``pbrdf render fitted.xml``).

A fit of unpolarized data thus gives a polarized material: the index it held
fixed (a named material's tabulated spectra, written by name) supplies the
polarization that the measurement could not. An index fitted per wavelength
is written as an irregular spectrum over the measured wavelengths (a constant
where there is one), held at its end values out to the ends of Mitsuba's
spectral range (360-830 nm), since an irregular spectrum is 0 outside its
points and an index of 0 is no metal (the plugin refuses it); a comment in the
file says so. The scene renders in polarized and unpolarized variants, spectral
or RGB. Text from the user (the data file's name, a material's) enters the
file through :func:`mitsuba_pbrdf.outputs.escape_text`.
"""

from __future__ import annotations

import re

import numpy as np

from ..choices import MODELS
from ..outputs import atomic_path, escape_text
from ..rendering.narrowband import CIE_RANGE
from ..rendering.scene_files import scenes_dir

__all__ = ["bsdf_xml", "write_fitted_scene"]

#: The shipped scene the fit is written into (``scenes/_fitted.xml``): its
#: first comment and its placeholder BSDF are replaced.
TEMPLATE = "_fitted.xml"
_PLACEHOLDER = re.compile(r'^ *<bsdf type="pbrdf" id="fitted"/>$', re.M)
_COMMENT = re.compile(r"^( *)<!--.*?-->$", re.M)


def _spectrum(wavelengths, values):
    """A fitted index as a ``<spectrum>`` value: a constant, or wavelength:value
    pairs in increasing order, extended flat to :data:`CIE_RANGE` (nm)."""
    values = np.atleast_1d(np.asarray(values, dtype=np.float64))
    if len(values) == 1:
        return f"{values[0]:.9g}"
    order = np.argsort(np.asarray(wavelengths, dtype=np.float64))
    points = [(float(wavelengths[i]), float(values[i])) for i in order]
    if points[0][0] > CIE_RANGE[0]:
        points.insert(0, (CIE_RANGE[0], points[0][1]))
    if points[-1][0] < CIE_RANGE[1]:
        points.append((CIE_RANGE[1], points[-1][1]))
    return ", ".join(f"{w:.9g}:{v:.9g}" for w, v in points)


def _held_note(result) -> str:
    """The comment on an index fitted at several wavelengths, or ``""``."""
    w = np.atleast_1d(np.asarray(result.wavelengths, dtype=np.float64))
    if np.atleast_1d(result.values["n"]).size < 2:
        return ""
    return (f"eta and k: fitted at {', '.join(f'{x:g}' for x in np.sort(w))} nm; held at the end "
            f"values outside {w.min():g}-{w.max():g} nm, out to {CIE_RANGE[0]:g}-"
            f"{CIE_RANGE[1]:g} nm")


def bsdf_xml(result, material=None, bsdf_id="fitted", indent="    ") -> str:
    """The fitted BSDF as a ``<bsdf type="pbrdf">`` element. *material*: write
    the index by name where the fit held it at that material's."""
    v = result.values
    lines = [f'<bsdf type="pbrdf" id="{escape_text(bsdf_id, "xml")}">']
    if material is not None and result.index_note.startswith("n, k fixed from material"):
        lines.append(f'    <string name="material" value="{escape_text(material, "xml")}"/>')
    else:
        if _held_note(result):
            lines.append(f"    <!-- {escape_text(_held_note(result), 'xml-comment')} -->")
        lines.append(f'    <spectrum name="eta" value="{_spectrum(result.wavelengths, v["n"])}"/>')
        lines.append(f'    <spectrum name="k" value="{_spectrum(result.wavelengths, v["k"])}"/>')
    for name in ("sigma", "sigma_u", "sigma_v"):
        if name in v:
            lines.append(f'    <float name="{name}" value="{float(v[name]):.9g}"/>')
    lines.append(f'    <spectrum name="ks" value="{float(v["ks"]):.9g}"/>')
    if "kdd" in MODELS[result.model].fixed:     # the lobe off: no width to give
        lines.append('    <spectrum name="kdd" value="0"/>')
    else:
        lines.append(f'    <spectrum name="kdd" value="{float(v["kdd"]):.9g}"/>')
        lines.append(f'    <float name="sigma_dd" value="{float(v["sigma_dd"]):.9g}"/>')
    lines.append(f'    <spectrum name="kid" value="{float(v["kid"]):.9g}"/>')
    lines.append(f'    <string name="shadowing" value="{result.shadowing}"/>')
    lines.append(f'    <string name="distribution" value="{result.distribution}"/>')
    lines.append(f'    <string name="dd_distribution" value="{result.dd_distribution}"/>')
    lines.append("</bsdf>")
    return "\n".join(indent + line for line in lines)


def write_fitted_scene(result, path, material=None, source=None):
    """Write the scene (see the module docstring) to *path*, atomically."""
    comment = (f"pbrdf fitted by pbrdf fit{' to ' + source if source else ''}: "
               f"{result.model}-component, {result.distribution} lobes, {result.objective} "
               f"objective, reduced chi2 {result.reduced_chi2:.3g}. Render with "
               f"pbrdf render {path} (a polarized variant; in an unpolarized one, render the "
               f"path integrator nested in stokes alone)")
    text = (scenes_dir() / TEMPLATE).read_text(encoding="utf-8")
    note = escape_text(comment, "xml-comment")
    text = _COMMENT.sub(lambda m: f"{m.group(1)}<!-- {note} -->", text, count=1)
    text = _PLACEHOLDER.sub(lambda m: bsdf_xml(result, material), text, count=1)
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
    return path
