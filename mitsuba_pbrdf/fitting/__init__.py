"""Least-squares fits of the pBRDF model to measured reflectance::

    from mitsuba_pbrdf.measured import read_measurements
    from mitsuba_pbrdf.fitting import fit_models, report, plot_fit

    data = read_measurements("measurements.csv")
    results = fit_models(data, material="Al")          # three- and two-component
    print(report(data, results))
    plot_fit(data, results, "fit.png")

or, any file in one call (CSV layouts, ``.pbsdf``), ``fit_file("measurements.csv",
material="Al")`` (:mod:`.files`), or ``pbrdf fit measurements.csv --material Al
--plot fit.png``. Modules:
:mod:`.observables` (the model on the measurements' geometry; synthetic
data), :mod:`.vector` (the parameter vector, defaults, bounds), :mod:`.backends`
(the model and its Jacobian from the reference, lobe by lobe
(:mod:`.lobes`), or the plugin), :mod:`.objectives` (the residuals minimized),
:mod:`.starts` (starting points, the lobes' order), :mod:`.solver` (the fit and
its uncertainties), :mod:`.diagnosis` (goodness of fit by region, warnings),
:mod:`.report` (text), :mod:`.plots` (the picture), :mod:`.scene_out` (the fit
as a scene). The CSV format is
in :mod:`mitsuba_pbrdf.measured.measurements`.
"""

from ..choices import MODELS
from .vector import BOUNDS, DEFAULTS, SHARED
from .observables import model_observables, synthetic_measurements
from .plots import plot_fit
from .report import report
from .solver import FitResult, fit_model, fit_models
from .files import FileFit, fit_file

__all__ = ["BOUNDS", "DEFAULTS", "MODELS", "SHARED", "model_observables",
           "synthetic_measurements", "plot_fit", "report", "FitResult", "fit_model", "fit_models",
           "FileFit", "fit_file"]
