"""A material's complex refractive index n + ik against wavelength, from a file
(``pbrdf fit --nk FILE``), interpolated linearly to the measurements' wavelengths.

Two layouts, told by the header:

* one table with a header row ``wavelength,n,k`` (nm) or ``wl,n,k`` /
  ``wavelength_um,n,k`` (µm), comma-, tab- or space-separated;
* refractiveindex.info's CSV export: a block headed ``wl,n`` and a block
  headed ``wl,k``, wavelengths in µm (the two blocks may sample different
  wavelengths; a file with only the ``wl,n`` block has k = 0).

Lines starting with ``#`` are comments. Errors (:class:`IndexTableError`) name
the file and line: no header, a non-numeric or non-finite cell, n <= 0 or k < 0,
wavelengths that do not increase, fewer than one row, and measurement
wavelengths outside the table's range (no extrapolation).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass

import numpy as np

__all__ = ["IndexTableError", "IndexTable", "read_index_table"]


class IndexTableError(ValueError):
    """An index table that cannot be used, with the reason."""


@dataclass
class IndexTable:
    """n(λ) and k(λ) sampled at their own wavelengths (nm, increasing)."""
    n_wavelengths: np.ndarray
    n: np.ndarray
    k_wavelengths: np.ndarray
    k: np.ndarray
    source: str = "<memory>"

    def check(self):
        """Raise :class:`IndexTableError` unless the table is usable: what
        :func:`read_index_table` requires of a file's rows, for a table built
        in memory too (at least one row, finite values, n > 0, k >= 0,
        increasing wavelengths)."""
        for name, grid, values in (("n", self.n_wavelengths, self.n),
                                   ("k", self.k_wavelengths, self.k)):
            grid, values = np.asarray(grid, np.float64), np.asarray(values, np.float64)
            if grid.ndim != 1 or grid.shape != values.shape or not grid.size:
                raise IndexTableError(f"{self.source}: {name} needs one value per wavelength "
                                      f"and at least one row")
            if not (np.all(np.isfinite(grid)) and np.all(np.isfinite(values))):
                raise IndexTableError(f"{self.source}: {name} or its wavelengths are not finite")
            bad = values[values <= 0] if name == "n" else values[values < 0]
            if bad.size:
                raise IndexTableError(f"{self.source}: {name} = {bad[0]:g} is not physical "
                                      f"({'n > 0' if name == 'n' else 'k >= 0'})")
            if np.any(np.diff(grid) <= 0) or grid[0] <= 0:
                raise IndexTableError(f"{self.source}: the wavelengths of {name} must be > 0 "
                                      f"and increase")
        return self

    def at(self, wavelengths_nm):
        """(n, k) at *wavelengths_nm*, linearly interpolated."""
        w = np.asarray(wavelengths_nm, dtype=np.float64)
        for name, grid in (("n", self.n_wavelengths), ("k", self.k_wavelengths)):
            outside = w[(w < grid[0] - 1e-9) | (w > grid[-1] + 1e-9)]
            if outside.size:
                raise IndexTableError(
                    f"{self.source}: its {name} covers {grid[0]:g}-{grid[-1]:g} nm, not "
                    f"{', '.join(f'{x:g}' for x in outside)} nm (no extrapolation)")
        return (np.interp(w, self.n_wavelengths, self.n),
                np.interp(w, self.k_wavelengths, self.k))


_SPLIT = re.compile(r"[,\t ;]+")
_NM_NAMES = ("wavelength", "wavelength_nm", "lambda_nm", "nm")
_UM_NAMES = ("wl", "wavelength_um", "lambda_um", "um", "µm")


def _cells(line):
    return [c for c in _SPLIT.split(line.strip()) if c]


def _number(text, path, line, column):
    try:
        v = float(text)
    except ValueError:
        raise IndexTableError(f"{path}: line {line}: {column} is not a number: {text!r}") from None
    if not math.isfinite(v):
        raise IndexTableError(f"{path}: line {line}: {column} is not finite: {text!r}")
    return v


def _unit(name, path, line):
    if name in _NM_NAMES:
        return 1.0
    if name in _UM_NAMES:
        return 1000.0
    raise IndexTableError(f"{path}: line {line}: the first column must be the wavelength "
                          f"(wavelength or wavelength_nm in nm; wl or wavelength_um in µm), "
                          f"not {name!r}")


def read_index_table(path) -> IndexTable:
    """Read an index table (see the module docstring)."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            raw = f.read()
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise IndexTableError(f"{path}: not a text file (expected a CSV table of "
                              f"wavelength, n, k)") from None
    except OSError as e:
        raise IndexTableError(f"{path}: cannot read: {e.strerror or e}") from None
    blocks = []                 # [unit, columns, rows, header line]
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cells = _cells(line)
        if not re.match(r"^[-+.\d]", cells[0]):
            names = [c.lower() for c in cells]
            columns = names[1:]
            if not columns or any(c not in ("n", "k") for c in columns):
                raise IndexTableError(f"{path}: line {number}: expected the columns "
                                      f"wavelength, n, k (or wl,n / wl,k blocks), got {line.strip()!r}")
            blocks.append([_unit(names[0], path, number), columns, [], number])
            continue
        if not blocks:
            raise IndexTableError(f"{path}: line {number}: no header before the numbers "
                                  f"(expected wavelength,n,k in nm or wl,n,k in µm)")
        unit, columns, rows, _ = blocks[-1]
        if len(cells) != 1 + len(columns):
            raise IndexTableError(f"{path}: line {number}: expected {1 + len(columns)} values, "
                                  f"got {len(cells)}")
        values = [_number(c, path, number, name)
                  for c, name in zip(cells, ["the wavelength"] + columns)]
        values[0] *= unit
        for name, v in zip(columns, values[1:]):
            if (name == "n" and v <= 0) or (name == "k" and v < 0):
                raise IndexTableError(f"{path}: line {number}: {name} = {v:g} is not physical "
                                      f"({'n > 0' if name == 'n' else 'k >= 0'})")
        if rows and values[0] <= rows[-1][0]:
            raise IndexTableError(f"{path}: line {number}: the wavelengths must increase "
                                  f"({values[0]:g} nm after {rows[-1][0]:g} nm)")
        rows.append(values)
    series = {}
    for unit, columns, rows, line in blocks:
        if not rows:
            raise IndexTableError(f"{path}: line {line}: a header with no rows after it")
        a = np.array(rows)
        for i, name in enumerate(columns, 1):
            if name in series:
                raise IndexTableError(f"{path}: line {line}: a second {name} column")
            series[name] = (a[:, 0], a[:, i])
    if "n" not in series:
        raise IndexTableError(f"{path}: no n column (expected wavelength, n, k)")
    k = series.get("k", (series["n"][0], np.zeros_like(series["n"][1])))
    return IndexTable(series["n"][0], series["n"][1], k[0], k[1], source=path).check()
