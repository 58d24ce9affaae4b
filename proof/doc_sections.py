"""A docs page's section run as a reader would run it: the ```python blocks
under one ``## heading`` executed in order, each in a fresh namespace (the
tests of docs/python.md's one-call sections)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import List

ROOT = Path(__file__).resolve().parents[1]


def python_blocks(page: str, heading: str) -> List[str]:
    """The ```python blocks of the section ``## heading`` of docs/*page*."""
    text = (ROOT / "docs" / page).read_text(encoding="utf-8")
    body = text.split(f"## {heading}\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", body, re.S)


def run_section(page: str, heading: str) -> int:
    """Execute the section's blocks in the current folder; returns how many ran."""
    blocks = python_blocks(page, heading)
    for code in blocks:
        exec(compile(code, f"docs/{page}", "exec"), {})
    return len(blocks)
