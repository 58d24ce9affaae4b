"""One rule for the outputs of every command (mitsuba_pbrdf.outputs.check_plan):
an output that is an input or another output, an output of a format its
writer does not give, or one that cannot be written is refused before any
work, on one line naming the option, exit status 2, with no file created or
touched.

The rows are a pairwise covering array, generated here, over each command's
output options, each taking one of: a good path, a path with odd characters
(valid: the row's refusal comes from another option), the path of an input
(through a symlink or ``./``, so the paths are compared resolved), the path
of another output, a bad format, no extension, an unwritable place, a file
where a folder should be. Rows with no fault in them (they would do the work)
are left out. Cheap: every refusal happens before the work.
"""

import itertools
import os
import shutil

import numpy as np
import pytest

from mitsuba_pbrdf import variant as variant_module
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.outputs import OutputPlanError, check_plan, escape_text, same_file
from proof.covering import pairwise

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir))
CSV = os.path.join(ROOT, "tests", "data", "fit_example.csv")
README = os.path.join(ROOT, "README.md")
ODD = "odd al---é 'q\"<&>\n\x1b"   # a valid name: the refusal of its row is another option's

FAULTS = ("input", "other", "format", "noext", "unwritable", "notfolder")

pytestmark = pytest.mark.usefixtures("restore_variant")


# command: (argv before the outputs, {option: (kind, extension, values)}); kind "file" or
# "folder" (or "stem": render's --out, which gives STEM.exr and STEM.png)
COMMANDS = {
    "fit": (["fit", "{data}"], {
        "--plot": ("file", "png", ("ok", "odd", "input", "other", "format", "noext",
                                   "unwritable")),
        "--json": ("file", "json", ("ok", "odd", "input", "other", "unwritable")),
        "--scene-out": ("file", "xml", ("ok", "odd", "input", "other", "format", "noext",
                                        "unwritable"))}),
    "view": (["view", "{exr}"], {
        "--out": ("file", "png", ("ok", "odd", "input", "format", "noext", "unwritable"))}),
    "view-spectrum": (["view", "{exr}", "--spectrum", "1,1"], {
        "--out": ("file", "png", ("input", "format", "noext", "unwritable"))}),
    "plot": (["plot"], {
        "--out": ("file", "png", ("ok", "odd", "format", "noext", "unwritable"))}),
    "export": (["export", "--grid", "2x2x2"], {
        "--out": ("file", "pbsdf", ("ok", "odd", "format", "noext", "unwritable"))}),
    "render": (["render", "{textured}", "--spp", "1"], {
        "--out": ("stem", "exr", ("ok", "odd", "input", "unwritable", "notfolder"))}),
    "polcam": (["polcam", "{exr}"], {
        "--out": ("folder", None, ("ok", "odd", "unwritable", "notfolder"))}),
    "recover-normals": (["recover-normals", "{plate}", "--targets", "{exr}", "--truth",
                         "{truth}", "--iterations", "1", "--spp", "1"], {
        "--out": ("folder", None, ("ok", "odd", "input", "unwritable", "notfolder"))}),
    "gallery": (["gallery", "--only", "sheet", "--spp", "1"], {
        "--out": ("folder", None, ("ok", "odd", "unwritable", "notfolder")),
        "--exr-dir": ("folder", None, ("ok", "odd", "unwritable", "notfolder"))}),
}

ROWS = [(command, row) for command, (_, options) in COMMANDS.items()
        for row in pairwise({o: v for o, (_, _, v) in options.items()})
        if any(value in FAULTS for value in row.values())]


def _path(files, command, option, value, row):
    """The argument of *option* for *value* (see the module docstring)."""
    kind, ext, _ = COMMANDS[command][1][option]
    tmp = files["tmp"]
    suffix = f".{ext}" if kind == "file" else ""
    name = option.strip("-")
    if value == "ok":
        return f"{tmp}/{name}{suffix}"
    if value == "odd":
        return f"{tmp}/{ODD}{name}{suffix}"
    if value == "input":
        if kind == "stem":       # the scene's texture: STEM.exr is the file it reads
            return f"./{os.path.basename(files['texture'])[:-4]}"
        if kind == "folder":     # the folder whose normals.exr is --truth
            return "./previous/"
        link = f"{tmp}/input_{command}{suffix}"   # same extension, resolved to the input
        if not os.path.lexists(link):
            os.symlink(files["data"] if command == "fit" else files["exr"], link)
        return link
    if value == "other":
        others = [o for o in row if o != option]
        other = others[0]
        return "./" + os.path.relpath(_path(files, command, other, row[other], row)
                                      if row[other] != "other" else f"{tmp}/shared.png", tmp)
    if value == "format":
        return f"{tmp}/{name}.txt"
    if value == "noext":
        return f"{tmp}/{name}"
    if value == "unwritable":   # odd characters too: the message names it on one line
        return f"/sys/{name}{ODD}{suffix}"
    if value == "notfolder":
        return f"{README}/{name}"
    raise AssertionError(value)


