"""Starts on a subsample, the polish on all rows: how a fit of a whole
measurement campaign (10^5-10^6 rows) stays within a minute.

The starts of :mod:`.starts` only choose the basin the fit ends in, and a
uniform random sample of the rows estimates the objective's landscape as well
as all of them do (each term of the sum is a row; the sample's cost is an
unbiased estimate of the whole's, scaled). So where the data hold more than
:data:`START_ROWS` rows, every start runs on :data:`START_ROWS` of them (drawn
per wavelength, in proportion, so that every wavelength keeps its rows), and
the best one is polished on all rows: the result is the optimum of the whole
data, its uncertainties those of the whole data. The objective is the same
function on the sample: its terms (:class:`.objectives.Term`) are the whole
data's, restricted to the sample's rows, with the whole data's floors and
scales.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..measured.selection import _subset

__all__ = ["START_ROWS", "sample_rows", "sample"]

#: Rows the starts run on when the data hold more (``fit_model(start_rows=...)``).
START_ROWS = 20_000


def sample_rows(data, count, seed=0) -> np.ndarray:
    """Sorted indices of about *count* rows of *data*, drawn uniformly at random
    within each wavelength in proportion to its rows (at least one each)."""
    rng = np.random.default_rng([seed, 35])
    total = len(data)
    rows = []
    for w in data.wavelengths:
        at = np.flatnonzero(data.wavelength == w)
        take = min(len(at), max(1, round(count * len(at) / total)))
        rows.append(rng.choice(at, take, replace=False))
    return np.sort(np.concatenate(rows))


def _restrict(term, rows):
    """*term* on the rows *rows* (sorted indices of the data) of its data."""
    pos = np.minimum(np.searchsorted(rows, term.rows), len(rows) - 1)
    keep = rows[pos] == term.rows
    changes = {f.name: getattr(term, f.name)[keep] for f in dataclasses.fields(term)
               if isinstance(getattr(term, f.name), np.ndarray)
               and getattr(term, f.name).shape[:1] == term.rows.shape}
    changes["rows"] = pos[keep]
    return dataclasses.replace(term, **changes)


def sample(data, terms, count, seed=0):
    """``(rows, data of those rows, terms restricted to them)``, or None where
    *data* holds no more than *count* rows (or *count* is None)."""
    if count is None or len(data) <= count:
        return None
    rows = sample_rows(data, count, seed)
    sub = _subset(data, rows, data.observed, data.uncertainty)
    return rows, sub, [_restrict(t, rows) for t in terms]
