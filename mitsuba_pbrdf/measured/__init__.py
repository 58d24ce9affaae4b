"""Measured pBRDF data and the files it comes in: goniometer measurements in a
CSV file (:mod:`.measurements`). Readers check what they read and name the
file, row and column of anything wrong."""

from .measurements import (ANGLES, ELEMENTS, OBSERVABLES, MeasurementError, Measurements,
                           check_measurements, read_measurements, write_measurements)

__all__ = ["ANGLES", "ELEMENTS", "OBSERVABLES", "MeasurementError", "Measurements",
           "check_measurements", "read_measurements", "write_measurements"]
