"""The parameter schema drives every place that takes a model parameter: the
plugin's checks and ``traverse``, the reference's record, the commands' model
options, the fit layout and the docs' table. Each test compares one of them
with the schema, and the last one adds a parameter to the schema alone and
finds it everywhere."""

import os
import re
import subprocess
import sys

import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf import schema, schema_tables

ROOT = os.path.join(os.path.dirname(__file__), os.pardir)
VALUED = [p for p in schema.PARAMETERS if p.plugin and p.kind in ("float", "spectrum")]


def test_docs_table_is_the_schemas():
    with open(os.path.join(ROOT, "docs", "plugin.md"), encoding="utf-8") as f:
        text = f.read()
    assert schema_tables.docs_table(text) == schema_tables.markdown_table(), (
        "docs/plugin.md's parameter table is out of date: run "
        "`python -m mitsuba_pbrdf.schema_tables docs/plugin.md`")


def test_plugin_docstring_holds_the_table():
    from mitsuba_pbrdf.registry import plugin_class

    doc = plugin_class("pbrdf").__doc__
    for p in schema.PARAMETERS:
        assert f"``{p.name}``" in doc
    assert schema_tables.rst_table() in doc, (
        "bsdfs/pbrdf.py's parameter table is out of date: run "
        "`python -m mitsuba_pbrdf.schema_tables mitsuba_pbrdf/bsdfs/pbrdf.py`")


@pytest.mark.parametrize("p", VALUED, ids=lambda p: p.name)
def test_plugin_checks_each_declared_bound(p):
    """A value below the declared bound, and NaN, are refused at load time
    with the parameter named."""
    extra = {"k": 1.0} if p.name == "eta" else {"eta": 1.0} if p.name == "k" else {}
    bad = [float("nan"), -0.5] + ([0.0] if p.positive and not p.smooth_at_zero else [])
    if p.floor is not None:
        bad.append(p.floor * 0.5)
    for value in bad:
        with pytest.raises((RuntimeError, ValueError), match=f"parameter '{p.name}'"):
            mi.load_dict({"type": "pbrdf", p.name: value, **extra})
    ok = 0.2 if p.floor is None else max(0.2, p.floor)
    mi.load_dict({"type": "pbrdf", p.name: ok, **extra})
    if p.smooth_at_zero:   # the smooth limit (tests/bsdfs/test_pbrdf_smooth_limit.py)
        smooth = {q: 0.0 for q in schema.REFINEMENTS.get(p.refines or p.name, ())}
        mi.load_dict({"type": "pbrdf", **smooth, p.name: 0.0, **extra})


@pytest.mark.parametrize("p", [p for p in schema.PARAMETERS if p.plugin and p.kind == "choice"],
                         ids=lambda p: p.name)
def test_plugin_checks_each_declared_choice(p):
    for choice in p.choices:
        mi.load_dict({"type": "pbrdf", p.name: choice})
    with pytest.raises((RuntimeError, ValueError), match=f"parameter '{p.name}'.*{p.choices[-1]}"):
        mi.load_dict({"type": "pbrdf", p.name: "no_such_choice"})


def plugin_reads():
    """The names the pbrdf constructor reads: each ``self.NAME = ...`` in
    ``PolarizedBRDF.__init__`` (tuple targets included), read from the source."""
    import ast

    path = os.path.join(ROOT, "mitsuba_pbrdf", "bsdfs", "pbrdf.py")
    tree = ast.parse(open(path, encoding="utf-8").read())
    cls = next(n for n in ast.walk(tree) if isinstance(n, ast.ClassDef) and n.name == "PolarizedBRDF")
    init = next(n for n in cls.body if isinstance(n, ast.FunctionDef) and n.name == "__init__")
    names = set()
    for node in ast.walk(init):
        if isinstance(node, ast.Assign):
            for target in node.targets:
                for t in (target.elts if isinstance(target, ast.Tuple) else [target]):
                    if isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name) \
                            and t.value.id == "self":
                        names.add(t.attr)
    return names


def test_plugin_reads_each_declared_parameter_by_name():
    """The constructor assigns one attribute per parameter the schema declares
    for the plugin, by the parameter's name (as roughconductor reads each
    property): a parameter added to the schema and not read fails here."""
    declared = {p.name for p in schema.PARAMETERS if p.plugin}
    read = plugin_reads()
    assert declared <= read, f"declared but not read by the plugin: {sorted(declared - read)}"
    extra = read - declared - {"lobes", "m_components", "m_flags"}
    assert not extra, f"read by the plugin but not declared in schema.py: {sorted(extra)}"


