"""A measurement file fitted in one call: :func:`fit_file` reads it
(:func:`mitsuba_pbrdf.measured.read_file`) and fits the models to it
(:func:`.solver.fit_models`); :meth:`FileFit.save` writes the fit's picture,
JSON and scene, what ``pbrdf fit`` writes."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable, Dict, Optional, Sequence

from ..choices import PLOT_FORMATS, preferred
from ..measured import Measurements, PbsdfTable, read_file
from ..measured.reading import PathLike
from .solver import FitResult, fit_models

__all__ = ["FileFit", "fit_file"]


@dataclass(frozen=True)
class FileFit:
    """What :func:`fit_file` fitted: the measurements, the ``.pbsdf`` table
    they were sampled from (None for a CSV file) and a :class:`.FitResult`
    per model, and the file's path."""
    data: Measurements
    table: Optional[PbsdfTable]
    results: Dict[str, FitResult]
    path: Optional[str] = None

    def save(self, plot: Optional[PathLike] = None, json: Optional[PathLike] = None,
             scene: Optional[PathLike] = None, material: Optional[str] = None) -> None:
        """Write what ``pbrdf fit`` writes, all the files given or none.

        Parameters
        ----------
        plot : str or os.PathLike, optional
            The picture of fit versus data (``.png``, ``.pdf`` or ``.svg``):
            :func:`.plots.plot_fit`, or for a table :func:`.table_plots.plot_table_fit`.
        json : str or os.PathLike, optional
            Every fit's :meth:`.FitResult.as_dict`, by model.
        scene : str or os.PathLike, optional
            A Mitsuba scene with the preferred fit (:func:`mitsuba_pbrdf.choices.preferred`)
            as a ``pbrdf`` BSDF (:func:`.scene_out.write_fitted_scene`).
        material : str, optional
            The material whose index the fit held, written by name in the scene.

        Raises
        ------
        OutputPlanError
            Before anything is written: a file in a format its writer does not
            give, or one that is the file fitted or another of them, naming it.
        OSError
            A file cannot be written; none of them is then left.

        Example
        -------
        >>> fit.save(json="fit.json", scene="fit.xml")  # doctest: +SKIP
        """
        from ..outputs import atomic_path, check_plan, escape_text, together, write_json

        check_plan([("plot", plot, PLOT_FORMATS), ("json", json, None), ("scene", scene, ("xml",))],
                   inputs=[("path", self.path)])
        name = os.path.basename(self.path) if self.path is not None else None
        with together():   # the files given, or none of them (mitsuba_pbrdf.outputs)
            if plot is not None:
                title = escape_text(name, "line") if name is not None else None
                with atomic_path(plot) as tmp:
                    if self.table is not None:
                        from .table_plots import plot_table_fit
                        plot_table_fit(self.table, self.results, tmp, title=title)
                    else:
                        from .plots import plot_fit
                        plot_fit(self.data, self.results, tmp, title=title)
            if json is not None:
                write_json(json, {m: r.as_dict() for m, r in self.results.items()})
            if scene is not None:
                from .scene_out import write_fitted_scene
                write_fitted_scene(preferred(self.results), scene, material=material,
                                   source=name)


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
                   fit_models(reading.data, tuple(models), **options), os.fspath(path))
