"""Sweep files: a scene, its render settings and a ``[params]`` table whose
Cartesian product defines the jobs of ``pbrdf batch`` (docs/batch.md).

::

    scene = "../gallery/sphere.xml"   # relative to the sweep file
    spp = 16
    seed = 0
    out = "renders"                   # relative to the sweep file
    bands = "450:650:20"              # optional: a Stokes cube per job (pbrdf render --bands)
    outputs = ["stokes", "aov"]       # optional; default ["stokes"]; also "polcam"
    [polcam]                          # optional, with "polcam": the camera (pbrdf polcam)
    sensor = "colour"
    [params]
    material = ["Al", "Cu", "Au"]
    sigma = [0.05, 0.2]

:func:`load_sweep` checks the whole file before anything renders and raises
:class:`SweepError` (a ``ValueError``) with one line naming the file and the
key: unknown keys, wrong types, empty or repeated values, a missing scene, an
unwritable ``out`` folder, a parameter the scene does not declare, a value the
scene cannot use (:mod:`mitsuba_pbrdf.rendering.scene_params`), an unknown or
unpolarized variant.

Each :class:`Job` has a file-system-safe unique name made of the parameters
that take several values (``material-Al_sigma-0.05``) and a seed fixed by the sweep: the sweep's
``seed`` plus a hash of the job's parameters (mod 2^32), so a job keeps its
seed when values are added to the sweep and a retried job renders with the
same seed.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import re
import sys
import zlib
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

from ..numbers import MAX_SPP

__all__ = ["SweepError", "Job", "Sweep", "OUTPUTS", "POLCAM_KEYS", "MANIFEST_NAME", "load_sweep",
           "format_value", "job_seed"]

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.9/3.10 (pyproject installs tomli there)
    import tomli as tomllib

#: What a job can write, by the name used in the sweep's ``outputs`` list.
#: ``stokes``: the Stokes EXR (always); ``aov``: normals and depth from
#: Mitsuba's ``aov`` integrator; ``polcam``: what a polarization camera records
#: (``pbrdf polcam``'s files, set by the ``[polcam]`` table). New outputs are
#: added here and in :mod:`mitsuba_pbrdf.batch.job`.
OUTPUTS = ("stokes", "aov", "polcam")
#: Keys of the ``[polcam]`` table: the ``pbrdf polcam`` options (the noise seed
#: is the job's seed).
POLCAM_KEYS = ("sensor", "band", "exposure", "full_well", "read_noise", "bits")
MANIFEST_NAME = "manifest.csv"
#: Manifest columns that are not parameters (a parameter may not take these names).
FIXED_COLUMNS = ("job", "seed", "spp", "status", "seconds", "file", "aov", "polcam", "error",
                 "note")
_KEYS = ("scene", "spp", "seed", "out", "variant", "bands", "outputs", "polcam", "params",
         "slurm")
_NAME_MAX = 120
#: Most jobs in one sweep: their names, seeds and manifest rows are built
#: before the first render (10^5 jobs: seconds and tens of MB).
MAX_JOBS = 100_000


class SweepError(ValueError):
    """A sweep file that cannot run (one line, naming the file and the key)."""


@dataclass(frozen=True)
class Job:
    """One render of a sweep: its name, ``{parameter: value text}`` (as ``-D``
    takes them) and seed."""

    name: str
    params: Dict[str, str]
    seed: int


@dataclass
class Sweep:
    """A checked sweep file; paths are absolute."""

    path: str
    scene: str
    out: str
    spp: Optional[int] = None
    seed: int = 0
    variant: Optional[str] = None
    #: bands of a Stokes cube per job (:func:`~mitsuba_pbrdf.rendering.bands.parse_bands` syntax)
    bands: Optional[str] = None
    outputs: Tuple[str, ...] = ("stokes",)
    polcam: Dict[str, object] = field(default_factory=dict)
    #: the ``[slurm]`` table, checked (:func:`mitsuba_pbrdf.batch.slurm_options.slurm_options`)
    slurm: Dict[str, object] = field(default_factory=dict)
    param_names: List[str] = field(default_factory=list)
    jobs: List[Job] = field(default_factory=list)

    @property
    def manifest(self) -> str:
        return os.path.join(self.out, MANIFEST_NAME)


def format_value(value) -> str:
    """A TOML value as the text ``-D`` would give: booleans ``true``/``false``,
    numbers in their shortest form (``0.05``, ``3``), strings as they are."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)  # Python's shortest round-trip form; 1.0 stays "1.0"