def snapshot(folder):
    """{path: (size, mtime_ns, bytes)} of every file under *folder*."""
    found = {}
    for top, dirs, names in os.walk(folder):
        for n in names + dirs:
            p = os.path.join(top, n)
            st = os.lstat(p)
            data = open(p, "rb").read() if os.path.isfile(p) and not os.path.islink(p) else b""
            found[p] = (st.st_size if not os.path.isdir(p) else 0, st.st_mtime_ns, data)
    return found


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from mitsuba_pbrdf.inverse.normals.scenes import write_plate_files
    from mitsuba_pbrdf.stokes.exr import write_exr, write_stokes_exr
    from mitsuba_pbrdf.stokes.image import StokesImage
    from tests.cli.test_cli import TINY_SCENE

    tmp = tmp_path_factory.mktemp("outputs")
    data = shutil.copy(CSV, tmp / "data.csv")
    stokes = np.zeros((8, 8, 4, 3), np.float32)
    stokes[:, :, 0] = 1.0
    stokes[:, :, 1] = 0.2
    exr = write_stokes_exr(tmp / "stokes.exr", StokesImage(stokes, ["R", "G", "B"]))
    texture = write_exr(tmp / "tex.exr", {c: np.ones((4, 4), np.float32) for c in "RGB"})
    textured = tmp / "textured.xml"
    textured.write_text(TINY_SCENE.replace(
        '<string name="material" value="Cu"/>',
        '<string name="material" value="Cu"/><texture type="bitmap" name="kdd">'
        '<string name="filename" value="tex.exr"/></texture>').replace(
        '<spectrum name="kdd" value="0.1"/>', ""))
    (tmp / "plate").mkdir()
    flat = np.zeros((4, 4, 3), np.float32)
    flat[..., 2] = 1.0
    plate = write_plate_files(tmp / "plate", flat, size=8, spp=1)
    (tmp / "previous").mkdir()
    truth = write_exr(tmp / "previous" / "normals.exr",
                      {c: np.full((4, 4), v, np.float32) for c, v in zip("XYZ", (0, 0, 1))})
    return dict(tmp=str(tmp), data=str(data), exr=str(exr), texture=str(texture),
                textured=str(textured), plate=plate, truth=str(truth))


@pytest.fixture(autouse=True)
def cpu_default_variant(monkeypatch):
    monkeypatch.setattr(variant_module, "cuda_available", lambda: False)


def test_the_covering_arrays_cover_every_pair():
    """Every pair of values of two options of a command is in some row
    (before the fault-free rows are dropped), and the arrays stay small."""
    for command, (_, options) in COMMANDS.items():
        factors = {o: v for o, (_, _, v) in options.items()}
        rows = pairwise(factors)
        for a, b in itertools.combinations(factors, 2):
            pairs = {(r[a], r[b]) for r in rows}
            assert pairs == set(itertools.product(factors[a], factors[b])), command
    assert len(ROWS) < 100


@pytest.mark.parametrize("command, row", ROWS,
                         ids=[f"{c}:" + ",".join(f"{o}={v}" for o, v in r.items())
                              for c, r in ROWS])
def test_outputs_are_refused_before_any_work(command, row, files, capfd, monkeypatch):
    monkeypatch.chdir(files["tmp"])
    argv_head, options = COMMANDS[command]
    argv = [a.format(**files) for a in argv_head]
    for option, value in row.items():
        argv += [option, _path(files, command, option, value, row)]
    before = snapshot(files["tmp"])
    assert main(argv) == 2
    out, err = capfd.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    line = lines[0]
    assert not any(ord(c) < 32 for c in line), line    # no terminal escape from a file name
    assert line.startswith(f"pbrdf {argv[0]}: error: "), line
    faulty = [o for o, v in row.items() if v in FAULTS]
    assert any(o in line for o in faulty), (line, faulty)
    if "name the same file" in line:
        assert line.count(" and ") >= 1 and "an output never replaces" in line
    assert snapshot(files["tmp"]) == before   # nothing created, replaced or touched
    assert "chi2" not in out


# ---------------------------------------------------------------- the cases of the issue


