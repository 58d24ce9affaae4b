"""Which layout a measurement file is in, and reading it: the project's
goniometer CSV (:mod:`.measurements`) or NIST's published Mueller-matrix BRDF
layout (:mod:`.nist_layout`), told apart by the header."""

from __future__ import annotations

import os

from ..choices import LAYOUT_CHOICES, LAYOUTS as _LAYOUTS, layout_of
from .measurements import MeasurementError, Measurements, read_goniometer, read_table
from .nist_layout import read_nist

__all__ = ["LAYOUTS", "READERS", "read_measurements"]

#: The values of :func:`read_measurements`' ``layout``: ``auto`` (told by the
#: header) and the layouts of :data:`mitsuba_pbrdf.choices.LAYOUTS`.
LAYOUTS = LAYOUT_CHOICES
#: Each layout's reader: (path, header, rows) -> :class:`Measurements`, from
#: :func:`~.measurements.read_table`'s header and rows.
READERS = {"goniometer": read_goniometer, "nist": read_nist}


def read_measurements(path, layout="auto") -> Measurements:
    """Read and check a measurement file in one of the layouts of
    :data:`mitsuba_pbrdf.choices.LAYOUTS`: the goniometer CSV
    (:mod:`.measurements`) or NIST's Mueller-matrix BRDF layout
    (:mod:`.nist_layout`). ``layout="auto"`` recognises the layout from the
    header; ``"goniometer"`` or ``"nist"`` force one."""
    if layout not in LAYOUTS:
        raise MeasurementError(f"layout must be one of {', '.join(LAYOUTS)}, not {layout!r}")
    first, *others = _LAYOUTS.values()
    _, header, rows = read_table(
        path, first.columns + "".join(f" (or {lay.columns})" for lay in others))
    return READERS[layout_of(header, layout).name](os.fspath(path), header, rows)
