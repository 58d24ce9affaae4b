"""A scene file made ready for a Stokes render, in one place for every render
mode (:mod:`.modes`) and for the checks before a render
(:func:`~mitsuba_pbrdf.rendering.render.check_render`).

The scene is read by Mitsuba's own parser (``mi.parser``: the ``<include>`` s
merged in, the ``$key`` parameters substituted, the ``<ref>`` s resolved),
which is what ``mi.load_file`` does before it builds the objects; so the
sensor and the integrator are found wherever the file keeps them, and a scene
loads as ``mi.load_file`` would load it. :func:`prepare` then edits the parsed
nodes as :class:`SceneSetup` asks, and :func:`load_prepared` builds the scene:

* the integrator (``integrator``):

  - ``"stokes"``: Stokes output. A ``stokes`` integrator (or ``stokes_prb``)
    is kept; ``path``, ``direct``, ``volpath`` or ``volpathmis`` without one
    (or no integrator at all: Mitsuba's default is ``path``) is wrapped in
    ``stokes``, and ``moment`` around one of them (Mitsuba's published scenes
    use it for a variance estimate) is replaced by ``stokes`` around it; the
    setup's :attr:`Prepared.notice` says so in one line. ``auto_stokes=False``
    refuses instead. Any other integrator is refused (:class:`StokesSceneError`):
    the ``prb*`` integrators ignore Mueller frame rotations (S1..S3 come out
    wrong), ``aov`` and the like write no radiance;
  - ``"nested"``: the integrator ``stokes`` wraps (a Stokes cube runs it
    itself: :mod:`.cube`), found the same way;
  - ``"as_is"``: untouched (an unpolarized render of the scene as published);

* ``size``: every sensor's film set to (width, height) pixels, whatever the
  film's properties are called in the file (``$resx``, a literal ...);
* ``srf``: every sensor given this spectral response (a ``regular`` spectrum:
  ``(wavelength_min, wavelength_max, values)`` in nm; :mod:`.narrowband`).

Errors are one line, before anything is built: :class:`StokesSceneError` for
a scene that cannot give Stokes output,
:class:`~mitsuba_pbrdf.errors.ParameterError` (``size``, or the
``error_parameter`` of the setup: ``wavelength``, ``bands``) for the rest,
:class:`~.scene_loading.SceneLoadError` for what Mitsuba's parser refuses.
Parsing needs ``mitsuba`` imported, not a variant set.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import List, Optional, Tuple

from ..errors import ParameterError
from .scene_loading import require_scene_file, scene_load_errors

__all__ = ["SceneSetup", "Prepared", "StokesSceneError", "WRAPPABLE", "parse_size",
           "parse_scene", "prepare", "load_prepared", "load_scene_setup", "check_scene_setup"]

#: Integrators that ``stokes`` can wrap: they carry Mueller matrices and rotate
#: their Stokes frames along the path.
WRAPPABLE = ("path", "direct", "volpath", "volpathmis")
#: Mitsuba's default when a scene names no integrator.
DEFAULT_INTEGRATOR = "path"
_SIZE = re.compile(r"^\s*(\d+)\s*[xX×]\s*(\d+)\s*$")
#: Largest film side accepted from ``size``: a bound, so that no absurd size (2^63 - 1)
#: reaches Mitsuba; 32768 x 32768 pixels (2^30) stay within 32-bit pixel indices.
MAX_SIDE = 1 << 15


class StokesSceneError(ValueError):
    """The scene cannot give a Stokes image (its integrator cannot be wrapped
    in ``stokes``, or the caller refused the wrapping)."""


@dataclass(frozen=True)
class SceneSetup:
    """How to load a scene file (see the module docstring): ``integrator``
    ``"stokes"``, ``"nested"`` or ``"as_is"``; ``auto_stokes`` (wrap a bare
    integrator in ``stokes``, else refuse); ``size`` (width, height) or None;
    ``srf`` ``(wavelength_min, wavelength_max, values)`` or None (values
    None: the sensors are only checked for a response of their own);
    ``error_parameter``: the parameter the setup's refusals name."""

    integrator: str = "stokes"
    auto_stokes: bool = True
    size: Optional[Tuple[int, int]] = None
    srf: Optional[tuple] = None
    error_parameter: str = "srf"


@dataclass
class Prepared:
    """A parsed scene edited as its :class:`SceneSetup` asks: Mitsuba's parser
    config and state, the scene file, and the one-line ``notice`` of what was
    changed in the integrator (None: nothing)."""

    config: object
    state: object
    scene_path: str
    notice: Optional[str] = None


