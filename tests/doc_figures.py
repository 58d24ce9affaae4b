"""Measured figures in README.md and docs/*.md, and the reports that hold them.

A time or memory figure (a number with ``ms``, ``s``, ``min``, ``h``, ``kB``,
``MB``, ``GB``, ``MiB``, ``GiB``) in a doc's prose stands in a block (a
paragraph, a list item, a table: text between blank lines) that links a
report, ``benchmarks/*.md`` or ``validation/*.md``, and the report holds the
number (as written or rounded, :func:`occurs`) beside the command that
produced it. A figure that is a setting rather than a measurement (a timeout,
a budget) is written in a code span, which is not read. Times and memory are
what changes when code changes; a doc cannot restate them without a report.
"""

from __future__ import annotations

import os
import re
from typing import List

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir))

NUMBER = r"[-−]?\d[\d,]*(?:\.\d+)?(?:[eE][-+−]?\d+)?"
MEASUREMENT = re.compile(rf"(?<![\w.])(?P<num>{NUMBER})\s?(?:ms|s|min|h|MiB|GiB|kB|MB|GB)\b")
LINK = re.compile(r"\]\(([^)#\s]+\.md)(?:#[^)\s]*)?\)")


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


def _value(text: str) -> float:
    return float(text.replace("−", "-").replace(",", ""))


def _significant(text: str) -> int:
    """Significant digits of a number as written (``0.0120`` has 3, ``4e-16`` 1)."""
    mantissa = re.split(r"[eE]", text.replace("−", "-").replace(",", "").lstrip("-"))[0]
    return max(len(mantissa.replace(".", "").lstrip("0")), 1)


def occurs(number: str, text: str) -> bool:
    """Whether *text* holds *number* as written, or a number that rounds to it
    at its significant digits (``3.2`` quotes ``3.21``; ``1.6`` is not in ``11.6``)."""
    value, digits = _value(number), _significant(number)
    for m in re.finditer(rf"(?<![\w.]){NUMBER}", text.replace("−", "-")):
        found = _value(m.group(0))
        if found == value or (_significant(m.group(0)) >= digits
                              and float(f"{found:.{digits - 1}e}") == float(f"{value:.{digits - 1}e}")):
            return True
    return False


def unsourced(doc: str) -> List[str]:
    """``doc:line: figure (why)`` of every time or memory figure of *doc* that
    no report linked from its block holds."""
    lines, bad, start = prose_lines(read(doc)) + [""], [], 0
    for i, line in enumerate(lines):
        if line.strip():
            continue
        block = "\n".join(lines[start:i])
        reports = [os.path.normpath(os.path.join(os.path.dirname(doc), m.group(1)))
                   for m in LINK.finditer(block)]
        reports = [read(r) for r in reports if r.startswith(("benchmarks", "validation"))
                   and os.path.isfile(os.path.join(ROOT, r))]
        prose = re.sub(r"`[^`]*`|\]\([^)\s]*\)", "", block)
        for m in MEASUREMENT.finditer(prose):
            if not any(occurs(m.group("num"), r) for r in reports):
                why = "in none of the linked reports" if reports else "no report linked"
                bad.append(f"{doc}:{start + 1}: {m.group(0)} ({why})")
        start = i + 1
    return bad
