"""What pyproject.toml cannot say: the top-level scenes/ folder also ships inside
the package, as mitsuba_pbrdf/scenes (package data), so that installed commands
find the example scenes and the gallery's environment map from any directory,
with one copy of the files in the repository (mitsuba_pbrdf.rendering.scene_files
looks in both places). Everything else is in pyproject.toml."""

from setuptools import find_packages, setup

setup(
    packages=find_packages(include=["mitsuba_pbrdf", "mitsuba_pbrdf.*"])
    + ["mitsuba_pbrdf.scenes", "mitsuba_pbrdf.scenes.gallery"],
    package_dir={"mitsuba_pbrdf.scenes": "scenes"},
    package_data={"mitsuba_pbrdf.scenes": ["*.xml"],
                  "mitsuba_pbrdf.scenes.gallery": ["*.xml", "*.exr"]},
)