def test_traverse_exposes_the_declared_parameters_with_their_flags():
    bsdf = mi.load_dict({"type": "pbrdf", "kdd": 0.1, "kid": 0.1})
    params = mi.traverse(bsdf)
    exposed = {key.split(".")[0] for key in params.keys()}
    # refinements (sigma_u ...) are exposed instead of what they refine only
    # where given (tests/bsdfs/test_microfacet.py)
    declared = {p.name for p in schema.PARAMETERS if p.plugin and p.differentiable
                and not p.refines}
    assert exposed == declared
    for p in schema.PARAMETERS:
        if p.name in exposed:
            key = next(k for k in params.keys() if k.split(".")[0] == p.name)
            flags = params.flags(key)
            assert bool(flags & mi.ParamFlags.Discontinuous) == p.discontinuous, p.name
            assert not (flags & mi.ParamFlags.NonDifferentiable), p.name
    # an absent lobe's parameters are not exposed
    names = {key.split(".")[0] for key in mi.traverse(mi.load_dict({"type": "pbrdf"})).keys()}
    assert names == {"eta", "k", *schema.LOBES["specular"]}


def test_lobes_follow_the_schema():
    bsdf = mi.load_dict({"type": "pbrdf", "kdd": 0.1, "kid": 0.1})
    assert [lobe.name for lobe in bsdf.lobes] == list(schema.LOBES)
    assert bsdf.component_count() == len(schema.LOBES)


def test_reference_record_has_one_field_per_parameter():
    from dataclasses import fields

    from mitsuba_pbrdf.reference import PBRDFParams

    record = PBRDFParams()
    assert [f.name for f in fields(record)] == list(schema.names(reference=True))
    for p in schema.PARAMETERS:
        if p.reference:
            assert getattr(record, p.name) == p.default
    for p in VALUED:
        if p.reference and p.name not in ("eta", "k"):   # sigma_u ... too
            with pytest.raises(ValueError, match=p.name):
                PBRDFParams(**{p.name: -1.0}).validate()


def test_command_options_are_the_schemas():
    from mitsuba_pbrdf.cli import build_parser

    parser = build_parser()
    subparsers = next(a for a in parser._actions if a.dest == "command").choices
    for command in ("plot", "export"):
        options = {a.dest: a for a in subparsers[command]._actions}
        for p in schema.PARAMETERS:
            if p.cli:
                assert p.name in options, (command, p.name)
                assert options[p.name].option_strings == [p.option]
                if p.kind not in ("material",):
                    assert options[p.name].default == p.default, (command, p.name)
                if p.kind == "choice":
                    assert tuple(options[p.name].choices) == p.choices
            else:
                assert p.name not in options
    fit_options = {a.dest for a in subparsers["fit"]._actions}
    assert set(schema.names(kind="choice", cli=True)) <= fit_options


def test_fit_layout_is_the_schemas():
    from mitsuba_pbrdf.fitting import vector as layout

    fitted = [p for p in schema.PARAMETERS if p.fit is not None]
    assert set(layout.SHARED + layout.PER_WAVELENGTH) == {p.fit.name or p.name for p in fitted}
    for p in fitted:
        name = p.fit.name or p.name
        assert layout.BOUNDS[name] == (p.fit.lower, p.fit.upper)
        assert p.fit.lower <= layout.DEFAULTS[name] <= p.fit.upper
        assert layout.PLUGIN_NAMES[name] == p.name
    assert layout.TWO_COMPONENT_FIXED == ("kdd", "sigma_dd")


ADD_ONE = r"""
import dataclasses, sys
from mitsuba_pbrdf import schema, schema_tables
extra = schema.Parameter("zeta", "float", 0.25, "A parameter declared only in the schema.",
                         positive=True, differentiable=True, cli=True)
schema.PARAMETERS = schema.PARAMETERS + (extra,)
schema._BY_NAME["zeta"] = extra
from mitsuba_pbrdf.reference import PBRDFParams
from mitsuba_pbrdf.cli import build_parser
p = PBRDFParams()
print("record", p.zeta)
try:
    PBRDFParams(zeta=-1.0).validate()
except ValueError as e:
    print("record-check", e)
args = build_parser().parse_args(["plot", "--zeta", "0.5"])
print("cli", args.zeta)
print("table", "`zeta`" in schema_tables.markdown_table())
sys.path.insert(0, "tests")
from test_schema import plugin_reads
print("plugin-unread", sorted(set(schema.names(plugin=True)) - plugin_reads()))
"""