def parse_size(text) -> Tuple[int, int]:
    """``"320x240"`` (or a (width, height) pair) as ``(320, 240)``;
    :class:`ParameterError` naming ``size`` otherwise."""
    if isinstance(text, (tuple, list)) and len(text) == 2:
        text = f"{text[0]}x{text[1]}"
    match = _SIZE.match(str(text))
    if not match:
        raise ParameterError("size", f"expects WIDTHxHEIGHT in pixels (e.g. 320x240), got {text!r}")
    width, height = int(match.group(1)), int(match.group(2))
    if min(width, height) < 1 or max(width, height) > MAX_SIDE:
        raise ParameterError("size", f"each side must be 1 to {MAX_SIDE} pixels, got {text!r}")
    return width, height


def parse_scene(scene_path, variant: str, params=None):
    """``(config, state)`` of Mitsuba's parser for the scene file with its
    ``$key`` *params*, references resolved; relative paths resolved from the
    file's folder as ``mi.load_file`` does. Raises ``FileNotFoundError`` or
    :class:`~.scene_loading.SceneLoadError`."""
    import mitsuba as mi

    path = require_scene_file(scene_path)
    config = mi.parser.ParserConfig(variant)
    # one loader thread: Mitsuba's parallel instantiation builds the scene's
    # Python plugins (pbrdf, the wrappers) on several threads at once, and
    # they share per-variant modules and the process-wide file resolver
    config.parallel = False
    with _resolver(path), scene_load_errors():
        state = mi.parser.parse_file(config, path,
                                     **{str(k): str(v) for k, v in (params or {}).items()})
        mi.parser.transform_resolve_references(config, state)
    return config, state


def prepare(scene_path, variant: str, params=None, setup: SceneSetup = SceneSetup()) -> Prepared:
    """The scene file parsed (:func:`parse_scene`) and edited as *setup* asks;
    raises the module's one-line errors. Builds no object."""
    import mitsuba as mi

    config, state = parse_scene(scene_path, variant, params)
    prepared = Prepared(config, state, os.fspath(scene_path))
    if state.nodes[_ROOT].type != mi.ObjectType.Scene:
        raise StokesSceneError(f"{os.path.basename(prepared.scene_path)} is not a scene: its "
                               f"root is a {str(state.nodes[_ROOT].type).split('.')[-1]}")
    if setup.integrator != "as_is":
        prepared.notice = _integrator(prepared, setup)
    if setup.size is not None:
        _set_size(prepared, setup.size)
    if setup.srf is not None:
        _set_srf(prepared, setup.srf, setup.error_parameter)
    elif setup.integrator == "nested":  # a Stokes cube: its bands are the spectral response
        _refuse_spectral_sensor(prepared, setup.error_parameter, "the bands")
    return prepared


def load_prepared(prepared: Prepared):
    """The scene object of a :func:`prepare` d scene (the variant set); Mitsuba's
    errors as :func:`~.scene_loading.scene_load_errors` turns them."""
    import mitsuba as mi

    with _resolver(prepared.scene_path), scene_load_errors():
        mi.parser.transform_all(prepared.config, prepared.state)
        return mi.parser.instantiate(prepared.config, prepared.state)


def load_scene_setup(scene_path, params=None, setup: SceneSetup = SceneSetup()):
    """The scene file loaded in the active variant as *setup* asks
    (:func:`prepare` then :func:`load_prepared`)."""
    import mitsuba as mi

    return load_prepared(prepare(scene_path, mi.variant(), params, setup))


def check_scene_setup(scene_path, variant: str, params=None,
                      setup: SceneSetup = SceneSetup()) -> Optional[str]:
    """Every check :func:`prepare` makes, without a variant set or an object
    built; returns the notice (None: the integrator is used as it is)."""
    return prepare(scene_path, variant, params, setup).notice


# -- the parsed nodes -------------------------------------------------------------------------
# Nodes are handled by their index in ``state.nodes`` and fetched again after
# each append: a node object that Python holds points into the list's storage,
# which an append may move (a stale one crashes the process).

_ROOT = 0  # the parser puts the scene's root node first


def _props(state, index: int):
    """The properties of node *index* (fetched now: see above)."""
    return state.nodes[index].props


