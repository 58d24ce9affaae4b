"""Docs that cannot drift: every measured time or memory figure a doc quotes
is in a report its paragraph links (``tests/doc_figures.py``), and every
option a doc gives a ``pbrdf`` command is one that command's ``--help``
lists (the argparse parser is built in-process; nothing is rendered)."""

import os
import re

import pytest

from mitsuba_pbrdf.cli import build_parser
from mitsuba_pbrdf.rendering.scene_params import declared_parameters

from doc_figures import doc_files, prose_lines, read, unsourced

DOCS = doc_files()


# ---------------------------------------------------------------- figures

@pytest.mark.parametrize("doc", DOCS)
def test_every_measured_figure_is_in_a_linked_report(doc):
    bad = unsourced(doc)
    assert not bad, ("time/memory figures that no report linked from their paragraph holds "
                     "(link the report, or write a setting as code):\n" + "\n".join(bad))


def test_the_figure_check_can_fail(tmp_path, monkeypatch):
    """Not vacuous: a figure its linked report lacks, and a figure with no
    report linked, are reported; a rounded figure, a setting in code and a
    figure of a code block are not."""
    import doc_figures

    reports = tmp_path / "benchmarks"  # a made-up report folder
    reports.mkdir()
    (tmp_path / "notes").mkdir()
    (reports / "r.md").write_text("| drjit | 1.604 s |\n")
    (tmp_path / "notes" / "page.md").write_text(
        f"drjit 1.60 s, reference 3.52 s ([r](../{reports.name}/r.md)).\n\n"
        "took 9 s here, timeout `20 s`.\n\n```\ncode 5 s\n```\n")
    monkeypatch.setattr(doc_figures, "ROOT", str(tmp_path))
    assert doc_figures.unsourced(os.path.join("notes", "page.md")) == [
        "notes/page.md:1: 3.52 s (in none of the linked reports)",
        "notes/page.md:3: 9 s (no report linked)"]


# ---------------------------------------------------------------- options

COMMAND = re.compile(r"(?:\bpbrdf(?:-fit)?|python -m mitsuba_pbrdf)\s+(?P<rest>.*)")


def subcommand_options():
    """``{command: set of option strings}`` from the argparse parser itself
    (``None``: the top-level options)."""
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    options = {None: {s for a in parser._actions for s in a.option_strings}}
    for name, p in sub.choices.items():
        options[name] = {s for a in p._actions for s in a.option_strings}
    return options


def command_spans(doc):
    """``(line, text)`` of every piece of a doc that gives a ``pbrdf`` command:
    each line of a code block (indented lines continue the command above)
    and each inline code span that starts with ``pbrdf``, ``pbrdf-fit`` or
    ``python -m mitsuba_pbrdf``; in a table whose rows start with a
    subcommand (docs/cli.md), that first cell."""
    text = read(doc)
    lines = text.splitlines()
    prose = prose_lines(text)
    spans = []
    fenced = False
    for i, line in enumerate(lines):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if fenced:
            if line.startswith((" ", "\t")) and spans and spans[-1][0] == i:
                spans[-1] = (i + 1, spans[-1][1] + " " + line.strip())
            else:
                spans.append((i + 1, line))
    for i, line in enumerate(prose):
        for span in re.findall(r"`([^`]+)`", line.replace("\\|", "|")):
            spans.append((i + 1, span))
        row = re.match(r"^\|\s*`(?P<cell>[a-z]+ [^`]*)`\s*\|", line)
        if row:
            spans.append((i + 1, "pbrdf " + row.group("cell").replace("\\|", "|")))
    return spans


def named_options(doc, commands):
    """``(line, command, option)`` of every ``--option`` given to a ``pbrdf``
    command in *doc* (``pbrdf-fit`` is ``pbrdf fit``)."""
    for line, span in command_spans(doc):
        for m in COMMAND.finditer(span):
            words = m.group("rest").split()
            if "pbrdf-fit" in m.group(0):
                command, args = "fit", words
            elif words and words[0] in commands:
                command, args = words[0], words[1:]
            elif words and words[0].startswith("-"):
                command, args = None, words
            else:
                continue
            # stop at the next command in the same span, or a shell comment
            for word in args:
                if word.startswith("#") or word in ("pbrdf", "&&", ";"):
                    break
                for option in re.findall(r"(?<![\w-])--?[a-zA-Z][\w-]*", word):
                    if option.startswith("--") or option in ("-D", "-h"):
                        yield line, command, option


@pytest.mark.parametrize("doc", DOCS)
def test_every_option_a_doc_names_is_in_the_help(doc):
    options = subcommand_options()
    commands = {c for c in options if c}
    named = list(named_options(doc, commands))
    bad = [f"{doc}:{line}: pbrdf {command or ''} {option}" for line, command, option in named
           if option not in options[command] and option != "-D" or
           option == "-D" and command not in ("render", None)]
    assert not bad, "options that `--help` does not list:\n" + "\n".join(bad)


