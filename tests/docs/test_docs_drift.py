"""README.md and docs/*.md against what they describe: links and anchors
resolve; Python snippets import names that exist; every option a page gives
exists; every full ``pbrdf`` command parses and names files and ``-D`` keys
that exist; a measured time or memory figure is in a report its block links;
tables copied from code match it. README's commands run in order (slow)."""

import ast
import glob
import importlib
import importlib.util
import os
import re
import shlex
import textwrap

import pytest

from mitsuba_pbrdf.cli import build_parser
from mitsuba_pbrdf.rendering.scene_params import declared_parameters

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
DOCS = ["README.md"] + sorted(f"docs/{n}" for n in os.listdir(os.path.join(ROOT, "docs"))
                              if n.endswith(".md"))


def read(path):
    with open(os.path.join(ROOT, path), encoding="utf-8") as f:
        return f.read()


def prose(text):
    """*text* with its fenced code blocks blanked (line numbers kept)."""
    return re.sub(r"^[ \t]*```.*?^[ \t]*```", lambda m: "\n" * m.group(0).count("\n"),
                  text, flags=re.S | re.M)


# ---------------------------------------------------------------- links, snippets, code map

def links(doc):
    """``(file relative to the root, anchor)`` of each relative link outside code."""
    for target in re.findall(r"\]\(([^)\s]+)\)", re.sub(r"`[^`\n]*`", "", prose(read(doc)))):
        if not re.match(r"[a-z]+:", target):
            file, _, anchor = target.partition("#")
            yield (os.path.normpath(os.path.join(os.path.dirname(doc), file)) if file else doc,
                   anchor)


def anchors(doc):
    """The anchors GitHub gives *doc*'s headings."""
    return {re.sub(r"[^\w\- ]", "", re.sub(r"[`*]", "", h.strip().lower())).replace(" ", "-")
            for h in re.findall(r"^#{1,6} (.+)$", prose(read(doc)), flags=re.M)}


@pytest.mark.parametrize("doc", DOCS)
def test_links_resolve(doc):
    bad = [f"{file}#{anchor}".rstrip("#") for file, anchor in links(doc)
           if not os.path.exists(os.path.join(ROOT, file))
           or anchor and file.endswith(".md") and anchor not in anchors(file)]
    assert not bad, f"{doc}: links to no such file or heading: {bad}"
    if doc == "README.md":  # README is the index of docs/
        assert sorted(set(DOCS[1:]) - {f for f, _ in links(doc)}) == [], "unlinked from README"


@pytest.mark.parametrize("doc", DOCS)
def test_python_snippets_parse_and_import_what_exists(doc):
    """Running them is for examples/ and by hand: some render for minutes."""
    for code in re.findall(r"^[ \t]*```python\n(.*?)^[ \t]*```", read(doc), flags=re.S | re.M):
        for node in ast.walk(ast.parse(textwrap.dedent(code))):
            if isinstance(node, ast.ImportFrom) and node.module.startswith("mitsuba_pbrdf"):
                module = importlib.import_module(node.module)
                for a in node.names:
                    assert hasattr(module, a.name) or importlib.util.find_spec(
                        f"{node.module}.{a.name}"), f"{doc}: {node.module}.{a.name}"
            elif isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.startswith("mitsuba_pbrdf"):
                        importlib.import_module(a.name)


def test_layout_page_names_every_subpackage_and_module():
    text, package = read("docs/layout.md"), os.path.join(ROOT, "mitsuba_pbrdf")
    missing = [n for n in os.listdir(package) if n != "__pycache__" and (
        n.endswith(".py") and n not in text
        or os.path.isdir(os.path.join(package, n)) and f"  {n}/" not in text)]
    assert not missing, f"docs/layout.md's tree lacks mitsuba_pbrdf/{missing}"


# ---------------------------------------------------------------- commands and options

PARSER = build_parser()
SUBPARSERS = {None: PARSER, **next(a for a in PARSER._actions
                                   if a.__class__.__name__ == "_SubParsersAction").choices}
OPTIONS = {c: {s for a in p._actions for s in a.option_strings} for c, p in SUBPARSERS.items()}
#: Commands that take a file first: ``render --bands 450:650:50`` inline is a fragment.
POSITIONAL = {c for c, p in SUBPARSERS.items() if any(
    a.required and not a.option_strings for a in p._actions)}
PLACEHOLDER = re.compile(r"[A-Z]{3}|[<>{}\[\]|]|\.\.\.|…")


