"""``pbrdf convert`` (mitsuba_pbrdf.rendering.scene_convert): what it writes,
what it reports, what it refuses. XML only (no render)."""

import math
import os
import shutil
import xml.etree.ElementTree as ET

import pytest

from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.rendering.scene_convert import convert_scene

DATA = os.path.join(os.path.dirname(__file__), os.pardir, "data", "mitsuba_scenes")
SQRT2 = math.sqrt(2.0)


def scene(tmp_path, body, name="s.xml"):
    path = tmp_path / name
    path.write_text(f'<scene version="3.0.0">\n    {body}\n</scene>\n')
    return str(path)


def props(bsdf):
    return {c.get("name"): c for c in bsdf if isinstance(c.tag, str)}


def metals(path):
    return [b for b in ET.parse(path).getroot().iter("bsdf") if b.get("type") == "pbrdf"]


def test_published_copper_converts_beside_the_original_which_is_left_as_it_was(tmp_path):
    shutil.copytree(DATA, tmp_path / "data")
    original = tmp_path / "data" / "docs" / "scenes" / "bsdf_roughconductor_copper.xml"
    before = original.read_bytes()
    result = convert_scene(original)
    new = str(tmp_path / "data" / "docs" / "scenes" / "bsdf_roughconductor_copper_pbrdf.xml")
    assert result.scene == new and result.files == {str(original): new}
    assert original.read_bytes() == before
    (bsdf,) = metals(new)
    p = props(bsdf)
    assert bsdf.get("id") == "object_bsdf"
    assert float(p["sigma"].get("value")) == pytest.approx(0.1 / SQRT2, rel=1e-8)
    assert {n: p[n].get("value") for n in ("material", "distribution", "shadowing", "kdd", "kid")} \
        == {"material": "Cu", "distribution": "beckmann", "shadowing": "smith", "kdd": "0",
            "kid": "0"}
    assert "alpha" not in p
    assert any(n.endswith("alpha 0.1 -> sigma 0.0707107 (alpha / sqrt(2))") for n in result.notes)
    assert any(n.endswith("material Cu kept") for n in result.notes)
    # the include holds no metal: not copied, still named as it was
    assert '<include filename="include/matpreview.xml"' in open(new).read()


def test_included_metals_get_converted_copies_and_the_chain_to_them_too(tmp_path):
    (tmp_path / "parts").mkdir()
    scene(tmp_path / "parts", '<bsdf type="roughconductor" id="m"><float name="alpha" '
          'value="0.2"/></bsdf>', "metal.xml")
    scene(tmp_path / "parts", '<include filename="metal.xml"/>', "middle.xml")
    scene(tmp_path / "parts", '<bsdf type="diffuse" id="d"/>', "plain.xml")
    main_scene = scene(tmp_path, '<include filename="parts/middle.xml"/>\n    '
                                 '<include filename="parts/plain.xml"/>')
    originals = {p: open(p).read() for p in map(str, tmp_path.rglob("*.xml"))}
    result = convert_scene(main_scene)
    assert list(result.files.values()) == [
        str(tmp_path / "s_pbrdf.xml"), str(tmp_path / "parts" / "middle_pbrdf.xml"),
        str(tmp_path / "parts" / "metal_pbrdf.xml")]
    assert {p: open(p).read() for p in originals} == originals
    text = open(tmp_path / "s_pbrdf.xml").read()
    assert 'filename="parts/middle_pbrdf.xml"' in text and 'filename="parts/plain.xml"' in text
    assert 'filename="metal_pbrdf.xml"' in open(tmp_path / "parts" / "middle_pbrdf.xml").read()
    (bsdf,) = metals(tmp_path / "parts" / "metal_pbrdf.xml")
    assert float(props(bsdf)["sigma"].get("value")) == pytest.approx(0.2 / SQRT2, rel=1e-8)


def test_wrappers_refs_and_ids_stay_around_the_converted_metal(tmp_path):
    path = scene(tmp_path, """<bsdf type="twosided" id="two">
        <bsdf type="roughconductor" id="inner">
            <!-- a comment kept -->
            <texture name="alpha" type="checkerboard">
                <float name="color1" value="0.3"/>
            </texture>
            <spectrum name="specular_reflectance" value="0.8"/>
            <boolean name="sample_visible" value="false"/>
            <spectrum name="eta" value="400:1.2, 700:0.3"/>
            <spectrum name="k" value="400:2.0, 700:4.0"/>
        </bsdf>
    </bsdf>
    <bsdf type="blendbsdf" id="blend">
        <float name="weight" value="0.3"/>
        <bsdf type="diffuse"/>
        <ref id="two"/>
    </bsdf>
    <bsdf type="mask" id="masked"><float name="opacity" value="0.5"/>
        <bsdf type="conductor"/></bsdf>""")
    result = convert_scene(path)
    root = ET.parse(result.scene).getroot()
    assert [b.get("type") for b in root.iter("bsdf")] == [
        "twosided", "pbrdf", "blendbsdf", "diffuse", "mask", "pbrdf"]
    assert root.find("bsdf[@id='blend']/ref").get("id") == "two"
    inner = props(root.find(".//bsdf[@id='inner']"))
    checker = props(inner["sigma"])   # Mitsuba's default color0 0.4 written out, scaled
    assert float(checker["color0"].get("value")) == pytest.approx(0.4 / SQRT2, rel=1e-8)
    assert float(checker["color1"].get("value")) == pytest.approx(0.3 / SQRT2, rel=1e-8)
    assert inner["ks"].get("value") == "0.8" and "sample_visible" not in inner
    assert inner["eta"].get("value") == "360:1.2, 400:1.2, 700:0.3, 830:0.3"
    assert "a comment kept" in open(result.scene).read()
    mirror = props(root.find("bsdf[@id='masked']/bsdf"))
    # Mitsuba's conductor without material or eta: eta = 0, k = 1
    assert {n: mirror[n].get("value") for n in ("sigma", "eta", "k")} == \
        {"sigma": "0", "eta": "0.0001", "k": "1"}
    notes = "\n".join(result.notes)
    for line in ("alpha checkerboard (0.4, 0.3) -> sigma checkerboard (0.282843, 0.212132)",
                 "specular_reflectance 0.8 kept as ks",
                 "sample_visible false dropped (pbrdf always samples visible normals; the "
                 "renders agree in expectation, not per seed)",
                 "eta/k given as spectra kept",
                 "eta spectrum covers 400-700 nm: its end values held out to 360-830 nm "
                 "(Mitsuba's conductor has n = k = 0 there: black in polarized variants, a "
                 "mirror in the others)",
                 "conductor #2 (no id): no material nor eta (Mitsuba's perfect mirror, eta = 0)"):
        assert line in notes
    assert all("\n" not in n for n in result.notes)


