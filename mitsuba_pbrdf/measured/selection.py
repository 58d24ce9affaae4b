"""Subsets of :class:`~mitsuba_pbrdf.measured.measurements.Measurements`: the
rows at chosen wavelengths (``pbrdf fit --wavelength``) and a choice of the
observed quantities, with the degree of linear polarization derived from the
Mueller elements (``pbrdf fit --observables``)."""

from __future__ import annotations

import numpy as np

from .measurements import OBSERVABLES, MeasurementError, Measurements

__all__ = ["WAVELENGTH_TOLERANCE", "select_wavelengths", "select_observables"]

#: A row is at a chosen wavelength when within this many nm of it (files in
#: micrometres give 532 nm as 531.9999999).
WAVELENGTH_TOLERANCE = 0.5


def _subset(data: Measurements, rows, observed, uncertainty) -> Measurements:
    take = lambda a: None if a is None else a[rows]
    return Measurements(data.theta_i[rows], data.phi_i[rows], data.theta_r[rows],
                        data.phi_r[rows], data.wavelength[rows],
                        {q: v[rows] for q, v in observed.items()},
                        {q: u[rows] for q, u in uncertainty.items()},
                        data.source, list(data.ignored_columns), take(data.row_scale),
                        take(data.lines))


def select_wavelengths(data: Measurements, wavelengths) -> Measurements:
    """The rows within :data:`WAVELENGTH_TOLERANCE` of any of ``wavelengths``
    (nm); :class:`MeasurementError` naming the file's wavelengths if one
    matches no row."""
    wanted = np.atleast_1d(np.asarray(wavelengths, dtype=np.float64))
    have = data.wavelengths
    for w in wanted:
        if not np.any(np.abs(have - w) <= WAVELENGTH_TOLERANCE):
            raise MeasurementError(f"{data.source}: no measurement at {w:g} nm (wavelengths "
                                   f"in the file: {', '.join(f'{x:g}' for x in have)} nm)")
    close = np.abs(data.wavelength[:, None] - wanted[None, :]) <= WAVELENGTH_TOLERANCE
    rows = np.flatnonzero(close.any(axis=1))
    # the chosen wavelength itself, not the file's float (0.532 um * 1000)
    data = _subset(data, rows, data.observed, data.uncertainty)
    data.wavelength = wanted[np.argmax(close[rows], axis=1)]
    return data


def select_observables(data: Measurements, names) -> Measurements:
    """The quantities ``names`` (``m00`` ... ``m33``, ``dolp``) of ``data``;
    ``dolp`` may be derived from ``m00``, ``m10``, ``m20`` (sqrt(m10^2 +
    m20^2) / m00, where m00 > 0) when the file does not give it. Rows that
    measure none of them are dropped."""
    names = [n.strip().lower() for n in names if n.strip()]
    if not names:
        raise MeasurementError("no quantity chosen (e.g. m00,dolp)")
    observed, uncertainty = {}, {}
    for name in names:
        if name not in OBSERVABLES:
            raise MeasurementError(f"unknown quantity {name!r}; quantities: m00 ... m33, dolp")
        if name in data.observed:
            observed[name] = data.observed[name]
            if name in data.uncertainty:
                uncertainty[name] = data.uncertainty[name]
        elif name == "dolp" and {"m00", "m10", "m20"} <= set(data.observed):
            m00 = data.observed["m00"]
            with np.errstate(divide="ignore", invalid="ignore"):
                dolp = np.hypot(data.observed["m10"], data.observed["m20"]) / m00
            dolp = np.where(m00 > 0, dolp, np.nan)
            bad = np.flatnonzero(dolp > 1)
            if bad.size:
                where = (f"line {data.lines[bad[0]]}" if data.lines is not None
                         else f"row {bad[0]}")
                raise MeasurementError(f"{data.source}: {where}: the DoLP derived from m00, "
                                       f"m10, m20 is {dolp[bad[0]]:.3g} > 1 (non-physical)")
            observed[name] = dolp
        else:
            have = ", ".join(data.observed) + (
                "; dolp needs m00, m10 and m20" if name == "dolp" else "")
            raise MeasurementError(f"{data.source}: no quantity {name!r} in the file "
                                   f"(it has {have})")
    rows = np.flatnonzero(np.any([np.isfinite(v) for v in observed.values()], axis=0))
    if not rows.size:
        raise MeasurementError(f"{data.source}: no row measures {', '.join(names)}")
    return _subset(data, rows, observed, uncertainty)