def commands(doc):
    """``(line, command, args, in_block)`` of each ``pbrdf`` command that starts
    a line of a code block (a line after ``\\``, or starting ``[`` or ``-``,
    continues it), an inline code span or a table row's first cell (cli.md),
    or follows ``&&``; ``pbrdf-fit`` is ``fit``, ``None`` the top-level command."""
    pieces, fenced = [], False
    for i, line in enumerate(read(doc).splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif fenced and pieces and pieces[-1][0] == i - 1 and (
                pieces[-1][1].endswith("\\") or line.lstrip().startswith(("[", "-"))):
            pieces[-1] = (i, pieces[-1][1].rstrip("\\") + " " + line.split(" #")[0].strip(), True)
        elif fenced:
            pieces.append((i, line.split(" #")[0].rstrip(), True))
        else:
            spans = re.findall(r"`([^`]+)`", line.replace("\\|", "|"))
            if line.startswith("| `") and spans and spans[0].split()[0] in OPTIONS:
                spans[0] = "pbrdf " + spans[0]
            pieces += [(i, s, False) for s in spans]
    for i, text, block in pieces:
        for part in re.split(r"&&|;", text):
            try:
                words = shlex.split(part)
            except ValueError:  # an unpaired quote: prose, not a command
                words = part.split()
            if words[:1] == ["pbrdf-fit"]:
                words = ["pbrdf", "fit"] + words[1:]
            elif words[1:3] == ["-m", "mitsuba_pbrdf"]:
                words = ["pbrdf"] + words[3:]
            if words[:1] == ["pbrdf"] and words[1:] and (words[1] in OPTIONS or words[1][0] == "-"):
                c = words[1] if words[1] in OPTIONS else None
                yield i, c, words[2 if c else 1:], block


@pytest.mark.parametrize("doc", DOCS)
def test_every_option_a_page_names_exists(doc):
    """An option given to a ``pbrdf`` command is that command's; any other
    ``--option`` is some command's, a study or benchmark script's, install.sh's."""
    bad = [f"line {i}: pbrdf {c or ''} {o}" for i, c, args, _ in commands(doc) for word in args
           for o in re.findall(r"(?<![\w-])--?[a-zA-Z][\w-]*", word)
           if (o.startswith("--") or o in ("-D", "-h")) and o not in OPTIONS[c]]
    known = set().union(*OPTIONS.values(), {"--collect-only"}, re.findall(
        r"^\s*(--[\w-]+)\)", read("install.sh"), flags=re.M))
    for script in glob.glob(f"{ROOT}/validation/*.py") + glob.glob(f"{ROOT}/benchmarks/*.py"):
        known.update(re.findall(r"add_argument\(\s*[\"'](--[\w-]+)", read(script)))
    bad += sorted(set(re.findall(r"(?<![\w-])--[a-zA-Z][\w-]*", read(doc))) - known)
    assert not bad, f"{doc}: options that no --help lists: {bad}"


def full_commands(doc):
    """The commands of *doc* given in full: no placeholder (``SCENE.xml``,
    ``[--x]``, ``...``) and not an inline fragment (``render --bands 450:650:50``)."""
    return [(i, [c] + args if c else args) for i, c, args, block in commands(doc)
            if not any(PLACEHOLDER.search(w) and not os.path.exists(f"{ROOT}/{w}") for w in args)
            and (block or any(not w.startswith("-") for w in args)
                 and (c not in POSITIONAL or not args[0].startswith("-")))]


@pytest.mark.parametrize("doc", DOCS)
def test_every_full_command_parses_and_names_what_exists(doc):
    """Each parses (argparse, in-process); the repository files it names exist;
    each ``-D`` key of a render is one of its scene's parameters."""
    bad = []
    for i, argv in full_commands(doc):
        try:
            PARSER.parse_args(argv)
        except SystemExit as e:
            bad += [f"line {i}: {argv} does not parse"] if e.code else []
        files = [w for w in argv if w.startswith(("scenes/", "validation/", "tests/", "examples/"))]
        bad += [f"line {i}: no {f}" for f in files if not os.path.exists(os.path.join(ROOT, f))]
        keys = {argv[k + 1].partition("=")[0] for k, w in enumerate(argv[:-1]) if w == "-D"}
        if keys and os.path.isfile(os.path.join(ROOT, argv[1])):
            bad += [f"line {i}: {argv[1]} has no -D {k}" for k in
                    keys - declared_parameters(os.path.join(ROOT, argv[1]))]
    assert not bad, f"{doc}:\n" + "\n".join(bad)


# ---------------------------------------------------------------- figures and tables

NUMBER = r"(?<![\w.])\d[\d,]*(?:\.\d+)?"
FIGURE = re.compile(rf"({NUMBER})\s?(?:ms|s|min|h|MiB|GiB|kB|MB|GB)\b")


def quoted(figure, report):
    """Whether *report* holds *figure* as written or rounded to its decimals
    (``1.60`` quotes 1.604; ``1.6`` is not in 11.6)."""
    value, places = float(figure.replace(",", "")), len(figure.partition(".")[2])
    return any(round(float(n.replace(",", "")), places) == value
               for n in re.findall(NUMBER, report))


@pytest.mark.parametrize("doc", DOCS)
def test_every_measured_figure_is_in_a_linked_report(doc):
    """A time or memory figure in prose (code spans are settings) is in a
    ``benchmarks/*.md`` or ``validation/*.md`` report linked from its block
    (paragraph, list item, table), which gives the command that produced it."""
    bad = []
    for block in re.split(r"\n[ \t]*\n", prose(read(doc))):
        reports = [os.path.normpath(os.path.join(os.path.dirname(doc), r))
                   for r in re.findall(r"\]\(([^)#\s]+\.md)", block)]
        reports = [read(r) for r in reports if r.startswith(("benchmarks/", "validation/"))
                   and os.path.isfile(os.path.join(ROOT, r))]
        for m in FIGURE.finditer(re.sub(r"`[^`]*`|\]\([^)\s]*\)", "", block)):
            if not any(quoted(m.group(1), r) for r in reports):
                bad.append(f"{m.group(0)!r} ({'not in the' if reports else 'no'} linked report) "
                           f"in: {block.strip()[:80]}")
    assert not bad, f"{doc}: link the report, or write a setting as code:\n" + "\n".join(bad)


def test_stokes_prb_parameter_table_is_the_integrators():
    """docs/path-replay.md's table has the names and defaults of the
    integrator's docstring table."""
    from mitsuba_pbrdf.integrators import stokes_prb

    rows = re.findall(r"\* - ``(\w+)``\n\s+- \w+\n(?:.*\n)*?\s+- (\S+)\n", stokes_prb.__doc__)
    assert {name for name, _ in rows} == {"max_depth", "rr_depth", "hide_emitters"}
    assert dict(re.findall(r"^\| `(\w+)` \| \w+ \| (\S+) \|", read("docs/path-replay.md"),
                           flags=re.M)) == dict(rows)


def test_gallery_help_names_every_gallery_item():
    from mitsuba_pbrdf.visualization.gallery import GALLERY_ITEMS

    only = next(a for a in SUBPARSERS["gallery"]._actions if "--only" in a.option_strings)
    assert [i for i in GALLERY_ITEMS if i not in only.help] == []


def test_the_checks_read_every_form_a_doc_uses():
    """Not vacuous: commands in code blocks, inline, in cli.md's table, continued
    by ``[`` or a ``\\``; figures as written or rounded, not inside other numbers."""
    found = {(d, c, w) for d in DOCS for _, c, args, _ in commands(d) for w in args}
    assert {("README.md", "plot", "--theta-i"), ("README.md", "render", "-D"),
            ("docs/cli.md", "polcam", "--full-well"), ("docs/batch.md", "batch", "--walltime"),
            ("docs/fitting.md", "fit", "[--abs-uncertainty")} <= found
    assert FIGURE.findall("1.60 s, 11.6 min; 236 MiB") == ["1.60", "11.6", "236"]
    assert quoted("1.60", "| 1.604 |") and not quoted("1.6", "11.6 s") and quoted("3", "2.9")


# ---------------------------------------------------------------- README's commands

def test_readme_test_command_is_ci_and_its_install_brings_dask():
    """``.ci/run`` ends with README's test command; README's install (no
    extra) brings Dask, which its ``pbrdf batch`` example needs."""
    import tomllib

    blocks = re.findall(r"```bash\n(.*?)\n```", read("README.md"), flags=re.S)
    assert [b for b in blocks if "pytest" in b] == [read(".ci/run").strip().splitlines()[-1]]
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        assert "dask[distributed]" in tomllib.load(f)["project"]["dependencies"]
    assert any(argv[0] == "batch" for _, argv in full_commands("README.md"))


#: Renders shrunk to 32 x 24 pixels at 4 spp (every scene README renders has
#: width and height defaults); the gallery and the sweeps are left out (minutes
#: of rendering; ``pbrdf gallery`` and ``batch`` have tests of their own).
SHRINK = ["-D", "width=32", "-D", "height=24", "--spp", "4"]


@pytest.mark.slow
def test_readme_commands_run_in_order(tmp_path, monkeypatch, capsys):
    """From a folder holding only the repository's scenes, README's commands
    exit 0 in README's order and write the files later ones read."""
    from mitsuba_pbrdf import variant
    from mitsuba_pbrdf.cli import main

    monkeypatch.setattr(variant, "cuda_available", lambda: False)
    monkeypatch.chdir(tmp_path)
    os.symlink(os.path.join(ROOT, "scenes"), tmp_path / "scenes")
    for line, argv in full_commands("README.md"):
        if argv[0] not in ("gallery", "batch"):
            argv += SHRINK if argv[0] == "render" else []
            assert main(argv) == 0, f"README.md:{line}: {argv}: {capsys.readouterr().err}"
    for name in ("out/default.png", "out/polarizer45.exr", "cu.png", "out/cam"):
        assert os.path.exists(name), name
