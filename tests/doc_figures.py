"""Figures that README.md and docs/*.md quote, and where they come from.

A doc may keep a measured figure only with a marker naming the report that
holds it, right after the figure (HTML comments do not show on GitHub):

* ``1.60 s<!-- from: validation/fit_synthetic.md | 14490 -->``: the number
  just before the marker (``1.60``) must occur in the report
  ``validation/fit_synthetic.md`` (a path from the repository root), on a
  line that contains the label after ``|`` (a table row's label, a heading's
  words); without a label anywhere in the report.
* ``<!-- table from: benchmarks/batch.md -->`` on the line before a Markdown
  table: every number of the table's body, first column excepted, must occur
  in the report; ``<!-- table from: row-links -->``: in the report that the
  row's first link points to.
* ``20 s<!-- fixed -->``: the figure is a setting or an exact quantity (a
  timeout, a file size computed from the grid), not a measurement.

:func:`unsourced_measurements` lists every time or memory figure (a number
with ``ms``, ``s``, ``min``, ``MiB``, ``GiB``, ``kB``, ``GB`` ...) outside
code blocks that has none of these: times and memory are what changes when
code changes, and a doc cannot restate them without a report to check.
Reports are referred to by file and row label, never by module, so they
survive moving code around.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import Iterator, List, Optional

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir))

NUMBER = r"[-−]?\d[\d,]*(?:\.\d+)?(?:[eE][-+−]?\d+)?"
MARKER = re.compile(r"<!--\s*(from:\s*(?P<src>[^|>]+?)(?:\s*\|\s*(?P<label>[^>]+?))?"
                    r"|(?P<fixed>fixed))\s*-->")
TABLE_MARKER = re.compile(r"^<!--\s*table from:\s*(?P<src>\S+)\s*-->\s*$")
# the figure a marker refers to: the last number before it, then at most a
# unit, a closing bracket or emphasis
BEFORE_MARKER = re.compile(rf"(?P<num>{NUMBER})\s?(?P<unit>[A-Za-zµ%×]+)?[*)\]]*\s*$")
MEASUREMENT = re.compile(rf"(?<![\w.]){NUMBER}\s?(?:ms|s|min|h|MiB|GiB|kB|MB|GB)\b"
                         r"(?P<rest>[*)\]]*\s*(?P<marker><!--[^>]*-->)?)")


@dataclass
class Figure:
    """A figure a doc attributes to a report."""
    doc: str
    line: int
    number: str
    source: str
    label: Optional[str]
    percent: bool = False  # written as a percentage: the report may hold the fraction


def doc_files() -> List[str]:
    """README.md and docs/*.md, relative to the repository root."""
    docs = os.path.join(ROOT, "docs")
    return ["README.md"] + sorted(os.path.join("docs", n) for n in os.listdir(docs)
                                  if n.endswith(".md"))


def read(path: str) -> str:
    with open(os.path.join(ROOT, path), encoding="utf-8") as f:
        return f.read()


def prose_lines(text: str) -> List[str]:
    """The lines of *text* with fenced code blocks blanked (line numbers kept)."""
    out, fenced = [], False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
            out.append("")
            continue
        out.append("" if fenced else line)
    return out


def table_spans(lines: List[str]) -> Iterator[tuple]:
    """``(source, first, last)`` of every table that follows a table marker
    (line indices of the table body, header and rule excluded)."""
    for i, line in enumerate(lines):
        m = TABLE_MARKER.match(line.strip())
        if not m:
            continue
        j = i + 1
        while j < len(lines) and lines[j].lstrip().startswith("|"):
            j += 1
        yield m.group("src"), i + 3, j - 1


def figures(doc: str) -> List[Figure]:
    """Every figure of *doc* attributed to a report."""
    lines = prose_lines(read(doc))
    found = []
    for i, line in enumerate(lines):
        for m in MARKER.finditer(line):
            if m.group("fixed"):
                continue
            before = BEFORE_MARKER.search(line[:m.start()])
            number = before.group("num") if before else ""
            percent = bool(before) and before.group("unit") == "%"
            found.append(Figure(doc, i + 1, number, m.group("src").strip(),
                                (m.group("label") or "").strip() or None, percent))
    for source, first, last in table_spans(lines):
        for k in range(first, last + 1):
            row_source = source
            if source == "row-links":  # each row's first link is its report
                link = re.search(r"\]\(([^)#\s]+)", lines[k])
                row_source = (os.path.normpath(os.path.join(os.path.dirname(doc), link.group(1)))
                              if link else "(no link in this row)")
            cells = lines[k].strip().strip("|").split("|")[1:]
            for cell in cells:
                cell = re.sub(r"`[^`]*`", "", cell)
                for m in re.finditer(rf"(?<![\w.])(?P<num>{NUMBER})(?P<pc>\s?%)?", cell):
                    found.append(Figure(doc, k + 1, m.group("num"), row_source, None,
                                        bool(m.group("pc"))))
    return found


def _normal(text: str) -> str:
    return text.replace("−", "-")


def _value(text: str) -> float:
    return float(_normal(text).replace(",", ""))


def _significant(text: str) -> int:
    """Significant digits of a number as written (``0.0120`` has 3, ``4e-16`` 1)."""
    mantissa = re.split(r"[eE]", _normal(text).replace(",", "").lstrip("-"))[0]
    digits = mantissa.replace(".", "").lstrip("0")
    return max(len(digits), 1)


def _round(value: float, digits: int) -> float:
    return float(f"{value:.{digits - 1}e}")


def occurs(number: str, text: str) -> bool:
    """Whether *text* holds *number*: as written (``1.6`` is not in ``11.6``),
    or a number of *text* rounded to *number*'s significant digits equals it
    (a doc may quote ``4.0e-16`` as ``4e-16``, ``88.0 %`` as ``88 %``, ``0.0148``
    as ``0.015``; ``14,490`` is ``14490``). A rounded figure is still the
    report's figure; a different one is not."""
    try:
        value, digits = _value(number), _significant(number)
    except ValueError:
        return False
    for m in re.finditer(rf"(?<![\w.]){NUMBER}", _normal(text)):
        try:
            found = _value(m.group(0))
        except ValueError:
            continue
        if not re.match(r"[-−]", number):
            found = abs(found)  # "within 2.2 %" quotes a report's "-2.2 %"
        if found == value or (found != 0 and _round(found, digits) == _round(value, digits)
                              and _significant(m.group(0)) >= digits):
            return True
    return False


def _held(figure: Figure, text: str) -> bool:
    if occurs(figure.number, text):
        return True
    if figure.percent:  # 0.57 % quotes a report's 0.00572
        fraction = _value(figure.number) / 100
        return occurs(f"{fraction:.{_significant(figure.number) - 1}e}", text)
    return False


def check(figure: Figure) -> Optional[str]:
    """None if the report holds the figure, else why not."""
    where = f"{figure.doc}:{figure.line}"
    if not figure.number:
        return f"{where}: a 'from:' marker with no number just before it"
    path = os.path.join(ROOT, figure.source)
    if not os.path.isfile(path):
        return f"{where}: {figure.number} is attributed to {figure.source}, which does not exist"
    report = read(figure.source)
    if figure.label is not None:
        rows = [line for line in report.splitlines() if figure.label in line]
        if not rows:
            return f"{where}: {figure.source} has no line with {figure.label!r}"
        if not any(_held(figure, row) for row in rows):
            return (f"{where}: {figure.number} is not in the line(s) of {figure.source} "
                    f"with {figure.label!r}: {rows[0].strip()[:160]}")
        return None
    if not _held(figure, report):
        return f"{where}: {figure.number} does not occur in {figure.source}"
    return None


def unsourced_measurements(doc: str) -> List[str]:
    """``doc:line: figure`` of every time or memory figure outside code blocks
    and marked tables that has no marker right after it."""
    lines = prose_lines(read(doc))
    in_table = set()
    for _, first, last in table_spans(lines):
        in_table.update(range(first, last + 1))
    bad = []
    for i, line in enumerate(lines):
        if i in in_table:
            continue
        line = re.sub(r"\]\([^)\s]*\)", "]()", line)  # link targets are not figures
        comments = [c.span() for c in re.finditer(r"<!--.*?-->", line)]
        for m in MEASUREMENT.finditer(line):
            if any(a <= m.start() < b for a, b in comments):
                continue  # a marker's label
            if not m.group("marker"):
                bad.append(f"{doc}:{i + 1}: {m.group(0).strip()}")
    return bad