def test_the_option_check_reads_the_docs():
    """The option check is not vacuous: it finds the options of README's and
    cli.md's commands (table rows, code blocks, continued lines)."""
    commands = {c for c in subcommand_options() if c}
    readme = {(c, o) for _, c, o in named_options("README.md", commands)}
    assert {("plot", "--theta-i"), ("batch", "--workers"), ("render", "-D")} <= readme
    cli = {(c, o) for _, c, o in named_options("docs/cli.md", commands)}
    assert {("polcam", "--full-well"), ("export", "--grid"), ("gallery", "--only")} <= cli
    fitting = {(c, o) for _, c, o in named_options("docs/fitting.md", commands)}
    assert ("fit", "--abs-uncertainty") in fitting  # on the continued usage line


def test_gallery_help_lists_every_gallery_item():
    from mitsuba_pbrdf.visualization.gallery import GALLERY_ITEMS

    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    only = next(a for a in sub.choices["gallery"]._actions if "--only" in a.option_strings)
    assert [i for i in GALLERY_ITEMS if i not in only.help] == []


def test_stokes_prb_parameter_table_matches_the_integrator():
    """docs/path-replay.md's parameter table lists exactly the parameters and
    defaults of the integrator's own docstring table."""
    from mitsuba_pbrdf.integrators import stokes_prb

    doc = stokes_prb.__doc__
    rows = re.findall(r"\* - ``(\w+)``\n\s+- (\w+)\n(?:.*\n)*?\s+- (\S+)\n", doc)
    assert {r[0] for r in rows} == {"max_depth", "rr_depth", "hide_emitters"}
    page = read("docs/path-replay.md")
    documented = dict(re.findall(r"^\| `(\w+)` \| \w+ \| (\S+) \|", page, flags=re.M))
    assert documented == {name: default for name, _, default in rows}


def rendered_and_read(doc, commands):
    """``(line, kind, path)`` in the order of *doc*: ``("writes", out/x.exr)``
    for each ``pbrdf render`` and ``("reads", x.exr)`` for each ``pbrdf view``
    or ``pbrdf polcam`` of a concrete (not upper-case placeholder) EXR; a
    ``polcam`` with ``--out`` also writes its EXRs in that folder."""
    for line, span in sorted(command_spans(doc), key=lambda s: s[0]):
        for m in COMMAND.finditer(span):
            words = m.group("rest").split()
            if not words or words[0] not in ("render", "view", "polcam") or len(words) < 2:
                continue
            target = words[1]
            if words[0] == "render":
                out = words[words.index("--out") + 1] if "--out" in words[:-1] else None
                stem = out or "out/" + os.path.splitext(os.path.basename(target))[0]
                yield line, "writes", stem.removesuffix(".exr") + ".exr"
            elif target.endswith(".exr") and not re.search(r"[A-Z]{3}|[<>{}]", target):
                yield line, "reads", target
                if words[0] == "polcam" and "--out" in words[:-1]:  # what polcam writes
                    folder = words[words.index("--out") + 1]
                    stem = os.path.splitext(os.path.basename(target))[0]
                    for suffix in ("I0", "I45", "I90", "I135", "mosaic", "mosaic_rgb"):
                        yield line, "writes", f"{folder}/{stem}_{suffix}.exr"


@pytest.mark.parametrize("doc", DOCS)
def test_every_exr_a_doc_views_is_rendered_first(doc):
    """A doc that views or feeds ``out/x.exr`` to ``polcam`` runs the render
    that writes it first (in the same doc, or README's quick start)."""
    commands = {c for c in subcommand_options() if c}
    written = {p for _, kind, p in rendered_and_read("README.md", commands)
               if kind == "writes"} if doc != "README.md" else set()
    missing = []
    for line, kind, path in rendered_and_read(doc, commands):
        if kind == "writes":
            written.add(path)
        elif path not in written:
            missing.append(f"{doc}:{line}: {path}")
    assert not missing, "EXRs read before any render writes them:\n" + "\n".join(missing)


def script_options():
    """Options that the repository's validation and benchmark scripts define
    (their ``add_argument("--x", ...)`` calls), and those ``install.sh`` takes."""
    import glob

    from doc_figures import ROOT

    found = set()
    install = os.path.join(ROOT, "install.sh")
    if os.path.isfile(install):
        with open(install, encoding="utf-8") as f:
            found.update(re.findall(r"^\s*(--[\w-]+)\)", f.read(), flags=re.M))  # case arms
    for path in glob.glob(os.path.join(ROOT, "validation", "*.py")) + glob.glob(
            os.path.join(ROOT, "benchmarks", "*.py")):
        with open(path, encoding="utf-8") as f:
            found.update(re.findall(r"add_argument\(\s*[\"'](--[\w-]+)", f.read()))
    return found


