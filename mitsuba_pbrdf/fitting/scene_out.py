"""A fit as a scene: the fitted parameters written as a ``pbrdf`` BSDF on a
sphere, lit as the project's default scene (two soft boxes and a dim sky over
a matte floor), ready to render in a polarized variant
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

import numpy as np

from ..outputs import atomic_path, escape_text
from ..rendering.narrowband import CIE_RANGE

__all__ = ["bsdf_xml", "write_fitted_scene"]

_SCENE = """<scene version="3.0.0">
    <!-- {comment} -->
    <default name="spp" value="64"/>
    <default name="width" value="320"/>
    <default name="height" value="240"/>
    <default name="max_depth" value="6"/>

    <integrator type="stokes">
        <integrator type="path">
            <integer name="max_depth" value="$max_depth"/>
        </integrator>
    </integrator>

    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world">
            <lookat origin="0, 3.2, 7.5" target="0, 1.0, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="$width"/>
            <integer name="height" value="$height"/>
            <string name="pixel_format" value="rgb"/>
        </film>
    </sensor>

{bsdf}
    <shape type="sphere">
        <point name="center" value="0, 1.0, 0"/>
        <float name="radius" value="1.0"/>
        <ref id="fitted"/>
    </shape>

    <shape type="rectangle">
        <transform name="to_world">
            <scale value="30"/>
            <rotate x="1" angle="-90"/>
        </transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.18, 0.18, 0.19"/>
        </bsdf>
    </shape>

    <shape type="rectangle">
        <transform name="to_world">
            <scale x="4.5" y="3.0"/>
            <lookat origin="-5.0, 6.0, 4.0" target="-0.5, 1.0, 0" up="0, 1, 0"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="0.89, 0.84, 0.78"/>
        </emitter>
    </shape>

    <shape type="rectangle">
        <transform name="to_world">
            <scale x="6.0" y="3.0"/>
            <lookat origin="5.0, 5.5, -5.0" target="0.5, 1.0, 0" up="0, 1, 0"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="0.89, 0.89, 0.94"/>
        </emitter>
    </shape>

    <emitter type="constant">
        <rgb name="radiance" value="0.08, 0.09, 0.11"/>
    </emitter>
</scene>
"""


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
    if result.model == "three":
        lines.append(f'    <spectrum name="kdd" value="{float(v["kdd"]):.9g}"/>')
        lines.append(f'    <float name="sigma_dd" value="{float(v["sigma_dd"]):.9g}"/>')
    else:
        lines.append('    <spectrum name="kdd" value="0"/>')
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
    text = _SCENE.format(comment=escape_text(comment, "xml-comment"),
                         bsdf=bsdf_xml(result, material))
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
    return path
