"""Any supported measurement file in one call: a CSV file in one of the
:data:`~.formats.LAYOUTS` (the project's goniometer layout, NIST's Mueller
BRDF layout) or a ``.pbsdf`` table (its cells sampled by
:mod:`.table_sampling`), told apart by its first bytes; then the wavelengths
and quantities asked for selected (:mod:`.selection`)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Optional, Sequence, Union

from ..errors import ParameterError, one_line
from .formats import LAYOUTS, read_measurements
from .measurements import MeasurementError, Measurements
from .pbsdf import MAGIC, PbsdfTable, read_pbsdf
from .selection import select_observables, select_wavelengths
from .table_sampling import sample_table

__all__ = ["Reading", "is_pbsdf", "read", "read_file"]

PathLike = Union[str, "os.PathLike[str]"]


@dataclass(frozen=True)
class Reading:
    """What :func:`read_file` read: the measurements, and the ``.pbsdf``
    table they were sampled from (None for a CSV file)."""
    data: Measurements
    table: Optional[PbsdfTable] = None


def is_pbsdf(path: PathLike) -> bool:
    """Whether *path* is a tensor file (``.pbsdf``) by its first bytes, or by
    its extension when it cannot be read."""
    name = os.fspath(path).lower()
    try:
        with open(path, "rb") as f:
            return f.read(len(MAGIC)) == MAGIC or name.endswith(".pbsdf")
    except OSError:
        return name.endswith(".pbsdf")


def read_file(path: PathLike, layout: str = "auto",
              wavelengths: Optional[Sequence[float]] = None,
              observables: Optional[Sequence[str]] = None, cells: int = 3000,
              max_angle: float = 80.0, seed: int = 0) -> Reading:
    """:func:`read`, keeping the ``.pbsdf`` table the data were sampled from."""
    if layout not in LAYOUTS:
        raise ParameterError("layout", f"must be one of {', '.join(LAYOUTS)}, not {layout!r}")
    quantities = list(observables) if observables else None
    if is_pbsdf(path):
        if layout != "auto":
            raise ParameterError("layout", "applies to CSV files (a .pbsdf table has one layout)")
        table = read_pbsdf(path)
        data = sample_table(table, cells, max_angle, seed, quantities)
        return Reading(select_wavelengths(data, wavelengths) if wavelengths else data, table)
    data = read_measurements(path, layout=layout)
    if wavelengths:
        data = select_wavelengths(data, wavelengths)
    if quantities:
        try:
            data = select_observables(data, quantities)
        except MeasurementError as e:
            raise ParameterError("observables", one_line(e)) from e
    return Reading(data)


def read(path: PathLike, layout: str = "auto", wavelengths: Optional[Sequence[float]] = None,
         observables: Optional[Sequence[str]] = None, cells: int = 3000,
         max_angle: float = 80.0, seed: int = 0) -> Measurements:
    """Read any supported measurement file.

    Parameters
    ----------
    path : str or os.PathLike
        A CSV file (``layout``) or a ``.pbsdf`` table (told by its first bytes).
    layout : str
        CSV files: one of :data:`~.formats.LAYOUTS`; ``"auto"`` tells them
        apart by the header. A ``.pbsdf`` table takes ``"auto"`` only.
    wavelengths : sequence of float, optional
        Keep only these wavelengths, nm (within 0.5 nm).
    observables : sequence of str, optional
        Keep only these quantities (``m00`` ... ``m33``, ``dolp``; DoLP derived
        from m00, m10, m20 where the file has no ``dolp`` column).
    cells, max_angle, seed : int, float, int
        ``.pbsdf`` tables: how many cells to sample, the largest angle of the
        light and the viewer from the normal (degrees), the sample's seed.

    Returns
    -------
    Measurements

    Raises
    ------
    MeasurementError, PbsdfError
        The file is not readable or not in the layout, naming the file, line and column.
    ParameterError
        A bad ``layout`` or ``observables``.

    Example
    -------
    >>> from mitsuba_pbrdf.measured import read
    >>> data = read("measurements.csv", wavelengths=[633])  # doctest: +SKIP
    """
    return read_file(path, layout, wavelengths, observables, cells, max_angle, seed).data
