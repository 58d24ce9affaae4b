"""A scene's Mitsuba metals turned into ``pbrdf`` (``pbrdf convert``).

Every ``conductor`` and ``roughconductor`` of a scene file and of the files it
``<include>``\\ s becomes a ``pbrdf`` of the same material and roughness that
renders the same: Smith shadowing (``roughconductor``'s), the same normal
distribution, no diffuse lobes (``kdd = kid = 0``), specular slope
``sigma = alpha / sqrt(2)`` (``conductor``: ``sigma = 0``, the smooth limit),
``specular_reflectance`` as ``ks`` (both scale the Fresnel Mueller matrix).
The BSDF element is converted where it stands, so its ``id``, the ``<ref>``\\ s
to it, and ``twosided``/``blendbsdf``/``mask`` around it stay as they are::

    result = convert_scene("bsdf_roughconductor_copper.xml")
    result.files   # {original: converted}, main scene first
    result.notes   # one line per change and per thing left

The new main scene goes beside the original (``<stem>_pbrdf.xml``, or *out*);
an included file that holds a metal, or includes one that does, gets a
converted copy beside it under the same kind of name, and the copies include
each other. No original is modified and no output may be an input. Pure XML
(no Mitsuba variant needed); Mitsuba's own rules for these plugins (eta, k and
material, alpha against alpha_u/alpha_v, checkerboard defaults) are followed so
that a scene Mitsuba loads converts to one that renders alike.
"""

from __future__ import annotations

import importlib.util
import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Dict, List, Optional

from ..errors import ParameterError
from ..outputs import check_writable, together, write_text

__all__ = ["SUFFIX", "Conversion", "convert_scene", "converted_name"]

#: Added to a converted file's stem: ``scene.xml`` -> ``scene_pbrdf.xml``.
SUFFIX = "_pbrdf"
_SQRT2 = math.sqrt(2.0)

_COMMON = ("material", "eta", "k", "specular_reflectance")
#: The parameters each of Mitsuba's metals takes (Mitsuba refuses any other).
_TAKES = {"conductor": _COMMON,
          "roughconductor": _COMMON + ("distribution", "alpha", "alpha_u", "alpha_v",
                                       "sample_visible")}
#: roughconductor's alpha name -> pbrdf's slope name.
_WIDTHS = {"alpha": "sigma", "alpha_u": "sigma_u", "alpha_v": "sigma_v"}
#: Mitsuba's checkerboard colours when not given.
_CHECKER_DEFAULTS = {"color0": 0.4, "color1": 0.2}
#: Mitsuba's conductors without material or eta: eta = 0, k = 1 (a perfect
#: mirror). pbrdf needs eta > 0; at eta = 1e-4, k = 1 the Fresnel reflectance
#: is lower by at most 4 eta cos / (1 + cos^2) <= 2e-4.
_EPSILON_ETA = 1e-4


@dataclass
class Conversion:
    """What :func:`convert_scene` did: *files* maps each original scene file it
    rewrote to its converted copy (the main scene first), *notes* says in one
    line each what was changed and what was left, *replaced* lists the
    converted copies that replaced a file of that name (none of them an input)."""

    scene: str
    files: Dict[str, str] = field(default_factory=dict)
    notes: List[str] = field(default_factory=list)
    replaced: List[str] = field(default_factory=list)


def converted_name(path) -> str:
    """``dir/scene.xml`` -> ``dir/scene_pbrdf.xml``."""
    base, ext = os.path.splitext(os.fspath(path))
    return base + SUFFIX + (ext or ".xml")


@dataclass
class _File:
    path: str                                  # absolute, as read
    root: ET.Element
    head: str                                  # the XML declaration and what precedes the root
    tail: str
    metals: List[ET.Element] = field(default_factory=list)
    includes: List[tuple] = field(default_factory=list)  # (element, _File)
    notes: List[str] = field(default_factory=list)
    new_path: Optional[str] = None


def _parse(path: str) -> _File:
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except UnicodeDecodeError as e:
        raise ValueError(f"{path}: not a UTF-8 text file ({e.reason})") from None
    builder = ET.TreeBuilder(insert_comments=True, insert_pis=True)
    parser = ET.XMLParser(target=builder)
    try:
        parser.feed(text)
        root = parser.close()
    except ET.ParseError as e:
        raise ValueError(f"{path}: not a Mitsuba scene: XML error: {e}") from None
    if root.tag != "scene":
        raise ValueError(f"{path}: not a Mitsuba scene: its root is <{root.tag}>, not <scene>")
    start = re.search(r"<scene\b", text)
    close = text.rfind("</scene>")
    end = close + len("</scene>") if close >= 0 else len(text.rstrip())
    return _File(path, root, text[:start.start()] if start else "", text[end:])


