"""Pairwise covering arrays: few rows in which every pair of levels of every
two factors appears at least once (the rows of a test of products, where the
full product is too large to run).

:func:`pairwise` builds one greedily and deterministically: each new row
starts from the first pair not yet covered and fills the other factors with
the level that covers most pairs still missing (ties: the first level), with
rows that ``allowed`` rejects skipped. :func:`uncovered` checks an array.
"""

from __future__ import annotations

from itertools import combinations
from typing import Callable, Dict, List, Optional, Sequence


def _pairs(factors: Dict[str, Sequence], allowed):
    """Every pair ((f1, i1), (f2, i2)) of levels of two factors that some
    allowed row can hold (checked on the pair alone)."""
    names = list(factors)
    out = set()
    for a, b in combinations(names, 2):
        for i, x in enumerate(factors[a]):
            for j, y in enumerate(factors[b]):
                if allowed is None or allowed({a: x, b: y}):
                    out.add(((a, i), (b, j)))
    return out


def pairwise(factors: Dict[str, Sequence],
             allowed: Optional[Callable[[dict], bool]] = None) -> List[dict]:
    """Rows (dicts factor -> level) covering every allowed pair of levels.
    ``allowed(partial_row)`` says whether a (partial) row may exist; it sees
    only the factors set so far."""
    names = list(factors)
    if len(names) == 1:  # no pairs: each allowed level once
        return [{names[0]: v} for v in factors[names[0]]
                if allowed is None or allowed({names[0]: v})]
    missing = _pairs(factors, allowed)
    rows = []
    while missing:
        (a, i), (b, j) = min(missing)
        choice = {a: i, b: j}
        for name in names:
            if name in choice:
                continue
            best, gain = None, -1
            for k in range(len(factors[name])):
                trial = dict(choice, **{name: k})
                if allowed is not None and not allowed(
                        {f: factors[f][v] for f, v in trial.items()}):
                    continue
                g = sum(((f, v), (name, k)) in missing or ((name, k), (f, v)) in missing
                        for f, v in choice.items())
                if g > gain:
                    best, gain = k, g
            if best is None:
                raise ValueError(f"no level of {name!r} is allowed with {choice}")
            choice[name] = best
        covered = {((x, choice[x]), (y, choice[y])) for x, y in combinations(names, 2)}
        if not covered & missing:
            raise ValueError(f"pairwise: a pair cannot be covered: {min(missing)}")
        missing -= covered
        rows.append({f: factors[f][choice[f]] for f in names})
    return rows


def uncovered(factors: Dict[str, Sequence], rows: List[dict],
              allowed: Optional[Callable[[dict], bool]] = None) -> set:
    """The allowed pairs of levels that no row holds (empty: a covering array)."""
    index = [{f: list(factors[f]).index(row[f]) for f in factors} for row in rows]
    covered = {((x, r[x]), (y, r[y])) for r in index for x, y in combinations(list(factors), 2)}
    return _pairs(factors, allowed) - covered
