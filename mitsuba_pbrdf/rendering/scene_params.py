"""Checking the values given to a scene's ``$key`` parameters (``-D key=value``,
``render_scene(params=...)``) by what the scene does with them, and listing
those parameters (``pbrdf params SCENE``: :func:`scene_parameters`).

Mitsuba's parser checks a value's syntax and range where the plugin declares
one, but lets through values that fail later, during rendering, with an
unrelated error: a film 0 pixels wide, a sampler with 0 samples, a NaN
light. This module reads the scene file to find what each ``$key`` feeds (the
property's type and name and the plugin it belongs to) and checks the value
for that use, before anything renders:

* ``<integer>``: an integer; in a film or a sampler (sizes and sample counts)
  at least 1, except offsets (``crop_offset_x``...), at least 0;
* ``<float>``, ``<rgb>``, ``<point>``, ``<vector>`` and numeric ``<spectrum>``
  values: finite numbers;
* ``<boolean>``: true or false.

:func:`check_loaded_scene` then checks the loaded scene itself (the film's
size, the sampler's sample count), whatever set them. Errors are
:class:`SceneParameterError` (a ``ValueError``) on one line, naming ``-D key``
and what it sets. A key the scene does not take is refused before Mitsuba
sees it, with the closest name and the scene's list
(:func:`unknown_parameter_message`).
"""

from __future__ import annotations

import difflib
import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Dict, List, Mapping, Optional

__all__ = ["SceneParameterError", "ParameterUse", "SceneParameter", "parameter_uses",
           "declared_parameters", "scene_parameters", "did_you_mean", "unknown_parameter_message",
           "check_parameter_values", "check_loaded_scene"]

_REFERENCE = re.compile(r"\$(\w+)")
_NUMBER_LISTS = ("rgb", "point", "vector", "spectrum")
#: Keys users give for the image size; a scene without them takes ``size`` instead.
_SIZE_KEYS = ("width", "height", "resx", "resy")
#: Plugin kinds whose integer properties are sizes or counts.
_COUNTING_PLUGINS = ("film", "sampler")


class SceneParameterError(ValueError):
    """A scene parameter's value cannot work for what the scene uses it for."""


@dataclass(frozen=True)
class ParameterUse:
    """One place a ``$key`` is used: the property's tag (``integer``, ``float``,
    ...) and name, and the plugin it belongs to (``film``, type ``hdrfilm``)."""

    tag: str
    name: str
    plugin: str
    plugin_type: str
    whole: bool  # the value is exactly "$key" (not part of a longer text)

    def describe(self, scene_name: str) -> str:
        owner = f"the {self.plugin}" + (f" ({self.plugin_type})" if self.plugin_type else "")
        return f'it sets <{self.tag} name="{self.name}"> of {owner} in {scene_name}'


def parameter_uses(scene_path) -> Dict[str, List[ParameterUse]]:
    """``{key: [ParameterUse, ...]}`` for every ``$key`` in the scene file's
    attribute values, and in the files it ``<include>`` s. An unreadable file
    gives ``{}`` (an unreadable included file is skipped): loading it reports
    the problem."""
    try:
        root = ET.parse(os.fspath(scene_path)).getroot()
    except (ET.ParseError, OSError):
        return {}
    uses: Dict[str, List[ParameterUse]] = {}
    seen = {os.path.abspath(os.fspath(scene_path))}

    def walk(element, plugin, plugin_type, folder):
        if element.tag == "include" and "$" not in element.get("filename", "$"):
            included = os.path.abspath(os.path.join(folder, element.get("filename")))
            if included not in seen:
                seen.add(included)
                try:
                    walk(ET.parse(included).getroot(), plugin, plugin_type,
                         os.path.dirname(included))
                except (ET.ParseError, OSError):
                    pass
        if element.get("type") is not None:
            plugin, plugin_type = element.tag, element.get("type")
        for attribute, value in element.attrib.items():
            if attribute == "name" and element.tag == "default":
                continue
            for key in _REFERENCE.findall(value):
                uses.setdefault(key, []).append(ParameterUse(
                    tag=element.tag, name=element.get("name", attribute), plugin=plugin,
                    plugin_type=plugin_type, whole=value.strip() == f"${key}"))
        for child in element:
            walk(child, plugin, plugin_type, folder)

    walk(root, root.tag, "", os.path.dirname(os.path.abspath(os.fspath(scene_path))))
    return uses


