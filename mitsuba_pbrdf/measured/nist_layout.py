"""NIST's layout of Mueller-matrix BRDF measurements (the files T. A. Germer
publishes, e.g. the sintered PTFE of Applied Optics 2017), read into
:class:`~mitsuba_pbrdf.measured.measurements.Measurements` in the project's
conventions.

**The layout.** A CSV header row, then one row per measurement:

* ``lambda``: wavelength in micrometres (0.1 to 20 µm; a value outside is
  refused as another unit);
* ``thetai``, ``phi``: the incident polar angle and the azimuth of the
  direction towards the source, degrees. In-plane files give a *signed*
  ``thetai`` with ``phi = 0``: a negative ``thetai`` puts the source at
  azimuth ``phi + 180``. Out-of-plane files give ``thetai >= 0`` and any
  ``phi``; the specular direction is at ``phir = phi + 180``;
* ``thetar``, ``phir``: the viewing polar angle and azimuth, degrees;
* ``f_r11`` (or ``m11``): the unpolarized BRDF, 1/sr; the other elements
  1-indexed, either normalized by it (``f_r12/f_r11`` ... ``f_r44/f_r11``,
  ``m12/m11`` ...; each in [-1, 1]) or in 1/sr (``f_r12`` ...), not both kinds
  in one file. Cells may be empty (not measured); other columns are ignored.

**The conventions** (SCATMECH's, in which NIST states its data: Stokes bases
``psps``). Each ray's Stokes basis has ``s = z x k`` (k its propagation
direction, z the surface normal) and ``p`` completing the right-handed
``(s, p, k)`` frame, the reference evaluator's global s/p frames; SCATMECH's
circular sign is the opposite of Mitsuba's (``tests/bsdfs/test_scatmech.py``).
So element ``f_rIJ`` becomes ``m(I-1)(J-1)`` with

    M_project = R(eta_out) D M_NIST D R(-eta_in),   D = diag(1, 1, 1, -1)

``R`` the Stokes rotator: the identity except at normal incidence or viewing,
where SCATMECH's basis is the limit along the ray's azimuth and the project's
is the surface x-axis (``eta_out = -(phir + 90 deg)``, ``eta_in = phi_i -
90 deg``). Directions: ``theta_i = |thetai|``, ``phi_i = phi`` (``+ 180`` when
``thetai < 0``), ``theta_r, phi_r = thetar, phir``; wavelength in nm =
1000 ``lambda``. ``docs/fitting.md`` derives this.

**Uncertainties.** The layout gives none. The elements are measured relative to
``f_r11``, so the rows carry it as ``row_scale``: the fit's assumed absolute
floor is ``--abs-uncertainty`` times the row's ``f_r11`` (as for ``.pbsdf``
tables), not times the column's largest value.
"""

from __future__ import annotations

import math
import re

import numpy as np

from .measurements import MeasurementError, Measurements, check_measurements, number_cell

__all__ = ["NIST_ANGLES", "read_nist", "nist_to_project"]

#: The angle and wavelength columns of the layout.
NIST_ANGLES = ("lambda", "thetai", "phi", "thetar", "phir")
#: A 1-indexed Mueller element, absolute or normalized by element 11.
ELEMENT = re.compile(r"^(f_r|m)([1-4])([1-4])(?:\s*/\s*(f_r|m)11)?$")
#: The range of ``lambda`` taken as micrometres.
MICROMETRES = (0.1, 20.0)
#: SCATMECH's circular sign against the project's (Mitsuba's).
D = np.diag([1.0, 1.0, 1.0, -1.0])


def nist_to_project(M, theta_i, phi_i, theta_r, phi_r):
    """Mueller BRDFs (N, 4, 4) in SCATMECH's ``psps`` bases and circular sign
    to the project's global s/p frames (angles in degrees, the project's:
    ``theta_i >= 0``, ``phi_i`` the source's azimuth). NaN (an element not
    measured) stays NaN and spreads only to the elements a rotation mixes it
    into."""
    M = np.array(M, dtype=np.float64) * (np.diag(D)[:, None] * np.diag(D)[None, :])
    out = np.asarray(theta_r) == 0
    if out.any():            # S_project = R(eta_out) S_NIST on the output side
        eta = -np.radians(np.asarray(phi_r, dtype=np.float64)[out] + 90.0)
        c, s = np.cos(2 * eta)[:, None], np.sin(2 * eta)[:, None]
        r1, r2 = M[out, 1, :], M[out, 2, :]
        M[out, 1, :], M[out, 2, :] = c * r1 + s * r2, -s * r1 + c * r2
    inc = np.asarray(theta_i) == 0
    if inc.any():            # M R(-eta_in) on the input side
        eta = np.radians(np.asarray(phi_i, dtype=np.float64)[inc] - 90.0)
        c, s = np.cos(2 * eta)[:, None], np.sin(2 * eta)[:, None]
        c1, c2 = M[inc, :, 1], M[inc, :, 2]
        M[inc, :, 1], M[inc, :, 2] = c * c1 + s * c2, -s * c1 + c * c2
    return M


