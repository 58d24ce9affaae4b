"""A measurement file fitted in one call: :func:`fit_file` reads it
(:func:`mitsuba_pbrdf.measured.read_file`) and fits the models to it
(:func:`.solver.fit_models`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Dict, Optional, Sequence

from ..measured import Measurements, PbsdfTable, read_file
from ..measured.reading import PathLike
from .solver import FitResult, fit_models

__all__ = ["FileFit", "fit_file"]


@dataclass(frozen=True)
class FileFit:
    """What :func:`fit_file` fitted: the measurements, the ``.pbsdf`` table
    they were sampled from (None for a CSV file) and a :class:`.FitResult`
    per model."""
    data: Measurements
    table: Optional[PbsdfTable]
    results: Dict[str, FitResult]


def fit_file(path: PathLike, models: Sequence[str] = ("three", "two"), layout: str = "auto",
             wavelengths: Optional[Sequence[float]] = None,
             observables: Optional[Sequence[str]] = None, cells: int = 3000,
             max_angle: float = 80.0, seed: int = 0,
             on_read: Optional[Callable[[], None]] = None, **options) -> FileFit:
    """Fit the models to a measurement file.

    Parameters
    ----------
    path : str or os.PathLike
        Any file :func:`mitsuba_pbrdf.measured.read` reads (CSV layouts, ``.pbsdf``).
    models : sequence of str
        ``"three"`` and/or ``"two"`` (:data:`mitsuba_pbrdf.fitting.MODELS`).
    layout, wavelengths, observables, cells, max_angle, seed
        What to read, as in :func:`mitsuba_pbrdf.measured.read`; ``seed``
        seeds the table's cell sample (the fit's starts: ``options``).
    on_read : callable, optional
        Called once the file is read and before the fit starts.
    **options
        :func:`.fit_models`' options (``material``, ``nk``, ``distribution``,
        ``objective``, ``init``, ``fix``, ``starts``, ``progress`` ...).

    Returns
    -------
    FileFit

    Raises
    ------
    MeasurementError, PbsdfError
        The file cannot be read, naming the file, line and column.
    ParameterError, ValueError
        A bad option, naming it.

    Example
    -------
    >>> from mitsuba_pbrdf.fitting import fit_file
    >>> fit = fit_file("measurements.csv", material="Al")  # doctest: +SKIP
    >>> fit.results["three"].values["sigma"]  # doctest: +SKIP
    """
    reading = read_file(path, layout, wavelengths, observables, cells, max_angle, seed)
    if on_read is not None:
        on_read()
    return FileFit(reading.data, reading.table,
                   fit_models(reading.data, tuple(models), **options))
