"""Mitsuba's own published scenes with metals (tests/data/mitsuba_scenes, provenance
in its README.md), converted by ``pbrdf convert``, render as the originals.

Each original renders polarized with its integrator wrapped in ``stokes``
(mitsuba_pbrdf.diagnostics.scene_match), and its conversion is rendered at the
same seed and spp. With sigma = alpha / sqrt(2), Smith shadowing and no diffuse
lobes, ``pbrdf`` draws its random numbers as ``roughconductor`` does, so the
two agree tile by tile far below the seed-to-seed noise. The one known
difference: ``roughconductor``'s Beckmann pdf uses an approximate G1 (0.35 % at
most, tests/bsdfs/test_pbrdf_roughconductor.py), which enters the MIS weights and sampled
weights under area and environment light; a tile therefore differs by at most
twice that factor of its own S0 (``G1_FACTOR``). The scenes here light the
metals by a constant sky and a spherical lamp (``include/matpreview.xml`` is a
stand-in without meshes: README.md).

Fast tier: the copper and gold scenes and a scene of wrappers (twosided, blendbsdf, mask,
<ref>s to a BSDF and to a texture kept as alpha_u, specular_reflectance,
Mitsuba's default mirror) at 48x36 and 32x24
pixels, 8 spp; the other published scenes in the slow tier; all at full size in
validation/published_scenes.py.
"""

import os
import shutil

import pytest

from mitsuba_pbrdf.diagnostics.scene_match import compare_scenes
from mitsuba_pbrdf.rendering.scene_convert import convert_scene

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DATA = os.path.join(ROOT, "tests", "data", "mitsuba_scenes")
G1_FACTOR = 0.0035       # roughconductor's Beckmann G1 approximation, at most
#: pbrdf needs eta > 0: Mitsuba's default mirror (eta = 0, k = 1) becomes eta = 1e-4,
#: whose Fresnel reflectance is lower by at most 2e-4.
MIRROR_ETA = 2e-4
SMALL = (48, 36)


def converted_copy(tmp_path, path):
    """A copy of the data folder in *tmp_path*; *path* (from the repository
    root) in it, and its conversion."""
    shutil.copytree(DATA, tmp_path / "data")
    original = str(tmp_path / "data" / os.path.relpath(os.path.join(ROOT, path), DATA))
    return original, convert_scene(original).scene


def check(match, bound=2 * G1_FACTOR):
    assert match.polarization_finite
    assert match.worst_tile <= bound, match
    assert abs(match.mean_s0_ratio - 1) <= bound, match
    assert match.tile_difference <= match.seed_to_seed / 20, match


WRAPPERS = """<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0, -6, 2.5" target="0, 0, 0.3" up="0, 0, 1"/>
        </transform>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/>
            <rfilter type="box"/></film>
        <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
    <emitter type="point"><point name="position" x="2" y="-3" z="4"/>
        <rgb name="intensity" value="20"/></emitter>
    <texture type="checkerboard" id="rough"><float name="color0" value="0.05"/>
        <float name="color1" value="0.2"/></texture>
    <bsdf type="twosided" id="coated">
        <bsdf type="roughconductor">
            <float name="alpha" value="0.2"/>
            <spectrum name="eta" value="360:1.2, 830:0.3"/>
            <spectrum name="k" value="360:2.0, 830:4.0"/>
            <spectrum name="specular_reflectance" value="0.6"/>
        </bsdf>
    </bsdf>
    <shape type="sphere"><point name="center" x="-2.2" y="0" z="1"/><ref id="coated"/></shape>
    <shape type="sphere"><point name="center" x="0" y="0" z="1"/>
        <bsdf type="blendbsdf">
            <texture name="weight" type="checkerboard"/>
            <bsdf type="diffuse"/>
            <bsdf type="roughconductor"><string name="distribution" value="ggx"/>
                <float name="alpha" value="0.15"/></bsdf>
        </bsdf>
    </shape>
    <shape type="sphere"><point name="center" x="2.2" y="0" z="1"/>
        <bsdf type="mask"><float name="opacity" value="0.7"/>
            <bsdf type="roughconductor"><string name="material" value="Au"/>
                <ref name="alpha_u" id="rough"/><float name="alpha_v" value="0.3"/></bsdf>
        </bsdf>
    </shape>
    <shape type="rectangle"><transform name="to_world"><scale value="6"/></transform>
        <bsdf type="diffuse"/></shape>
</scene>
"""


def test_wrapped_metals_and_specular_reflectance_converted_render_as_the_original(tmp_path):
    original = tmp_path / "wrappers.xml"
    original.write_text(WRAPPERS)
    converted = convert_scene(original).scene
    check(compare_scenes(str(original), converted, spp=8), bound=2 * G1_FACTOR + MIRROR_ETA)


#: Every published scene: (file, the size of a tiny render; None: its own 32 x 32); a
#: roughconductor and a conductor in the fast tier, the others in the slow one.
PUBLISHED = [
    pytest.param("tests/data/mitsuba_scenes/docs/scenes/bsdf_roughconductor_copper.xml",
                 SMALL, id="copper"),
    pytest.param("tests/data/mitsuba_scenes/docs/scenes/bsdf_conductor_gold.xml",
                 SMALL, id="gold"),
    pytest.param(
        "tests/data/mitsuba_scenes/docs/scenes/bsdf_roughconductor_anisotropic_aluminium.xml",
        SMALL, id="anisotropic_aluminium", marks=pytest.mark.slow),
    pytest.param("tests/data/mitsuba_scenes/docs/scenes/bsdf_roughconductor_textured_carbon.xml",
                 SMALL, id="textured_carbon", marks=pytest.mark.slow),
    pytest.param("tests/data/mitsuba_scenes/tests/scenes/infinite_mirrors/scene_path.xml",
                 None, id="infinite_mirrors", marks=pytest.mark.slow),
]


@pytest.mark.parametrize("path, size", PUBLISHED)
def test_published_scene_converted_renders_as_the_original(tmp_path, path, size):
    original, converted = converted_copy(tmp_path, path)
    check(compare_scenes(original, converted, spp=8, size=size))
