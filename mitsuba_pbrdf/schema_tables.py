"""The declarations of :mod:`mitsuba_pbrdf.schema` written as tables: the
Markdown table of ``docs/plugin.md`` (:func:`markdown_table`), ``pbrdf``'s
docstring list-table (:func:`rst_table`) and each declared row of another
plugin's docstring table (:func:`rst_row`), and the rewriting of those files
in place (``python -m mitsuba_pbrdf.schema_tables docs/plugin.md PLUGIN_MODULE.py
...``). Pure Python, as the schema; tests/test_schema.py checks each table.
"""

from __future__ import annotations

import re
from typing import Tuple

from . import schema

__all__ = ["markdown_table", "rst_table", "rst_row", "docs_table", "write_docs_table",
           "write_plugin_docstring_table", "TABLE_START", "TABLE_END", "main"]

_KIND_DOC = {"spectrum": "spectrum or texture", "float": "float or texture",
             "choice": "string", "material": "string", "number": "float",
             "integer": "integer", "boolean": "boolean"}


def _documented() -> Tuple[schema.Parameter, ...]:
    """The plugin's parameters in table order, each followed by its alias."""
    return tuple(q for p in schema.PARAMETERS if p.plugin
                 for q in ((p, schema.ALIASES[p.alias.name]) if p.alias else (p,)))


def _flags(p: schema.Parameter) -> str:
    if p.flags_doc:
        return p.flags_doc
    if not p.differentiable:
        return "--"
    refined = (p.stands_for or p.name) in schema.REFINEMENTS
    exposed = ("exposed where the lobe is anisotropic" if p.refines else
               "exposed where the lobe is isotropic" if refined else "exposed")
    return exposed + ", differentiable" + (", discontinuous" if p.discontinuous else "")


def _default(p: schema.Parameter) -> str:
    if p.stands_for:
        return "--"
    if p.refines:
        return f"``{p.default_doc}``"
    if p.kind == "boolean":
        return str(p.default).lower()
    return p.default_doc if p.default_doc else f"``{p.default}``" if p.kind in (
        "choice", "material") else f"{p.default:g}"


def markdown_table() -> str:
    """The plugin's parameter table in Markdown (``docs/plugin.md``)."""
    rows = ["| name | type | default | unit | valid (typical) | meaning | flags |",
            "|---|---|---|---|---|---|---|"]
    for p in _documented():
        if p.plugin:
            valid = p.bound_doc.replace("``", "`")
            if p.typical:
                valid = f"{valid} ({p.typical})" if valid else p.typical
            rows.append(f"| `{p.name}` | {_KIND_DOC[p.kind]} | {_default(p).replace('``', '`')} "
                        f"| {p.unit} | {valid} | {p.doc} | {_flags(p)} |")
    return "\n".join(rows) + "\n"


def rst_table() -> str:
    """The same table as a reStructuredText list-table (the plugin's docstring)."""
    lines = [".. list-table::", "   :header-rows: 1", "",
             "   * - Parameter", "     - Type", "     - Description", "     - Default",
             "     - Flags"]
    return "\n".join(lines) + "\n" + "".join(rst_row(p) for p in _documented() if p.plugin)


def rst_row(p: schema.Parameter) -> str:
    """Parameter *p*'s row of a plugin docstring's list-table."""
    bound = f" Valid: {p.bound_doc}." if p.bound_doc else ""
    return "\n".join([f"   * - ``{p.name}``", f"     - {_KIND_DOC[p.kind]}",
                      f"     - {p.doc}{bound}", f"     - {_default(p)}",
                      f"     - {_flags(p)}"]) + "\n"


#: The markers around the generated table in ``docs/plugin.md``.
TABLE_START = "<!-- schema table: generated from mitsuba_pbrdf/schema.py"
TABLE_END = "<!-- end of schema table -->"


def docs_table(text: str) -> str:
    """The generated table as it stands in *text* (a Markdown file), between
    :data:`TABLE_START`'s line and :data:`TABLE_END`."""
    start = text.index("\n", text.index(TABLE_START)) + 1
    return text[start:text.index(TABLE_END, start)]


def write_docs_table(path: str) -> None:
    """Replace the generated table in Markdown file *path* by :func:`markdown_table`."""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    old = docs_table(text)
    start = text.index(old, text.index(TABLE_START))
    with open(path, "w", encoding="utf-8") as f:
        f.write(text[:start] + markdown_table() + text[start + len(old):])


def write_plugin_docstring_table(path: str) -> None:
    """Rewrite the declared rows of the ``.. list-table::`` in plugin module
    *path* (the plugin: the file's first ````name````): ``pbrdf``'s whole
    table is :func:`rst_table`, another plugin's declared rows each its
    :func:`rst_row`, in place."""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    plugin = re.search(r"``(\w+)``", text).group(1)
    if plugin == "pbrdf":
        start = text.index(".. list-table::")
        end = text.index("\n\n", text.index("   * - ", start) + 1)
        while text.startswith("   ", end + 2) or text.startswith("     ", end + 1):
            end = text.index("\n\n", end + 1)
        text = text[:start] + rst_table().rstrip("\n") + text[end:]
    for p in schema.PLUGIN_PARAMETERS[plugin] if plugin != "pbrdf" else ():
        start = text.index(f"   * - ``{p.name}``\n")
        # the row runs to the next row or the end of the table
        end = re.compile(r"^(?! {5})", re.M).search(text, text.index("\n", start) + 1).start()
        text = text[:start] + rst_row(p) + text[end:]
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def main(targets) -> None:
    """Rewrite each of *targets*: a plugin module (``.py``) or a Markdown
    file; with none, print the Markdown table."""
    for target in targets:
        (write_plugin_docstring_table if target.endswith(".py") else write_docs_table)(target)
    if not targets:
        print(markdown_table(), end="")


if __name__ == "__main__":  # python -m mitsuba_pbrdf.schema_tables docs/plugin.md PLUGIN_MODULE.py ...
    import sys

    main(sys.argv[1:])
