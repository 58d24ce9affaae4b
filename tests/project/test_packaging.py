"""A non-editable install works on its own: the project is built into a wheel,
installed into a fresh virtual environment, and its commands run from a
directory that has no scenes/ folder.

The fresh environment reuses the dependencies already installed (Mitsuba,
Dr.Jit, ...) through a ``.pth`` file naming this interpreter's site-packages
(paths only: the ``.pth`` files in there, such as an editable install's
finder, are not run), so nothing is downloaded: the wheel is built with
``--no-build-isolation --no-index`` by the setuptools of the test extra.
"""

import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
#: What a build needs from the repository, and the folders beside the package that
#: must stay out of the wheel (copied so that the build could pick them up).
SOURCES = ("mitsuba_pbrdf", "scenes", "setup.py", "pyproject.toml", "README.md",
           "proof", "tests")


def run(argv, cwd, timeout=300):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    result = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True,
                            timeout=timeout)
    assert result.returncode == 0, f"{argv}: {result.stdout}\n{result.stderr}"
    return result


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    """The wheel built from a copy of the repository's sources."""
    root = tmp_path_factory.mktemp("packaging")
    source = root / "source"
    source.mkdir()
    for name in SOURCES:
        path = os.path.join(ROOT, name)
        if os.path.isdir(path):
            shutil.copytree(path, source / name,
                            ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy(path, source / name)
    run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index",
         "-q", "-w", str(root / "wheels"), str(source)], cwd=root)
    wheels = list((root / "wheels").glob("mitsuba_pbrdf-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


@pytest.fixture(scope="module")
def installed(wheel):
    """(bin folder of a fresh venv holding the wheel, an empty working folder)."""
    root = wheel.parent.parent

    venv = root / "venv"
    run([sys.executable, "-m", "venv", "--without-pip", str(venv)], cwd=root)
    python = venv / "bin" / "python"
    run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
         "--no-index", "-q", str(wheel)], cwd=root)
    # only now the dependencies: pip, installing, must not see (and offer to replace) the
    # mitsuba_pbrdf this interpreter has
    purelib = run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                  cwd=root).stdout.strip()
    ours = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    with open(os.path.join(purelib, "_dependencies.pth"), "w") as f:
        f.write("\n".join(sorted(ours)) + "\n")
    work = root / "elsewhere"
    work.mkdir()
    return venv / "bin", work


def test_wheel_carries_the_scenes(installed):
    bin_dir, work = installed
    out = run([str(bin_dir / "python"), "-c",
               "import mitsuba_pbrdf, os; from mitsuba_pbrdf.rendering.scene_files import "
               "scenes_dir, packaged_scenes; print(mitsuba_pbrdf.__file__); "
               "print(scenes_dir()); print(' '.join(packaged_scenes())); "
               "print(os.path.isfile(scenes_dir() / 'gallery' / 'studio.exr'))"], cwd=work)
    module, scenes, names, envmap = out.stdout.split("\n")[:4]
    venv = str(bin_dir.parent)
    assert module.startswith(venv), module  # the installed copy, not the repository's
    assert scenes.startswith(venv) and scenes.endswith(os.path.join("mitsuba_pbrdf", "scenes"))
    assert {"default.xml", "analytic_plane.xml", "gallery/sphere.xml",
            "gallery/polarizer.xml"} <= set(names.split())
    assert envmap == "True"


@pytest.mark.slow
def test_installed_commands_run_from_any_directory(installed):
    bin_dir, work = installed
    version = run([str(bin_dir / "pbrdf"), "--version"], cwd=work).stdout
    assert version.startswith("pbrdf 0.1.0") and "Mitsuba 3.9" in version

    run([str(bin_dir / "pbrdf"), "gallery", "--only", "plot", "--out", "g"], cwd=work)
    assert (work / "g" / "pbrdf_plot.png").stat().st_size > 10_000

    # README's main command, from a folder without scenes/: the packaged scene
    result = run([str(bin_dir / "pbrdf"), "render", "scenes/default.xml", "--spp", "2",
                  "-D", "width=32", "-D", "height=24", "--out", "r"], cwd=work)
    assert "packaged scene" in result.stderr
    assert (work / "r.exr").is_file() and (work / "r.png").is_file()
    # a gallery scene: its environment map (studio.exr) is package data too
    run([str(bin_dir / "pbrdf"), "render", "gallery/sphere", "--spp", "1", "-D", "width=24",
         "-D", "height=18", "--out", "s"], cwd=work)
    assert (work / "s.exr").is_file()
    assert not (work / "scenes").exists()


def scaffolding_names():
    """The file names of the test and study scaffolding (proof/)."""
    return {p.name for p in (Path(ROOT) / "proof").glob("*.py") if p.name != "__init__.py"}


def test_wheel_holds_no_test_scaffolding(wheel):
    """The wheel is the package alone: no proof/, tests/ or validation/, and no
    file named like a proof/ module anywhere in it (a scaffolding module moved
    back into the package would be one)."""
    names = zipfile.ZipFile(wheel).namelist()
    top = {n.split("/")[0] for n in names}
    assert top == {"mitsuba_pbrdf", wheel.name.split("-")[0] + "-" + wheel.name.split("-")[1]
                   + ".dist-info"}, top
    scaffolding = scaffolding_names()
    assert len(scaffolding) >= 8, scaffolding  # the scan below looks at real names
    found = [n for n in names if n.rsplit("/", 1)[-1] in scaffolding]
    assert not found, found
