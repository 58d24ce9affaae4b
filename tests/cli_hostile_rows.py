"""The rows of tests/hostile/test_cli_hostile.py's table for the surfaces added since
it was written (issue 28: cubes, sweeps, the NIST layout, recover-normals,
anisotropy, normal and bump maps), and the files they need.

Each row is a :class:`Hostile`: the case, the command's arguments, its exit
status, text its one line must contain, and a file that must not exist
afterwards. ``{tmp}`` and the other names are the keys of
:func:`hostile_files` and of the table's ``files`` fixture.
"""

import re
from typing import List, NamedTuple, Optional

import numpy as np


class Hostile(NamedTuple):
    """One hostile command line and what it must end in."""
    case: str                      #: what is wrong, in words (the test's id)
    argv: List[str]                #: pbrdf's arguments; ``{name}`` is filled from the files
    status: int                    #: the exit status
    text: str                      #: text the one line on stderr must contain
    absent: Optional[str] = None   #: a file that must not exist afterwards


ROWS = [
    # one number parser: float extremes and bounded counts
    Hostile("render: --bands with a denormal step",
            ["render", "{scene}", "--bands", "400:500:1e-320"],
            status=2, text="--bands: '400:500:1e-320' is more than 1e308 bands; at most 64",
            absent="{tmp}/out"),
    Hostile("render: --bands with a huge range",
            ["render", "{scene}", "--bands", "400:1e308:1e-308"],
            status=2, text="--bands: '400:1e308:1e-308' is more than 1e308 bands; at most 64",
            absent="{tmp}/out"),
    Hostile("render: --spp 2^63-1",
            ["render", "{scene}", "--spp", str(2 ** 63 - 1)],
            status=2, text="--spp: must be an integer of at most 16777216", absent="{tmp}/out"),
    Hostile("render: --passes 2^63-1",
            ["render", "{scene}", "--spp", "1", "--passes", str(2 ** 63 - 1)],
            status=2, text="--passes: must be an integer of at most 16777216", absent="{tmp}/out"),
    # any scene's size (issue 36)
    Hostile("render: --size not WIDTHxHEIGHT",
            ["render", "{scene}", "--size", "320x"],
            status=2, text="--size: expects WIDTHxHEIGHT in pixels", absent="{tmp}/out"),
    Hostile("render: --size 0 pixels wide",
            ["render", "{scene}", "--size", "0x240"],
            status=2, text="--size: each side must be 1 to 32768 pixels", absent="{tmp}/out"),
    Hostile("render: --size 2^63-1 pixels",
            ["render", "{scene}", "--size", f"{2 ** 63 - 1}x2"],
            status=2, text="--size: each side must be 1 to 32768 pixels", absent="{tmp}/out"),
    Hostile("render: an integrator stokes cannot wrap (prb), before loading",
            ["render", "{prb_scene}"],
            status=2, text="prb ignores Mueller frame rotations", absent="{tmp}/out"),
    Hostile("export: --bands with a denormal step",
            ["export", "--bands", "400:500:1e-320", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--bands: '400:500:1e-320' must be a whole number of nm",
            absent="{tmp}/h.pbsdf"),
    Hostile("batch: spp 2^63-1",
            ["batch", "{sweep_huge_spp}"],
            status=2, text="spp must be at most 16777216 (2^24), got 9223372036854775807",
            absent="{tmp}/out/manifest.csv"),
    Hostile("batch: bands with a denormal step",
            ["batch", "{sweep_denormal_bands}"],
            status=2, text="bands: '400:500:1e-320' is more than 1e308 bands; at most 64",
            absent="{tmp}/out/manifest.csv"),
    Hostile("batch: 10^7 jobs",
            ["batch", "{sweep_many_jobs}"],
            status=2, text="= 10000000 jobs; at most 100000 in one sweep",
            absent="{tmp}/out/manifest.csv"),
    # one unusable-pixel rule for every reader of Stokes data
    Hostile("view --cube: all-NaN cube",
            ["view", "{cube_nan}", "--cube", "--out", "{tmp}/c.png"],
            status=2, text="no usable pixel", absent="{tmp}/c.png"),
    Hostile("view --cube: S0 < 0 everywhere",
            ["view", "{cube_negative}", "--cube", "--out", "{tmp}/c.png"],
            status=2, text="192 with S0 < 0", absent="{tmp}/c.png"),
    Hostile("view --cube: one band all NaN",
            ["view", "{cube_band_nan}", "--cube", "--out", "{tmp}/c.png"],
            status=2, text="no usable pixel", absent="{tmp}/c.png"),
    Hostile("view --spectrum: all-NaN cube",
            ["view", "{cube_nan}", "--spectrum", "1,1", "--out", "{tmp}/c.png"],
            status=2, text="no usable pixel", absent="{tmp}/c.csv"),
    Hostile("view --spectrum: the pixel is NaN",
            ["view", "{cube_pixel_nan}", "--spectrum", "1,1", "--out", "{tmp}/c.png"],
            status=2, text="--spectrum: pixel (1, 1): no pixel is usable in every band",
            absent="{tmp}/c.csv"),
    Hostile("view --spectrum: an RGB image (no wavelengths)",
            ["view", "{exr}", "--spectrum", "1,1", "--out", "{tmp}/c.png"],
            status=2, text="--spectrum: a Stokes spectrum needs bands named after their wavelengths",
            absent="{tmp}/c.csv"),
    Hostile("polcam: cube with S0 < 0 everywhere",
            ["polcam", "{cube_negative}", "--out", "{tmp}/cam"],
            status=2, text="no usable pixel", absent="{tmp}/cam"),
    Hostile("polcam: S0 < 0 everywhere",
            ["polcam", "{negative_exr}", "--out", "{tmp}/cam"],
            status=2, text="no usable pixel", absent="{tmp}/cam"),
    Hostile("polcam: one band with S0 < 0",
            ["polcam", "{negative_exr}", "--band", "G", "--out", "{tmp}/cam"],
            status=2, text="no usable pixel", absent="{tmp}/cam"),
    # floors from the schema
    Hostile("export: --sigma-u below the floor",
            ["export", "--sigma-u", "1e-300", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--sigma-u: must be >= 7.07e-05", absent="{tmp}/h.pbsdf"),
    Hostile("export: --sigma-dd-u below the floor",
            ["export", "--kdd", "0.2", "--sigma-dd-u", "1e-9", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--sigma-dd-u: must be >= 7.07e-05", absent="{tmp}/h.pbsdf"),
    Hostile("plot: --sigma below the floor",
            ["plot", "--sigma", "1e-5", "--out", "{tmp}/p.png"],
            status=2, text="--sigma: must be >= 7.07e-05", absent="{tmp}/p.png"),
    Hostile("plot: --sigma-v below the floor",
            ["plot", "--sigma-v", "5e-324", "--out", "{tmp}/p.png"],
            status=2, text="--sigma-v: must be >= 7.07e-05", absent="{tmp}/p.png"),
    # recover-normals (the library's checks: tests/inverse/test_normals.py)
    Hostile("recover-normals: --seed -1",
            ["recover-normals", "{plate}", "--targets", "{exr8}", "--out", "{tmp}/rn", "--seed",
             "-1"],
            status=2, text="--seed: must be an integer in [0, 2^32 - 1]",
            absent="{tmp}/rn/normals.exr"),
    Hostile("recover-normals: --seed 2^40",
            ["recover-normals", "{plate}", "--targets", "{exr8}", "--out", "{tmp}/rn", "--seed",
             str(2 ** 40)],
            status=2, text="--seed: must be an integer of at most 4294967295",
            absent="{tmp}/rn/normals.exr"),
    Hostile("recover-normals: an all-zero target",
            ["recover-normals", "{plate}", "--targets", "{zero8}", "--out", "{tmp}/rn",
             "--iterations", "1"],
            status=2, text="--targets: target 0 is zero everywhere",
            absent="{tmp}/rn/recovery.json"),
    Hostile("recover-normals: a target with S0 < 0 everywhere",
            ["recover-normals", "{plate}", "--targets", "{negative8}", "--out", "{tmp}/rn",
             "--iterations", "1"],
            status=2, text="--targets: target 0: no usable pixel", absent="{tmp}/rn/recovery.json"),
    Hostile("recover-normals: an all-zero polcam frame",
            ["recover-normals", "{plate}", "--targets", "{zero_frame}", "--out", "{tmp}/rn",
             "--observables", "polcam", "--iterations", "1"],
            status=2, text="--targets: target 0 is zero everywhere",
            absent="{tmp}/rn/recovery.json"),
    Hostile("recover-normals: a NaN truth",
            ["recover-normals", "{plate}", "--targets", "{exr8}", "--out", "{tmp}/rn",
             "--iterations", "1", "--truth", "{nan_truth}"],
            status=2, text="nan_truth.exr: not a normal map (vectors of length nan to nan",
            absent="{tmp}/rn/recovery.json"),
    Hostile("recover-normals: a zero-length truth",
            ["recover-normals", "{plate}", "--targets", "{exr8}", "--out", "{tmp}/rn",
             "--iterations", "1", "--truth", "{zero_truth}"],
            status=2, text="zero_truth.exr: not a normal map (vectors of length 0 to 0",
            absent="{tmp}/rn/recovery.json"),
    # a polarizer image's siblings (issue 35): KeyError 'R', NumPy's broadcast error
    Hostile("view: a polarizer image whose _I45 has other bands",
            ["view", "{polcam_bands}", "--out", "{tmp}/pb.png"],
            status=2, text="bands_I45.exr: channels Y, but bands_I0.exr has B, G, R",
            absent="{tmp}/pb.png"),
    Hostile("view: a polarizer image whose _I45 has another size",
            ["view", "{polcam_size}", "--out", "{tmp}/ps.png"],
            status=2, text="size_I45.exr: 6x4 pixels, but size_I0.exr has 8x8",
            absent="{tmp}/ps.png"),
    # files named in their errors
    Hostile("fit: a binary file",
            ["fit", "{binary}"],
            status=2, text="binary.csv: not a text (UTF-8) CSV file"),
    Hostile("fit: a file with NUL bytes",
            ["fit", "{nul_csv}"],
            status=2, text="nul.csv: not a text CSV file (it holds NUL bytes)"),
    # convert: never over an input, nothing half-done
    Hostile("convert: --out is the scene",
            ["convert", "{metal}", "--out", "{metal}"],
            status=2, text="--out: ", absent="{tmp}/metal_pbrdf.xml"),
    Hostile("convert: --out is an included file",
            ["convert", "{metal}", "--out", "{tmp}/part.xml"],
            status=2, text="is an input of the conversion (", absent="{tmp}/metal_pbrdf.xml"),
    Hostile("convert: --out not .xml",
            ["convert", "{metal}", "--out", "{tmp}/new.exr"],
            status=2, text="--out: must name an .xml file", absent="{tmp}/new.exr"),
    Hostile("convert: a scene without metals",
            ["convert", "{scene}", "--out", "{tmp}/none.xml"],
            status=2, text="no conductor or roughconductor in the scene or its includes",
            absent="{tmp}/none.xml"),
    Hostile("convert: alpha beside alpha_u",
            ["convert", "{metal_both}", "--out", "{tmp}/b.xml"],
            status=2, text="roughconductor needs both alpha_u and alpha_v, without alpha",
            absent="{tmp}/b.xml"),
]


def _cube(path, tweak=None):
    from mitsuba_pbrdf.rendering.bands import parse_bands
    from mitsuba_pbrdf.rendering.cube import cube_image
    from mitsuba_pbrdf.stokes.exr import write_stokes_exr

    stokes = np.zeros((12, 16, 4, 4), np.float32)
    stokes[:, :, 0] = 1.0
    stokes[:, :, 1] = 0.2
    if tweak is not None:
        tweak(stokes)
    return str(write_stokes_exr(path, cube_image(stokes, parse_bands("450:530:20"), {})))


def hostile_files(tmp_path, scene, stokes_exr) -> dict:
    """The files of :data:`ROWS` in *tmp_path*; *scene*: the tiny scene,
    *stokes_exr(path, tweak)*: the table's Stokes EXR writer."""
    def sweep(name, body):
        path = tmp_path / f"{name}.toml"
        path.write_text(f'scene = "{scene}"\nout = "out"\n' + body)
        return str(path)

    def set_(index, value):
        def tweak(s):
            s[index] = value
        return tweak

    from mitsuba_pbrdf.stokes.exr import write_exr

    zeros = np.zeros((8, 8), np.float32)

    def polarizer_images(stem, odd_one):
        """pbrdf polcam's four polarizer images of *stem*, _I45 replaced by *odd_one*."""
        for a in (0, 45, 90, 135):
            channels = odd_one if a == 45 else {c: zeros + 1 for c in "RGB"}
            write_exr(tmp_path / f"{stem}_I{a}.exr", channels, {"polcam": f"I{a}"})
        return str(tmp_path / f"{stem}_I0.exr")

    many = "".join(f"p{i} = {list(range(10))}\n" for i in range(7))
    (tmp_path / "binary.csv").write_bytes(bytes(range(256)) * 8)
    (tmp_path / "nul.csv").write_text("theta_i,phi_i\n\0\0\n")
    (tmp_path / "part.xml").write_text('<scene version="3.0.0"><bsdf type="conductor" id="m"/>'
                                       '</scene>')
    (tmp_path / "metal.xml").write_text('<scene version="3.0.0"><include filename="part.xml"/>'
                                        '</scene>')
    (tmp_path / "metal_both.xml").write_text(
        '<scene version="3.0.0"><bsdf type="roughconductor"><float name="alpha" value="0.1"/>'
        '<float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/></bsdf></scene>')
    (tmp_path / "prb.xml").write_text(re.sub(  # the scene's stokes(path) made prb
        r'<integrator type="stokes">.*?</integrator>\s*</integrator>', '<integrator type="prb"/>',
        open(scene).read(), count=1, flags=re.S))
    return dict(
        sweep_huge_spp=sweep("huge_spp", f"spp = {2 ** 63 - 1}\n"),
        sweep_denormal_bands=sweep("denormal", 'bands = "400:500:1e-320"\n'),
        sweep_many_jobs=sweep("many", "[params]\n" + many),
        cube_nan=_cube(tmp_path / "cube_nan.exr", set_((Ellipsis,), np.nan)),
        cube_negative=_cube(tmp_path / "cube_negative.exr", set_((Ellipsis, 0, slice(None)), -1.0)),
        cube_band_nan=_cube(tmp_path / "cube_band_nan.exr", set_((Ellipsis, 2), np.nan)),
        cube_pixel_nan=_cube(tmp_path / "cube_pixel_nan.exr", set_((1, 1), np.nan)),
        negative_exr=stokes_exr(tmp_path / "negative.exr", set_((Ellipsis, 0, slice(None)), -1.0)),
        binary=str(tmp_path / "binary.csv"), nul_csv=str(tmp_path / "nul.csv"),
        metal=str(tmp_path / "metal.xml"), metal_both=str(tmp_path / "metal_both.xml"),
        prb_scene=str(tmp_path / "prb.xml"),
        polcam_bands=polarizer_images("bands", {"Y": zeros + 1}),
        polcam_size=polarizer_images("size", {c: np.ones((4, 6), np.float32) for c in "RGB"}),
        exr8=stokes_exr(tmp_path / "good8.exr", h=8, w=8),
        zero8=stokes_exr(tmp_path / "zero8.exr", set_((Ellipsis,), 0.0), h=8, w=8),
        negative8=stokes_exr(tmp_path / "negative8.exr", set_((Ellipsis, 0, slice(None)), -1.0),
                             h=8, w=8),
        zero_frame=str(write_exr(tmp_path / "zero_mosaic.exr", {"Y": zeros})),
        nan_truth=str(write_exr(tmp_path / "nan_truth.exr",
                                {c: np.full((4, 4), np.nan, np.float32) for c in "XYZ"})),
        zero_truth=str(write_exr(tmp_path / "zero_truth.exr", {c: zeros[:4, :4] for c in "XYZ"})))