def test_fit_json_over_its_measurements_is_refused(files, capfd, monkeypatch):
    """`pbrdf fit victim.csv --json victim.csv` exited 0 and replaced the
    measurements with JSON; `--json X.xml --scene-out X.xml` lost one output."""
    monkeypatch.chdir(files["tmp"])
    before = open(files["data"], "rb").read()
    assert main(["fit", "data.csv", "--json", "./data.csv"]) == 2
    assert ("--json and FILE name the same file ./data.csv: an output never replaces an "
            "input") in capfd.readouterr().err
    assert main(["fit", "data.csv", "--json", "X.xml", "--scene-out", "X.xml"]) == 2
    assert "--scene-out and --json name the same file X.xml" in capfd.readouterr().err
    assert open(files["data"], "rb").read() == before and not os.path.exists("X.xml")


@pytest.mark.parametrize("plot, message", [
    ("fit.txt", "--plot: cannot write a .txt file (fit.txt); it writes .png or .pdf or .svg"),
    ("noext", "--plot: noext has no extension; give a .png or .pdf or .svg file name"),
])
def test_fit_plot_format_is_checked_before_the_fit(plot, message, files, capfd, monkeypatch):
    monkeypatch.chdir(files["tmp"])
    assert main(["fit", "data.csv", "--plot", plot]) == 2
    out, err = capfd.readouterr()
    assert message in err and "chi2" not in out


def test_render_refuses_to_write_over_the_scenes_texture(files, capfd, monkeypatch):
    """`--out tex` gives tex.exr and tex.png; tex.exr is the scene's texture."""
    monkeypatch.chdir(files["tmp"])
    assert main(["render", "textured.xml", "--spp", "1", "--out", "tex"]) == 2
    assert ("--out and a file the scene reads name the same file tex.exr"
            in capfd.readouterr().err)


def test_view_spectrum_csv_is_an_output_too(files, capfd, monkeypatch):
    """With --spectrum, view writes <out>.png and the derived <out>.csv: a
    CSV path that resolves to the input (here by a link) is refused too."""
    monkeypatch.chdir(files["tmp"])
    os.makedirs("spec", exist_ok=True)
    if not os.path.lexists("spec/s.csv"):
        os.symlink(files["exr"], "spec/s.csv")
    before = open(files["exr"], "rb").read()
    assert main(["view", files["exr"], "--spectrum", "1,1", "--out", "spec/s.png"]) == 2
    assert "--out and STOKES.exr name the same file spec/s.csv" in capfd.readouterr().err
    assert open(files["exr"], "rb").read() == before and not os.path.exists("spec/s.png")


def test_check_plan_resolves_paths(tmp_path):
    (tmp_path / "a.csv").write_text("x\n")
    os.symlink(tmp_path / "a.csv", tmp_path / "b.json")
    os.link(tmp_path / "a.csv", tmp_path / "hard.json")
    for given in (tmp_path / "b.json", tmp_path / "hard.json", f"{tmp_path}/sub/../a.csv"):
        assert same_file(given, tmp_path / "a.csv")
        with pytest.raises(OutputPlanError, match="--json and FILE name the same file"):
            check_plan([("--json", given, None)], inputs=[("FILE", tmp_path / "a.csv")])
    assert not same_file(tmp_path / "a.csv", tmp_path / "c.csv")
    check_plan([("--json", tmp_path / "c.json", ("json",)), ("--plot", None, ("png",))],
               inputs=[("FILE", tmp_path / "a.csv"), ("--nk", None)])


@pytest.mark.parametrize("text, context, escaped", [
    ("al---sample.csv", "xml-comment", "al- - -sample.csv"),
    ("ends-", "xml-comment", "ends- "),
    ('a<b & "c" \'d\'\n', "xml", "a&lt;b &amp; &quot;c&quot; &apos;d&apos;&#10;"),
    ("bad\udcffname\x1b", "line", "bad\\xffname\\x1b"),
    ("two\nlines\tx", "line", "two lines x"),
    ("a,b", "csv", '"a,b"'),
    ('say "hi"', "csv", '"say ""hi"""'),
    ("#x", "csv", '"#x"'),
    ("plain", "csv", "plain"),
])
def test_escape_text(text, context, escaped):
    assert escape_text(text, context) == escaped
    escape_text(text, context).encode("utf-8")   # always encodable


def test_escaped_xml_parses():
    import xml.etree.ElementTree as ET

    nasty = "al---x-- <&> \"' \udcff\x00\x1b\ufffe-"
    doc = (f"<a v=\"{escape_text(nasty, 'xml')}\"><!-- {escape_text(nasty, 'xml-comment')}"
           f"-->{escape_text(nasty, 'xml')}</a>")
    root = ET.fromstring(doc.encode("utf-8"))
    assert root.get("v").startswith("al---x-- <&>") and root.text == root.get("v")



