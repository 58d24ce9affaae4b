"""Scenes laid out as Mitsuba publishes its own (mitsuba-data ``docs/scenes``):
a main file that ``<include>`` s its integrator (``path``, ``moment`` around
``path``, never ``stokes``) and its sensor from other files, ``<ref>`` s to a
``roughconductor``, a ``conductor`` beside it, no width ``<default>``. Each
renders polarized as published (mitsuba_pbrdf.rendering.scene_setup): the same
image, seed for seed, as the scene wrapped in ``stokes`` by hand; a scene that
cannot give Stokes output is refused before anything loads; ``--wavelength``
and ``--bands`` find the sensor and integrator through the includes; ``size``
sizes any scene."""

import logging
import os
import re

import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf import use_variant
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.errors import ParameterError
from mitsuba_pbrdf.rendering import render_scene
from mitsuba_pbrdf.rendering.render import UnpolarizedVariantError, check_render
from mitsuba_pbrdf.rendering.scene_setup import (SceneSetup, StokesSceneError, load_scene_setup,
                                                 parse_size)
from mitsuba_pbrdf.stokes.image import dolp
from tests.rendering.test_render import SCENE

pytestmark = pytest.mark.usefixtures("restore_variant")
VARIANT = "llvm_ad_spectral_polarized"
PATH = '<integrator type="path"><integer name="max_depth" value="3"/></integrator>'
INTEGRATORS = {
    "path": PATH,
    "moment": f'<integrator type="moment">{PATH}</integrator>',
    "none": "",
    "stokes": f'<integrator type="stokes">{PATH}</integrator>',
}
SENSOR = """<scene version="3.0.0">
    <sensor type="perspective" id="camera">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="16"/><integer name="height" value="12"/>
            <rfilter type="box"/>{crop}
        </film>
    </sensor>
</scene>"""
MAIN = """<scene version="3.0.0">
    <include filename="parts/integrator.xml"/>
    <include filename="parts/sensor.xml"/>
    <bsdf type="roughconductor" id="copper">
        <string name="material" value="Cu"/><float name="alpha" value="0.2"/>
    </bsdf>
    <shape type="sphere">
        <point name="center" value="-0.6, 0, 0"/><float name="radius" value="0.5"/>
        <ref id="copper"/>
    </shape>
    <shape type="sphere">
        <point name="center" value="0.6, 0, 0"/><float name="radius" value="0.5"/>
        <bsdf type="conductor"><string name="material" value="Au"/></bsdf>
    </shape>
    <emitter type="constant"/>
</scene>"""


def published(folder, integrator="path", crop=""):
    """A scene in Mitsuba's published layout in *folder*: its main file."""
    os.makedirs(folder / "parts", exist_ok=True)
    (folder / "parts" / "integrator.xml").write_text(
        f'<scene version="3.0.0">{INTEGRATORS.get(integrator, integrator)}</scene>')
    (folder / "parts" / "sensor.xml").write_text(SENSOR.format(crop=crop))
    (folder / "main.xml").write_text(MAIN)
    return folder / "main.xml"


@pytest.mark.parametrize("integrator", ["path", "moment",
                                        pytest.param("none", marks=pytest.mark.slow)])
def test_a_published_scene_renders_as_the_scene_wrapped_by_hand(integrator, tmp_path, caplog):
    """The automatic stokes gives the image a hand edit gives, seed for seed
    (before: the render ran, then failed with "no Stokes channels"), and says
    so in one warning line; the metals polarize what they reflect."""
    scene = published(tmp_path / "auto", integrator)
    # no integrator: Mitsuba's default, path with its default depth
    by_hand = published(tmp_path / "hand", '<integrator type="stokes"><integrator type="path"/>'
                        '</integrator>' if integrator == "none" else "stokes")
    with caplog.at_level(logging.WARNING, logger="mitsuba_pbrdf.rendering.render"):
        image = render_scene(scene, spp=4, seed=5, variant=VARIANT)
    notices = [r.getMessage() for r in caplog.records if "stokes" in r.getMessage()]
    assert len(notices) == 1 and "\n" not in notices[0] and "main.xml" in notices[0]
    assert ("integrator.xml line 1" in notices[0]) == (integrator != "none")
    expected = render_scene(by_hand, spp=4, seed=5, variant=VARIANT)
    assert image.bands == ["R", "G", "B"] and np.array_equal(image.stokes, expected.stokes)
    assert np.all(np.isfinite(image.stokes)) and np.nanmax(dolp(image)) > 0.05


@pytest.mark.parametrize("integrator, variant, error, text", [
    ('<integrator type="prb"/>', VARIANT, StokesSceneError, "prb ignores Mueller frame rotations"),
    ('<integrator type="aov"><string name="aovs" value="d:depth"/></integrator>', VARIANT,
     StokesSceneError, "aov writes arbitrary output variables"),
    ('<integrator type="stokes"><integrator type="prb_basic"/></integrator>', VARIANT,
     StokesSceneError, "wraps prb_basic"),
    (f'<integrator type="moment">{PATH}{PATH}</integrator>', VARIANT, StokesSceneError,
     "averages path, path"),
    ("path", "llvm_ad_rgb", UnpolarizedVariantError, "does not track polarization"),
])
def test_a_scene_without_stokes_output_is_refused_before_loading(integrator, variant, error,
                                                                 text, tmp_path, monkeypatch):
    """One line naming the scene's file and line, from check_render: no object
    is built, no variant set."""
    monkeypatch.setattr(mi.parser, "instantiate", lambda *a: pytest.fail("the scene was loaded"))
    scene = published(tmp_path, integrator)
    with pytest.raises(error, match=text) as raised:
        check_render(scene, spp=4, variant=variant)
    assert "\n" not in str(raised.value)
    if error is StokesSceneError:
        assert "(integrator.xml line 1)" in str(raised.value)