def job_seed(base: int, params: Dict[str, str]) -> int:
    """The seed of the job with *params*: ``base`` plus the CRC-32 of the
    parameters as sorted JSON, mod 2^32 (independent of the job's position in
    the sweep)."""
    text = json.dumps(params, sort_keys=True, separators=(",", ":"))
    return (int(base) + zlib.crc32(text.encode("utf-8"))) & 0xFFFFFFFF


def _safe(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.+]+", "-", text).strip("-.") or "x"


def _job_names(combos: List[Dict[str, str]], varying: List[str], fallback: str) -> List[str]:
    """File-system-safe, unique names: ``key-value`` pairs of the *varying*
    parameters (those with several values) joined by ``_``; names that collide
    after cleaning (or are too long) get a short hash."""
    names = []
    for params in combos:
        name = "_".join(f"{_safe(k)}-{_safe(params[k])}" for k in varying) or _safe(fallback)
        names.append(name)
    counts: Dict[str, int] = {}
    for name in names:
        counts[name.lower()] = counts.get(name.lower(), 0) + 1  # case-insensitive file systems
    unique = []
    for name, params in zip(names, combos):
        if counts[name.lower()] > 1 or len(name) > _NAME_MAX:
            digest = f"{zlib.crc32(json.dumps(params, sort_keys=True).encode()):08x}"
            name = f"{name[:_NAME_MAX - 9]}~{digest}"
        unique.append(name)
    return unique


def _fail(path: str, message: str):
    raise SweepError(f"{path}: {message}")


def _int(path, key, value, low, high=None):
    if isinstance(value, bool) or not isinstance(value, int):
        _fail(path, f"{key} must be an integer, got {value!r}")
    if value < low or (high is not None and value > high):
        rng = f">= {low}" if high is None else f"in [{low}, {high}]"
        _fail(path, f"{key} must be an integer {rng}, got {value}")
    return value


def _string(path, key, value):
    if not isinstance(value, str) or not value.strip():
        _fail(path, f"{key} must be a non-empty string, got {value!r}")
    return value


def _param_values(path, key, values) -> List[str]:
    where = f"params.{key}"
    if not re.fullmatch(r"\w+", key):
        _fail(path, f"{where}: a scene parameter name is letters, digits and '_'")
    if key in FIXED_COLUMNS:
        _fail(path, f"{where}: the name clashes with the manifest column {key!r}")
    if not isinstance(values, list):
        values = [values]
    if not values:
        _fail(path, f"{where} is an empty list; give at least one value")
    texts = []
    for value in values:
        if isinstance(value, float) and not math.isfinite(value):
            _fail(path, f"{where}: {value} is not a finite number")
        if not isinstance(value, (str, int, float, bool)):
            _fail(path, f"{where}: values must be strings, numbers or booleans, got {value!r}")
        text = format_value(value)
        if text in texts:
            _fail(path, f"{where}: value {text!r} is listed twice")
        texts.append(text)
    return texts


def _bands(path, value, variant: Optional[str]) -> str:
    """The sweep's ``bands`` (a string in ``pbrdf render --bands`` syntax), checked."""
    from ..errors import ParameterError
    from ..rendering.bands import parse_bands, require_spectral_bands

    text = _string(path, "bands", value)
    try:
        parse_bands(text)
        if variant is not None:
            require_spectral_bands(variant)
    except ParameterError as e:
        _fail(path, f"bands: {e.detail}")
    return text


def _check_variant(path, variant: str):
    from ..rendering.render import UnpolarizedVariantError, require_polarized

    import mitsuba as mi

    if variant not in mi.variants():
        polarized = [v for v in mi.variants() if v.endswith("_polarized")]
        _fail(path, f"variant: unknown variant {variant!r}; this Mitsuba has "
                    f"{', '.join(polarized) or 'no polarized variant'}")
    try:
        require_polarized(variant)
    except UnpolarizedVariantError as e:
        _fail(path, f"variant: {e}")


