"""The command line under hostile input: every case of the table below ends
with the expected exit status and a one-line message on stderr (no Python
traceback, no library noise: stderr is captured at the file-descriptor level),
and leaves no partial output file. Ctrl-C is tested for real, on a rendering
subprocess.

Each row is a ``Hostile`` (tests/cli_hostile_rows.py): the case, argv, the
exit status, text the one line must contain, and an output that must not
exist afterwards. ``{tmp}`` is the test's folder, ``{scene}``
the tiny scene, ``{exr}`` a good Stokes EXR, ``{csv}`` the example
measurements; ``/sys`` and ``/proc`` cannot take new files even for root.
"""

import os
import re
import select
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from cli_hostile_rows import ROWS, Hostile, hostile_files
from mitsuba_pbrdf import cli
from mitsuba_pbrdf import variant as variant_module
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.stokes.exr import read_stokes_exr, write_stokes_exr
from mitsuba_pbrdf.stokes.image import StokesImage

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
DEFAULT = os.path.join(ROOT, "scenes", "default.xml")
CSV = os.path.join(ROOT, "tests", "data", "fit_example.csv")
PTFE = os.path.join(ROOT, "tests", "data", "nist_ptfe_subset.csv")
README = os.path.join(ROOT, "README.md")
SMALL = ["-D", "width=32", "-D", "height=24", "--spp", "2"]

pytestmark = pytest.mark.usefixtures("restore_variant")


@pytest.fixture(autouse=True)
def cpu_default_variant(monkeypatch):
    monkeypatch.setattr(variant_module, "cuda_available", lambda: False)


def stokes_exr(path, tweak=None, h=12, w=16):
    """A physical Stokes EXR (DoLP 0.3, AoLP 20 degrees), changed by *tweak*."""
    stokes = np.zeros((h, w, 4, 3), np.float32)
    stokes[:, :, 0] = 1.0
    stokes[:, :, 1] = 0.3 * np.cos(np.radians(40))
    stokes[:, :, 2] = 0.3 * np.sin(np.radians(40))
    if tweak is not None:
        tweak(stokes)
    write_stokes_exr(path, StokesImage(stokes, ["R", "G", "B"]))
    return str(path)


def set_nan(s):
    s[...] = np.nan


def some_bad(s):
    s[0, :4] = np.nan           # 4 non-finite pixels
    s[1, :3, 0] = -1.0          # 3 with S0 < 0
    s[2, :2, 1] = 5.0           # 2 with DoP > 1