def _search_folders(file: _File, main_dir: str) -> List[str]:
    """Where Mitsuba looks for a file this one names: its folder, the main
    scene's, and the folders of its ``<path>`` elements."""
    here = os.path.dirname(file.path)
    paths = [os.path.join(here, p.get("value", "")) for p in file.root.iter("path")]
    return [here, main_dir] + paths


def _read_tree(path: str, main_dir: str, seen: Dict[str, _File]) -> _File:
    """The file at *path* and, recursively, the files it includes."""
    key = os.path.realpath(path)
    if key in seen:
        return seen[key]
    file = seen[key] = _parse(path)
    file.metals = [e for e in file.root.iter("bsdf") if e.get("type") in _TAKES]
    for element in file.root.iter("include"):
        name = element.get("filename", "")
        if "$" in name:
            file.notes.append(f"{_rel(file.path)}: include {name} depends on a scene parameter: "
                              "not followed (a metal in it stays as it is)")
            continue
        found = next((os.path.normpath(os.path.join(d, name))
                      for d in _search_folders(file, main_dir)
                      if os.path.isfile(os.path.join(d, name))), None)
        if found is None:
            raise ValueError(f"{file.path}: included file {name} not found")
        file.includes.append((element, _read_tree(found, main_dir, seen)))
    return file


def _rel(path: str) -> str:
    rel = os.path.relpath(path)
    return path if rel.startswith("..") else rel


def _needs_copy(file: _File, visiting=()) -> bool:
    if file.metals:
        return True
    return any(f.path not in visiting and _needs_copy(f, visiting + (file.path,))
               for _, f in file.includes)


def convert_scene(scene, out=None) -> Conversion:
    """Convert the metals of scene file *scene* (and its includes) into
    ``pbrdf`` and write the converted files (see the module docstring). *out*
    is the new main scene (default: ``<stem>_pbrdf.xml`` beside *scene*);
    it must name an ``.xml`` file that is none of the files read.

    Raises ``FileNotFoundError``, ``ValueError`` naming the file and element
    (no metal at all, a parameter or material Mitsuba would refuse too),
    :class:`~mitsuba_pbrdf.errors.ParameterError` for *out*, or
    :class:`~mitsuba_pbrdf.outputs.OutputError`; nothing is written then."""
    scene = os.fspath(scene)
    if not os.path.isfile(scene):
        raise FileNotFoundError(f"scene file not found: {scene}")
    scene = os.path.abspath(scene)
    out = os.path.abspath(os.fspath(out)) if out is not None else converted_name(scene)
    if not out.lower().endswith(".xml"):
        raise ParameterError("out", f"must name an .xml file, got {out}")
    seen: Dict[str, _File] = {}
    main = _read_tree(scene, os.path.dirname(scene), seen)
    if not any(f.metals for f in seen.values()):
        raise ValueError(f"{scene}: no conductor or roughconductor in the scene or its "
                         "includes: nothing to convert")
    copies = [main] + [f for f in seen.values() if f is not main and _needs_copy(f)]
    for f in copies:
        f.new_path = out if f is main else converted_name(f.path)
    _check_outputs(copies, seen)

    result = Conversion(scene=out)
    for f in copies:
        for number, metal in enumerate(f.metals, 1):
            where = f"{_rel(f.path)}: {metal.get('type')} " + (
                f"'{metal.get('id')}'" if metal.get("id") else f"#{number} (no id)")
            f.notes += convert_metal(metal, where)
        for element, included in f.includes:
            if included.new_path is not None:
                old = element.get("filename")
                element.set("filename", converted_name(old))
                f.notes.append(f"{_rel(f.path)}: include {old} -> {converted_name(old)}")
        if f is main and os.path.dirname(out) != os.path.dirname(scene):
            # Mitsuba resolves relative names (meshes, textures, includes) from
            # the scene's folder: point the new one at the original's
            folder = os.path.relpath(os.path.dirname(scene), os.path.dirname(out))
            _insert(f.root, 0, ET.Element("path", value=folder))
            f.notes.append(f"{_rel(out)}: <path value=\"{folder}\"/> added (the original "
                           "scene's folder, for its relative file names)")
        result.notes += f.notes
        result.files[f.path] = f.new_path
    for f in seen.values():
        if f.new_path is None:
            result.notes += f.notes
    result.replaced = [f.new_path for f in copies if os.path.exists(f.new_path)]
    with together():
        for f in copies:
            write_text(f.new_path, f.head + ET.tostring(f.root, encoding="unicode") + f.tail)
    return result


