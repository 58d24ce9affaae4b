"""Measured pBRDF data and the files it comes in: goniometer measurements in a
CSV file (:mod:`.measurements`) and tabulated pBRDFs in ``.pbsdf`` files, the
KAIST database's and Mitsuba's ``measured_polarized`` format (:mod:`.pbsdf`;
their geometry :mod:`.rusinkiewicz`, the plugin's lookup emulated in
:mod:`.lookup`, the model tabulated by :mod:`.export`; Mitsuba's plugin as an
oracle is the tests' and studies' ``proof/measured_oracle.py``), and a
material's index n + ik against wavelength (:mod:`.index_table`); any of
them in one call: :func:`read` (:mod:`.reading`). Readers check
what they read and name the file, line and column (or field) of anything
wrong. NumPy only."""

from .index_table import IndexTable, IndexTableError, read_index_table
from .formats import LAYOUTS, read_measurements
from .measurements import (ANGLES, ELEMENTS, OBSERVABLES, MeasurementError, Measurements,
                           check_measurements, write_measurements)
from .pbsdf import PbsdfError, PbsdfTable, check_renderable, read_pbsdf, write_pbsdf
from .reading import Reading, read, read_file

__all__ = ["ANGLES", "ELEMENTS", "OBSERVABLES", "MeasurementError", "Measurements",
           "check_measurements", "LAYOUTS", "read_measurements", "write_measurements",
           "PbsdfError", "PbsdfTable", "check_renderable", "read_pbsdf", "write_pbsdf",
           "IndexTable", "IndexTableError", "read_index_table", "Reading", "read", "read_file"]