def test_batch_manifest_never_replaces_the_sweep_file(files, capfd, monkeypatch):
    """A sweep file called manifest.csv with out = "." would be replaced by
    the manifest it describes."""
    monkeypatch.chdir(files["tmp"])
    os.makedirs("sweep", exist_ok=True)
    with open("sweep/manifest.csv", "w") as f:
        f.write(f'scene = "{files["textured"]}"\nout = "."\n')
    before = open("sweep/manifest.csv").read()
    assert main(["batch", "sweep/manifest.csv"]) == 2
    line = capfd.readouterr().err.strip()
    assert "out and the sweep file name the same file" in line and len(line.splitlines()) == 1
    assert open("sweep/manifest.csv").read() == before


# ---------------------------------------------------------------- what is written is valid


def _fit_at(wavelengths, n, k):
    """A two-wavelength fit's result, as write_fitted_scene reads it."""
    import types

    return types.SimpleNamespace(
        values={"n": np.array(n), "k": np.array(k), "sigma": 0.2, "ks": 1.0, "kdd": 0.1,
                "sigma_dd": 0.4, "kid": 0.05},
        wavelengths=np.array(wavelengths), model="three", index_note="n, k fitted per wavelength",
        shadowing="vgroove", distribution="ggx", dd_distribution="ggx", objective="log",
        reduced_chi2=1.2)


def test_fitted_scene_spectra_cover_the_spectral_range(tmp_path):
    """A fit at 500 and 600 nm wrote eta = 0 outside 500-600 nm, which the
    plugin refuses; now the end values are held out to 360 and 830 nm, and a
    comment says so. The data file's odd name is escaped (valid XML)."""
    import xml.etree.ElementTree as ET

    from mitsuba_pbrdf.fitting.scene_out import write_fitted_scene

    path = write_fitted_scene(_fit_at([600.0, 500.0], [0.9, 1.1], [7.0, 6.0]),
                              str(tmp_path / "fitted.xml"), source="al---sample\udcff.csv")
    text = open(path, encoding="utf-8").read()
    root = ET.fromstring(text)                       # al---sample: valid XML
    eta = root.find(".//bsdf[@type='pbrdf']/spectrum[@name='eta']").get("value")
    k = root.find(".//bsdf[@type='pbrdf']/spectrum[@name='k']").get("value")
    assert eta == "360:1.1, 500:1.1, 600:0.9, 830:0.9" and k == "360:6, 500:6, 600:7, 830:7"
    assert "held at the end values outside 500-600 nm, out to 360-830 nm" in text
    assert "al- - -sample\\xff.csv" in text


@pytest.mark.parametrize("variant", ["llvm_ad_spectral_polarized", "llvm_ad_rgb",
                                     "llvm_ad_spectral"])
def test_fitted_scene_renders_polarized_and_unpolarized(variant, tmp_path):
    """The scene of a two-wavelength fit loads and renders (finite, not black)
    in a polarized variant as it is, and in unpolarized ones without its
    stokes integrator (SceneSetup(integrator="nested"), as render --bands
    loads it)."""
    import mitsuba as mi

    from mitsuba_pbrdf.fitting.scene_out import write_fitted_scene
    from mitsuba_pbrdf.registry import use_variant
    from mitsuba_pbrdf.rendering.scene_setup import SceneSetup, load_scene_setup

    path = write_fitted_scene(_fit_at([500.0, 600.0], [1.1, 0.9], [6.0, 7.0]),
                              str(tmp_path / "fitted.xml"), source="al---sample.csv")
    use_variant(variant)
    params = {"width": 8, "height": 6, "spp": 2}
    setup = SceneSetup(integrator="stokes" if "polarized" in variant else "nested")
    scene = load_scene_setup(path, params, setup)
    image = np.asarray(mi.render(scene))
    assert np.isfinite(image).all() and image[..., :3].max() > 0


def test_exr_header_text_is_escaped(tmp_path):
    """A title with a line break and a byte of a file name that is not UTF-8
    (how Python decodes one) raised UnicodeEncodeError inside OpenEXR."""
    from mitsuba_pbrdf.stokes.exr import read_exr, write_exr

    path = write_exr(tmp_path / "h.exr", {"Y": np.zeros((2, 2), np.float32)},
                     {"title": "two\nlines \udcff.exr", "source": "a\tb"})
    metadata, _ = read_exr(path)
    assert metadata["title"] == "two lines \\xff.exr" and metadata["source"] == "a b"