def _check_outputs(copies: List[_File], seen: Dict[str, _File]):
    inputs = {os.path.realpath(f.path): f.path for f in seen.values()}
    written = {}
    for f in copies:
        real = os.path.realpath(f.new_path)
        if real in inputs:
            what = "the scene" if f is copies[0] and real == os.path.realpath(f.path) \
                else f"an input of the conversion ({_rel(inputs[real])})"
            message = f"{f.new_path} is {what}: never written over; choose another name"
            if f is copies[0]:
                raise ParameterError("out", message)
            raise ValueError(f"the converted copy of {f.path}: {message}")
        if real in written:
            raise ParameterError("out", f"{f.new_path} is also the converted copy of "
                                        f"{written[real]}; choose another name")
        written[real] = f.path
        check_writable(f.new_path)


# ---------------------------------------------------------------------------
# One metal
# ---------------------------------------------------------------------------

def convert_metal(element: ET.Element, where: str = "bsdf") -> List[str]:
    """Turn one ``<bsdf type="conductor|roughconductor">`` element into a
    ``pbrdf`` in place; returns the notes, one line each, opening with
    *where*."""
    kind = element.get("type")
    props = {}
    for child in element:
        if not isinstance(child.tag, str):
            continue  # a comment
        name = child.get("name")
        if name not in _TAKES[kind]:
            shown = f"parameter '{name}'" if name else f"an unnamed <{child.tag}>"
            raise ValueError(f"{where}: {kind} takes no {shown} (Mitsuba refuses the "
                             "scene too)")
        props[name] = child
    notes = [f"{where}: {kind} -> pbrdf (shadowing smith, kdd = kid = 0)"]
    element.set("type", "pbrdf")
    notes += _index(element, props, kind, where)
    if kind == "conductor":
        _append(element, ET.Element("float", name="sigma", value="0"))
        notes.append(f"{where}: sigma = 0 (a smooth conductor: pbrdf's delta lobe)")
    else:
        notes += _roughness(element, props, where)
    if "specular_reflectance" in props:
        props["specular_reflectance"].set("name", "ks")
        notes.append(f"{where}: specular_reflectance {_describe(props['specular_reflectance'])} "
                     "kept as ks (pbrdf's weight of the same Fresnel lobe)")
    for tag, name, value in (("string", "shadowing", "smith"), ("float", "kdd", "0"),
                             ("float", "kid", "0")):
        _append(element, ET.Element(tag, name=name, value=value))
    return notes


def _index(element, props, kind, where) -> List[str]:
    """material / eta / k by Mitsuba's rule: eta and k (defaults 0 and 1) when
    eta is given or material is ``none`` (its default), else the material."""
    material = props["material"].get("value") if "material" in props else "none"
    if "eta" not in props and material != "none":
        if "k" in props:
            raise ValueError(f"{where}: {kind} gives k beside material {material} "
                             "(Mitsuba refuses the scene too)")
        return [f"{where}: material {material} kept"] + _table_range(material, where)
    if "material" in props:
        if material != "none":
            raise ValueError(f"{where}: {kind} gives eta beside material {material} "
                             "(Mitsuba refuses the scene too)")
        element.remove(props["material"])
    notes = []
    if "eta" not in props:
        _append(element, ET.Element("float", name="eta", value=f"{_EPSILON_ETA:g}"))
        notes.append(f"{where}: no material nor eta (Mitsuba's perfect mirror, eta = 0): "
                     f"eta = {_EPSILON_ETA:g}, as pbrdf needs eta > 0 (reflectance lower by "
                     f"<= {2 * _EPSILON_ETA:g})")
    elif _number(props["eta"]) == 0:
        props["eta"].set("value", f"{_EPSILON_ETA:g}")
        notes.append(f"{where}: eta 0 -> {_EPSILON_ETA:g}, as pbrdf needs eta > 0 "
                     f"(reflectance lower by <= {2 * _EPSILON_ETA:g})")
    for name in ("eta", "k"):
        if name in props:
            notes += _held_spectrum(props[name], name, where)
    if "k" not in props:
        _append(element, ET.Element("float", name="k", value="1"))
        notes.append(f"{where}: k not given: Mitsuba's default 1 written out")
    given = [props[n] for n in ("eta", "k") if n in props]
    kinds = sorted({_describe(e, plural=len(given) > 1) for e in given})
    if given:
        names = "/".join(n for n in ("eta", "k") if n in props)
        notes.append(f"{where}: {names} {' and '.join(kinds)} kept")
    return notes