def test_a_parameter_added_to_the_schema_reaches_every_consumer():
    """The proof that one declaration is enough: a parameter added to the
    schema alone (no physics) is in the reference's record and checked there,
    is a command-line option and is in the docs' table; the plugin, which
    reads each parameter by name as Mitsuba's plugins do, is caught not
    reading it (test_plugin_reads_each_declared_parameter_by_name)."""
    result = subprocess.run([sys.executable, "-c", ADD_ONE], capture_output=True, text=True,
                            cwd=ROOT, timeout=300)
    assert result.returncode == 0, result.stderr
    lines = dict(line.split(" ", 1) for line in result.stdout.splitlines())
    assert lines["record"] == "0.25"
    assert "zeta" in lines["record-check"]
    assert lines["cli"] == "0.5"
    assert lines["plugin-unread"] == "['zeta']"
    assert lines["table"] == "True"


def test_min_sigma_is_mitsubas_alpha_floor():
    assert np.isclose(np.sqrt(2.0) * schema.MIN_SIGMA, 1e-4)
    assert schema.parameter("sigma").floor == schema.parameter("sigma_dd").floor == schema.MIN_SIGMA


OTHER_PLUGINS = [name for name in schema.PLUGIN_PARAMETERS if name != "pbrdf"]


def test_every_registered_plugin_is_declared():
    from mitsuba_pbrdf.registry import PLUGINS

    assert sorted(schema.PLUGIN_PARAMETERS) == sorted(name for _, name, _, _ in PLUGINS)


@pytest.mark.parametrize("plugin", OTHER_PLUGINS)
def test_each_plugins_docstring_rows_are_its_declarations(plugin):
    """The other plugins' tables are written by hand around the declared rows,
    which are generated from schema.py."""
    import importlib

    from mitsuba_pbrdf.registry import PLUGINS

    module = importlib.import_module(next(m for _, name, m, _ in PLUGINS if name == plugin))
    for p in schema.PLUGIN_PARAMETERS[plugin]:
        assert schema_tables.rst_row(p) in module.__doc__, (
            f"{module.__name__}'s row of '{p.name}' is out of date: run "
            f"`python -m mitsuba_pbrdf.schema_tables {module.__file__}`")


@pytest.fixture(scope="module")
def stokes_map(tmp_path_factory):
    from mitsuba_pbrdf.stokes import write_stokes_exr

    path = tmp_path_factory.mktemp("decl") / "map.exr"
    stokes = np.zeros((2, 4, 4, 3), np.float32)
    stokes[:, :, 0] = 1.0
    write_stokes_exr(path, stokes, bands=["R", "G", "B"])
    return str(path)


def _scene(plugin, stokes_map):
    """A scene of plugin *plugin* that loads, as a dict."""
    raw = {"type": "bitmap", "raw": True, "filter_type": "nearest"}
    return {"polarized_sky": {"sun_direction": [0, 0.5, 1]},
            "polarized_emitter": {"lamp": {"type": "constant"}},
            "stokes_envmap": {"filename": stokes_map},
            "polarized_normalmap": {"normalmap": dict(raw, bitmap=mi.Bitmap(
                np.tile(np.float32([0.5, 0.5, 1.0]), (2, 2, 1)))), "bsdf": {"type": "diffuse"}},
            "polarized_bumpmap": {"height": dict(raw, bitmap=mi.Bitmap(
                np.zeros((2, 2, 1), np.float32))), "bsdf": {"type": "diffuse"}},
            }[plugin] | {"type": plugin}


def _declared(exclude):
    return [(plugin, p) for plugin in OTHER_PLUGINS for p in schema.PLUGIN_PARAMETERS[plugin]
            if not exclude(plugin, p)]


# stokes_prb's settings are read by Mitsuba's ADIntegrator and stokes_prb's own check, in
# their words (test_stokes_prb_runs_with_the_declared_defaults)
@pytest.mark.parametrize("plugin, p", _declared(lambda plugin, p: plugin == "stokes_prb"),
                         ids=lambda x: getattr(x, "name", x))
