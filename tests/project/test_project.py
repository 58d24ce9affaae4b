"""Project wiring: CI runs exactly README's test command; README links every
page of docs/, and the links and code snippets of README and docs/ are sound."""

import ast
import importlib
import importlib.util
import os
import re
import sys
import textwrap

import pytest

ROOT = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir)


def read(path):
    with open(os.path.join(ROOT, path)) as f:
        return f.read()


def readme_commands():
    return re.findall(r"```bash\n(.*?)\n```", read("README.md"), flags=re.S)


def test_ci_runs_readme_test_command():
    commands = readme_commands()
    test_commands = [c for c in commands if "pytest" in c]
    assert len(test_commands) == 1
    ci_lines = [line for line in read(".ci/run").splitlines() if line and not line.startswith("#")]
    assert ci_lines[-1] == test_commands[0]


def test_readme_main_job_renders_the_default_scene():
    main = [c for c in readme_commands() if "render" in c]
    assert main and "scenes/default.xml" in main[0]
    assert os.path.exists(os.path.join(ROOT, "scenes", "default.xml"))


# ---------------------------------------------------------------------------
# Documentation: README links every page of docs/, and every relative link
# (file and #anchor) in README and docs/ resolves.

DOC_FILES = ["README.md"] + sorted(
    os.path.join("docs", n) for n in os.listdir(os.path.join(ROOT, "docs")) if n.endswith(".md"))
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def github_anchor(heading):
    """The anchor GitHub gives a Markdown heading: lower case, punctuation
    other than '-' and '_' dropped, spaces turned into '-'."""
    text = re.sub(r"[`*]", "", heading.strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(path):
    text = re.sub(r"```.*?```", "", read(path), flags=re.S)
    return {github_anchor(h) for h in re.findall(r"^#{1,6} (.+)$", text, flags=re.M)}


def relative_links(path):
    """(target path relative to ROOT or None for the same file, anchor) of
    every link that is not a URL, outside code blocks."""
    text = re.sub(r"```.*?```", "", read(path), flags=re.S)
    text = re.sub(r"`[^`\n]*`", "", text)
    for target in LINK.findall(text):
        if re.match(r"[a-z]+:", target):
            continue
        file, _, anchor = target.partition("#")
        if file:
            file = os.path.normpath(os.path.join(os.path.dirname(path), file))
        yield file or None, anchor


def test_readme_links_every_docs_page():
    linked = {f for f, _ in relative_links("README.md") if f}
    pages = {p for p in DOC_FILES if p.startswith("docs")}
    assert pages, "docs/ has no pages"
    assert pages <= linked, f"not linked from README: {sorted(pages - linked)}"


@pytest.mark.parametrize("path", DOC_FILES)
def test_relative_links_resolve(path):
    broken = []
    for file, anchor in relative_links(path):
        target = file or path
        if not os.path.exists(os.path.join(ROOT, target)):
            broken.append(f"{file}: no such file")
        elif anchor and target.endswith(".md") and anchor not in anchors(target):
            broken.append(f"{target}#{anchor}: no such heading")
    assert not broken, f"{path}: {broken}"


def test_the_link_check_sees_broken_links(tmp_path, monkeypatch):
    """The checks above fail on a missing file and on a missing heading."""
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "a.md").write_text("# Title here\n[x](b.md) [y](#nope) [z](#title-here)\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", str(tmp_path))
    links = list(relative_links(os.path.join("docs", "a.md")))
    assert links == [(os.path.join("docs", "b.md"), ""), (None, "nope"), (None, "title-here")]
    assert anchors(os.path.join("docs", "a.md")) == {"title-here"}
    assert not os.path.exists(tmp_path / "docs" / "b.md")


def python_snippets(path):
    return [textwrap.dedent(code) for code in
            re.findall(r"^[ \t]*```python\n(.*?)^[ \t]*```", read(path), flags=re.S | re.M)]


@pytest.mark.parametrize("path", DOC_FILES)
def test_python_snippets_parse_and_their_imports_exist(path):
    """Every ```python block is valid Python and every name it imports from
    mitsuba_pbrdf exists (running them is for the examples and by hand: some
    render for minutes)."""
    for code in python_snippets(path):
        tree = ast.parse(code)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module.startswith("mitsuba_pbrdf"):
                module = importlib.import_module(node.module)
                for alias in node.names:
                    assert hasattr(module, alias.name) or importlib.util.find_spec(
                        f"{node.module}.{alias.name}"), f"{path}: {node.module}.{alias.name}"
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.startswith("mitsuba_pbrdf"):
                        importlib.import_module(alias.name)


def test_layout_page_names_every_subpackage_and_module():
    """docs/layout.md's tree lists every sub-package and top-level module."""
    text = read(os.path.join("docs", "layout.md"))
    package = os.path.join(ROOT, "mitsuba_pbrdf")
    for name in sorted(os.listdir(package)):
        if os.path.isdir(os.path.join(package, name)) and not name.startswith("__"):
            assert f"  {name}/" in text, f"docs/layout.md does not list mitsuba_pbrdf/{name}/"
        elif name.endswith(".py"):
            assert name in text, f"docs/layout.md does not list mitsuba_pbrdf/{name}"