def declared_parameters(scene_path) -> Optional[set]:
    """The names a scene takes as ``-D key=value``: its ``<default name=...>``
    declarations and ``$key`` references, in the file and the files it
    ``<include>`` s (Mitsuba rejects any other key). None when a file cannot
    be read (loading it reports the problem)."""
    names: set = set()
    seen: set = set()

    def visit(path) -> bool:
        path = os.path.abspath(os.fspath(path))
        if path in seen:
            return True
        seen.add(path)
        try:
            root = ET.parse(path).getroot()
        except (ET.ParseError, OSError):
            return False
        for element in root.iter():
            if element.tag == "default" and element.get("name"):
                names.add(element.get("name"))
            for attribute, value in element.attrib.items():
                if not (attribute == "name" and element.tag == "default"):
                    names.update(_REFERENCE.findall(value))
            if element.tag == "include" and element.get("filename"):
                included = os.path.join(os.path.dirname(path), element.get("filename"))
                if "$" in included or not visit(included):
                    return False
        return True

    return names if visit(scene_path) else None


@dataclass(frozen=True)
class SceneParameter:
    """One ``-D key=value`` parameter of a scene: its ``<default>`` value
    (None where the scene has none, so ``-D`` must give it) and its uses."""

    name: str
    default: Optional[str]
    uses: tuple

    def doc(self) -> str:
        """What it sets: for a property of a ``pbrdf`` BSDF, the model
        parameter's doc line (:mod:`mitsuba_pbrdf.schema`), else the property
        and its plugin; ``"unused"`` for a ``<default>`` nothing refers to."""
        from .. import schema

        lines = []
        for use in self.uses:
            if use.plugin_type == "pbrdf" and use.name in schema.names():
                line = f"pbrdf {use.name}: {schema.parameter(use.name).doc}"
            elif use.plugin_type == f"${self.name}":
                line = f"the plugin type of a <{use.tag}>"
            else:
                owner = use.plugin + (f" ({use.plugin_type})" if use.plugin_type else "")
                line = f'<{use.tag} name="{use.name}"> of the {owner}'
            if line not in lines:
                lines.append(line)
        return "; ".join(lines) or "unused"


def _scene_defaults(scene_path) -> Dict[str, str]:
    """``{name: value}`` of the ``<default>`` s of the scene file and the files
    it ``<include>`` s, in the order they come (the scene's own first: they
    are what an included file sees)."""
    found: Dict[str, str] = {}
    seen: set = set()

    def visit(path):
        path = os.path.abspath(os.fspath(path))
        if path in seen:
            return
        seen.add(path)
        try:
            root = ET.parse(path).getroot()
        except (ET.ParseError, OSError):
            return
        for element in root.iter("default"):
            if element.get("name"):
                found.setdefault(element.get("name"), element.get("value", ""))
        for element in root.iter("include"):
            name = element.get("filename", "$")
            if "$" not in name:
                visit(os.path.join(os.path.dirname(path), name))

    visit(scene_path)
    return found


def scene_parameters(scene_path) -> List[SceneParameter]:
    """The scene's ``-D`` parameters: each ``<default>`` in file order, then
    the ``$key`` s that have none (:class:`SceneParameter`). Raises
    ``FileNotFoundError`` or :class:`SceneParameterError` for a file that
    cannot be read as XML."""
    path = os.fspath(scene_path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"scene file not found: {path}")
    try:
        ET.parse(path)
    except ET.ParseError as e:
        raise SceneParameterError(f"{path} is not a valid XML scene: {e}") from None
    defaults = _scene_defaults(path)
    uses = parameter_uses(path)
    names = list(defaults) + sorted(k for k in uses if k not in defaults)
    return [SceneParameter(n, defaults.get(n), tuple(uses.get(n, ()))) for n in names]