#: Mitsuba's spectral range (MI_CIE_MIN, MI_CIE_MAX), nm.
_SPECTRAL_RANGE = (360.0, 830.0)


def _held_spectrum(prop: ET.Element, name: str, where: str) -> List[str]:
    """An eta or k ``<spectrum>`` of wavelength:value pairs that stops short of
    Mitsuba's spectral range is 0 beyond its ends, where Mitsuba's conductors
    then have n = k = 0 (a black lobe in polarized variants, whose Fresnel
    matrix is undefined there; a perfect mirror in the others) and pbrdf
    refuses eta = 0: its end values are held out to the range, as pbrdf does
    for Mitsuba's own tables (``bsdfs/ior.py``). Returns the note, if any."""
    if prop.tag != "spectrum" or ":" not in prop.get("value", ""):
        return []
    try:
        pairs = [tuple(float(x) for x in item.split(":"))
                 for item in prop.get("value").split(",") if item.strip()]
    except ValueError:
        return []  # Mitsuba's own parser reports it
    low, high = _SPECTRAL_RANGE
    if pairs[0][0] <= low and pairs[-1][0] >= high:
        return []
    covered = f"{pairs[0][0]:g}-{pairs[-1][0]:g} nm"
    if pairs[0][0] > low:
        pairs.insert(0, (low, pairs[0][1]))
    if pairs[-1][0] < high:
        pairs.append((high, pairs[-1][1]))
    prop.set("value", ", ".join(f"{w:.9g}:{v:.9g}" for w, v in pairs))
    return [f"{where}: {name} spectrum covers {covered}: its end values held out to "
            f"{low:.0f}-{high:.0f} nm (Mitsuba's conductor has n = k = 0 there: black in "
            "polarized variants, a mirror in the others)"]


def _table_range(material: str, where: str) -> List[str]:
    """A note when Mitsuba's table of *material* stops short of 360-830 nm
    (pbrdf holds its end values there; Mitsuba's conductors give n = k = 0)."""
    spec = importlib.util.find_spec("mitsuba")
    folder = os.path.join(os.path.dirname(spec.origin), "data", "ior") if spec else None
    table = os.path.join(folder, f"{material}.eta.spd") if folder else None
    if table is None or not os.path.isfile(table):
        raise ValueError(f"{where}: unknown material {material!r} (Mitsuba's tables: "
                         f"{folder or 'Mitsuba not installed'})")
    with open(table) as f:
        waves = [float(line.split()[0]) for line in f if line.strip() and line[0] != "#"]
    if waves[0] <= 360 and waves[-1] >= 830:
        return []
    return [f"{where}: Mitsuba's {material} table covers {waves[0]:.0f}-{waves[-1]:.0f} nm; "
            "outside it pbrdf holds the end values, Mitsuba's conductor uses n = k = 0"]


def _roughness(element, props, where) -> List[str]:
    """alpha, alpha_u/alpha_v -> sigma, sigma_u/sigma_v; sample_visible dropped."""
    notes = []
    if "sample_visible" in props:
        element.remove(props["sample_visible"])
        value = props["sample_visible"].get("value", "")
        notes.append(f"{where}: sample_visible {value} dropped (pbrdf always samples visible "
                     "normals" + (")" if value.lower() == "true" else
                                  "; the renders agree in expectation, not per seed)"))
    given = [n for n in ("alpha_u", "alpha_v") if n in props]
    if given and ("alpha" in props or len(given) == 1):
        raise ValueError(f"{where}: roughconductor needs both alpha_u and alpha_v, without "
                         "alpha (Mitsuba refuses the scene too)")
    names = given or ["alpha"]
    for name in names:
        if name not in props:  # Mitsuba's default
            _append(element, ET.Element("float", name="sigma", value=f"{0.1 / _SQRT2:.9g}"))
            notes.append(f"{where}: alpha not given (Mitsuba's default 0.1) -> sigma "
                         f"{0.1 / _SQRT2:.6g}")
            continue
        notes.append(f"{where}: {_scaled(props[name], _WIDTHS[name], where)}")
    return notes