def _children(state, index: int, kind=None) -> List[tuple]:
    """``[(property name, child index), ...]`` of the objects nested in node
    *index* (of ``mi.ObjectType`` *kind*, or all)."""
    import mitsuba as mi

    props, found = _props(state, index), []
    for key in props.keys():
        # read only references: other values (a transform) need a variant set
        if props.type(key) == mi.Properties.Type.ResolvedReference:
            child = props[key].index()
            if kind is None or state.nodes[child].type == kind:
                found.append((key, child))
    return found


def _kind(state, index: int) -> str:
    return _props(state, index).plugin_name()


def _where(prepared: Prepared, index: int) -> str:
    """``integrator.xml line 3`` for node *index*: its file's name and line."""
    import mitsuba as mi

    location = mi.parser.file_location(prepared.state, prepared.state.nodes[index])
    match = re.match(r"(.*) \(line (\d+)", location)
    if not match:
        return os.path.basename(location)
    return f"{os.path.basename(match.group(1))} line {match.group(2)}"


def _new_node(state, kind, plugin: str, **props) -> int:
    """The index of a new node appended to *state*."""
    import mitsuba as mi

    node = mi.parser.SceneNode()
    node.type = kind
    node.props.set_plugin_name(plugin)
    for key, value in props.items():
        node.props[key] = value
    node.file_index = 0
    state.nodes.append(node)
    return len(state.nodes) - 1


def _link(state, parent: int, key: str, child: int):
    """Node *child* as property *key* of node *parent*."""
    import mitsuba as mi

    _props(state, parent)[key] = mi.Properties.ResolvedReference(child)


def _integrator(prepared: Prepared, setup: SceneSetup) -> Optional[str]:
    """Put the integrator *setup* asks for at the scene's root; the notice."""
    import mitsuba as mi

    state, name = prepared.state, os.path.basename(prepared.scene_path)
    found = _children(state, _ROOT, mi.ObjectType.Integrator)
    if len(found) > 1:
        raise StokesSceneError(f"{name} has {len(found)} integrators; Mitsuba renders one")
    if found:
        key, top = found[0]
        what = f"the integrator '{_kind(state, top)}' of {name} ({_where(prepared, top)})"
    else:  # Mitsuba's default, made explicit so that it can be wrapped
        key, what = "integrator", f"{name} (no integrator: Mitsuba's default, path)"
        top = _new_node(state, mi.ObjectType.Integrator, DEFAULT_INTEGRATOR)
        _link(state, _ROOT, key, top)
    inner, notice = _inner(state, top, what, setup)
    if setup.integrator == "nested":
        _link(state, _ROOT, key, inner)
    elif notice is not None:
        stokes = _new_node(state, mi.ObjectType.Integrator, "stokes")
        _link(state, stokes, "integrator", inner)
        _link(state, _ROOT, key, stokes)
    return notice


def _inner(state, top: int, what: str, setup: SceneSetup):
    """The index of the integrator that ``stokes`` runs (or would wrap) for
    the scene's integrator *top*, and the notice of a wrapping (None: *top*
    gives Stokes output itself)."""
    import mitsuba as mi

    kind = _kind(state, top)
    nested = [child for _, child in _children(state, top, mi.ObjectType.Integrator)]
    single = _kind(state, nested[0]) if len(nested) == 1 else None
    if kind == "stokes_prb":
        if setup.integrator == "nested":
            raise StokesSceneError(f"{what} replays paths itself; a Stokes cube needs "
                                   "<integrator type=\"stokes\"> around path, direct or volpath")
        return top, None
    if kind == "stokes":
        if single not in WRAPPABLE:
            raise StokesSceneError(f"{what} wraps {single or 'no single integrator'}; stokes "
                                   f"needs one of {', '.join(WRAPPABLE)} inside{_why(single)}")
        return nested[0], None
    if kind == "moment":  # a variance estimate around the integrator that matters
        if single not in WRAPPABLE:
            kinds = ", ".join(_kind(state, n) for n in nested) or "nothing"
            raise StokesSceneError(f"{what} averages {kinds}; a Stokes render needs one of "
                                   f"{', '.join(WRAPPABLE)}{_why(single)}")
        inner, inner_kind = nested[0], single
    elif kind in WRAPPABLE:
        inner, inner_kind = top, kind
    else:
        raise StokesSceneError(f"{what} cannot give Stokes output: stokes wraps "
                               f"{', '.join(WRAPPABLE)}{_why(kind)}")
    if setup.integrator == "nested":
        return inner, None
    if not setup.auto_stokes:
        raise StokesSceneError(f"{what} has no stokes integrator around {inner_kind}, so the "
                               "render would have no Stokes channels; wrap it in "
                               "<integrator type=\"stokes\"> or allow the automatic wrapping")
    dropped = (" without moment (its variance channels have no place in a Stokes image)"
               if kind == "moment" else "")
    return inner, (f"{what} has no stokes integrator around it: rendering {inner_kind} inside "
                   f"<integrator type=\"stokes\">{dropped}")


