"""A pairwise covering array: rows of factor values in which every pair of
values of any two factors occurs at least once (all-pairs testing), made
greedily and deterministically.

    rows = covering_array({"objective": ["log", "linear"], "model": ["two", "three"], ...})

Each row starts from the first pair not yet covered; every other factor then
takes the value that covers the most pairs still uncovered with the values
already in the row (ties: the first). The size is near the product of the two
largest factors' sizes, not the product of all."""

from itertools import combinations

__all__ = ["covering_array", "uncovered_pairs"]


def _pairs(sizes):
    return {(a, i, b, j) for a, b in combinations(range(len(sizes)), 2)
            for i in range(sizes[a]) for j in range(sizes[b])}


def covering_array(factors):
    """Rows ({factor: value}) covering every pair of values of *factors*
    ({name: list of values})."""
    names = list(factors)
    sizes = [len(factors[n]) for n in names]
    uncovered = _pairs(sizes)
    rows = []
    while uncovered:
        a, i, b, j = min(uncovered)
        row = {a: i, b: j}
        for f in range(len(names)):
            if f in row:
                continue
            def gain(v):
                return sum((min(f, g), v if f < g else w, max(f, g), w if f < g else v)
                           in uncovered for g, w in row.items())
            row[f] = max(range(sizes[f]), key=lambda v: (gain(v), -v))
        uncovered -= {(p, row[p], q, row[q]) for p, q in combinations(sorted(row), 2)}
        rows.append({names[f]: factors[names[f]][row[f]] for f in range(len(names))})
    return rows


def uncovered_pairs(factors, rows):
    """The pairs of *factors*' values that no row of *rows* holds (empty: a covering array)."""
    names = list(factors)
    want = {(a, x, b, y) for a, b in combinations(names, 2)
            for x in range(len(factors[a])) for y in range(len(factors[b]))}
    have = {(a, factors[a].index(r[a]), b, factors[b].index(r[b]))
            for r in rows for a, b in combinations(names, 2)}
    return want - have
