"""Which layout a measurement file is in, and reading it: the project's
goniometer CSV (:mod:`.measurements`) or NIST's published Mueller-matrix BRDF
layout (:mod:`.nist_layout`), told apart by the header."""

from __future__ import annotations

import os

from . import nist_layout
from .measurements import ANGLES, MeasurementError, Measurements, read_goniometer, read_table

__all__ = ["LAYOUTS", "read_measurements"]

#: The file layouts :func:`read_measurements` reads: ``goniometer`` (this
#: module's CSV) and ``nist`` (NIST's published Mueller-matrix BRDF layout,
#: :mod:`.nist_layout`); ``auto`` tells them apart by the header.
LAYOUTS = ("auto", "goniometer", "nist")


def read_measurements(path, layout="auto") -> Measurements:
    """Read and check a measurement file: the goniometer CSV of the module
    docstring, or NIST's Mueller-matrix BRDF layout (:mod:`.nist_layout`).
    ``layout="auto"`` recognises the layout from the header; ``"goniometer"``
    or ``"nist"`` force one."""
    if layout not in LAYOUTS:
        raise MeasurementError(f"layout must be one of {', '.join(LAYOUTS)}, not {layout!r}")
    _, header, rows = read_table(
        path, f"{', '.join(ANGLES)}, wavelength, m00 ... (or NIST's lambda, thetai, phi, "
              "thetar, phir, f_r11 ...)")
    if layout == "nist" or (layout == "auto" and nist_layout.is_nist_header(header)):
        return nist_layout.read_nist(os.fspath(path), header, rows)
    return read_goniometer(os.fspath(path), header, rows)