def test_odd_names_are_written_as_given(files, capfd, monkeypatch):
    """A valid output name with odd characters (a line break, quotes, '--',
    an escape character) is written under that exact name."""
    monkeypatch.chdir(files["tmp"])
    out = os.path.join(files["tmp"], "written", f"{ODD}.png")
    assert main(["view", files["exr"], "--out", out]) == 0
    assert os.path.isfile(out)


def test_json_outputs_are_strict_json(tmp_path):
    """json.dumps wrote NaN and Infinity (a fit's reduced chi2 with no degree
    of freedom), which strict JSON parsers refuse; they are null now."""
    import json

    from mitsuba_pbrdf.outputs import write_json

    path = write_json(tmp_path / "r.json", {"chi2": float("nan"), "rms": [float("inf"), 1.5],
                                            "name": "al---\udcff"})

    def refuse(constant):
        raise ValueError(constant)

    assert json.loads(open(path).read(), parse_constant=refuse) == {
        "chi2": None, "rms": [None, 1.5], "name": "al---\udcff"}


def test_fit_never_replaces_its_index_table(files, capfd, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "nk.csv").write_text("wavelength,n,k\n400,1,6\n700,1.5,8\n")
    before = (tmp_path / "nk.csv").read_text()
    assert main(["fit", files["data"], "--nk", "nk.csv", "--json", f"{tmp_path}/./nk.csv"]) == 2
    assert "--json and --nk name the same file" in capfd.readouterr().err
    assert (tmp_path / "nk.csv").read_text() == before


def test_names_that_are_not_utf8(files, capfd, monkeypatch, tmp_path):
    """File names with bytes that are not UTF-8 (Python: lone surrogates):
    OpenEXR took neither such an input ('not a readable OpenEXR file') nor
    such an output, and matplotlib's fonts raised on a title made of one
    (view's, an internal error); each is now read, written and drawn, the
    name escaped (\\xff) where it enters a file."""
    from mitsuba_pbrdf.stokes.exr import read_exr, read_stokes_exr

    monkeypatch.chdir(tmp_path)
    odd = os.fsdecode(b"b\xff.exr")
    shutil.copy(files["exr"], odd)
    assert main(["polcam", odd, "--out", os.fsdecode(b"cam\xfe")]) == 0
    frame = os.path.join(os.fsdecode(b"cam\xfe"), os.fsdecode(b"b\xff_I0.exr"))
    assert read_exr(frame)[0]["source"] == "b\\xff.exr"
    assert main(["view", frame]) == 0
    assert os.path.isfile(frame[:-4] + ".png")
    assert read_stokes_exr(odd).stokes.shape == (8, 8, 4, 3)
    _, err = capfd.readouterr()
    assert "error" not in err


@pytest.mark.slow
def test_fit_outputs_of_a_data_file_not_named_in_utf8(tmp_path, monkeypatch):
    """The plot's title (the data file's name) made matplotlib raise after the
    fit: an internal error, no output. Slow: it fits (about 10 s)."""
    import json

    monkeypatch.chdir(tmp_path)
    data = os.fsdecode(b"d\xff---.csv")
    shutil.copy(CSV, data)
    assert main(["fit", data, "--model", "two", "--distribution", "ggx", "--plot", "p.png",
                 "--json", "j.json", "--scene-out", "s.xml"]) == 0
    import xml.etree.ElementTree as ET

    assert "d\\xff- - -.csv" in open("s.xml", encoding="utf-8").read()
    ET.parse("s.xml")
    assert json.load(open("j.json"))["two"]["model"] == "two"
    assert os.path.getsize("p.png") > 1000


def test_scene_inputs_follow_includes_and_parameters(tmp_path):
    from mitsuba_pbrdf.rendering.scene_params import scene_inputs

    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "part.xml").write_text(
        '<scene version="3.0.0"><texture type="bitmap" id="t">'
        '<string name="filename" value="$tex.exr"/></texture></scene>')
    (tmp_path / "main.xml").write_text(
        '<scene version="3.0.0"><default name="tex" value="maps/a"/>'
        '<include filename="sub/part.xml"/><emitter type="envmap">'
        '<string name="filename" value="sky.exr"/></emitter></scene>')
    found = scene_inputs(tmp_path / "main.xml")
    assert found == [str(tmp_path / "sub/part.xml"), str(tmp_path / "sky.exr"),
                     str(tmp_path / "sub/maps/a.exr")]
    assert scene_inputs(tmp_path / "main.xml", {"tex": "b"})[-1] == str(tmp_path / "sub/b.exr")
