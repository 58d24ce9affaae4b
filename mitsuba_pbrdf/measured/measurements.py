"""Goniometer measurements of a pBRDF: the :class:`Measurements` record and its
CSV file format (reading with checks, writing).

**CSV format.** One header row, then one row per measurement; names are
case-insensitive, columns in any order:

* ``theta_i, phi_i, theta_r, phi_r``: directions towards the light and towards
  the detector, degrees (zenith in [0, 90), azimuth in [-360, 360]); the
  specular direction has ``phi_r = phi_i + 180``;
* ``wavelength``: nm, > 0;
* observed quantities, at least one: ``m00`` ... ``m33`` (Mueller BRDF
  elements, 1/sr, no cosine factor, in the global s/p frames of
  :mod:`mitsuba_pbrdf.reference`: S1 = I_s - I_p, Mitsuba's sign for the
  circular elements) and/or ``dolp`` (degree of linear polarization of the
  reflected light for unpolarized illumination, sqrt(m10^2 + m20^2) / m00, in
  [0, 1]). A row may leave some of them empty (not measured there);
* optional standard uncertainties ``<quantity>_err`` (e.g. ``m00_err``,
  ``dolp_err``), > 0. Without them each value is given
  ``rel * |value| + abs * max|column|`` (``pbrdf fit --rel-uncertainty 0.05
  --abs-uncertainty 0.005``) and the parameters' uncertainties are scaled by
  the reduced chi-square.

Lines starting with ``#`` are comments; errors name the line of the file
(comments and blank lines counted). Other columns are ignored (and listed).
A file that ends without a newline in the middle of a row, or with a last
number cut short (``2.``, ``1e``), is refused as truncated. Malformed files (missing columns, no
observed quantity, non-numeric or NaN values where a value is required,
angles or wavelengths out of range, negative M00, DoLP outside [0, 1],
non-positive uncertainties) raise :class:`MeasurementError` naming the file,
row and column.

::

    from mitsuba_pbrdf.measured import read_measurements
    data = read_measurements("measurements.csv")
    data.observed["m00"], data.wavelengths
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np

__all__ = ["ANGLES", "ELEMENTS", "OBSERVABLES", "MeasurementError", "Measurements",
           "read_goniometer", "read_table", "number_cell", "check_measurements",
           "write_measurements"]

ANGLES = ("theta_i", "phi_i", "theta_r", "phi_r")
ELEMENTS = tuple(f"m{i}{j}" for i in range(4) for j in range(4))
OBSERVABLES = ELEMENTS + ("dolp",)


class MeasurementError(ValueError):
    """A measurement file that cannot be used, with the reason."""


@dataclass
class Measurements:
    """Measured pBRDF data. Angles in degrees as in the file; ``observed`` and
    ``uncertainty`` map a quantity (``m00`` ... ``m33``, ``dolp``) to an array
    with NaN where a row does not measure it (``uncertainty`` holds only the
    given ``<quantity>_err`` columns)."""
    theta_i: np.ndarray
    phi_i: np.ndarray
    theta_r: np.ndarray
    phi_r: np.ndarray
    wavelength: np.ndarray
    observed: Dict[str, np.ndarray]
    uncertainty: Dict[str, np.ndarray] = field(default_factory=dict)
    source: str = "<memory>"
    ignored_columns: List[str] = field(default_factory=list)
    #: Per-row intensity scale (M00, 1/sr) of the absolute uncertainty floor of
    #: the Mueller elements, or None (then each column's largest value). Rows of a
    #: ``.pbsdf`` table carry it: a polarimeter's errors scale with the intensity.
    row_scale: Optional[np.ndarray] = None
    #: Line number in the file of each row (for error messages), or None.
    lines: Optional[np.ndarray] = None

    def __len__(self):
        return len(self.theta_i)

    @property
    def wavelengths(self) -> np.ndarray:
        """Distinct wavelengths, sorted."""
        return np.unique(self.wavelength)

    def radians(self):
        return tuple(np.radians(a) for a in (self.theta_i, self.phi_i, self.theta_r, self.phi_r))

    def count(self) -> int:
        """Number of measured values."""
        return int(sum(np.isfinite(v).sum() for v in self.observed.values()))


def number_cell(text, path, row, column, required):
    text = (text or "").strip()
    if text == "":
        if required:
            raise MeasurementError(f"{path}: line {row}: column {column!r} is empty")
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise MeasurementError(f"{path}: line {row}: column {column!r} is not a number: "
                               f"{text!r}") from None
    if math.isnan(value):
        raise MeasurementError(f"{path}: line {row}: column {column!r} is NaN")
    if math.isinf(value):
        raise MeasurementError(f"{path}: line {row}: column {column!r} is infinite")
    return value


def read_table(path, what):
    """The lines of a CSV file: ``(header line number, header (stripped,
    lower case), rows)`` where ``rows`` yields ``(line number, cells)``, each
    row with as many cells as the header and a last row cut short by the end of
    the file refused (:class:`MeasurementError` naming the line). ``#`` lines
    and blank lines are skipped but keep their place in the numbering. ``what``
    says what the header should hold (for the empty-file message)."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise MeasurementError(f"{path}: no such file")
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            text = f.read()
    except UnicodeDecodeError as e:  # a binary file: name it, and where it stops being text
        raise MeasurementError(f"{path}: not a text (UTF-8) CSV file: byte "
                               f"0x{e.object[e.start]:02x} at offset {e.start}") from None
    if "\0" in text:
        raise MeasurementError(f"{path}: not a text CSV file (it holds NUL bytes)")
    # (line number in the file, line): comments and blank lines are skipped
    # but keep their place in the numbering of the error messages
    lines = [(number, line) for number, line in enumerate(text.splitlines(), start=1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise MeasurementError(f"{path}: empty file (expected a header row: {what})")
    truncated = not text.endswith(("\n", "\r"))
    header_line = lines[0][0]
    header = [h.strip().lower() for h in next(csv.reader([lines[0][1]]), [])]
    duplicates = sorted({h for h in header if header.count(h) > 1})
    if duplicates:
        raise MeasurementError(f"{path}: duplicate column(s) {', '.join(duplicates)}")
    last = lines[-1][0]

    def rows():
        for row_number, line in lines[1:]:
            row = next(csv.reader([line]), [])
            if len(row) != len(header):
                cut = " (the file ends there without a newline: cut short?)" if (
                    truncated and row_number == last) else ""
                raise MeasurementError(f"{path}: line {row_number}: {len(row)} fields, "
                                       f"the header has {len(header)}{cut}")
            if truncated and row_number == last:
                cell = row[-1].strip()
                if cell and cell[-1] in ".eE+-":
                    raise MeasurementError(
                        f"{path}: line {row_number}: column {header[-1]!r} = {cell!r} is cut "
                        f"short (the file ends there without a newline)")
            yield row_number, row
    return header_line, header, rows()


def read_goniometer(path, header, reader) -> Measurements:
    """The measurements of a goniometer CSV file (this module's layout) from
    :func:`read_table`'s header and rows."""
    required = list(ANGLES) + ["wavelength"]
    missing = [c for c in required if c not in header]
    if missing:
        raise MeasurementError(
            f"{path}: missing column(s) {', '.join(missing)}; a measurement file needs "
            f"{', '.join(required)} and at least one of m00 ... m33, dolp")
    quantities = [c for c in OBSERVABLES if c in header]
    if not quantities:
        raise MeasurementError(f"{path}: no measured quantity: add a column m00 ... m33 "
                               f"or dolp (found {', '.join(header)})")
    errors = [c for c in header if c.endswith("_err")]
    for c in errors:
        if c[:-4] not in quantities:
            raise MeasurementError(f"{path}: uncertainty column {c!r} has no column "
                                   f"{c[:-4]!r} to go with")
    known = set(required) | set(quantities) | set(errors)
    ignored = [c for c in header if c not in known]

    columns = {c: [] for c in required + quantities + errors}
    numbers = []
    for row_number, row in reader:
        cells = dict(zip(header, row))
        for c in required:
            columns[c].append(number_cell(cells[c], path, row_number, c, True))
        values = {c: number_cell(cells[c], path, row_number, c, False) for c in quantities}
        if all(math.isnan(v) for v in values.values()):
            raise MeasurementError(f"{path}: line {row_number}: no measured value "
                                   f"({', '.join(quantities)} all empty)")
        for c in quantities:
            columns[c].append(values[c])
        for c in errors:
            v = number_cell(cells[c], path, row_number, c, False)
            if math.isnan(v) and not math.isnan(values[c[:-4]]):
                raise MeasurementError(f"{path}: line {row_number}: {c!r} is empty but "
                                       f"{c[:-4]!r} is given")
            columns[c].append(v)
        numbers.append(row_number)
    if not columns["theta_i"]:
        raise MeasurementError(f"{path}: no data rows after the header")
    arrays = {c: np.array(v, dtype=np.float64) for c, v in columns.items()}
    data = Measurements(*(arrays[c] for c in ANGLES), arrays["wavelength"],
                        {c: arrays[c] for c in quantities},
                        {c[:-4]: arrays[c] for c in errors}, path, ignored,
                        lines=np.array(numbers))
    check_measurements(data)
    return data


def check_measurements(data: Measurements):
    """Range checks (raise :class:`MeasurementError` naming the first bad row:
    its line in the file when read from one, else its index from 0)."""
    def fail(mask, message):
        rows = np.flatnonzero(mask)
        if rows.size:
            more = f" (and {rows.size - 1} more rows)" if rows.size > 1 else ""
            where = (f"line {data.lines[rows[0]]}" if data.lines is not None
                     else f"row {rows[0]}")
            raise MeasurementError(f"{data.source}: {where}: {message}{more}")

    for name in ("theta_i", "theta_r"):
        a = getattr(data, name)
        fail(~np.isfinite(a), f"{name} is not finite")
        fail((a < 0) | (a >= 90), f"{name} = {a[(a < 0) | (a >= 90)][:1]} deg is out of "
             "range [0, 90) (zenith angle from the surface normal)")
    for name in ("phi_i", "phi_r"):
        a = getattr(data, name)
        fail(~np.isfinite(a) | (np.abs(a) > 360), f"{name} is out of range [-360, 360] deg")
    w = data.wavelength
    fail(~np.isfinite(w) | (w <= 0), "wavelength must be > 0 (nm)")
    if "m00" in data.observed:
        fail(data.observed["m00"] < 0, "m00 is negative")
    if "dolp" in data.observed:
        d = data.observed["dolp"]
        fail((d < 0) | (d > 1), "dolp is outside [0, 1]")
    for name, u in data.uncertainty.items():
        fail(np.isfinite(data.observed[name]) & ~(u > 0), f"{name}_err must be > 0")


def write_measurements(data: Measurements, path, uncertainties=True):
    """Write ``data`` as a CSV in the format :func:`read_measurements` reads."""
    cols = list(ANGLES) + ["wavelength"] + list(data.observed)
    if uncertainties:
        cols += [f"{c}_err" for c in data.uncertainty]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for i in range(len(data)):
            row = [getattr(data, c)[i] for c in ANGLES] + [data.wavelength[i]]
            row += [data.observed[c][i] for c in data.observed]
            if uncertainties:
                row += [data.uncertainty[c][i] for c in data.uncertainty]
            w.writerow(["" if not np.isfinite(v) else f"{v:.9g}" for v in row])
    return path