TABLE = [
    Hostile("render: unwritable output (read-only file system)",
            ["render", "{scene}", "--out", "/sys/x"],
            status=2, text="cannot write /sys/x.exr"),
    Hostile("render: output folder is a file",
            ["render", "{scene}", "--out", README + "/x"],
            status=2, text="README.md is not a folder"),
    Hostile("render: output folder cannot exist",
            ["render", "{scene}", "--out", "/proc/x"],
            status=2, text="cannot write /proc/x.exr"),
    Hostile("render: -D film width 0",
            ["render", DEFAULT, "-D", "width=0"],
            status=2, text="-D width must be a positive integer, got 0", absent="{tmp}/out"),
    Hostile("render: -D sample count 0",
            ["render", DEFAULT, "-D", "spp=0"],
            status=2, text="-D spp must be a positive integer, got 0"),
    Hostile("render: -D integer that is not one",
            ["render", DEFAULT, "-D", "height=1.5"],
            status=2, text="-D height must be an integer"),
    Hostile("render: -D NaN light",
            ["render", DEFAULT, "-D", "key_light=nan,1,1"],
            status=2, text="-D key_light must be finite numbers"),
    Hostile("render: -D float that is not a number",
            ["render", DEFAULT, "-D", "sigma=abc"],
            status=2, text="-D sigma must be a number"),
    Hostile("render: --spp 0",
            ["render", "{scene}", "--spp", "0"],
            status=2, text="--spp: must be at least 1"),
    Hostile("render: unpolarized variant",
            ["render", "{scene}", "--variant", "llvm_ad_rgb"],
            status=2, text="variant 'llvm_ad_rgb' does not track polarization"),
    Hostile("render: unknown variant",
            ["render", "{scene}", "--variant", "llvm_ad_nonsense"],
            status=2, text="unknown Mitsuba variant 'llvm_ad_nonsense'"),
    Hostile("render: missing scene",
            ["render", "{tmp}/nope.xml"],
            status=2, text="scene file not found"),
    Hostile("render: --dolp-limit nan",
            ["render", "{scene}", "--dolp-limit", "nan"],
            status=2, text="--dolp-limit must be a finite number > 0"),
    Hostile("render: unknown band, before rendering",
            ["render", "{scene}", "--band", "Q", "--out", "{tmp}/b"],
            status=2, text="no band 'Q'", absent="{tmp}/b.exr"),
    Hostile("render: a folder as the scene",
            ["render", "{tmp}"],
            status=2, text="is a folder"),
    Hostile("view: unwritable output",
            ["view", "{exr}", "--out", "/sys/x.png"],
            status=2, text="cannot write /sys/x.png"),
    Hostile("view: output in a missing /proc folder",
            ["view", "{exr}", "--out", "/proc/x.png"],
            status=2, text="cannot write /proc/x.png"),
    Hostile("view: --exposure nan",
            ["view", "{exr}", "--exposure", "nan", "--out", "{tmp}/e.png"],
            status=2, text="--exposure must be a finite number", absent="{tmp}/e.png"),
    Hostile("view: --dolp-limit 0",
            ["view", "{exr}", "--dolp-limit", "0"],
            status=2, text="--dolp-limit must be a finite number > 0"),
    Hostile("view: --dolp-limit word",
            ["view", "{exr}", "--dolp-limit", "big"],
            status=2, text="--dolp-limit must be a number > 0 or 'auto'"),
    Hostile("view: --min-dolp above 1",
            ["view", "{exr}", "--min-dolp", "2"],
            status=2, text="--min-dolp must be a finite number in [0, 1]"),
    Hostile("view: all-NaN Stokes image",
            ["view", "{nan_exr}", "--out", "{tmp}/n.png"],
            status=2, text="no usable pixel", absent="{tmp}/n.png"),
    Hostile("view: truncated EXR",
            ["view", "{truncated}", "--out", "{tmp}/t.png"],
            status=2, text="truncated or corrupt", absent="{tmp}/t.png"),
    Hostile("view: not an EXR",
            ["view", "{text}", "--out", "{tmp}/x.png"],
            status=2, text="not a readable OpenEXR file", absent="{tmp}/x.png"),
    Hostile("view: unknown band",
            ["view", "{exr}", "--band", "Q", "--out", "{tmp}/q.png"],
            status=2, text="no band 'Q'", absent="{tmp}/q.png"),
    Hostile("render: --wavelength not a number",
            ["render", "{scene}", "--wavelength", "red"],
            status=2, text="--wavelength: expects NM or NM:WIDTH", absent="{tmp}/out"),
    Hostile("render: --wavelength outside the colour tables",
            ["render", "{scene}", "--wavelength", "900"],
            status=2, text="must lie within 360-830 nm", absent="{tmp}/out"),
    Hostile("render: --wavelength with a negative width",
            ["render", "{scene}", "--wavelength", "600:-5"],
            status=2, text="width >= 0", absent="{tmp}/out"),
    Hostile("render: --wavelength in an RGB variant",
            ["render", "{scene}", "--wavelength", "600", "--variant", "llvm_ad_mono_polarized"],
            status=2, text="--wavelength: needs a spectral variant, not llvm_ad_mono_polarized",
            absent="{tmp}/out"),
    Hostile("render: --band of another wavelength",
            ["render", "{scene}", "--wavelength", "600", "--band", "R"],
            status=2, text="no band 'R' in a render; bands are 600nm", absent="{tmp}/out"),
    Hostile("render: --bands overlapping",
            ["render", "{scene}", "--bands", "450:500,480:520"],
            status=2, text="--bands: the bands 450-500 and 480-520 nm overlap", absent="{tmp}/out"),
    Hostile("render: --bands reversed band",
            ["render", "{scene}", "--bands", "500:450"],
            status=2, text="--bands: the band '500:450' is reversed or empty", absent="{tmp}/out"),
    Hostile("render: --bands reversed range",
            ["render", "{scene}", "--bands", "650:450:20"],
            status=2, text="--bands: the range '650:450:20' needs START < STOP",
            absent="{tmp}/out"),
    Hostile("render: --bands out of order",
            ["render", "{scene}", "--bands", "600:650,450:500"],
            status=2, text="overlap or are out of order", absent="{tmp}/out"),
    Hostile("render: --bands outside the colour tables",
            ["render", "{scene}", "--bands", "800:860:20"],
            status=2, text="--bands: the band 820-840 nm must lie within 360-830 nm",
            absent="{tmp}/out"),
    Hostile("render: --bands below the colour tables",
            ["render", "{scene}", "--bands", "300:400"],
            status=2, text="must lie within 360-830 nm", absent="{tmp}/out"),
    Hostile("render: --bands more than 64",
            ["render", "{scene}", "--bands", "400:730:5"],
            status=2, text="--bands: '400:730:5' is 66 bands; at most 64", absent="{tmp}/out"),
    Hostile("render: --bands more than 64 in a list",
            ["render", "{scene}", "--bands", "400:560:5,560:720:5,720:730"],
            status=2, text="more than 64 bands", absent="{tmp}/out"),
    Hostile("render: --bands not whole steps",
            ["render", "{scene}", "--bands", "450:650:30"],
            status=2, text="not a whole number of 30 nm steps", absent="{tmp}/out"),
    Hostile("render: --bands not numbers",
            ["render", "{scene}", "--bands", "blue"],
            status=2, text="--bands: each item is START:STOP:STEP or LOW:HIGH", absent="{tmp}/out"),
    Hostile("render: --bands nan",
            ["render", "{scene}", "--bands", "nan:500"],
            status=2, text="--bands: wavelengths must be finite", absent="{tmp}/out"),
    Hostile("render: --bands empty item",
            ["render", "{scene}", "--bands", "450:500,,600:650"],
            status=2, text="--bands: expects a comma-separated list", absent="{tmp}/out"),
    Hostile("render: --bands in a non-spectral variant",
            ["render", "{scene}", "--bands", "450:650:20", "--variant", "llvm_ad_mono_polarized"],
            status=2, text="--bands: needs a spectral variant, not llvm_ad_mono_polarized",
            absent="{tmp}/out"),
    Hostile("render: --bands with --wavelength",
            ["render", "{scene}", "--bands", "450:650:20", "--wavelength", "600"],
            status=2, text="--bands: renders a Stokes cube; give wavelength (one band) or bands, not both",
            absent="{tmp}/out"),
    Hostile("render: --bands with too few samples",
            ["render", "{scene}", "--bands", "450:650:5", "--spp", "4"],
            status=2, text="--bands: 40 bands need at least 10 samples per pixel",
            absent="{tmp}/out"),
    Hostile("render: --band not in the cube",
            ["render", "{scene}", "--bands", "450:650:20", "--band", "R", "--spp", "4"],
            status=2, text="no band 'R' in a render; bands are 460nm", absent="{tmp}/out"),
    Hostile("polcam: missing EXR",
            ["polcam", "{tmp}/none.exr", "--out", "{tmp}/cam"],
            status=2, text="EXR file not found", absent="{tmp}/cam"),
    Hostile("polcam: not an EXR",
            ["polcam", "{text}", "--out", "{tmp}/cam"],
            status=2, text="not a readable OpenEXR file", absent="{tmp}/cam"),
    Hostile("polcam: truncated EXR",
            ["polcam", "{truncated}", "--out", "{tmp}/cam"],
            status=2, text="truncated or corrupt", absent="{tmp}/cam"),
    Hostile("polcam: EXR without Stokes channels",
            ["polcam", "{plain_exr}", "--out", "{tmp}/cam"],
            status=2, text="no Stokes channels", absent="{tmp}/cam"),
    Hostile("polcam: NaN Stokes values",
            ["polcam", "{nan_exr}", "--out", "{tmp}/cam"],
            status=2, text="non-finite Stokes values", absent="{tmp}/cam"),
    Hostile("polcam: odd image size",
            ["polcam", "{odd_exr}", "--out", "{tmp}/cam"],
            status=2, text="need an even image width and height, got 16x13", absent="{tmp}/cam"),
    Hostile("polcam: unwritable folder",
            ["polcam", "{exr}", "--out", "/sys/cam"],
            status=2, text="cannot write /sys/cam/good_I0.exr"),
    Hostile("polcam: --out is a file",
            ["polcam", "{exr}", "--out", README],
            status=2, text="README.md is not a folder"),
    Hostile("polcam: --bits 17",
            ["polcam", "{exr}", "--out", "{tmp}/cam", "--bits", "17"],
            status=2, text="--bits must be in 1..16, got 17", absent="{tmp}/cam"),
    Hostile("polcam: --full-well negative",
            ["polcam", "{exr}", "--out", "{tmp}/cam", "--full-well", "-5"],
            status=2, text="--full-well must be a finite number > 0", absent="{tmp}/cam"),
    Hostile("polcam: --read-noise nan",
            ["polcam", "{exr}", "--out", "{tmp}/cam", "--full-well", "100", "--read-noise", "nan"],
            status=2, text="--read-noise must be a finite number >= 0", absent="{tmp}/cam"),
    Hostile("polcam: --read-noise without --full-well",
            ["polcam", "{exr}", "--out", "{tmp}/cam", "--read-noise", "2"],
            status=2, text="--read-noise (electrons) needs --full-well", absent="{tmp}/cam"),
    Hostile("polcam: --exposure 0",
            ["polcam", "{exr}", "--out", "{tmp}/cam", "--exposure", "0"],
            status=2, text="--exposure must be a finite number > 0", absent="{tmp}/cam"),
    Hostile("polcam: --exposure alone would be ignored",
            ["polcam", "{exr}", "--out", "{tmp}/cam", "--exposure", "2"],
            status=2, text="--exposure (the radiance at full well) needs --full-well or --bits",
            absent="{tmp}/cam"),
    Hostile("polcam: --seed without noise would be ignored",
            ["polcam", "{exr}", "--out", "{tmp}/cam", "--bits", "8", "--seed", "3"],
            status=2, text="--seed (of the shot and read noise) needs --full-well",
            absent="{tmp}/cam"),
    Hostile("polcam: unknown band",
            ["polcam", "{exr}", "--out", "{tmp}/cam", "--band", "Q"],
            status=2, text="no band 'Q'; bands are R, G, B", absent="{tmp}/cam"),
    Hostile("polcam: --band with the colour sensor",
            ["polcam", "{exr}", "--out", "{tmp}/cam", "--sensor", "colour", "--band", "R"],
            status=2, text="--band is for the mono sensor", absent="{tmp}/cam"),
    Hostile("polcam: colour sensor on a one-band image",
            ["polcam", "{y_exr}", "--out", "{tmp}/cam", "--sensor", "colour"],
            status=2, text="the colour sensor needs Stokes bands R, G, B", absent="{tmp}/cam"),
    Hostile("plot: unwritable output",
            ["plot", "--out", "/sys/p.png"],
            status=2, text="cannot write /sys/p.png"),
    Hostile("gallery: output folder is a file",
            ["gallery", "--only", "plot", "--out", README + "/g"],
            status=2, text="README.md is not a folder"),
    Hostile("fit: unwritable --plot, before fitting",
            ["fit", CSV, "--plot", "/proc/x.png"],
            status=2, text="cannot write /proc/x.png"),
    Hostile("fit: unwritable --json, before fitting",
            ["fit", CSV, "--json", "/sys/x.json"],
            status=2, text="cannot write /sys/x.json"),
    Hostile("plot: negative --sigma-u",
            ["plot", "--sigma-u", "-1", "--out", "{tmp}/p.png"],
            status=2, text="sigma_u must be > 0", absent="{tmp}/p.png"),
    Hostile("plot: NaN --sigma-v",
            ["plot", "--sigma-v", "nan", "--out", "{tmp}/p.png"],
            status=2, text="sigma_v must be > 0", absent="{tmp}/p.png"),
    Hostile("plot: NaN --phi-i",
            ["plot", "--sigma-u", "0.3", "--phi-i", "nan", "--out", "{tmp}/p.png"],
            status=2, text="--phi-i must be in [-360, 360] degrees", absent="{tmp}/p.png"),
    Hostile("fit: sigma_u in an isotropic fit",
            ["fit", CSV, "--init", "sigma_u=0.2"],
            status=2, text="sigma_u is fitted only in an anisotropic fit"),
    Hostile("fit: negative sigma_v",
            ["fit", CSV, "--anisotropic", "--fix", "sigma_v=-0.1"],
            status=2, text="--fix: sigma_v=-0.1 is outside the allowed range"),
    Hostile("fit: NIST layout without f_r11",
            ["fit", "{nist_no_f11}"],
            status=2, text="missing column f_r11"),
    Hostile("fit: NIST layout, a normalized element above 1",
            ["fit", "{nist_over_one}"],
            status=2, text="line 3: f_r23/f_r11 = -1.5 is above 1 in magnitude"),
    Hostile("fit: NIST layout, mixed units (a wavelength in nm among um)",
            ["fit", "{nist_nm}"],
            status=2, text="line 4: lambda = 532 is not a wavelength in µm"),
    Hostile("fit: NIST layout, mixed units (normalized and 1/sr elements)",
            ["fit", "{nist_mixed}"],
            status=2, text="mixed units: 'f_r12/f_r11' is normalized by f_r11 but 'f_r13' is in 1/sr"),
    Hostile("fit: --layout nist on a goniometer file",
            ["fit", CSV, "--layout", "nist"],
            status=2, text="missing column(s) lambda, thetai, phi, thetar, phir"),
    Hostile("fit: --wavelength not in the file",
            ["fit", PTFE, "--wavelength", "500"],
            status=2, text="no measurement at 500 nm (wavelengths in the file: 532, 633 nm)"),
    Hostile("fit: --wavelength not a number",
            ["fit", PTFE, "--wavelength", "green"],
            status=2, text="--wavelength expects comma-separated numbers"),
    Hostile("export: --bands range without a step",
            ["export", "--bands", "400:700", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--bands: '400:700' must be a whole number of nm or START:STOP:STEP",
            absent="{tmp}/h.pbsdf"),
    Hostile("export: --bands empty item",
            ["export", "--bands", "450,,500", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--bands: expected comma-separated wavelengths", absent="{tmp}/h.pbsdf"),
    Hostile("export: --bands decreasing",
            ["export", "--bands", "500,450", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--bands: wavelengths must be strictly increasing",
            absent="{tmp}/h.pbsdf"),
    Hostile("export: --bands word",
            ["export", "--bands", "visible", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--bands: 'visible' is not a wavelength (nm) or START:STOP:STEP",
            absent="{tmp}/h.pbsdf"),
    Hostile("export: --bands zero step",
            ["export", "--bands", "400:700:0", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--bands: '400:700:0' needs STEP > 0", absent="{tmp}/h.pbsdf"),
    Hostile("export: --bands fractional nm",
            ["export", "--bands", "450.5,500", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--bands: '450.5' must be a whole number of nm", absent="{tmp}/h.pbsdf"),
    Hostile("export: --bands beyond uint16",
            ["export", "--bands", "60000:70000:5000", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--bands: wavelengths must lie in 1..65535 nm", absent="{tmp}/h.pbsdf"),
    # the library's ParameterError("grid") becomes the option's name on the command line
    Hostile("export: --grid malformed",
            ["export", "--grid", "49x80", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--grid: must be default, kaist or PxDxH (e.g. 49x80x80), got '49x80'",
            absent="{tmp}/h.pbsdf"),
    Hostile("export: --grid too few points",
            ["export", "--grid", "1x9x9", "--out", "{tmp}/h.pbsdf"],
            status=2, text="--grid: phi_d needs 2 to 4096 points, got 1", absent="{tmp}/h.pbsdf"),
    Hostile("export: --bands with --wavelengths",
            ["export", "--bands", "400:700:10", "--wavelengths", "450,500,550,600,650", "--out",
             "{tmp}/h.pbsdf"],
            status=2, text="give --wavelengths (the 5 bands measured_polarized renders) or --bands",
            absent="{tmp}/h.pbsdf"),
    # pbrdf batch --slurm: checked before Slurm is asked (the rows that need a running
    # Slurm, Ctrl-C among them, are in tests/batch/test_slurm.py)
    Hostile("batch: --slurm, malformed walltime",
            ["batch", "{sweep}", "--slurm", "--walltime", "2h"],
            status=2, text="--walltime '2h' is not a Slurm time", absent="{tmp}/out/manifest.csv"),
    Hostile("batch: --slurm, walltime under a minute",
            ["batch", "{sweep}", "--slurm", "--walltime", "0:30"],
            status=2, text="--walltime: '0:30' is too short", absent="{tmp}/out/manifest.csv"),
    Hostile("batch: --slurm, no cores",
            ["batch", "{sweep}", "--slurm", "--cores", "0"],
            status=2, text="--cores: must be a positive integer, got 0",
            absent="{tmp}/out/manifest.csv"),
    Hostile("batch: a Slurm option without --slurm",
            ["batch", "{sweep}", "--partition", "debug"],
            status=2, text="--partition is a Slurm option: add --slurm",
            absent="{tmp}/out/manifest.csv"),
    Hostile("recover-normals: missing scene",
            ["recover-normals", "{tmp}/none.xml", "--targets", "{exr}", "--out", "{tmp}/rn"],
            status=2, text="none.xml", absent="{tmp}/rn/normals.exr"),
    Hostile("recover-normals: not a scene",
            ["recover-normals", "{text}", "--targets", "{exr}", "--out", "{tmp}/rn"],
            status=2, text="text.exr", absent="{tmp}/rn/normals.exr"),
    Hostile("recover-normals: no polarized_normalmap in the scene",
            ["recover-normals", "{scene}", "--targets", "{exr}", "--out", "{tmp}/rn"],
            status=2, text="polarized_normalmap", absent="{tmp}/rn/normals.exr"),
    Hostile("recover-normals: unwritable --out",
            ["recover-normals", "{plate}", "--targets", "{exr}", "--out", "/sys/rn"],
            status=2, text="cannot write /sys/rn"),
    Hostile("recover-normals: bad --observables",
            ["recover-normals", "{plate}", "--targets", "{exr}", "--out", "{tmp}/rn",
             "--observables", "colour"],
            status=2, text="--observables: must be one of intensity, stokes, polcam",
            absent="{tmp}/rn/normals.exr"),
    Hostile("recover-normals: --iterations 0",
            ["recover-normals", "{plate}", "--targets", "{exr}", "--out", "{tmp}/rn",
             "--iterations", "0"],
            status=2, text="--iterations: must be an integer >= 1", absent="{tmp}/rn/normals.exr"),
    Hostile("recover-normals: --lr-end above 1",
            ["recover-normals", "{plate}", "--targets", "{exr}", "--out", "{tmp}/rn", "--lr-end",
             "2"],
            status=2, text="--lr-end: must be a number in (0, 1]", absent="{tmp}/rn/normals.exr"),
    Hostile("recover-normals: target of another size",
            ["recover-normals", "{plate}", "--targets", "{exr}", "--out", "{tmp}/rn",
             "--iterations", "1"],
            status=2, text="--targets: target 0 must be", absent="{tmp}/rn/normals.exr"),
    Hostile("recover-normals: two targets, one sensor",
            ["recover-normals", "{plate}", "--targets", "{exr}", "{exr}", "--out", "{tmp}/rn"],
            status=2, text="--targets: 2 given, the scene has 1 sensors",
            absent="{tmp}/rn/normals.exr"),
]


# the rows of the surfaces added since (issue 28), kept in their own module
TABLE += ROWS


def nist_files(tmp_path):
    """Files in NIST's layout, each with one fault, from the PTFE subset's
    header and first rows."""
    with open(PTFE) as f:
        header, *rows = f.read().splitlines()[:4]
    def write(name, head, body):
        path = tmp_path / f"{name}.csv"
        path.write_text("\n".join([head] + body) + "\n")
        return str(path)
    over = rows[1].split(",")
    over[header.split(",").index("f_r23/f_r11")] = "-1.5"
    nm = rows[2].split(",")
    nm[0] = "532"
    return dict(nist_no_f11=write("no_f11", header.replace(",f_r11,", ",f_r00,"), rows),
                nist_over_one=write("over", header, [rows[0], ",".join(over), rows[2]]),
                nist_nm=write("nm", header, rows[:2] + [",".join(nm)]),
                nist_mixed=write("mixed", header.replace("f_r13/f_r11", "f_r13"), rows))


@pytest.fixture
def files(tmp_path):
    scene = tmp_path / "tiny.xml"
    from tests.cli.test_cli import TINY_SCENE

    scene.write_text(TINY_SCENE)
    good = stokes_exr(tmp_path / "good.exr")
    with open(good, "rb") as f:
        data = f.read()
    (tmp_path / "truncated.exr").write_bytes(data[: len(data) // 2])
    (tmp_path / "text.exr").write_text("not an image\n")
    from mitsuba_pbrdf.stokes.exr import write_exr

    plain = write_exr(tmp_path / "plain.exr", {"Y": np.ones((4, 4), np.float32)})
    y_exr = write_stokes_exr(tmp_path / "y.exr", np.ones((4, 4, 4), np.float32) * [1, 0, 0, 0])
    from mitsuba_pbrdf.inverse.normals.scenes import write_plate_files

    flat = np.zeros((4, 4, 3), np.float32)
    flat[..., 2] = 1.0
    plate = write_plate_files(tmp_path, flat, size=8, spp=1)
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'scene = "{scene}"\nout = "out"\n')
    return dict(tmp=str(tmp_path), scene=str(scene), sweep=str(sweep), exr=good, plate=plate, plain_exr=plain,
                y_exr=y_exr, **hostile_files(tmp_path, scene, stokes_exr),
                **nist_files(tmp_path),
                odd_exr=stokes_exr(tmp_path / "odd.exr", h=13),
                nan_exr=stokes_exr(tmp_path / "nan.exr", set_nan),
                truncated=str(tmp_path / "truncated.exr"), text=str(tmp_path / "text.exr"))


#: The newcomer's options (issue 29): pbrdf params, unknown -D keys, gallery's
#: --update-repo-pictures.
TABLE += [
    Hostile("params: no such scene",
            ["params", "{tmp}/nope.xml"],
            status=2, text="scene file not found"),
    Hostile("params: a folder",
            ["params", "{tmp}"],
            status=2, text="is a folder, not a scene file"),
    Hostile("params: not XML",
            ["params", README],
            status=2, text="README.md is not a valid XML scene"),
    Hostile("render: -D key the scene lacks",
            ["render", DEFAULT, "-D", "materal=Au", "--out", "{tmp}/m"],
            status=2, text="unknown scene parameter 'materal' (did you mean 'material'?)",
            absent="{tmp}/m.exr"),
    Hostile("view: bad --dolp-scale",
            ["view", "{exr}", "--cube", "--dolp-scale", "banded", "--out", "{tmp}/v.png"],
            status=2, text="--dolp-scale must be shared or per-band, got 'banded'",
            absent="{tmp}/v.png"),
    Hostile("recover-normals: --truth not a normal map",
            ["recover-normals", "{plate}", "--targets", "{exr}", "--out", "{tmp}/rn", "--truth",
             "{plain_exr}"],
            status=2, text="a normal map needs channels X, Y, Z", absent="{tmp}/rn/recovery.png"),
    Hostile("gallery: --update-repo-pictures with --out",
            ["gallery", "--only", "plot", "--update-repo-pictures", "--out", "{tmp}/g"],
            status=2, text="--update-repo-pictures writes README's pictures", absent="{tmp}/g"),
]


def one_line_error(capfd, command):
    """stderr (file descriptors, so C libraries' output too) as one line."""
    out, err = capfd.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"pbrdf {command}: error: "), lines[0]
    assert "Traceback" not in err
    return out, lines[0]


@pytest.mark.parametrize("case, argv, status, text, absent", TABLE, ids=[r.case for r in TABLE])
def test_hostile_input(case, argv, status, text, absent, files, capfd, monkeypatch):
    monkeypatch.chdir(files["tmp"])
    argv = [a.format(**files) for a in argv]
    if argv[0] in ("render", "recover-normals") and "-D" not in argv and "--spp" not in argv:
        argv += ["--spp", "1"]
    assert main(argv) == status
    out, line = one_line_error(capfd, argv[0])
    assert text in line
    if argv[0] == "fit":
        assert "chi2" not in out  # refused before the fit ran
    if absent:
        assert not os.path.exists(absent.format(**files))
    leftovers = [n for n in os.listdir(files["tmp"]) if ".tmp" in n]
    assert not leftovers


def test_unpolarized_variant_is_refused_before_loading_the_scene(files, capfd, monkeypatch):
    import mitsuba as mi

    def no_load(*args, **kwargs):
        raise AssertionError("the scene was loaded")

    for loader in ("load_file", "load_string"):
        monkeypatch.setattr(mi, loader, no_load)
    # every render mode builds its scene there (mitsuba_pbrdf.rendering.scene_setup)
    monkeypatch.setattr(mi.parser, "instantiate", no_load)
    assert main(["render", files["scene"], "--variant", "llvm_ad_rgb"]) == 2
    _, line = one_line_error(capfd, "render")
    assert "llvm_ad_spectral_polarized" in line and "llvm_ad_mono_polarized" in line


def test_unusable_pixels_are_counted_and_marked(files, capfd, tmp_path):
    """Some non-finite, negative and over-polarized pixels: exit 0, one warning
    line with the counts, and the picture paints them in each panel's marker."""
    from mitsuba_pbrdf.visualization.colours import MARKERS
    from mitsuba_pbrdf.visualization.panels import overview_figure
    from mitsuba_pbrdf.stokes.quality import assess

    path = stokes_exr(tmp_path / "bad.exr", some_bad)
    assert main(["view", path, "--out", str(tmp_path / "bad.png")]) == 0
    out, err = capfd.readouterr()
    assert err.count("\n") == 1 and "Traceback" not in err and "RuntimeWarning" not in err
    assert ("9 of 192 pixels unusable in the luminance Stokes vector (4 non-finite, "
            "3 with S0 < 0, 2 with degree of polarization > 1)") in err
    assert (tmp_path / "bad.png").is_file()

    image = read_stokes_exr(path)
    quality = assess(image)
    fig = overview_figure(image, "all")
    panels = [ax for ax in fig.axes if ax.get_title()]
    marker_of = {"Intensity": "intensity", "Degree of linear": "dolp", "Angle": "aolp",
                 "Degree of circular": "docp", "AoLP (hue)": "hsv", "S1": "stokes",
                 "S2": "stokes", "S3": "stokes"}
    assert len(panels) == 8
    for ax in panels:
        panel = next(v for k, v in marker_of.items() if ax.get_title().startswith(k))
        drawn = np.asarray(ax.images[0].get_array())[..., :3]
        colour, name = MARKERS[panel]
        np.testing.assert_allclose(drawn[quality.unusable], np.broadcast_to(colour, (9, 3)))
        legend = ax.get_legend()
        assert legend is not None and any(f"{name}: 9 unusable pixels" in t.get_text()
                                          for t in legend.get_texts())


def test_band_tolerance_allows_slightly_unphysical_rgb_bands(tmp_path):
    """One RGB band may be out of range by up to 5 % of the pixel's luminance S0;
    the luminance vector is judged strictly."""
    from mitsuba_pbrdf.stokes.quality import assess

    def blue_over(s):
        s[:, :, 0, 2] = 0.2             # dim blue band
        s[:, :, 1, 2] = 0.21            # its |S1| > S0 by 0.01, 1 % of the luminance
        s[:, :, 2, 2] = 0.0
    image = read_stokes_exr(stokes_exr(tmp_path / "b.exr", blue_over))
    assert assess(image, "B").count == 0
    assert assess(image).count == 0     # the luminance vector stays physical

    def blue_far(s):
        s[:, :, 0, 2] = 0.2
        s[:, :, 1, 2] = 0.4             # 0.2 over: 20 % of the luminance
        s[:, :, 2, 2] = 0.0
    assert assess(read_stokes_exr(stokes_exr(tmp_path / "c.exr", blue_far)), "B").count == 192

    def luminance_over(s):
        s[0, 0, 1] = 1.01               # DoP 1.01 in every band
        s[0, 0, 2] = 0.0
    assert assess(read_stokes_exr(stokes_exr(tmp_path / "d.exr", luminance_over))).count == 1


def test_version_and_help_list_every_command(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert re.match(r"pbrdf \d+\.\d+\.\d+ \(Mitsuba 3\.9", capsys.readouterr().out)
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    for command in cli.COMMANDS:
        name = command.__name__.rsplit(".", 1)[-1].replace("_", "-")  # recover_normals: recover-normals
        assert re.search(rf"^\s+{name}\s", out, flags=re.M), name


def test_existing_outputs_are_replaced_and_said_so(files, capfd, tmp_path):
    out = str(tmp_path / "r")
    assert main(["render", files["scene"], "--spp", "1", "--out", out]) == 0
    assert f"wrote {out}.exr" in capfd.readouterr().out
    assert main(["render", files["scene"], "--spp", "1", "--out", out]) == 0
    stdout = capfd.readouterr().out
    assert f"replaced {out}.exr" in stdout and f"replaced {out}.png" in stdout


def test_a_failed_write_leaves_the_previous_file(tmp_path, monkeypatch):
    """The writer fails half way (here: OpenEXR's write raises after writing
    part of the file): the previous EXR is untouched, no temporary file is left,
    and the error names the output."""
    import OpenEXR

    path = stokes_exr(tmp_path / "keep.exr")
    before = open(path, "rb").read()
    real_write = OpenEXR.File.write

    class Broken(OpenEXR.File):
        def write(self, filename):
            real_write(self, filename)
            with open(filename, "r+b") as f:
                f.truncate(100)
            raise RuntimeError("disk full")

    monkeypatch.setattr(OpenEXR, "File", Broken)
    with pytest.raises(OSError) as e:
        stokes_exr(path)
    assert e.value.filename == path and "disk full" in str(e.value)
    assert open(path, "rb").read() == before
    assert os.listdir(tmp_path) == ["keep.exr"]


def test_interrupted_write_removes_the_temporary_file(tmp_path):
    from mitsuba_pbrdf.outputs import atomic_path, write_text

    target = write_text(tmp_path / "a.json", "old\n")
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(target) as tmp:
            with open(tmp, "w") as f:
                f.write("half")
            raise KeyboardInterrupt
    assert open(target).read() == "old\n" and os.listdir(tmp_path) == ["a.json"]
    assert oct(os.stat(target).st_mode & 0o777) == oct(0o666 & ~current_umask())


def current_umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


# ---------------------------------------------------------------- Ctrl-C, for real


def test_ctrl_c_stops_a_render_between_passes(tmp_path):
    """SIGINT while rendering (1024 spp at 160 x 120 in 16 passes): the
    command stops at the end of the pass under way, prints `interrupted`, exits
    with 130, and leaves the previous outputs as they were, with no temporary
    file. Without the passes it would stop only when the whole render ends."""
    out = tmp_path / "default"
    for ext in (".exr", ".png"):
        (tmp_path / f"default{ext}").write_bytes(b"previous good file")
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    argv = [sys.executable, "-m", "mitsuba_pbrdf", "render", DEFAULT, "-D", "width=160",
            "-D", "height=120", "--spp", "1024", "--passes", "16",
            "--variant", "llvm_ad_spectral_polarized", "--progress", "--out", str(out)]
    process = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    err = b""
    started = first_pass = None
    deadline = time.monotonic() + 300
    try:
        while time.monotonic() < deadline and first_pass is None:
            ready, _, _ = select.select([process.stderr], [], [], 1.0)
            if ready:
                chunk = os.read(process.stderr.fileno(), 4096)
                if not chunk:
                    break
                err += chunk
            if started is None and b"(16 passes)" in err:
                started = time.monotonic()
            if started is not None and re.search(rb"\b[1-9]\d*/1024\b", err):
                first_pass = time.monotonic()
        assert first_pass is not None, err.decode(errors="replace")
        pass_time = first_pass - started
        process.send_signal(signal.SIGINT)
        sent = time.monotonic()
        stdout, rest = process.communicate(timeout=300)
        stopped = time.monotonic() - sent
    finally:
        if process.poll() is None:
            process.kill()
    err = (err + rest).decode(errors="replace")
    assert process.returncode == 130, err
    last = err.replace("\r", "\n").strip().splitlines()[-1]
    assert last == "pbrdf render: interrupted"
    assert "Traceback" not in err
    # Mitsuba's C++ SIGINT handler logs this warning (to stdout) when the signal
    # lands inside mi.render rather than between passes; nothing else may appear
    # (Mitsuba colours it: ANSI codes, the reset on a line of its own)
    plain = re.sub(r"\x1b\[[0-9;]*m", "", stdout.decode(errors="replace"))
    assert all("Received interrupt signal, winding down" in line
               for line in plain.splitlines() if line.strip()), stdout
    # it stopped within about a pass, far sooner than the 15 passes left would take
    assert stopped < 3 * pass_time + 5.0, (stopped, pass_time)
    assert sorted(os.listdir(tmp_path)) == ["default.exr", "default.png"]
    for ext in (".exr", ".png"):
        assert (tmp_path / f"default{ext}").read_bytes() == b"previous good file"


def test_ctrl_c_inside_the_plugin_is_reported_as_an_interruption(files, capfd, monkeypatch):
    """Ctrl-C that lands in the plugin's Python code while Mitsuba loads the
    scene or Dr.Jit traces a pass comes back wrapped in a RuntimeError; the
    command still says `interrupted` and exits with 130."""
    import mitsuba as mi

    def wrapped(*args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as e:
            raise RuntimeError("drjit.custom(): error while performing a custom "
                               "differentiable operation. (see above)") from e

    # mi.parser.instantiate builds the scene's objects (the plugins' constructors)
    for owner, name in ((mi, "render"), (mi.parser, "instantiate")):
        with monkeypatch.context() as m:
            m.setattr(owner, name, wrapped)
            assert main(["render", files["scene"], "--spp", "1",
                         "--out", files["tmp"] + "/w"]) == 130
        out, err = capfd.readouterr()
        assert err.strip() == "pbrdf render: interrupted" and not out
    assert not os.path.exists(files["tmp"] + "/w.exr")


def test_progress_lines_when_stderr_is_not_a_terminal(monkeypatch, capsys):
    """Logs get plain lines (not a bar's carriage returns), at most one per
    interval, and a last line saying how long it took; short work gets none."""
    from mitsuba_pbrdf.rendering import progress

    monkeypatch.setattr(progress.sys.stderr, "isatty", lambda: False, raising=False)
    with progress.progress_reporter(4, "rendering x.xml (4 passes)", "auto", steps=4) as p:
        for _ in range(4):
            p.update(1)
    assert capsys.readouterr().err == ""  # done before the first interval
    monkeypatch.setattr(progress, "LINE_INTERVAL_S", 0.0)
    with progress.progress_reporter(4, "rendering x.xml (4 passes)", "lines", steps=4) as p:
        for _ in range(4):
            p.update(1)
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("rendering x.xml (4 passes): 1/4 spp (25 %)")
    assert len(lines) == 4 and lines[-1].startswith("rendering x.xml (4 passes): done in")
    assert "\r" not in "".join(lines)
    with progress.progress_reporter(4, "one pass", "bar", steps=1) as p:
        p.update(4)
    assert capsys.readouterr().err == ""  # one step: nothing to show


def test_ctrl_c_during_recover_normals_leaves_no_output(files, capfd, monkeypatch, tmp_path):
    """Ctrl-C while recover-normals renders an iteration: `interrupted`, exit
    130, and none of its three outputs (they are written after the fit)."""
    import mitsuba as mi

    from mitsuba_pbrdf.inverse.normals.scenes import write_plate_files
    from mitsuba_pbrdf.stokes.image import from_mitsuba

    folder = tmp_path / "plate"
    folder.mkdir()
    flat = np.zeros((4, 4, 3), np.float32)
    flat[..., 2] = 1.0
    plate = write_plate_files(folder, flat, size=8, spp=1)
    scene = mi.load_file(plate)
    target = write_stokes_exr(folder / "t.exr", from_mitsuba(mi.render(scene, spp=4),
                                                             scene.sensors()[0].film()))
    calls = []
    render = mi.render

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:  # the second iteration
            raise KeyboardInterrupt
        return render(*args, **kwargs)

    monkeypatch.setattr(mi, "render", interrupted)
    out_dir = folder / "out"
    assert main(["recover-normals", plate, "--targets", target, "--out", str(out_dir),
                 "--iterations", "5", "--spp", "1", "--no-progress"]) == 130
    out, err = capfd.readouterr()
    assert err.strip() == "pbrdf recover-normals: interrupted" and not out
    assert len(calls) == 2
    assert not out_dir.exists() or not os.listdir(out_dir)