def test_each_plugin_checks_its_declared_parameters_at_load_time(plugin, p, stokes_map):
    """Each declared parameter is read through its declaration: a value out of
    its bounds, or of the wrong type, is refused with the declared words."""
    if p.lower is not None or p.upper is not None:
        bad = p.lower - 1 if p.lower is not None else p.upper + 1
        words = f"must be {re.escape(p.bound_doc)}"
    elif p.kind == "choice":
        bad, words = "no_such_choice", f"is 'no_such_choice'; valid values: {', '.join(p.choices)}"
    else:
        bad, words = "text", "must be a"
    mi.load_dict(_scene(plugin, stokes_map))
    with pytest.raises((RuntimeError, ValueError, TypeError),
                       match=f"{plugin}: parameter '{p.name}' {words}"):
        mi.load_dict(_scene(plugin, stokes_map) | {p.name: bad})


# bumpmap's scale is read by bumpmap.check_scale (tests/bsdfs/test_perturbed.py)
@pytest.mark.parametrize("plugin, p", _declared(lambda plugin, p: (plugin, p.name)
                                                == ("polarized_bumpmap", "scale")),
                         ids=lambda x: getattr(x, "name", x))
def test_declared_reads_give_the_default_and_refuse_what_is_out_of_bounds(plugin, p):
    from mitsuba_pbrdf import properties

    assert properties.declared(mi.Properties(), plugin, p.name) == p.default
    for bound, step in ((p.lower, -1.0), (p.upper, 1.0), (0.0 if p.positive else None, 0.0)):
        if bound is not None:
            props = mi.Properties()
            props[p.name] = bound + step
            with pytest.raises(ValueError, match=rf"^{plugin}: parameter '{p.name}' must be "
                                                 rf"{re.escape(p.bound_doc)}, got"):
                properties.declared(props, plugin, p.name)


def test_the_emitters_expose_the_differentiable_declarations():
    """``traverse`` puts a declared parameter as differentiable exactly where
    the declaration says so."""
    lamp = {"type": "constant"}
    emitters = {"polarized_sky": {"type": "polarized_sky", "sun_direction": [0, 0.5, 1],
                                  "radiance": 1.0},
                "polarized_emitter": {"type": "polarized_emitter", "lamp": lamp}}
    for plugin, scene in emitters.items():
        params = mi.traverse(mi.load_dict(scene))
        for p in schema.PLUGIN_PARAMETERS[plugin]:
            exposed = p.name in params.keys() and not (
                params.flags(p.name) & mi.ParamFlags.NonDifferentiable)
            assert exposed == p.differentiable, (plugin, p.name)


def test_the_declared_sunsky_defaults_are_sunskys():
    """polarized_sky hands only what is given to its internal ``sunsky``;
    the defaults its table states are sunsky's own: given explicitly, they
    change neither the sun nor the sky."""
    import drjit as dr

    if not (mi.is_rgb or mi.is_spectral):
        pytest.skip("sunsky needs an RGB or spectral variant")
    from mitsuba_pbrdf.emitters.polarized_sky import SUN_POSITION, SUNSKY_PARAMETERS

    given = {key: schema.parameter(key, "polarized_sky").default
             for key in (*SUNSKY_PARAMETERS, *SUN_POSITION)}
    default, explicit = (mi.load_dict({"type": "sunsky", **extra}) for extra in ({}, given))
    assert np.allclose(mi.traverse(default)["sun_direction"],
                       mi.traverse(explicit)["sun_direction"], rtol=0, atol=1e-6)
    # 15 directions over the sphere and the sun's centre (sun_scale, sun_aperture)
    w = np.random.default_rng(1).normal(size=(3, 15))
    sun = np.array(mi.traverse(default)["sun_direction"], np.float64).reshape(3, 1)
    w = np.concatenate([w / np.linalg.norm(w, axis=0), sun], 1)
    si = dr.zeros(mi.SurfaceInteraction3f, 16)
    si.wi = mi.Vector3f(*(-w))    # an infinite emitter is seen along -si.wi
    if mi.is_spectral:
        si.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
    assert np.array_equal(np.array(default.eval(si)), np.array(explicit.eval(si)))


def test_stokes_prb_runs_with_the_declared_defaults():
    from mitsuba_pbrdf.integrators.support import MAX_DEPTH_LIMIT, usable_variant

    if not usable_variant(mi.variant()):
        pytest.skip("stokes_prb needs a polarized JIT variant")
    integrator = mi.load_dict({"type": "stokes_prb"})
    for p in schema.PLUGIN_PARAMETERS["stokes_prb"]:
        assert getattr(integrator, p.name) == p.default, p.name
    assert MAX_DEPTH_LIMIT == schema.parameter("max_depth", "stokes_prb").upper
    with pytest.raises(Exception, match="greater than zero"):   # Mitsuba's check of rr_depth
        mi.load_dict({"type": "stokes_prb", "rr_depth": 0})