def _why(kind: Optional[str]) -> str:
    """Why *kind* cannot be wrapped, in parentheses, or ""."""
    if kind and (kind.startswith("prb") or kind.endswith("_projective")):
        return f" ({kind} ignores Mueller frame rotations: S1..S3 would be wrong; use path)"
    if kind == "aov":
        return " (aov writes arbitrary output variables, not radiance)"
    return ""


def _sensors(prepared: Prepared, parameter: str) -> List[int]:
    """The scene's sensors (indices); :class:`ParameterError` naming *parameter* if none."""
    import mitsuba as mi

    sensors = [i for _, i in _children(prepared.state, _ROOT, mi.ObjectType.Sensor)]
    if not sensors:
        raise ParameterError(parameter, f"{os.path.basename(prepared.scene_path)} has no sensor "
                             "(camera)")
    return sensors


def _films(prepared: Prepared, sensor: int) -> List[int]:
    import mitsuba as mi

    return [i for _, i in _children(prepared.state, sensor, mi.ObjectType.Film)]


def _set_size(prepared: Prepared, size: Tuple[int, int]):
    """Every sensor's film ``size`` pixels wide and high; a film with a crop
    window is refused (the crop would no longer mean what the file meant)."""
    import mitsuba as mi

    state, name = prepared.state, os.path.basename(prepared.scene_path)
    for sensor in _sensors(prepared, "size"):
        films = _films(prepared, sensor)
        if not films:  # Mitsuba's default film, made explicit so that it can be sized
            films = [_new_node(state, mi.ObjectType.Film, "hdrfilm")]
            _link(state, sensor, "film", films[0])
        for film in films:
            crop = [k for k in _props(state, film).keys() if k.startswith("crop_")]
            if crop:
                raise ParameterError("size", f"the film of {name} ({_where(prepared, film)}) has "
                                     f"a crop window ({crop[0]}); remove it to set the size")
            props = _props(state, film)
            props["width"], props["height"] = int(size[0]), int(size[1])


def _refuse_spectral_sensor(prepared: Prepared, parameter: str, replaces: str):
    """:class:`ParameterError` naming *parameter* if a sensor has a spectral
    response (``srf``) or a ``specfilm``, which *replaces* would override."""
    state, name = prepared.state, os.path.basename(prepared.scene_path)
    for sensor in _sensors(prepared, parameter):
        if "srf" in _props(state, sensor).keys():
            raise ParameterError(parameter, f"the sensor of {name} ({_where(prepared, sensor)}) "
                                 f"has a spectral response (srf); {replaces} replace it")
        if any(_kind(state, film) == "specfilm" for film in _films(prepared, sensor)):
            raise ParameterError(parameter, f"the film of {name} is a specfilm; use hdrfilm")


def _set_srf(prepared: Prepared, srf: tuple, parameter: str):
    """Every sensor given the spectral response *srf* (see :class:`SceneSetup`)."""
    import mitsuba as mi

    _refuse_spectral_sensor(prepared, parameter, "the passband would")
    low, high, values = srf
    if values is None:  # checked only (the values need the variant's colour tables)
        return
    for sensor in _sensors(prepared, parameter):
        response = _new_node(prepared.state, mi.ObjectType.Texture, "regular",
                             wavelength_min=float(low), wavelength_max=float(high),
                             values=", ".join(f"{v:.9g}" for v in values))
        _link(prepared.state, sensor, "srf", response)


class _resolver:
    """Mitsuba's file resolver with the scene's folder first, for the block
    (relative paths: includes, meshes, textures), put back after."""

    def __init__(self, scene_path):
        self.folder = os.path.dirname(os.path.abspath(os.fspath(scene_path)))

    def __enter__(self):
        import mitsuba as mi

        self.resolver = mi.file_resolver()
        self.saved = [self.resolver[i] for i in range(len(self.resolver))]
        self.resolver.prepend(self.folder)

    def __exit__(self, *exc):
        self.resolver.clear()
        for p in self.saved:
            self.resolver.append(p)
        return False