def did_you_mean(key: str, declared) -> str:
    """`` (did you mean 'material'?)`` for the declared name closest to *key*, or ``""``."""
    close = difflib.get_close_matches(key, sorted(declared), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def unknown_parameter_message(key: str, declared, scene_name: str) -> str:
    """``unknown scene parameter 'materal' (did you mean 'material'?); this
    scene's parameters: ...``; for ``spp`` (``width`` ...) in a scene without
    one, where the samples per pixel (the image size) are set instead."""
    message = f"unknown scene parameter {key!r}" + did_you_mean(key, declared)
    message += (f"; this scene's parameters: {', '.join(sorted(declared))}" if declared
                else f"; {scene_name} takes no parameters")
    if key == "spp":
        message += "; the samples per pixel are set with --spp N (spp= in Python)"
    if key in _SIZE_KEYS:
        message += "; the image size of any scene is set with --size WIDTHxHEIGHT (size= in Python)"
    return message


def _numbers(text: str) -> Optional[list]:
    parts = [p for p in re.split(r"[,\s]+", text.strip()) if p]
    try:
        return [float(p.split(":")[-1]) for p in parts]
    except ValueError:
        return None


def _check(key: str, value: str, use: ParameterUse, scene_name: str):
    where = use.describe(scene_name)
    text = str(value).strip()
    if use.tag == "integer":
        try:
            number = int(text)
        except ValueError:
            raise SceneParameterError(f"-D {key} must be an integer, got {text!r} ({where})") \
                from None
        if use.plugin in _COUNTING_PLUGINS:
            least = 0 if "offset" in use.name else 1
            if number < least:
                what = "a positive integer" if least else "an integer >= 0"
                raise SceneParameterError(f"-D {key} must be {what}, got {number} ({where})")
    elif use.tag == "float" or use.tag in _NUMBER_LISTS:
        numbers = _numbers(text)
        if numbers is None:
            if use.tag == "spectrum":
                return  # a file name or another form Mitsuba's parser judges
            kind = "a number" if use.tag == "float" else "numbers"
            raise SceneParameterError(f"-D {key} must be {kind}, got {text!r} ({where})")
        if not all(math.isfinite(x) for x in numbers):
            kind = "a finite number" if use.tag == "float" else "finite numbers"
            raise SceneParameterError(f"-D {key} must be {kind}, got {text!r} ({where})")
    elif use.tag == "boolean" and text.lower() not in ("true", "false"):
        raise SceneParameterError(f"-D {key} must be true or false, got {text!r} ({where})")


def check_parameter_values(scene_path, params: Optional[Mapping[str, object]]):
    """Check each ``key: value`` of *params* against every use of ``$key`` in the
    scene file (see the module docstring); raises :class:`SceneParameterError`,
    also for a key the scene does not take (:func:`unknown_parameter_message`;
    Mitsuba would refuse it with its parser's bare message)."""
    if not params:
        return
    declared = declared_parameters(scene_path)
    if declared is not None:
        for key in params:
            if str(key) not in declared:
                raise SceneParameterError(unknown_parameter_message(
                    str(key), declared, os.path.basename(os.fspath(scene_path))))
    uses = parameter_uses(scene_path)
    scene_name = os.path.basename(os.fspath(scene_path))
    for key, value in params.items():
        for use in uses.get(str(key), []):
            if use.whole:
                _check(str(key), value, use, scene_name)


def _feeding(uses, plugin: str, names, params) -> str:
    """The ``-D key=value`` that sets one of *names* of *plugin*, if any."""
    for key, value in (params or {}).items():
        for use in uses.get(str(key), []):
            if use.plugin == plugin and use.name in names:
                return f"-D {key}={value}"
    return ""


def check_loaded_scene(scene, scene_path, params: Optional[Mapping[str, object]] = None,
                       spp: Optional[int] = None):
    """Check the loaded scene's first sensor: a film of at least 1 x 1 pixels
    and, unless *spp* overrides it, a sampler with at least 1 sample per pixel.
    Raises :class:`SceneParameterError` naming the ``-D`` value responsible,
    if one is."""
    scene_name = os.path.basename(os.fspath(scene_path))
    if not scene.sensors():
        raise SceneParameterError(f"{scene_name} has no sensor (camera) to render from")
    sensor = scene.sensors()[0]
    size = [int(v) for v in sensor.film().crop_size()]
    uses = parameter_uses(scene_path) if params else {}
    if min(size) < 1:
        source = _feeding(uses, "film", ("width", "height", "crop_width", "crop_height"), params)
        raise SceneParameterError(
            f"{source + ': ' if source else ''}the film of {scene_name} is "
            f"{size[0]} x {size[1]} pixels; it needs at least 1 x 1")
    if spp is None and int(sensor.sampler().sample_count()) < 1:
        source = _feeding(uses, "sampler", ("sample_count",), params)
        raise SceneParameterError(
            f"{source + ': ' if source else ''}the sampler of {scene_name} takes 0 samples per "
            "pixel; give a positive count (or --spp N)")