def _polcam_options(path, table, outputs) -> Dict[str, object]:
    """The checked ``[polcam]`` table: ``{key: value}`` of :data:`POLCAM_KEYS`."""
    if table is None:
        return {}
    if "polcam" not in outputs:
        _fail(path, "polcam: the [polcam] table needs 'polcam' in outputs")
    if not isinstance(table, dict):
        _fail(path, f"polcam must be a table ([polcam]), got {table!r}")
    unknown = [k for k in table if k not in POLCAM_KEYS]
    if unknown:
        _fail(path, f"polcam: unknown key {unknown[0]!r}; [polcam] has {', '.join(POLCAM_KEYS)}")
    options = dict(table)
    if options.get("sensor", "mono") not in ("mono", "colour"):
        _fail(path, f"polcam.sensor must be 'mono' or 'colour', got {options['sensor']!r}")
    if "band" in options:
        _string(path, "polcam.band", options["band"])
        if options.get("sensor") == "colour":
            _fail(path, "polcam.band is for the mono sensor; the colour sensor sees R, G, B")
    for key in ("exposure", "full_well", "read_noise"):
        if key in options:
            value = options[key]
            if (isinstance(value, bool) or not isinstance(value, (int, float))
                    or not math.isfinite(value) or value < 0
                    or (value == 0 and key != "read_noise")):
                low = ">= 0" if key == "read_noise" else "> 0"
                _fail(path, f"polcam.{key} must be a finite number {low}, got {value!r}")
            options[key] = float(value)
    if options.get("read_noise") and "full_well" not in options:
        _fail(path, "polcam.read_noise (electrons) needs polcam.full_well")
    if "exposure" in options and "full_well" not in options and "bits" not in options:
        # without shot noise or an ADC nothing would use the exposure
        _fail(path, "polcam.exposure (the radiance at full well) needs polcam.full_well "
                    "or polcam.bits")
    if "bits" in options:
        _int(path, "polcam.bits", options["bits"], 1, 16)
    return options


def _slurm_table(path, table) -> Dict[str, object]:
    """The ``[slurm]`` table (settings of ``pbrdf batch --slurm``), checked."""
    from .slurm_options import SlurmError, slurm_options

    if table is None:
        return {}
    if not isinstance(table, dict):
        _fail(path, f"slurm must be a table ([slurm]), got {table!r}")
    try:
        slurm_options(table, where=f"{path}: ")
    except SlurmError as e:
        raise SweepError(str(e)) from None
    return dict(table)


def _scene_path(path: str, folder: str, scene: str) -> str:
    from ..rendering.scene_files import packaged_scene

    candidate = os.path.normpath(os.path.join(folder, os.path.expanduser(scene)))
    if os.path.isfile(candidate):
        return candidate
    if os.path.isdir(candidate):
        _fail(path, f"scene: {candidate} is a folder")
    packaged = packaged_scene(scene)
    if packaged is not None and not os.path.isabs(scene):
        return os.fspath(packaged)
    _fail(path, f"scene: no such file: {candidate} (relative to the sweep file)")


def load_sweep(path) -> Sweep:
    """Read and check the sweep file *path* (see the module docstring); raises
    :class:`SweepError`, or ``FileNotFoundError`` for a missing file."""
    from ..outputs import OutputPlanError, check_plan, check_writable

    path = os.path.abspath(os.fspath(path))
    data = _read_toml(path)
    folder = os.path.dirname(path)
    unknown = [k for k in data if k not in _KEYS]
    if unknown:
        _fail(path, f"unknown key {unknown[0]!r}; a sweep has {', '.join(_KEYS)}")
    for key, what in (("scene", "the scene file"), ("out", "the output folder")):
        if key not in data:
            _fail(path, f"{key} is missing ({what}, relative to the sweep file)")
    scene = _scene_path(path, folder, _string(path, "scene", data["scene"]))
    out = os.path.normpath(os.path.join(folder, os.path.expanduser(
        _string(path, "out", data["out"]))))
    spp = _int(path, "spp", data["spp"], 1) if "spp" in data else None
    if spp is not None and spp > MAX_SPP:   # a render's passes are a list: bounded
        _fail(path, f"spp must be at most {MAX_SPP} (2^24), got {spp}")
    seed = _int(path, "seed", data.get("seed", 0), 0, 0xFFFFFFFF)
    variant = _string(path, "variant", data["variant"]) if "variant" in data else None
    if variant is not None:
        _check_variant(path, variant)
    bands = _bands(path, data["bands"], variant) if "bands" in data else None
    outputs = _outputs(path, data.get("outputs", ["stokes"]))
    polcam = _polcam_options(path, data.get("polcam"), outputs)
    if bands is not None and polcam.get("sensor") == "colour":
        from ..camera.polcam import COLOUR_CUBE_REFUSAL

        _fail(path, f"polcam.sensor 'colour' cannot see the cube that bands renders: "
                    f"{COLOUR_CUBE_REFUSAL}")
    slurm = _slurm_table(path, data.get("slurm"))
    values = _params(path, data.get("params", {}), scene)
    try:  # the one rule of outputs (mitsuba_pbrdf.outputs): the manifest replaces no input
        check_plan([("out", os.path.join(out, MANIFEST_NAME), None)],
                   inputs=[("the sweep file", path), ("scene", scene)])
    except OutputPlanError as e:
        _fail(path, str(e))
    try:
        check_writable(os.path.join(out, MANIFEST_NAME))
    except OSError as e:
        _fail(path, f"out: cannot write in {out}: {e.strerror}")
    return Sweep(path=path, scene=scene, out=out, spp=spp, seed=seed, variant=variant,
                 bands=bands, outputs=tuple(outputs), polcam=polcam, slurm=slurm,
                 param_names=list(values), jobs=_jobs(values, seed, scene))