def test_no_auto_stokes_refuses_in_one_line(tmp_path, capsys):
    scene = published(tmp_path)
    with pytest.raises(StokesSceneError, match="has no stokes integrator around path"):
        check_render(scene, variant=VARIANT, auto_stokes=False)
    out = str(tmp_path / "out" / "s")
    assert main(["render", str(scene), "--variant", VARIANT, "--no-auto-stokes", "--out", out]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no stokes integrator around path" in err
    assert not os.path.exists(out + ".exr")


@pytest.mark.slow
def test_the_command_line_says_in_one_line_that_it_wraps_the_integrator(tmp_path, capsys):
    scene, out = published(tmp_path), str(tmp_path / "out" / "s")
    assert main(["render", str(scene), "--variant", VARIANT, "--spp", "4", "--panels", "intensity",
                 "--out", out, "--no-progress"]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and re.match(r"pbrdf render: the integrator 'path' of main\.xml "
                                        r"\(integrator\.xml line 1\) has no stokes", lines[0])


def test_size_sets_the_film_wherever_the_scene_keeps_it(tmp_path):
    """``size`` on a scene without a width <default>, its film in an included
    file: the loaded film is that size (in an unpolarized variant too, the
    scene's integrator as published). Malformed sizes and a crop window are
    refused before loading, naming ``size``."""
    scene = published(tmp_path)
    request = check_render(scene, variant=VARIANT, size="20x10")
    use_variant(VARIANT)
    loaded = request.mode.load(request.scene_path, None, request.setup)
    assert list(loaded.sensors()[0].film().crop_size()) == [20, 10]
    assert loaded.integrator().class_name() == "StokesIntegrator"
    use_variant("llvm_ad_rgb")
    plain = load_scene_setup(scene, setup=SceneSetup(integrator="as_is", size=(8, 6)))
    assert plain.integrator().class_name() == "PathIntegrator"
    assert np.array(mi.render(plain, spp=1)).shape == (6, 8, 3)
    assert parse_size((3, 4)) == (3, 4) and parse_size(" 640 x 480") == (640, 480)
    for bad, text in [("20", "expects WIDTHxHEIGHT"), ("0x10", "1 to 32768"),
                      ("20x10x3", "expects WIDTHxHEIGHT"), ("ax2", "expects"),
                      ("40000x2", "1 to 32768")]:
        with pytest.raises(ParameterError, match=text) as error:
            check_render(scene, variant=VARIANT, size=bad)
        assert error.value.parameter == "size"
    cropped = published(tmp_path / "crop", crop='<integer name="crop_width" value="8"/>')
    with pytest.raises(ParameterError, match=r"sensor\.xml line 7\) has a crop window"):
        check_render(cropped, variant=VARIANT, size="20x10")


def test_width_on_a_scene_without_it_points_to_size(tmp_path, capsys):
    scene = published(tmp_path)
    assert main(["render", str(scene), "--variant", VARIANT, "-D", "width=200"]) == 2
    err = capsys.readouterr().err
    assert "unknown scene parameter 'width'" in err and "--size WIDTHxHEIGHT" in err


def split(folder):
    """scenes/analytic_plane.xml in the published layout: its integrator
    (``direct``, without ``stokes``) and its sensor in included files."""
    text = open(SCENE).read()
    integrator = re.search(r"<integrator type=\"stokes\">\s*(<integrator[^>]*/>)\s*"
                           r"</integrator>", text)
    sensor = re.search(r"<sensor .*?</sensor>", text, re.S)
    os.makedirs(folder / "parts", exist_ok=True)
    (folder / "parts" / "integrator.xml").write_text(
        f'<scene version="3.0.0">{integrator.group(1)}</scene>')
    (folder / "parts" / "sensor.xml").write_text(f'<scene version="3.0.0">{sensor.group(0)}</scene>')
    text = text.replace(integrator.group(0), '<include filename="parts/integrator.xml"/>')
    (folder / "plane.xml").write_text(text.replace(sensor.group(0),
                                                   '<include filename="parts/sensor.xml"/>'))
    return folder / "plane.xml"


@pytest.mark.parametrize("options", [{"wavelength": "632.8"}, {"bands": "600:680:40"}],
                         ids=["wavelength", "bands"])
def test_passbands_and_cubes_find_the_sensor_and_integrator_through_includes(options, tmp_path):
    """``wavelength`` and ``bands`` (the Python entry point pbrdf render calls)
    on the published layout give the image of the scene file that keeps them
    itself, seed for seed (before: refused, "needs its own <integrator
    type="stokes">", "no <sensor> of its own")."""
    tiny = {"width": 8, "height": 6}
    image = render_scene(split(tmp_path), spp=4, seed=2, variant=VARIANT, params=tiny, **options)
    expected = render_scene(SCENE, spp=4, seed=2, variant=VARIANT, params=tiny, **options)
    assert image.bands == expected.bands and np.array_equal(image.stokes, expected.stokes)


def test_a_file_that_is_not_a_scene_is_refused_before_loading(tmp_path):
    (tmp_path / "bsdf.xml").write_text('<bsdf version="3.0.0" type="roughconductor"/>')
    with pytest.raises(StokesSceneError, match="bsdf.xml is not a scene: its root is a BSDF"):
        check_render(tmp_path / "bsdf.xml", variant=VARIANT)