def _scaled(prop: ET.Element, new_name: str, where: str) -> str:
    """Rename *prop* to *new_name* and divide its value(s) by sqrt(2): a
    number, or a checkerboard of numbers; anything else keeps Mitsuba's name,
    which pbrdf also takes (``schema.Alias``). Returns the note."""
    old_name = prop.get("name")
    value = _number(prop)
    if value is not None:
        prop.set("value", f"{value / _SQRT2:.9g}")
        prop.set("name", new_name)
        return f"{old_name} {value:g} -> {new_name} {value / _SQRT2:.6g} (alpha / sqrt(2))"
    if prop.tag == "texture" and prop.get("type") == "checkerboard":
        colours = {c.get("name"): c for c in prop if isinstance(c.tag, str)}
        values = {n: (_number(colours[n]) if n in colours else d)
                  for n, d in _CHECKER_DEFAULTS.items()}
        if all(v is not None for v in values.values()):
            for n, v in values.items():
                if n in colours:
                    colours[n].set("value", f"{v / _SQRT2:.9g}")
                else:
                    _append(prop, ET.Element("float", name=n, value=f"{v / _SQRT2:.9g}"))
            prop.set("name", new_name)
            return (f"{old_name} checkerboard ({values['color0']:g}, {values['color1']:g}) -> "
                    f"{new_name} checkerboard ({values['color0'] / _SQRT2:.6g}, "
                    f"{values['color1'] / _SQRT2:.6g}) (alpha / sqrt(2))")
    # a bitmap, a <ref>, a $parameter: pbrdf takes Mitsuba's name as it is
    return (f"{old_name} {_describe(prop)} kept as {old_name} (pbrdf's name for Mitsuba's "
            f"width: {new_name} = {old_name} / sqrt(2))")


def _number(prop: ET.Element) -> Optional[float]:
    """The value of a ``<float>``, ``<integer>``, one-value ``<spectrum>`` or
    grey ``<rgb>``, else None (a texture, a ``$parameter``, a spectrum)."""
    if prop.tag not in ("float", "integer", "spectrum", "rgb") or "value" not in prop.attrib:
        return None
    parts = [p for p in re.split(r"[,\s]+", prop.get("value").strip()) if p]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        return None
    if not values or len(set(values)) != 1 or (prop.tag == "spectrum" and len(values) > 1):
        return None
    return values[0]


def _describe(prop: ET.Element, plural: bool = False) -> str:
    """``0.8``, ``given as a spectrum``, ``given as RGB``, ``given as a texture``."""
    value = _number(prop)
    if "$" in prop.get("value", ""):
        return f"given as {prop.get('value')}"
    if value is not None and prop.tag != "rgb":
        return f"{value:g}" if not plural else "given as values"
    if prop.tag == "spectrum":
        return "given as spectra" if plural else "given as a spectrum"
    if prop.tag == "rgb":
        return "given as RGB" if plural else f"given as RGB ({prop.get('value')})"
    if prop.tag == "ref":
        return "given as references" if plural else f"given as a reference to '{prop.get('id')}'"
    if prop.tag == "texture":
        return "given as textures" if plural else f"given as a {prop.get('type')} texture"
    return f"given as <{prop.tag}>"


def _append(parent: ET.Element, child: ET.Element):
    _insert(parent, len(parent), child)


def _insert(parent: ET.Element, index: int, child: ET.Element):
    """Insert *child* at *index*, indented as *parent*'s other children."""
    children = list(parent)
    if children:
        indent = parent.text if parent.text and not parent.text.strip() else "\n    "
        if index >= len(children):
            last = children[-1]
            child.tail, last.tail = last.tail, indent
        else:
            child.tail = indent
    else:
        outer = parent.tail if parent.tail and not parent.tail.strip() else "\n"
        outer = outer.rsplit("\n", 1)[-1] if "\n" in outer else ""
        parent.text = "\n" + outer + "    "
        child.tail = "\n" + outer
    parent.insert(index, child)