def _columns(path, header):
    """{(i, j) 0-indexed: column} and whether the elements are normalized."""
    missing = [c for c in NIST_ANGLES if c not in header]
    if missing:
        raise MeasurementError(
            f"{path}: missing column(s) {', '.join(missing)}; NIST's layout has lambda (µm), "
            "thetai, phi, thetar, phir (deg), f_r11 (1/sr) and f_r12/f_r11 ... f_r44/f_r11")
    zero_indexed = [c for c in header if re.fullmatch(r"m[0-3][0-3]", c) and "0" in c]
    if zero_indexed:
        raise MeasurementError(f"{path}: column {zero_indexed[0]!r} is 0-indexed, but NIST's "
                               "layout names the elements 1-indexed (f_r11 ... f_r44 or "
                               "m11 ... m44)")
    elements, kinds = {}, {}
    for c in header:
        m = ELEMENT.match(c)
        if not m:
            continue
        ij = (int(m[2]) - 1, int(m[3]) - 1)
        if ij in elements:
            raise MeasurementError(f"{path}: element {m[2]}{m[3]} is given twice "
                                   f"({elements[ij]!r} and {c!r})")
        elements[ij] = c
        if ij != (0, 0):
            kinds[c] = bool(m[4])
        elif m[4]:
            raise MeasurementError(f"{path}: column {c!r}: element 11 normalized by itself")
    if (0, 0) not in elements:
        raise MeasurementError(f"{path}: missing column f_r11 (the unpolarized BRDF, 1/sr): "
                               "the other elements are normalized by it")
    if len(set(kinds.values())) > 1:
        normalized = [c for c, k in kinds.items() if k]
        absolute = [c for c, k in kinds.items() if not k]
        raise MeasurementError(f"{path}: mixed units: {normalized[0]!r} is normalized by "
                               f"f_r11 but {absolute[0]!r} is in 1/sr; give every element "
                               "one way")
    return elements, any(kinds.values())


def read_nist(path, header, rows) -> Measurements:
    """Read the rows of a file in NIST's layout (header: names stripped, lower
    case; rows: ``(line number, cells)``, as
    :func:`~mitsuba_pbrdf.measured.measurements.read_table` gives them) and
    convert them to the project's conventions (module docstring)."""
    elements, normalized = _columns(path, header)
    names = list(NIST_ANGLES)
    index = {c: header.index(c) for c in names + list(elements.values())}
    ignored = [c for c in header if c not in index]
    angles, values, numbers = [], [], []
    for line, cells in rows:
        a = [number_cell(cells[index[c]], path, line, c, True) for c in names]
        v = {ij: number_cell(cells[index[c]], path, line, c, False) for ij, c in elements.items()}
        if math.isnan(v[(0, 0)]):
            if all(math.isnan(x) for x in v.values()):
                raise MeasurementError(f"{path}: line {line}: no measured value (every "
                                       "element is empty)")
            if normalized:
                raise MeasurementError(f"{path}: line {line}: f_r11 is empty, but the "
                                       "elements of the row are normalized by it")
        lam = a[0]
        if not MICROMETRES[0] <= lam <= MICROMETRES[1]:
            raise MeasurementError(
                f"{path}: line {line}: lambda = {lam:g} is not a wavelength in µm (the "
                f"layout's unit: {MICROMETRES[0]:g} to {MICROMETRES[1]:g}); mixed units?")
        if not -90 < a[1] < 90:
            raise MeasurementError(f"{path}: line {line}: thetai = {a[1]:g} deg is out of "
                                   "range (-90, 90) (signed polar angle of the source)")
        for (ij, c) in elements.items():
            if normalized and ij != (0, 0) and abs(v[ij]) > 1:
                raise MeasurementError(
                    f"{path}: line {line}: {c} = {v[ij]:g} is above 1 in magnitude (an "
                    "element normalized by f_r11 lies in [-1, 1])")
        angles.append(a)
        values.append(v)
        numbers.append(line)
    if not angles:
        raise MeasurementError(f"{path}: no data rows after the header")
    a = np.array(angles, dtype=np.float64)
    N = len(a)
    M = np.full((N, 4, 4), np.nan)
    for ij in elements:
        M[:, ij[0], ij[1]] = [v[ij] for v in values]
    if normalized:
        m00 = M[:, 0, 0].copy()
        M *= m00[:, None, None]
        M[:, 0, 0] = m00
    theta_i = np.abs(a[:, 1])
    phi_i = np.where(a[:, 1] < 0, a[:, 2] + 180.0, a[:, 2])
    phi_i = (phi_i + 180.0) % 360.0 - 180.0            # in [-180, 180)
    M = nist_to_project(M, theta_i, phi_i, a[:, 3], a[:, 4])
    observed = {f"m{i}{j}": M[:, i, j] for i in range(4) for j in range(4)
                if (i, j) in elements}
    # the elements are measured relative to f_r11 (a polarimeter's errors scale
    # with the intensity): the assumed uncertainties' floor follows each row's
    # f_r11, as for .pbsdf tables, unless some row lacks it
    m00 = M[:, 0, 0]
    row_scale = m00.copy() if np.isfinite(m00).all() else None
    data = Measurements(theta_i, phi_i, a[:, 3], a[:, 4], 1000.0 * a[:, 0], observed, {},
                        path, ignored, row_scale, lines=np.array(numbers))
    check_measurements(data)
    return data

