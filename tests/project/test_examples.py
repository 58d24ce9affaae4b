"""The scripts in examples/ run as users run them (``python examples/<name>.py``
from the repository root, here with ``--quick``) and produce what they say:
valid EXR and PNG files, and printed numbers that are physically right.

Each runs in its own process (about 5-15 s each on 2 cores) with the
repository root as the working directory and its outputs sent to tmp_path.
"""

import os
import re
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
EXAMPLES = os.path.join(ROOT, "examples")
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def run_example(name, *args):
    """Run examples/<name> from the repository root; returns its stdout."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT] + [p for p in [env.get("PYTHONPATH")] if p])
    result = subprocess.run([sys.executable, os.path.join("examples", name), *args],
                            cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    return result.stdout


def number(pattern, text):
    m = re.search(pattern, text)
    assert m, f"{pattern!r} not in output:\n{text}"
    return float(m.group(1))


def assert_png(path, min_size=(100, 50)):
    from PIL import Image

    with open(path, "rb") as f:
        assert f.read(8) == PNG_SIGNATURE, path
    with Image.open(path) as image:
        image.verify()
    with Image.open(path) as image:
        assert image.size[0] >= min_size[0] and image.size[1] >= min_size[1], image.size


def test_every_example_has_a_docstring_a_quick_flag_and_a_test():
    names = sorted(n for n in os.listdir(EXAMPLES) if n.endswith(".py"))
    assert names == ["fit_measurements.py", "inverse_rendering.py", "render_stokes_image.py",
                     "svbrdf_recovery.py"]
    for name in names:
        text = open(os.path.join(EXAMPLES, name), encoding="utf-8").read()
        assert text.startswith('"""'), name
        assert "--quick" in text and "python examples/" + name in text, name
        assert f"def test_{name[:-3]}" in open(__file__, encoding="utf-8").read(), name


def test_render_stokes_image(tmp_path):
    """The region is the chromium sphere's reflection of the back light at
    55-60 degrees of incidence: Fresnel DoLP of chromium there is 0.25-0.45
    (scenes/default.xml), diluted by the depolarized lobes and by the soft
    box's spread of angles: one 320x240 run gave 0.246, the quick one 0.233.
    The bounds (0.1, 0.6) leave room for the
    Monte Carlo noise of 49 pixels at 8 spp and fail for an unpolarized or a
    wrongly normalized image. The diffuse floor depolarizes: its DoLP is the
    noise of light reflected once off the spheres (< 0.05)."""
    from mitsuba_pbrdf.stokes.exr import read_stokes_exr
    from mitsuba_pbrdf.stokes.image import aolp, dolp, luminance_stokes

    stem = str(tmp_path / "render")
    out = run_example("render_stokes_image.py", "--quick", "--out", stem)
    region_dolp = number(r"DoLP of the region's light: ([-\d.]+)", out)
    region_aolp = number(r"AoLP of the region's light: ([-\d.]+) deg", out)
    mean_dolp = number(r"mean per-pixel DoLP: ([-\d.]+)", out)
    assert 0.1 < region_dolp < 0.6 and 0.05 < mean_dolp < 0.6
    assert -90 < region_aolp <= 90

    image = read_stokes_exr(stem + ".exr")
    assert (image.height, image.width) == (60, 80) and image.bands == ["R", "G", "B"]
    assert np.all(np.isfinite(image.stokes)) and image.s0.min() >= 0 and image.s0.max() > 0
    assert_png(stem + ".png")

    # the printed numbers are those of the file's region (0.74..0.82 x 0.16..0.26)
    stokes = luminance_stokes(image)
    total = stokes[9:16, 59:66].reshape(-1, 4).sum(axis=0)
    assert abs(float(dolp(total, axis=-1)) - region_dolp) < 1e-3
    assert abs(np.degrees(float(aolp(total, axis=-1))) - region_aolp) < 0.02
    floor = stokes[-10:].reshape(-1, 4).sum(axis=0)
    assert float(dolp(floor, axis=-1)) < 0.05


