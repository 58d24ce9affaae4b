"""Every plugin's parameter table is written in its module docstring (one
convention for the BSDFs, the integrator and the emitters) and lists exactly
the parameters its constructor reads.

The reads are found in the source: the first string passed with ``props``
to a call (``props.get("x")``, ``read.number(props, NAME, "x")``), used as
``props["x"]`` or ``"x" in props``, and the keys of module-level tuples or
dicts iterated against ``props``. Parameters read by a Python base class
(Mitsuba's ``ADIntegrator``, ``bsdfs/perturbed.wrapper_base``) are found the
same way in its ``__init__``; those
that a C++ base reads are listed below with where they are read. pbrdf's
table and the other plugins' declared rows are also checked against schema.py
(tests/test_schema.py)."""

import ast
import importlib
import inspect
import re
import textwrap

import pytest

from mitsuba_pbrdf import schema
from mitsuba_pbrdf.registry import PLUGINS, plugin_class

#: Parameters that a C++ base class of Mitsuba reads for the plugin.
CPP_BASE_READS = {
    "stokes_prb": {"hide_emitters"},   # mi.SamplingIntegrator (src/render/integrator.cpp)
}

#: Parameters read under names the schema derives (Mitsuba's ``alpha`` beside
#: ``sigma``: ``bsdfs/pbrdf_properties.read_width``); tests/bsdfs/test_pbrdf_properties.py loads each.
SCHEMA_READS = {"pbrdf": set(schema.ALIASES)}


def documented(docstring: str) -> set:
    """The ``name`` of each row's first cell of the docstring's list-table."""
    names = set()
    for cell in re.findall(r"^ *\* - (.*)$", docstring, re.M):
        names |= set(re.findall(r"``(\w+)``", cell))
    return names


def _string_constants(node, constants):
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return {node.value}
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return set().union(*(_string_constants(e, constants) for e in node.elts))
    if isinstance(node, ast.Starred):
        return _string_constants(node.value, constants)
    if isinstance(node, ast.Name):
        return set(constants.get(node.id, ()))
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
            and isinstance(node.func.value, ast.Name):   # SUNSKY_PARAMETERS.items()
        return set(constants.get(node.func.value.id, ()))
    return set()


def reads(source: str) -> set:
    """The parameter names the code in *source* reads from ``props``."""
    tree = ast.parse(textwrap.dedent(source))
    constants = {}
    for node in tree.body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 \
                and isinstance(node.targets[0], ast.Name):
            value = node.value
            keys = value.keys if isinstance(value, ast.Dict) else \
                value.elts if isinstance(value, (ast.Tuple, ast.List, ast.Set)) else []
            constants[node.targets[0].id] = {k.value for k in keys
                                             if isinstance(k, ast.Constant) and isinstance(k.value, str)}

    def is_props(n):
        return isinstance(n, ast.Name) and n.id == "props"

    found = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.Call) and (any(is_props(a) for a in n.args)
                                        or isinstance(n.func, ast.Attribute) and is_props(n.func.value)):
            keys = [a.value for a in n.args if isinstance(a, ast.Constant) and isinstance(a.value, str)]
            found |= set(keys[:1])   # the key; a later string is a default
        elif isinstance(n, ast.Subscript) and is_props(n.value):
            found |= _string_constants(n.slice, constants)
        elif isinstance(n, ast.Compare) and any(isinstance(o, (ast.In, ast.NotIn)) for o in n.ops) \
                and any(is_props(c) for c in n.comparators):
            found |= _string_constants(n.left, constants)
        elif isinstance(n, ast.For) and any(
                isinstance(c, ast.Compare) and any(is_props(x) for x in c.comparators)
                for c in ast.walk(n) if c is not n):
            found |= _string_constants(n.iter, constants)
        elif isinstance(n, ast.comprehension) and any(
                isinstance(c, ast.Compare) and any(is_props(x) for x in c.comparators) for c in n.ifs):
            found |= _string_constants(n.iter, constants)
    return found


def python_base_reads(cls) -> set:
    """What the ``__init__`` of *cls*'s Python base classes (Mitsuba's, the
    package's) read."""
    found = set()
    for base in cls.__mro__[1:]:
        init = base.__dict__.get("__init__")
        if init is not None and getattr(base, "__module__", "").startswith(
                ("mitsuba.", "mitsuba_pbrdf.")) \
                and inspect.isfunction(init):   # Python code, not a C++ binding
            found |= reads(inspect.getsource(init))
    return found


@pytest.mark.parametrize("kind, name, module, cls", PLUGINS, ids=[p[1] for p in PLUGINS])
def test_the_table_lists_exactly_what_the_constructor_reads(kind, name, module, cls):
    source = inspect.getsource(importlib.import_module(module.rsplit(".", 1)[0] + "." +
                                                       module.rsplit(".", 1)[1]))
    docstring = ast.get_docstring(ast.parse(source))
    assert docstring and ".. list-table::" in docstring, f"{module}: no parameter table"
    table = documented(docstring)
    read = (reads(source) | python_base_reads(plugin_class(name)) | CPP_BASE_READS.get(name, set())
            | SCHEMA_READS.get(name, set()))
    assert table == read, (f"{module}: documented but not read {sorted(table - read)}; "
                           f"read but not documented {sorted(read - table)}")


def test_the_scan_sees_each_way_of_reading():
    source = '''
KEYS = {"a": 1, "b": 2}
def f(props):
    props.get("c", "default"); read.number(props, NAME, "d"); props["e"]; "g" in props
    for key in KEYS:
        if key in props:
            pass
    [k for k in ("h", "i") if k in props]
    read.declared(props, NAME, "j")
'''
    assert reads(source) == set("abcdeghij")
    assert documented("   * - ``x``, ``y``\n     - float\n   * - (nested)\n") == {"x", "y"}