def _read_toml(path: str) -> dict:
    """The sweep file's TOML table; one line naming the file if it is not TOML."""
    if not os.path.isfile(path):
        raise FileNotFoundError(f"sweep file not found: {path}")
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        _fail(path, f"not a valid TOML file: {e}")


def _outputs(path: str, outputs) -> list:
    """The ``outputs`` list, checked: known names, once each, ``stokes`` among them."""
    if not isinstance(outputs, list) or not all(isinstance(o, str) for o in outputs):
        _fail(path, f"outputs must be a list of names ({', '.join(OUTPUTS)}), got {outputs!r}")
    for name in outputs:
        if name not in OUTPUTS:
            _fail(path, f"outputs: unknown output {name!r}; known: {', '.join(OUTPUTS)}")
    if "stokes" not in outputs:
        _fail(path, "outputs must include 'stokes' (the Stokes EXR every job writes)")
    if len(set(outputs)) != len(outputs):
        _fail(path, "outputs: a name is listed twice")
    return outputs


def _params(path: str, table, scene: str) -> Dict[str, list]:
    """``{key: [value text, ...]}`` of the ``[params]`` table, checked against
    the scene's ``$key`` parameters and bounded in job count before any job
    is built."""
    from ..rendering.scene_params import (SceneParameterError, check_parameter_values,
                                          declared_parameters, did_you_mean)

    if not isinstance(table, dict):
        _fail(path, f"params must be a table ([params]), got {table!r}")
    values = {key: _param_values(path, key, v) for key, v in table.items()}
    if math.prod(len(v) for v in values.values()) > MAX_JOBS:   # before anything per job
        shape = " x ".join(f"{len(v)} {k}" for k, v in values.items())
        _fail(path, f"params: {shape} = {math.prod(len(v) for v in values.values())} jobs; "
                    f"at most {MAX_JOBS} in one sweep (split it into several sweep files)")
    declared = declared_parameters(scene)
    if declared is not None:
        for key in values:
            if key not in declared:
                _fail(path, f"params.{key}: {os.path.basename(scene)} has no parameter "
                            f"{key!r}{did_you_mean(key, declared)}; it has "
                            f"{', '.join(sorted(declared)) or 'none'}")
    for key, texts in values.items():
        for text in texts:
            try:
                check_parameter_values(scene, {key: text})
            except SceneParameterError as e:
                _fail(path, f"params.{key}: " + str(e).replace(f"-D {key} ", "", 1))
    return values


def _jobs(values: Dict[str, list], seed: int, scene: str) -> List["Job"]:
    """Every combination of the parameters' values, named by the varying ones,
    each with its seed from the sweep's."""
    keys = list(values)
    combos = [dict(zip(keys, combo)) for combo in itertools.product(*values.values())]
    varying = [key for key in keys if len(values[key]) > 1]
    names = _job_names(combos, varying, os.path.splitext(os.path.basename(scene))[0])
    return [Job(name=n, params=p, seed=job_seed(seed, p)) for n, p in zip(names, combos)]