@pytest.mark.parametrize("doc", DOCS)
def test_every_option_anywhere_in_a_doc_exists(doc):
    """Options the docs mention outside a ``pbrdf`` command line (in prose,
    or for a study script) are options of some ``pbrdf`` command, of a
    validation or benchmark script, or pytest's ``--collect-only``."""
    known = set().union(*subcommand_options().values()) | script_options() | {"--collect-only"}
    named = set(re.findall(r"(?<![\w-])--[a-zA-Z][\w-]*", read(doc)))
    assert sorted(named - known) == []


# ---------------------------------------------------------------- README's commands

def readme_commands():
    """``(line, argv)`` of every ``pbrdf`` command README gives in full, in
    order: each one in a code block, and each inline one that names
    something (a scene, a file, a value), not the fragments that only name
    options (``pbrdf render --bands``); usage templates (``SCENE.xml``,
    ``...``) are left out."""
    commands = {c for c in subcommand_options() if c}
    text = read("README.md")
    fenced_lines, fenced = set(), False
    for i, line in enumerate(text.splitlines()):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif fenced:
            fenced_lines.add(i + 1)
    found = []
    for line, span in command_spans("README.md"):
        for m in COMMAND.finditer(span):
            words = m.group("rest").split(" #")[0].split()
            if not words or words[0] not in commands:
                continue
            args = words[1:]
            if "..." in args or any(re.search(r"[A-Z]{3}|[<>{}]", w) for w in args):
                continue  # a usage template
            if line not in fenced_lines and all(w.startswith("-") for w in args):
                continue  # prose naming a command or its options
            found.append((line, words))
    return sorted(found, key=lambda f: f[0])


def test_every_command_readme_gives_parses_and_names_files_that_exist():
    """Each full ``pbrdf`` command of README parses (argparse, in-process)
    and the scene and sweep files it names are in the repository."""
    from doc_figures import ROOT

    commands = readme_commands()
    assert len(commands) >= 15, commands  # the check reads README's commands
    parser = build_parser()
    bad = []
    for line, argv in commands:
        try:
            parser.parse_args(argv)
        except SystemExit:
            bad.append(f"README.md:{line}: pbrdf {' '.join(argv)} does not parse")
        for word in argv[1:]:
            if word.endswith((".xml", ".toml")) and not os.path.isfile(os.path.join(ROOT, word)):
                bad.append(f"README.md:{line}: {word} is not in the repository")
        if argv[0] == "render":  # each -D key is one of the scene's parameters
            declared = declared_parameters(os.path.join(ROOT, argv[1]))
            keys = [argv[i + 1].partition("=")[0] for i, w in enumerate(argv[:-1]) if w == "-D"]
            bad += [f"README.md:{line}: {argv[1]} has no parameter {k!r}" for k in keys
                    if k not in declared]
    assert not bad, "\n".join(bad)


#: What README's commands become in :func:`test_readme_commands_run_in_order`:
#: renders shrunk to 32 x 24 pixels at 4 spp (every scene README renders has
#: width and height defaults); the gallery and the sweeps are left out (minutes
#: of rendering; ``pbrdf gallery`` and ``batch`` have tests of their own).
SHRINK = ["-D", "width=32", "-D", "height=24", "--spp", "4"]
NOT_RUN = ("gallery", "batch")


@pytest.mark.slow
def test_readme_commands_run_in_order(tmp_path, monkeypatch, capsys):
    """README's commands, in README's order, from a folder holding only the
    repository's scenes: each exits 0 (renders shrunk, see :data:`SHRINK`)
    and the files that later commands read are there."""
    from doc_figures import ROOT

    from mitsuba_pbrdf import variant as variant_module
    from mitsuba_pbrdf.cli import main

    monkeypatch.setattr(variant_module, "cuda_available", lambda: False)
    monkeypatch.chdir(tmp_path)
    os.symlink(os.path.join(ROOT, "scenes"), tmp_path / "scenes")
    ran = []
    for line, argv in readme_commands():
        if argv[0] in NOT_RUN:
            continue
        argv = argv + SHRINK if argv[0] == "render" else argv
        status = main(argv)
        assert status == 0, f"README.md:{line}: pbrdf {' '.join(argv)}: {capsys.readouterr().err}"
        ran.append(argv[0])
    assert {"render", "view", "plot", "polcam"} <= set(ran)
    for name in ("out/default.png", "out/polarizer45.exr", "cu.png", "out/cam"):
        assert os.path.exists(name), name


def test_readme_install_brings_what_readme_commands_use():
    """README's install (``pip install -e .``, no extra) brings Dask, which
    README's ``pbrdf batch`` example needs."""
    from doc_figures import ROOT

    try:
        import tomllib
    except ImportError:  # Python < 3.11
        import tomli as tomllib
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        dependencies = tomllib.load(f)["project"]["dependencies"]
    assert "dask[distributed]" in dependencies
    assert any(argv[0] == "batch" for _, argv in readme_commands())
    readme = read("README.md")
    assert "./install.sh && " in readme and "[batch]" not in readme