def test_fit_measurements(tmp_path):
    """tests/data/fit_example.csv holds the three-component model with
    sigma = 0.12 plus 2 % noise. The three-component fit finds sigma within 5
    of its standard uncertainties (one run: 1.4) and a reduced chi-square
    near 1 (0.74: the file's uncertainties are slightly generous; < 1.5 with
    533 degrees of freedom); the two-component model cannot follow the
    directional diffuse lobe (reduced chi-square 23, far above 5)."""
    plot = tmp_path / "fit.png"
    out = run_example("fit_measurements.py", "--quick", "--plot", str(plot))
    assert "## three-component" in out and "## two-component" in out
    assert "## Model comparison" in out
    sigma = number(r"three-component: sigma = ([\d.]+)", out)
    sigma_err = number(r"three-component: sigma = [\d.]+ \+/- ([\d.e-]+)", out)
    chi2_three = number(r"three-component: sigma = .*reduced chi2 = ([\d.]+)", out)
    chi2_two = number(r"two-component: sigma = .*reduced chi2 = ([\d.]+)", out)
    assert 0 < sigma_err < 0.01
    assert abs(sigma - 0.12) < 5 * sigma_err
    assert chi2_three < 1.5 and chi2_two > 5
    assert "'type': 'pbrdf'" in out
    assert_png(plot)


@pytest.mark.slow
def test_inverse_rendering(tmp_path):
    """The quick Adam fit (32x32, 40 iterations at 32 spp) starts 25 % (n, k,
    ks) and 50 % (sigma) off the truth. Five runs with other seeds recovered
    n, k within 4 %, ks within 5 % and sigma within 8.2 % (always below: the
    highlights of 32x32 pixels barely resolve the lobe). The bounds (10 %;
    15 % for sigma) fail if the fit does not move towards the truth."""
    from mitsuba_pbrdf.stokes.exr import read_stokes_exr

    prefix = str(tmp_path / "inverse")
    out = run_example("inverse_rendering.py", "--quick", "--out", prefix)
    first = number(r"loss: first ([\d.e+-]+)", out)
    last = number(r"mean of the last quarter ([\d.e+-]+)", out)
    assert last < 0.6 * first
    truth = {"eta": 2.0, "k": 4.0, "sigma": 0.12, "ks": 1.0}
    tolerance = {"eta": 0.10, "k": 0.10, "sigma": 0.15, "ks": 0.10}
    for name, true in truth.items():
        m = re.search(rf"^{name}\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)$", out, flags=re.M)
        assert m, out
        start, recovered, _, printed_truth = (float(g) for g in m.groups())
        assert printed_truth == pytest.approx(true)
        assert abs(recovered - true) < tolerance[name] * true, (name, recovered)
        assert abs(recovered - true) < abs(start - true), (name, start, recovered)
    for label in ("target", "fitted"):
        image = read_stokes_exr(f"{prefix}_{label}.exr")
        assert (image.height, image.width) == (32, 32)
        assert np.all(np.isfinite(image.stokes)) and image.s0.max() > 0
        assert_png(f"{prefix}_{label}.png")


@pytest.mark.slow
def test_svbrdf_recovery():
    """The quick run (16x16, 3 Adam steps on the sigma and kdd texels) prints
    the RMS error of each map before and after: finite, and the maps start
    off the truth (validation/svbrdf_recovery.md has the full study)."""
    out = run_example("svbrdf_recovery.py", "--quick")
    for name in ("sigma", "kdd"):
        m = re.search(rf"^{name}: RMS error ([\d.]+) \(start\) -> ([\d.]+)$", out, flags=re.M)
        assert m, out
        start, recovered = float(m.group(1)), float(m.group(2))
        assert start > 0.05 and np.isfinite(recovered) and recovered < 0.5
