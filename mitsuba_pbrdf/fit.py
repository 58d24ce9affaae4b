"""Deprecated: use :mod:`mitsuba_pbrdf.fitting` (fits), :mod:`mitsuba_pbrdf.measured`
(the CSV format) and ``pbrdf fit`` (the command). Kept so that old imports and
``python -m mitsuba_pbrdf.fit`` still work."""

import sys
import warnings

from .cli.fit import main
from .fitting import (BOUNDS, DEFAULTS, MODELS, SHARED, FitResult, fit_model, fit_models,
                      model_observables, plot_fit, report, synthetic_measurements)
from .measured import (ANGLES, ELEMENTS, OBSERVABLES, MeasurementError, Measurements,
                       check_measurements, read_measurements, write_measurements)

__all__ = ["MeasurementError", "Measurements", "read_measurements", "write_measurements",
           "check_measurements", "synthetic_measurements", "model_observables", "FitResult",
           "fit_model", "fit_models", "report", "plot_fit", "main", "ANGLES", "ELEMENTS",
           "OBSERVABLES", "SHARED", "DEFAULTS", "BOUNDS", "MODELS"]

if __name__ == "__main__":
    sys.exit(main())
else:
    warnings.warn("mitsuba_pbrdf.fit is deprecated; use mitsuba_pbrdf.fitting and "
                  "mitsuba_pbrdf.measured (command: pbrdf fit)", DeprecationWarning, stacklevel=2)