@pytest.mark.parametrize("body, text", [
    ('<bsdf type="roughconductor"><float name="alpha" value="0.1"/>'
     '<float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/></bsdf>',
     "needs both alpha_u and alpha_v, without alpha"),
    ('<bsdf type="roughconductor"><float name="alpha_u" value="0.1"/></bsdf>',
     "needs both alpha_u and alpha_v"),
    ('<bsdf type="conductor"><string name="material" value="Au"/><float name="k" value="2"/>'
     '</bsdf>', "gives k beside material Au"),
    ('<bsdf type="conductor"><float name="alpha" value="0.1"/></bsdf>',
     "conductor takes no parameter 'alpha'"),
    ('<bsdf type="conductor"><string name="material" value="Unobtainium"/></bsdf>',
     "unknown material 'Unobtainium'"),
    ('<bsdf type="diffuse"/>', "no conductor or roughconductor in the scene"),
])
def test_what_mitsuba_refuses_or_cannot_be_scaled_is_refused_before_writing(tmp_path, body,
                                                                            text):
    path = scene(tmp_path, body)
    with pytest.raises(ValueError, match=text.replace("(", r"\(").replace(")", r"\)")):
        convert_scene(path)
    assert sorted(os.listdir(tmp_path)) == ["s.xml"]


def test_an_alpha_that_cannot_be_divided_here_keeps_mitsubas_name(tmp_path):
    path = scene(tmp_path, """<default name="a" value="0.2"/>
    <texture type="bitmap" id="rough"><string name="filename" value="r.png"/></texture>
    <bsdf type="roughconductor" id="m1"><float name="alpha" value="$a"/></bsdf>
    <bsdf type="roughconductor" id="m2"><ref name="alpha_u" id="rough"/>
        <texture name="alpha_v" type="bitmap"><string name="filename" value="r.png"/></texture>
    </bsdf>""")
    result = convert_scene(path)
    root = ET.parse(result.scene).getroot()
    assert props(root.find("bsdf[@id='m1']"))["alpha"].get("value") == "$a"
    assert set(props(root.find("bsdf[@id='m2']"))) >= {"alpha_u", "alpha_v"}
    notes = "\n".join(result.notes)
    assert "'m1': alpha given as $a kept as alpha (pbrdf's name for Mitsuba's width: " \
           "sigma = alpha / sqrt(2))" in notes
    assert "'m2': alpha_u given as a reference to 'rough' kept as alpha_u" in notes
    assert "'m2': alpha_v given as a bitmap texture kept as alpha_v" in notes


def test_out_in_another_folder_points_at_the_original_folder(tmp_path):
    (tmp_path / "a").mkdir()
    path = scene(tmp_path / "a", '<include filename="m.xml"/>')
    scene(tmp_path / "a", '<bsdf type="conductor" id="c"/>', "m.xml")
    result = convert_scene(path, tmp_path / "b" / "new.xml")
    root = ET.parse(result.scene).getroot()
    assert root[0].tag == "path" and root[0].get("value") == "../a"
    assert root.find("include").get("filename") == "m_pbrdf.xml"
    assert os.path.isfile(tmp_path / "a" / "m_pbrdf.xml")


def test_command_prints_each_change_and_each_file(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = scene(tmp_path, '<bsdf type="roughconductor" id="rc"><string name="material" '
                           'value="Ag"/><float name="alpha_u" value="0.05"/>'
                           '<float name="alpha_v" value="0.3"/></bsdf>')
    assert main(["convert", path]) == 0
    out = capsys.readouterr().out.splitlines()
    where = "s.xml: roughconductor 'rc'"
    assert out == [f"{where}: roughconductor -> pbrdf (shadowing smith, kdd = kid = 0)",
                   f"{where}: material Ag kept",
                   f"{where}: alpha_u 0.05 -> sigma_u 0.0353553 (alpha / sqrt(2))",
                   f"{where}: alpha_v 0.3 -> sigma_v 0.212132 (alpha / sqrt(2))",
                   f"wrote {tmp_path / 's_pbrdf.xml'} (from {path})"]
    assert main(["convert", path]) == 0   # again: the copy is replaced, and says so
    assert capsys.readouterr().out.splitlines()[-1] == \
        f"replaced {tmp_path / 's_pbrdf.xml'} (from {path})"
